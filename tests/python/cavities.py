"""A seeded family of mould cavities built with Open CASCADE (cadquery-ocp)
and written as STEP AP214, for tests that plan real parts and check them
against the exact solid (part_oracle.py).

Each part is a block with a cavity cut from its top face: walls with a draft
(the opening at the top is the largest section), fillets between the walls
(corner fillets, cylinders about the drafted edges), fillets between the walls
and the floor (Open CASCADE writes them as rational B-splines of degree 10-14)
and a freeform B-spline floor (`GeomAPI_PointsToBSplineSurface` through a
seeded smooth height field). The cavity tool is built convex (a drafted
frustum, the half-space above the floor, its edges filleted) and subtracted
from the block, so the part's concave fillets are exact rolling-ball blends.

    cavity = build_cavity(seed, out_dir)          # or build_cavity(spec=CavitySpec(...))
    cavity.step_path                              # the STEP file
    cavity.groups["floor"], cavity.groups["fillets"], cavity.groups["walls"]
    cavity.solid                                  # the solid as read back from the file
    cavity.faces[face_id]                         # TopoDS_Face by STEP entity id
    cavity.tessellation(0.01)                     # vertices, triangles, face ids

Faces are named as `toolpath import --list` and a job's `faces` name them:
by the entity id `#N` of their `ADVANCED_FACE` in the written file. The ids
are read back from the file (STEPControl_Reader's transfer map from each face
of the read solid to its entity), so the solid the oracle checks is the one
the importer reads, face for face.

    python3 tests/python/cavities.py OUT_DIR [SEED ...]   # writes and lists parts
"""

from __future__ import annotations

import json
import math
import random
import re
import sys
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np
from OCP.BRep import BRep_Tool
from OCP.BRepAdaptor import BRepAdaptor_Curve, BRepAdaptor_Surface
from OCP.BRepAlgoAPI import BRepAlgoAPI_Common, BRepAlgoAPI_Cut
from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace, BRepBuilderAPI_Transform
from OCP.BRepCheck import BRepCheck_Analyzer
from OCP.BRepFilletAPI import BRepFilletAPI_MakeFillet
from OCP.BRepGProp import BRepGProp
from OCP.BRepMesh import BRepMesh_IncrementalMesh
from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeHalfSpace, BRepPrimAPI_MakeWedge
from OCP.collections import Array2_gp_Pnt
from OCP.GeomAbs import GeomAbs_BSplineSurface, GeomAbs_C2, GeomAbs_Cylinder, GeomAbs_Plane
from OCP.GeomAPI import GeomAPI_PointsToBSplineSurface, GeomAPI_ProjectPointOnSurf
from OCP.gp import gp_Ax1, gp_Dir, gp_Pnt, gp_Trsf, gp_Vec
from OCP.GProp import GProp_GProps
from OCP.IFSelect import IFSelect_RetDone
from OCP.Interface import Interface_Static
from OCP.STEPControl import STEPControl_AsIs, STEPControl_Reader, STEPControl_Writer
from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_REVERSED
from OCP.TopExp import TopExp_Explorer
from OCP.TopLoc import TopLoc_Location
from OCP.TopoDS import TopoDS

# A face point lies on a block side or on the floor surface within this, mm.
ON_SURFACE_MM = 1e-6


@dataclass(frozen=True)
class CavitySpec:
    """Sizes of one part, mm and degrees (`_deg`)."""

    seed: int
    length: float  # block along x
    width: float  # block along y
    height: float  # block along z (top face at z = height)
    opening_length: float  # cavity opening at the top face, along x
    opening_width: float  # along y
    depth: float  # top face to the floor's mean level
    draft_deg: float  # wall draft from the vertical
    floor_fillet: float  # fillet radius between walls and floor
    corner_fillet: float  # fillet radius between walls
    floor_amplitude: float  # peak-to-mean height of the freeform floor
    floor_waves: tuple = ()  # ((ax, ay, px, py, weight), ...) of the height field
    opening: str = "wide"  # "wide" or "tight"

    @staticmethod
    def from_seed(seed: int, opening: str | None = None) -> CavitySpec:
        """Sizes drawn from `random.Random(seed)`: depth 20-60, draft 0-10 deg,
        floor fillets 3-10, corner fillets above them, a tight (28-45 mm wide)
        or wide opening (two thirds of the block)."""
        rng = random.Random(seed)
        opening = opening or ("tight" if rng.random() < 0.35 else "wide")
        depth = rng.uniform(20.0, 60.0)
        draft_deg = 0.0 if rng.random() < 0.25 else rng.uniform(0.5, 10.0)
        floor_fillet = rng.uniform(3.0, 10.0)
        corner_fillet = rng.uniform(floor_fillet + 2.0, max(floor_fillet + 3.0, 15.0))
        if opening == "tight":
            ow = rng.uniform(max(28.0, 2 * corner_fillet + 6.0), 45.0)
            ol = rng.uniform(ow + 10.0, ow + 50.0)
            length, width = ol + rng.uniform(40.0, 80.0), ow + rng.uniform(40.0, 70.0)
        else:
            length, width = rng.uniform(140.0, 200.0), rng.uniform(100.0, 150.0)
            ol, ow = length * rng.uniform(0.6, 0.75), width * rng.uniform(0.55, 0.7)
        height = depth + rng.uniform(15.0, 30.0)
        # The floor's section must keep room for the corner fillets (and a
        # few mm of flat wall) 10 mm below the mean floor level.
        room = (min(ol, ow) - 2.0 * corner_fillet - 6.0) / (2.0 * (depth + 10.0))
        draft_deg = min(draft_deg, math.degrees(math.atan(max(room, 0.0))))
        floor_amplitude = rng.uniform(1.5, min(8.0, depth / 5.0))
        waves = tuple(
            (rng.uniform(0.5, 2.0), rng.uniform(0.5, 2.0), rng.uniform(0, math.tau), rng.uniform(0, math.tau), rng.uniform(0.3, 1.0))
            for _ in range(3)
        )
        return CavitySpec(
            seed=seed,
            length=length,
            width=width,
            height=height,
            opening_length=ol,
            opening_width=ow,
            depth=depth,
            draft_deg=draft_deg,
            floor_fillet=floor_fillet,
            corner_fillet=corner_fillet,
            floor_amplitude=floor_amplitude,
            floor_waves=waves,
            opening=opening,
        )

    @staticmethod
    def reference(depth=35.0) -> CavitySpec:
        """The mould cavity of the planning reports: a 160 x 120 x 60 mm
        block, a 120 x 80 mm opening, 35 mm deep (the deeper variant: 40),
        7 deg draft, 6 mm floor fillets, 10 mm corner fillets, a 3 mm floor."""
        return CavitySpec(
            seed=-1,
            length=160.0,
            width=120.0,
            height=60.0,
            opening_length=120.0,
            opening_width=80.0,
            depth=depth,
            draft_deg=7.0,
            floor_fillet=6.0,
            corner_fillet=10.0,
            floor_amplitude=3.0,
            floor_waves=((1.0, 1.0, 0.0, 0.0, 1.0), (2.0, 1.0, 1.0, 0.5, 0.4)),
            opening="wide",
        )

    def floor_height(self, x, y):
        """The floor's height field z(x, y), through which the B-spline floor
        is approximated: the mean level H - depth plus a sum of waves scaled
        so that its largest deviation over the opening is the amplitude."""
        return self.height - self.depth + self.floor_amplitude * self._wave(x, y) / self._wave_peak()

    def _wave(self, x, y):
        x0 = (self.length - self.opening_length) / 2.0
        y0 = (self.width - self.opening_width) / 2.0
        s = (np.asarray(x, float) - x0) / self.opening_length
        t = (np.asarray(y, float) - y0) / self.opening_width
        total = 0.0
        for ax, ay, px, py, w in self.floor_waves:
            total = total + w * np.sin(math.pi * ax * s + px) * np.cos(math.pi * ay * t + py)
        return total

    def _wave_peak(self):
        x0 = (self.length - self.opening_length) / 2.0
        y0 = (self.width - self.opening_width) / 2.0
        gx, gy = np.meshgrid(np.linspace(x0, x0 + self.opening_length, 41), np.linspace(y0, y0 + self.opening_width, 41))
        peak = float(np.max(np.abs(self._wave(gx, gy))))
        return peak if peak > 1e-9 else 1.0


@dataclass
class Cavity:
    """A written part: its file, its faces by STEP entity id and their roles."""

    spec: CavitySpec
    step_path: Path
    solid: object  # TopoDS_Shape (a solid) read back from step_path
    faces: dict  # STEP entity id -> TopoDS_Face
    groups: dict  # role -> sorted list of STEP entity ids
    face_types: dict = field(default_factory=dict)  # id -> surface entity type in the file
    floor_surface: object = None  # the Geom_BSplineSurface the floor lies on

    def face_ids(self, *roles):
        """Sorted ids of the faces of the given roles."""
        return sorted({i for r in roles for i in self.groups[r]})

    def role(self, face_id):
        """The role of a face (`floor`, `floor_fillets`, ...)."""
        for r in ROLES:
            if face_id in self.groups[r]:
                return r
        raise KeyError(face_id)

    def oracle_spacing(self, coarse=2.0):
        """Sample spacing per face for part_oracle: `coarse` mm on the block's
        outer sides and bottom (far from any tool of a cavity job), the
        oracle's default elsewhere."""
        return {i: coarse for i in self.groups["outside"]}

    def tessellation(self, deflection=0.01, angular=0.1):
        """The solid meshed by BRepMesh within `deflection` mm (and `angular`
        rad): vertices (n, 3), triangles (m, 3) with outward winding, and the
        STEP id of each triangle's face (m,)."""
        BRepMesh_IncrementalMesh(self.solid, deflection, False, angular, True)
        verts, tris, ids = [], [], []
        base = 0
        for fid in sorted(self.faces):
            face = self.faces[fid]
            loc = TopLoc_Location()
            tri = BRep_Tool.Triangulation_s(face, loc)
            if tri is None:
                raise RuntimeError(f"face #{fid} has no triangulation")
            trsf = loc.Transformation()
            for i in range(1, tri.NbNodes() + 1):
                p = tri.Node(i).Transformed(trsf)
                verts.append((p.X(), p.Y(), p.Z()))
            flip = face.Orientation() == TopAbs_REVERSED
            for i in range(1, tri.NbTriangles() + 1):
                a, b, c = tri.Triangle(i).Get()
                tris.append((base + a - 1, base + c - 1, base + b - 1) if flip else (base + a - 1, base + b - 1, base + c - 1))
                ids.append(fid)
            base += tri.NbNodes()
        return np.array(verts), np.array(tris, dtype=np.int64), np.array(ids, dtype=np.int64)

    def manifest(self):
        """JSON-ready description: file, spec, groups, face types and areas."""
        return {
            "file": str(self.step_path),
            "spec": asdict(self.spec),
            "groups": self.groups,
            "faces": {str(i): {"type": self.face_types.get(i, "?"), "area_mm2": face_area(f)} for i, f in sorted(self.faces.items())},
        }


ROLES = ("floor", "floor_fillets", "corner_fillets", "walls", "top", "outside")


def face_area(face):
    props = GProp_GProps()
    BRepGProp.SurfaceProperties_s(face, props)
    return props.Mass()


def _explore(shape, kind, cast):
    out = []
    ex = TopExp_Explorer(shape, kind)
    while ex.More():
        s = cast(ex.Current())
        if not any(s.IsSame(o) for o in out):
            out.append(s)
        ex.Next()
    return out


def faces_of(shape):
    return _explore(shape, TopAbs_FACE, TopoDS.Face)


def edges_of(shape):
    return _explore(shape, TopAbs_EDGE, TopoDS.Edge)


def _frustum(spec, z_bottom, z_top):
    """The drafted prism of the cavity from z_bottom to z_top: its section at
    the block's top face is the opening, and it narrows downwards by the draft.
    BRepPrimAPI_MakeWedge in its own frame (height along y), turned so that
    its y is the part's z."""
    t = math.tan(math.radians(spec.draft_deg))
    h = z_top - z_bottom
    below = spec.height - z_bottom
    dx = spec.opening_length - 2.0 * below * t
    dz = spec.opening_width - 2.0 * below * t
    e = h * t
    wedge = BRepPrimAPI_MakeWedge(dx, h, dz, -e, -e, dx + e, dz + e).Shape()
    turn = gp_Trsf()
    turn.SetRotation(gp_Ax1(gp_Pnt(0, 0, 0), gp_Dir(1, 0, 0)), math.pi / 2.0)
    place = gp_Trsf()
    place.SetTranslation(gp_Vec((spec.length - dx) / 2.0, (spec.width + dz) / 2.0, z_bottom))
    place.Multiply(turn)
    return BRepBuilderAPI_Transform(wedge, place, True).Shape()


def floor_surface(spec, n=11):
    """The B-spline floor through an n x n grid of the height field over the
    opening plus a margin (the fillets trim it inside), bicubic, C2."""
    margin = 10.0
    x0, x1 = (spec.length - spec.opening_length) / 2.0 - margin, (spec.length + spec.opening_length) / 2.0 + margin
    y0, y1 = (spec.width - spec.opening_width) / 2.0 - margin, (spec.width + spec.opening_width) / 2.0 + margin
    pts = Array2_gp_Pnt(1, n, 1, n)
    for i in range(n):
        for j in range(n):
            x = x0 + (x1 - x0) * i / (n - 1)
            y = y0 + (y1 - y0) * j / (n - 1)
            pts.SetValue(i + 1, j + 1, gp_Pnt(x, y, float(spec.floor_height(x, y))))
    return GeomAPI_PointsToBSplineSurface(pts, 3, 3, GeomAbs_C2, 1e-3).Surface()


def build_solid(spec):
    """The part as an OCP solid, and the floor's B-spline surface."""
    z_bottom = spec.height - spec.depth - spec.floor_amplitude - spec.floor_fillet - 5.0
    prism = _frustum(spec, z_bottom, spec.height + 5.0)
    floor = floor_surface(spec)
    above = BRepPrimAPI_MakeHalfSpace(
        BRepBuilderAPI_MakeFace(floor, 1e-6).Face(), gp_Pnt(spec.length / 2, spec.width / 2, spec.height)
    ).Solid()
    tool = BRepAlgoAPI_Common(prism, above).Shape()
    corners = BRepFilletAPI_MakeFillet(tool)
    for e in edges_of(tool):
        c = BRepAdaptor_Curve(e)
        a, b = c.Value(c.FirstParameter()), c.Value(c.LastParameter())
        if abs(b.Z() - a.Z()) > 0.5 * spec.depth:  # the drafted edges between walls
            corners.Add(spec.corner_fillet, e)
    corners.Build()
    if not corners.IsDone():
        raise RuntimeError(f"seed {spec.seed}: the corner fillets (R {spec.corner_fillet:.2f}) failed")
    tool = corners.Shape()
    floor_face = [f for f in faces_of(tool) if BRepAdaptor_Surface(f).GetType() == GeomAbs_BSplineSurface]
    if len(floor_face) != 1:
        raise RuntimeError(f"seed {spec.seed}: the cavity tool has {len(floor_face)} floor faces")
    blend = BRepFilletAPI_MakeFillet(tool)
    for e in edges_of(floor_face[0]):
        blend.Add(spec.floor_fillet, e)
    blend.Build()
    if not blend.IsDone():
        raise RuntimeError(f"seed {spec.seed}: the floor fillets (R {spec.floor_fillet:.2f}) failed")
    block = BRepPrimAPI_MakeBox(gp_Pnt(0, 0, 0), gp_Pnt(spec.length, spec.width, spec.height)).Shape()
    part = BRepAlgoAPI_Cut(block, blend.Shape()).Shape()
    if not BRepCheck_Analyzer(part).IsValid():
        raise RuntimeError(f"seed {spec.seed}: the part is not a valid solid")
    return part, floor


def quiet_occ():
    """Open CASCADE's messages at Fail level only: the STEP writer and reader
    print transfer statistics on stdout otherwise."""
    from OCP.Message import Message, Message_Gravity

    for printer in Message.DefaultMessenger_s().Printers():
        printer.SetTraceLevel(Message_Gravity.Message_Fail)


def write_step(shape, path):
    """STEP AP214 in mm, pcurves written (the importer uses them)."""
    quiet_occ()
    Interface_Static.SetCVal_s("write.step.schema", "AP214IS")
    Interface_Static.SetCVal_s("write.step.unit", "MM")
    Interface_Static.SetIVal_s("write.surfacecurve.mode", 1)
    w = STEPControl_Writer()
    w.Transfer(shape, STEPControl_AsIs)
    if w.Write(str(path)) != IFSelect_RetDone:
        raise RuntimeError(f"writing {path} failed")


def read_step_faces(path):
    """The solid of a STEP file and its faces keyed by the entity id of their
    ADVANCED_FACE (the transfer map from each read face to its entity; the
    entity's number in the read model is its `#N` label, checked against the
    file's text)."""
    r = STEPControl_Reader()
    if r.ReadFile(str(path)) != IFSelect_RetDone:
        raise RuntimeError(f"reading {path} failed")
    r.TransferRoots()
    shape = r.OneShape()
    model = r.WS().Model()
    tr = r.WS().TransferReader()
    # pybind11 hands back the same Python object for the same C++ entity while
    # it lives: keep every entity so the face's entity is found by identity.
    entities = [model.Value(i) for i in range(1, model.NbEntities() + 1)]
    number = {id(e): i + 1 for i, e in enumerate(entities)}
    faces = {}
    for f in faces_of(shape):
        ent = tr.EntityFromShapeResult(f, 1)
        n = number.get(id(ent)) if ent is not None else None
        if n is None:
            raise RuntimeError(f"{path}: a face has no STEP entity in the transfer map")
        faces[n] = f
    written = set(step_entities(path, "ADVANCED_FACE"))
    if set(faces) != written:
        raise RuntimeError(f"{path}: face entity numbers {sorted(faces)} are not the file's ADVANCED_FACE ids {sorted(written)}")
    return shape, faces


def step_records(path):
    """`{id: (names, text)}` of a Part 21 file's DATA section: `names` the
    entity type, or the list of types of a complex entity."""
    text = Path(path).read_text()
    data = text[text.index("DATA;") + 5 :]
    out = {}
    for m in re.finditer(r"#(\d+)\s*=\s*(.*?);\s*(?=#\d+\s*=|ENDSEC)", data, re.DOTALL):
        body = " ".join(m.group(2).split())
        if body.startswith("("):
            names = re.findall(r"([A-Z_][A-Z0-9_]*)\s*\(", body[1:])
            depth, top = 0, []
            # Only the top-level parts of a complex entity name its types.
            for tok in re.finditer(r"([A-Z_][A-Z0-9_]*)\s*\(|\(|\)", body[1:-1]):
                if tok.group(1) and depth == 0:
                    top.append(tok.group(1))
                if tok.group(0).endswith("("):
                    depth += 1
                else:
                    depth -= 1
            names = top
        else:
            names = re.match(r"([A-Z_][A-Z0-9_]*)", body).group(1)
        out[int(m.group(1))] = (names, body)
    return out


def step_entities(path, name):
    """Ids of the simple entities of type `name`."""
    return sorted(i for i, (n, _) in step_records(path).items() if n == name)


def surface_survey(path):
    """Per ADVANCED_FACE id: the surface entity it lies on, its type (complex
    entities: `RATIONAL_B_SPLINE_SURFACE` when rational, else the B-spline
    part) and, for B-splines, the degrees `(u, v)`."""
    recs = step_records(path)
    out = {}
    for fid, (names, body) in sorted(recs.items()):
        if names != "ADVANCED_FACE":
            continue
        sid = int(re.findall(r"#(\d+)", body)[-1])
        snames, sbody = recs[sid]
        info = {"surface": sid}
        if isinstance(snames, list):
            info["type"] = "RATIONAL_B_SPLINE_SURFACE" if "RATIONAL_B_SPLINE_SURFACE" in snames else "B_SPLINE_SURFACE"
            info["complex"] = snames
            m = re.search(r"B_SPLINE_SURFACE\s*\(\s*(\d+)\s*,\s*(\d+)", sbody)
            info["degrees"] = [int(m.group(1)), int(m.group(2))]
        else:
            info["type"] = snames
            if snames == "B_SPLINE_SURFACE_WITH_KNOTS":
                m = re.search(r"B_SPLINE_SURFACE_WITH_KNOTS\s*\(\s*'[^']*'\s*,\s*(\d+)\s*,\s*(\d+)", sbody)
                info["degrees"] = [int(m.group(1)), int(m.group(2))]
        out[fid] = info
    return out


def _on_box_side(face, spec):
    """Whether a planar face lies on one of the block's six sides."""
    ad = BRepAdaptor_Surface(face)
    u = 0.5 * (ad.FirstUParameter() + ad.LastUParameter())
    v = 0.5 * (ad.FirstVParameter() + ad.LastVParameter())
    p = ad.Value(u, v)
    n = ad.Plane().Axis().Direction()
    for axis, value in ((0, 0.0), (0, spec.length), (1, 0.0), (1, spec.width), (2, 0.0), (2, spec.height)):
        if abs(abs((n.X(), n.Y(), n.Z())[axis]) - 1.0) < 1e-9 and abs((p.X(), p.Y(), p.Z())[axis] - value) < ON_SURFACE_MM:
            return "top" if axis == 2 and value == spec.height else "outside"
    return None


def _on_floor(face, floor):
    """Whether a face lies on the floor's surface: three of its points
    project onto it within ON_SURFACE_MM."""
    ad = BRepAdaptor_Surface(face)
    u0, u1, v0, v1 = ad.FirstUParameter(), ad.LastUParameter(), ad.FirstVParameter(), ad.LastVParameter()
    for s, t in ((0.5, 0.5), (0.3, 0.6), (0.7, 0.4)):
        p = ad.Value(u0 + s * (u1 - u0), v0 + t * (v1 - v0))
        proj = GeomAPI_ProjectPointOnSurf(p, floor)
        if proj.NbPoints() == 0 or proj.LowerDistance() > ON_SURFACE_MM:
            return False
    return True


def classify(faces, spec, floor):
    """Roles of the faces by their geometry: block sides (`top`, `outside`),
    the `floor` (on the floor's surface), `walls` (the other planes),
    `corner_fillets` (cylinders) and `floor_fillets` (the other B-splines)."""
    groups = {r: [] for r in ROLES}
    for fid, f in faces.items():
        kind = BRepAdaptor_Surface(f).GetType()
        if kind == GeomAbs_Plane:
            role = _on_box_side(f, spec) or "walls"
        elif kind == GeomAbs_Cylinder:
            role = "corner_fillets"
        elif kind == GeomAbs_BSplineSurface:
            role = "floor" if _on_floor(f, floor) else "floor_fillets"
        else:
            raise RuntimeError(f"seed {spec.seed}: face #{fid} has an unexpected surface type {kind}")
        groups[role].append(fid)
    for r in groups:
        groups[r].sort()
    if len(groups["floor"]) != 1 or len(groups["top"]) != 1 or len(groups["outside"]) != 5:
        raise RuntimeError(f"seed {spec.seed}: unexpected faces {groups}")
    groups["fillets"] = sorted(groups["floor_fillets"] + groups["corner_fillets"])
    return groups


def build_cavity(seed=0, out_dir=".", spec=None, opening=None, name=None):
    """Builds, writes (`OUT_DIR/cavity_sSEED.step`) and reads back one part.

    A seeded spec whose floor fillet Open CASCADE cannot roll over the floor
    (a large fillet on a steep floor) is built again with the floor's
    amplitude scaled by 0.7, up to three times; `Cavity.spec` is the one
    built. A spec given explicitly is built as it is or refused."""
    if spec is None:
        spec = CavitySpec.from_seed(seed, opening)
        for _ in range(3):
            try:
                solid, floor = build_solid(spec)
                break
            except RuntimeError as e:
                if "floor fillets" not in str(e):
                    raise
                spec = replace(spec, floor_amplitude=0.7 * spec.floor_amplitude)
        else:
            solid, floor = build_solid(spec)
    else:
        solid, floor = build_solid(spec)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{name or f'cavity_s{spec.seed}'}.step"
    write_step(solid, path)
    read, faces = read_step_faces(path)
    groups = classify(faces, spec, floor)
    types = {fid: info["type"] for fid, info in surface_survey(path).items()}
    return Cavity(spec=spec, step_path=path, solid=read, faces=faces, groups=groups, face_types=types, floor_surface=floor)


def main(argv):
    out = Path(argv[1] if len(argv) > 1 else ".")
    seeds = [int(s) for s in argv[2:]] or [0]
    for seed in seeds:
        cav = build_cavity(seed, out)
        print(json.dumps(cav.manifest(), indent=1, default=str))


if __name__ == "__main__":
    main(sys.argv)
