"""`toolpath import` on STEP parts written here and now by Open CASCADE
(cadquery-ocp, tests/python/make_step_parts.py): every face's area as
listed against BRepGProp's, the written surface planned by `toolpath plan`
and judged by its simulator within h, and the committed fixtures
(tests/data/step) still what the generator writes."""

import json
import math
import re
import subprocess
import sys
from pathlib import Path

import pytest

from toolpath_bin import ROOT, toolpath_bin

HERE = Path(__file__).resolve().parent
AREA_REL = 5e-4


@pytest.fixture(scope="module")
def parts(tmp_path_factory):
    out = tmp_path_factory.mktemp("step")
    subprocess.run(
        [sys.executable, str(HERE / "make_step_parts.py"), str(out)],
        check=True,
        capture_output=True,
    )
    return out, json.loads((out / "parts.json").read_text())


def listed(path):
    r = subprocess.run([toolpath_bin(), "import", str(path), "--list"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    rows = [l for l in r.stdout.splitlines() if re.match(r"\s*#\d+", l)]
    return [(int(l.split()[0][1:]), l.split()[1], float(l.split()[2])) for l in rows]


def test_listed_areas_are_open_cascades(parts):
    out, manifest = parts
    for name, part in manifest.items():
        rows = listed(out / part["file"])
        assert len(rows) == 1, rows
        _, kind, area = rows[0]
        exact = part["area_mm2"]
        assert abs(area - exact) <= AREA_REL * exact, (name, kind, area, exact)


def test_the_fixtures_match_the_generator(parts):
    _, manifest = parts
    committed = json.loads((ROOT / "tests/data/step/parts.json").read_text())
    assert committed.keys() == manifest.keys()
    for name in manifest:
        assert committed[name]["area_mm2"] == pytest.approx(manifest[name]["area_mm2"], rel=1e-9)


def test_an_imported_face_is_planned_within_h(parts, tmp_path):
    out, _ = parts
    surface = tmp_path / "face.json"
    face = listed(out / "freeform.step")[0][0]
    r = subprocess.run(
        [toolpath_bin(), "import", str(out / "freeform.step"), "--face", str(face), "-o", str(surface)],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    s = json.loads(surface.read_text())
    assert s["kind"] == "nurbs" and len(s["trim"]["holes"]) == 1
    job = tmp_path / "job.json"
    job.write_text(
        json.dumps(
            {
                "job_id": "step_face",
                "surface": s,
                "strategy": "iso_parametric",
                "tool": {"kind": "ball", "radius": 4.0},
                "scallop": 0.05,
            }
        )
    )
    result = tmp_path / "result.json"
    r = subprocess.run([toolpath_bin(), "plan", str(job), "-o", str(result)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    res = json.loads(result.read_text())
    assert res["within_scallop"] is True
    assert res["stats"]["max_scallop_mm"] <= 0.05


def test_bad_step_input_exits_2_naming_the_entity(parts, tmp_path):
    out, _ = parts
    text = (out / "cylinder.step").read_text()
    cut = tmp_path / "cut.step"
    cut.write_text(text[: len(text) // 2])
    r = subprocess.run([toolpath_bin(), "import", str(cut), "--list"], capture_output=True, text=True)
    assert r.returncode == 2 and "truncated" in r.stderr, r.stderr
    r = subprocess.run(
        [toolpath_bin(), "import", str(out / "cylinder.step"), "--face", "4242", "-o", str(tmp_path / "x.json")],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2 and "#4242" in r.stderr, r.stderr


STEP_SAMPLES = ("step_freeform", "step_multi_face")


def occ_face_areas(path):
    """Areas of the faces of a STEP file as Open CASCADE reads them, in shell order."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_Reader
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer

    reader = STEPControl_Reader()
    assert reader.ReadFile(str(path)) == IFSelect_RetDone
    reader.TransferRoots()
    ex = TopExp_Explorer(reader.OneShape(), TopAbs_FACE)
    areas = []
    while ex.More():
        props = GProp_GProps()
        BRepGProp.SurfaceProperties_s(ex.Current(), props)
        areas.append(props.Mass())
        ex.Next()
    return areas


@pytest.mark.parametrize("name", STEP_SAMPLES)
def test_step_samples_list_open_cascades_areas(name, tmp_path):
    part = tmp_path / f"{name}.step"
    r = subprocess.run([toolpath_bin(), "sample", name, "-o", str(part)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    again = tmp_path / "again.step"
    subprocess.run([toolpath_bin(), "sample", name, "-o", str(again)], check=True)
    assert part.read_bytes() == again.read_bytes()
    rows = listed(part)
    occ = occ_face_areas(part)
    assert len(rows) == len(occ) == (1 if name == "step_freeform" else 4), (rows, occ)
    for (face, kind, area), exact in zip(rows, occ):
        assert abs(area - exact) <= AREA_REL * exact, (name, face, kind, area, exact)


def test_a_step_sample_face_named_by_a_job_plans_within_h(tmp_path):
    part = tmp_path / "part.step"
    subprocess.run([toolpath_bin(), "sample", "step_multi_face", "-o", str(part)], check=True)
    face = listed(part)[0][0]
    job = tmp_path / "job.json"
    job.write_text(
        json.dumps(
            {
                "job_id": "step_sample_face",
                "surface": {"file": "part.step", "face": face},
                "strategy": "iso_scallop",
                "tool": {"kind": "ball", "radius": 4.0},
                "scallop": 0.05,
            }
        )
    )
    result = tmp_path / "result.json"
    r = subprocess.run([toolpath_bin(), "plan", str(job), "-o", str(result)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    res = json.loads(result.read_text())
    assert res["within_scallop"] is True
    assert res["stats"]["max_scallop_mm"] <= 0.05


# The imported surfaces against Open CASCADE's own, point by point: every
# face of every part the generator writes (the fixtures' and the parts built
# at test time only), in both directions (our points on its face, its points
# on ours), and the trims against its face classification.

EXACT_MM = 1e-6
# OFFSET_FIT_TOLERANCE_MM of crates/formats/src/step/offset.rs.
FIT_MM = 1e-4
# A point on one side of a trim may lie this close to the other's boundary:
# the trim's default tolerance (1e-3 mm) and the polyline's chords.
TRIM_MM = 2e-3
GRID = 17


@pytest.fixture(scope="module")
def more_parts(tmp_path_factory):
    out = tmp_path_factory.mktemp("step_more")
    subprocess.run(
        [sys.executable, str(HERE / "make_step_parts.py"), "--more", str(out)],
        check=True,
        capture_output=True,
    )
    return out, json.loads((out / "more_parts.json").read_text())


def occ_faces(path):
    """The faces of a STEP file as Open CASCADE reads them."""
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_Reader
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    reader = STEPControl_Reader()
    assert reader.ReadFile(str(path)) == IFSelect_RetDone
    reader.TransferRoots()
    ex = TopExp_Explorer(reader.OneShape(), TopAbs_FACE)
    faces = []
    while ex.More():
        faces.append(TopoDS.Face(ex.Current()))
        ex.Next()
    return faces


def occ_surface(s):
    """An imported surface file as Open CASCADE's B-spline surface."""
    from OCP.Geom import Geom_BSplineSurface
    from OCP.collections import Array1_double, Array1_int, Array2_double, Array2_gp_Pnt
    from OCP.gp import gp_Pnt

    def knots_mults(knots):
        ks, ms = [], []
        for k in knots:
            if ks and k == ks[-1]:
                ms[-1] += 1
            else:
                ks.append(k)
                ms.append(1)
        a, m = Array1_double(1, len(ks)), Array1_int(1, len(ks))
        for i, (k, c) in enumerate(zip(ks, ms)):
            a.SetValue(i + 1, k)
            m.SetValue(i + 1, c)
        return a, m

    cp = s["control_points"]
    nu, nv = len(cp), len(cp[0])
    poles = Array2_gp_Pnt(1, nu, 1, nv)
    weights = Array2_double(1, nu, 1, nv)
    for i in range(nu):
        for j in range(nv):
            poles.SetValue(i + 1, j + 1, gp_Pnt(*cp[i][j]))
            weights.SetValue(i + 1, j + 1, s["weights"][i][j] if s.get("weights") else 1.0)
    ku, mu = knots_mults(s["knots_u"])
    kv, mv = knots_mults(s["knots_v"])
    return Geom_BSplineSurface(poles, weights, ku, kv, mu, mv, s["degree_u"], s["degree_v"])


def polylines(trim):
    return [c["polyline"] for c in trim["outer"]] + [c["polyline"] for h in trim.get("holes", []) for c in h]


def inside_polygon(loop, q):
    inside = False
    for a, b in zip(loop, loop[1:] + loop[:1]):
        if (a[1] > q[1]) != (b[1] > q[1]):
            x = a[0] + (q[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1])
            if x > q[0]:
                inside = not inside
    return inside


def in_trim(trim, q):
    loops = polylines(trim)
    return inside_polygon(loops[0], q) and not any(inside_polygon(h, q) for h in loops[1:])


def boundary_points(surface, trim):
    """The trim's loops on the surface, 3-D, densified."""
    out = []
    for loop in polylines(trim):
        for a, b in zip(loop, loop[1:] + loop[:1]):
            for t in (0.0, 0.25, 0.5, 0.75):
                p = surface.Value(a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]))
                out.append((p.X(), p.Y(), p.Z()))
    return out


def in_period(surface, ab, bounds):
    """Surface parameters (a, b) moved by whole periods next to the face's
    parameter range `bounds` (a0, a1, b0, b1)."""
    a, b = ab
    if surface.IsUPeriodic():
        period = surface.UPeriod()
        a += period * math.floor((0.5 * (bounds[0] + bounds[1]) - a) / period + 0.5)
    if surface.IsVPeriodic():
        period = surface.VPeriod()
        b += period * math.floor((0.5 * (bounds[2] + bounds[3]) - b) / period + 0.5)
    return a, b


def nearest(points, p):
    return min(math.dist(q, p) for q in points)


def face_box(face):
    from OCP.Bnd import Bnd_Box
    from OCP.BRepBndLib import BRepBndLib

    b = Bnd_Box()
    BRepBndLib.AddOptimal_s(face, b, False, False)
    lo, hi = b.CornerMin(), b.CornerMax()
    return (lo.X(), lo.Y(), lo.Z(), hi.X(), hi.Y(), hi.Z())


def match_faces(rows, faces):
    """Our listed faces to Open CASCADE's, by area and bounding box."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    props = []
    for f in faces:
        g = GProp_GProps()
        BRepGProp.SurfaceProperties_s(f, g)
        props.append((g.Mass(), face_box(f)))
    out = {}
    for face_id, area, lo, hi in rows:
        def cost(k):
            a, box = props[k]
            return abs(a - area) / max(a, 1.0) + sum(abs(x - y) for x, y in zip(box, lo + hi)) / 100.0
        best = min(range(len(faces)), key=cost)
        assert cost(best) < 1e-2, (face_id, area, props[best])
        out[face_id] = faces[best]
    assert len(set(map(id, out.values()))) == len(out), "two faces matched one"
    return out


def listed_boxes(path):
    r = subprocess.run([toolpath_bin(), "import", str(path), "--list"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    rows = []
    for line in r.stdout.splitlines():
        m = re.match(r"\s*#(\d+)\s+(\S+)\s+(\S+)\s+\[(.*)\] \.\. \[(.*)\]", line)
        if not m:
            assert not re.match(r"\s*#\d+", line), f"{path.name}: {line}"
            continue
        lo = [float(x) for x in m.group(4).split(",")]
        hi = [float(x) for x in m.group(5).split(",")]
        rows.append((int(m.group(1)), float(m.group(3)), lo, hi))
    return rows


def imported(path, ids, tmp_path):
    out = tmp_path / f"{path.stem}.json"
    args = [toolpath_bin(), "import", str(path), "-o", str(out)]
    for i in ids:
        args += ["--face", str(i)]
    r = subprocess.run(args, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    s = json.loads(out.read_text())
    return s if isinstance(s, list) else [s]


def check_face(name, ours, face, tol):
    """Our surface and trim against Open CASCADE's face, both ways."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepClass import BRepClass_FaceClassifier
    from OCP.BRepTools import BRepTools
    from OCP.GeomAPI import GeomAPI_ProjectPointOnSurf
    from OCP.TopAbs import TopAbs_IN, TopAbs_ON
    from OCP.gp import gp_Pnt, gp_Pnt2d

    mine = occ_surface(ours)
    theirs = BRep_Tool.Surface_s(face)
    bounds = BRepTools.UVBounds_s(face)
    trim = ours["trim"]
    border = boundary_points(mine, trim)
    worst = 0.0
    tested = 0
    # Our face's points: on Open CASCADE's surface, and inside its face
    # unless next to its boundary.
    u0, u1, v0, v1 = ours["knots_u"][0], ours["knots_u"][-1], ours["knots_v"][0], ours["knots_v"][-1]
    for i in range(GRID):
        for j in range(GRID):
            uv = (u0 + (u1 - u0) * (i + 0.5) / GRID, v0 + (v1 - v0) * (j + 0.5) / GRID)
            if not in_trim(trim, uv):
                continue
            p = mine.Value(*uv)
            proj = GeomAPI_ProjectPointOnSurf(p, theirs)
            assert proj.NbPoints() > 0, (name, uv)
            d = proj.LowerDistance()
            worst = max(worst, d)
            assert d <= tol, f"{name}: our point at {uv} is {d} mm off Open CASCADE's surface"
            a, b = in_period(theirs, proj.LowerDistanceParameters(), bounds)
            state = BRepClass_FaceClassifier(face, gp_Pnt2d(a, b), 1e-7).State()
            if state not in (TopAbs_IN, TopAbs_ON):
                gap = nearest(border, (p.X(), p.Y(), p.Z()))
                assert gap <= TRIM_MM, f"{name}: our point at {uv} lies outside its face, {gap} mm from our trim"
            tested += 1
    # Open CASCADE's face's points: on our surface and inside our trim
    # unless next to its boundary.
    a0, a1, b0, b1 = BRepTools.UVBounds_s(face)
    for i in range(GRID):
        for j in range(GRID):
            ab = (a0 + (a1 - a0) * (i + 0.5) / GRID, b0 + (b1 - b0) * (j + 0.5) / GRID)
            if BRepClass_FaceClassifier(face, gp_Pnt2d(*ab), 1e-7).State() != TopAbs_IN:
                continue
            q = theirs.Value(*ab)
            proj = GeomAPI_ProjectPointOnSurf(q, mine)
            assert proj.NbPoints() > 0, (name, ab)
            d = proj.LowerDistance()
            worst = max(worst, d)
            assert d <= tol, f"{name}: Open CASCADE's point at {ab} is {d} mm off our surface"
            uv = proj.LowerDistanceParameters()
            if not in_trim(trim, uv):
                gap = nearest(border, (q.X(), q.Y(), q.Z()))
                assert gap <= TRIM_MM, f"{name}: Open CASCADE's point at {ab} lies outside our trim, {gap} mm from it"
            tested += 1
    assert tested >= GRID, f"{name}: only {tested} points inside the face"
    return worst


def all_parts(parts, more_parts):
    (out, manifest), (more_out, more) = parts, more_parts
    return [out / p["file"] for p in manifest.values()] + [more_out / p["file"] for p in more.values()]


def test_every_face_imports_as_open_cascade_has_it(parts, more_parts, tmp_path):
    """Exact forms within 1e-6 mm, fitted offsets within their tolerance."""
    kinds = set()
    for path in all_parts(parts, more_parts):
        rows = listed_boxes(path)
        faces = occ_faces(path)
        assert len(rows) == len(faces), (path.name, len(rows), len(faces))
        matched = match_faces(rows, faces)
        text = path.read_text()
        for s, (face_id, *_rest) in zip(imported(path, [r[0] for r in rows], tmp_path), rows):
            surface_entity = re.search(rf"#{face_id} = ADVANCED_FACE\('[^']*',\([^)]*\),#(\d+)", text).group(1)
            kind = re.search(rf"#{surface_entity} = (\w+)", text)
            kind = kind.group(1) if kind else "complex"
            kinds.add(kind)
            tol = FIT_MM if kind == "OFFSET_SURFACE" and "B_SPLINE" in text else EXACT_MM
            check_face(f"{path.name} #{face_id} {kind}", s, matched[face_id], tol)
    for kind in ("PLANE", "CYLINDRICAL_SURFACE", "CONICAL_SURFACE", "SPHERICAL_SURFACE", "TOROIDAL_SURFACE",
                 "SURFACE_OF_REVOLUTION", "SURFACE_OF_LINEAR_EXTRUSION", "OFFSET_SURFACE",
                 "B_SPLINE_SURFACE_WITH_KNOTS", "complex"):
        assert kind in kinds, f"no {kind} face was checked"


def test_high_degree_fillets_evaluate_as_open_cascade_does(more_parts, tmp_path):
    """The mould's rational fillets of degree 10 and more: our evaluator
    (`toolpath inspect`) against Open CASCADE's at points of each, position
    to 1e-9 mm and normal to 1e-9."""
    from OCP.GeomLProp import GeomLProp_SLProps

    out, manifest = more_parts
    path = out / manifest["mould_cavity"]["file"]
    rows = listed_boxes(path)
    high = [s for s in imported(path, [r[0] for r in rows], tmp_path) if max(s["degree_u"], s["degree_v"]) >= 10]
    assert high and max(max(s["degree_u"], s["degree_v"]) for s in high) >= 11, [
        (s["degree_u"], s["degree_v"]) for s in high
    ]
    assert all(s.get("weights") for s in high)
    for k, s in enumerate(high):
        f = tmp_path / f"fillet_{k}.json"
        f.write_text(json.dumps(s))
        theirs = occ_surface(s)
        u0, u1, v0, v1 = s["knots_u"][0], s["knots_u"][-1], s["knots_v"][0], s["knots_v"][-1]
        for i in range(4):
            uv = (u0 + (u1 - u0) * (0.1 + 0.27 * i), v0 + (v1 - v0) * (0.83 - 0.23 * i))
            r = subprocess.run([toolpath_bin(), "inspect", str(f), "--uv", *map(str, uv)], capture_output=True, text=True)
            assert r.returncode == 0, r.stderr
            g = json.loads(r.stdout)
            props = GeomLProp_SLProps(theirs, uv[0], uv[1], 1, 1e-9)
            p, n = props.Value(), props.Normal()
            assert math.dist(g["point"], (p.X(), p.Y(), p.Z())) <= 1e-9, (s["name"], uv, g["point"])
            assert math.dist(g["normal"], (n.X(), n.Y(), n.Z())) <= 1e-9, (s["name"], uv, g["normal"])


def test_a_job_on_the_floor_plans_though_a_face_elsewhere_cannot_be_read(more_parts, tmp_path):
    """A face the job does not machine may be unreadable; the floor still
    plans, and a job on the unreadable face names it and why."""
    out, manifest = more_parts
    text = (out / manifest["mould_cavity"]["file"]).read_text()
    rows = listed_boxes(out / manifest["mould_cavity"]["file"])
    # The floor: the largest face between the bottom (z = 0) and the top (z = 60).
    floor = max((r for r in rows if r[2][2] > 15 and r[3][2] < 40), key=lambda r: r[1])[0]
    # Break one fillet: its complex surface entity loses its B_SPLINE_SURFACE
    # part's name, so no reader knows it.
    broken_face = next(r[0] for r in rows if r[0] != floor and "RATIONAL_B_SPLINE_SURFACE" in face_kind(text, r[0]))
    surface = re.search(rf"#{broken_face} = ADVANCED_FACE\('[^']*',\([^)]*\),#(\d+)", text).group(1)
    part = tmp_path / "mould.step"
    part.write_text(strip_bspline(text, surface))
    job = {
        "job_id": "mould_floor",
        "strategy": "iso_parametric",
        "tool": {"kind": "ball", "radius": 6.0},
        "scallop": 0.1,
    }
    (tmp_path / "floor.json").write_text(json.dumps({**job, "surface": {"file": "mould.step", "face": floor}}))
    r = subprocess.run([toolpath_bin(), "plan", str(tmp_path / "floor.json"), "-o", str(tmp_path / "r.json"), "--no-verify"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    (tmp_path / "fillet.json").write_text(json.dumps({**job, "surface": {"file": "mould.step", "face": broken_face}}))
    r = subprocess.run([toolpath_bin(), "plan", str(tmp_path / "fillet.json"), "-o", str(tmp_path / "r2.json")],
                       capture_output=True, text=True)
    assert r.returncode == 2, r.stderr
    assert f"surface (mould.step #{surface} " in r.stderr and "not a supported surface" in r.stderr, r.stderr


def face_kind(text, face_id):
    surface = re.search(rf"#{face_id} = ADVANCED_FACE\('[^']*',\([^)]*\),#(\d+)", text).group(1)
    m = re.search(rf"#{surface} = (.*?);", text, re.S)
    return m.group(1)


def strip_bspline(text, surface):
    """The complex entity `surface` with its B_SPLINE_SURFACE part renamed,
    so that no B-spline reader recognises it."""
    m = re.search(rf"#{surface} = \((.*?)\);", text, re.S)
    body = re.sub(r"(?<![A-Z_])B_SPLINE_SURFACE\(", "B_SPLINE_SURFACE_UNKNOWN(", m.group(1))
    return text[: m.start(1)] + body + text[m.end(1):]
