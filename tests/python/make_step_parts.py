"""Writes the STEP parts of the import tests with Open CASCADE (cadquery-ocp)
and their exact face areas (BRepGProp), as `parts.json` beside them.

    python3 tests/python/make_step_parts.py OUT_DIR
    python3 tests/python/make_step_parts.py --more OUT_DIR

The second form writes the parts that are built at test time only (nothing
of them is committed), listed in `more_parts.json`:
- mould_cavity: a 160 x 120 x 60 mm block with a 35 mm deep cavity, walls
  drafted 7 degrees, a freeform B-spline floor, 10 mm corner and 6 mm floor
  fillets (Open CASCADE writes the floor fillets as rational B-splines of
  degree up to 14, complex STEP entities);

Each part is one face in its own file:
- freeform: a bicubic B-spline face trimmed by a circle in (u, v) with a
  circular hole (pcurves written);
- freeform_nopcurves: the same face written without pcurves;
- rational_reversed: a rational B-spline face with a curved outer loop,
  its face orientation reversed;
- plane_hole: a 100 x 60 mm plane with a hole of radius 15 mm;
- plane_hole_inch: the same face written in inches;
- cylinder: a 120 degree patch of a cylinder of radius 20 mm, 50 mm high;
- cone: a 120 degree patch of a cone frustum, radii 30 and 15 mm, 40 mm high;
- sphere_zone: a 90 degree patch of a sphere of radius 25 mm between
  latitudes -30 and 45 degrees;
- sphere_pole: a 90 degree patch of the same sphere from latitude 30
  degrees up to its north pole (a loop through the pole);
- torus: a 100 degree patch of a torus, radii 40 and 10 mm, tube angles
  -60 to 80 degrees (its outer equator inside);
- revolution: a cubic B-spline profile in the xz plane turned 90 degrees
  about z (a SURFACE_OF_REVOLUTION);
- extrusion: a cubic B-spline curve in the xy plane swept along the oblique
  vector (0, 12, 40) (a SURFACE_OF_LINEAR_EXTRUSION);
- extrusion_arc: a 200 degree arc of an ellipse (semi-axes 30 and 18 mm) in
  the xy plane swept along (10, 0, 35);
- offset_bspline: a bicubic B-spline face offset by 3 mm (an
  OFFSET_SURFACE on a B-spline: fitted on import);
- offset_cylinder, offset_torus, offset_sphere, offset_cone: offsets of a
  cylinder of radius 20 mm by 2.5 mm, a torus (radii 40 and 10 mm) by
  -2 mm, a sphere of radius 25 mm by -5 mm and a cone (semi-angle
  atan(15 / 40), radius 30 mm at its placement) by 2 mm (exact on import);
- periodic_bspline: a B-spline surface periodic in u (written with an
  unclamped uniform knot vector).
"""

import json
import math
import sys
from pathlib import Path

from OCP.BRepAlgoAPI import BRepAlgoAPI_Common, BRepAlgoAPI_Cut
from OCP.BRepBuilderAPI import (
    BRepBuilderAPI_MakeEdge,
    BRepBuilderAPI_MakeFace,
    BRepBuilderAPI_MakePolygon,
    BRepBuilderAPI_MakeWire,
)
from OCP.BRepFilletAPI import BRepFilletAPI_MakeFillet
from OCP.BRepOffsetAPI import BRepOffsetAPI_ThruSections
from OCP.BRepAdaptor import BRepAdaptor_Curve
from OCP.GeomAPI import GeomAPI_PointsToBSplineSurface
from OCP.BRepGProp import BRepGProp
from OCP.BRepLib import BRepLib
from OCP.BRepPrimAPI import (
    BRepPrimAPI_MakeBox,
    BRepPrimAPI_MakeHalfSpace,
    BRepPrimAPI_MakeCone,
    BRepPrimAPI_MakePrism,
    BRepPrimAPI_MakeCylinder,
    BRepPrimAPI_MakeRevol,
    BRepPrimAPI_MakeSphere,
    BRepPrimAPI_MakeTorus,
)
from OCP.Geom import Geom_BSplineCurve
from OCP.collections import Array1_double, Array1_int, Array2_double, Array2_gp_Pnt
from OCP.Geom import (
    Geom_BSplineSurface,
    Geom_ConicalSurface,
    Geom_CylindricalSurface,
    Geom_OffsetSurface,
    Geom_SphericalSurface,
    Geom_ToroidalSurface,
)
from OCP.Geom2d import Geom2d_Circle, Geom2d_Ellipse
from OCP.GeomAbs import (
    GeomAbs_Cone,
    GeomAbs_Cylinder,
    GeomAbs_Sphere,
    GeomAbs_SurfaceOfExtrusion,
    GeomAbs_SurfaceOfRevolution,
    GeomAbs_Torus,
)
from OCP.BRepAdaptor import BRepAdaptor_Surface
from OCP.collections import Array1_gp_Pnt
from OCP.gp import gp_Ax1, gp_Ax2, gp_Ax22d, gp_Ax3, gp_Dir, gp_Dir2d, gp_Elips, gp_Pnt, gp_Pnt2d, gp_Vec
from OCP.GProp import GProp_GProps
from OCP.IFSelect import IFSelect_RetDone
from OCP.Interface import Interface_Static
from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer
from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
from OCP.TopExp import TopExp_Explorer
from OCP.TopoDS import TopoDS


def array1(values, kind=Array1_double):
    a = kind(1, len(values))
    for i, x in enumerate(values):
        a.SetValue(i + 1, x)
    return a


def bspline_surface(rational):
    """Clamped bicubic over [0, 1]^2, 5 x 5 poles over 100 x 80 mm."""
    poles = Array2_gp_Pnt(1, 5, 1, 5)
    weights = Array2_double(1, 5, 1, 5)
    for i in range(5):
        for j in range(5):
            x, y = 25.0 * i, 20.0 * j
            poles.SetValue(i + 1, j + 1, gp_Pnt(x, y, 8.0 * math.sin(x / 30.0) * math.cos(y / 25.0)))
            weights.SetValue(i + 1, j + 1, 1.0 + 0.5 * ((i + 2 * j) % 3) / 2.0)
    knots = array1([0.0, 0.5, 1.0])
    mults = array1([4, 1, 4], Array1_int)
    if rational:
        return Geom_BSplineSurface(poles, weights, knots, knots, mults, mults, 3, 3)
    return Geom_BSplineSurface(poles, knots, knots, mults, mults, 3, 3)


def uv_wire(curve2d, surface):
    edge = BRepBuilderAPI_MakeEdge(curve2d, surface).Edge()
    return BRepBuilderAPI_MakeWire(edge).Wire()


def circle2d(cx, cy, r):
    return Geom2d_Circle(gp_Ax22d(gp_Pnt2d(cx, cy), gp_Dir2d(1, 0), gp_Dir2d(0, 1)), r)


def freeform_face(rational):
    s = bspline_surface(rational)
    if rational:
        outer = Geom2d_Ellipse(gp_Ax22d(gp_Pnt2d(0.5, 0.5), gp_Dir2d(1, 0), gp_Dir2d(0, 1)), 0.45, 0.35)
    else:
        outer = circle2d(0.5, 0.5, 0.45)
    make = BRepBuilderAPI_MakeFace(s, uv_wire(outer, s), True)
    if not rational:
        hole = uv_wire(circle2d(0.6, 0.5, 0.15), s)
        hole.Reverse()
        make.Add(hole)
    face = make.Face()
    BRepLib.BuildCurves3d_s(face)
    return face


def plane_face():
    w = BRepBuilderAPI_MakeWire()
    corners = [gp_Pnt(0, 0, 0), gp_Pnt(100, 0, 0), gp_Pnt(100, 60, 0), gp_Pnt(0, 60, 0)]
    for a, b in zip(corners, corners[1:] + corners[:1]):
        w.Add(BRepBuilderAPI_MakeEdge(a, b).Edge())
    make = BRepBuilderAPI_MakeFace(w.Wire(), True)
    from OCP.gp import gp_Circ

    circ = gp_Circ(gp_Ax2(gp_Pnt(35, 30, 0), gp_Dir(0, 0, 1)), 15.0)
    hole = BRepBuilderAPI_MakeWire(BRepBuilderAPI_MakeEdge(circ).Edge()).Wire()
    hole.Reverse()
    make.Add(hole)
    return make.Face()


def cylinder_face():
    solid = BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)), 20.0, 50.0, 2.0 * math.pi / 3.0).Shape()
    ex = TopExp_Explorer(solid, TopAbs_FACE)
    while ex.More():
        f = TopoDS.Face(ex.Current())
        if BRepAdaptor_Surface(f).GetType() == GeomAbs_Cylinder:
            return f
        ex.Next()
    raise RuntimeError("no cylindrical face")


def face_of(shape, kind):
    ex = TopExp_Explorer(shape, TopAbs_FACE)
    while ex.More():
        f = TopoDS.Face(ex.Current())
        if BRepAdaptor_Surface(f).GetType() == kind:
            return f
        ex.Next()
    raise RuntimeError(f"no face of type {kind}")


def axes():
    return gp_Ax2(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1))


def cone_face():
    solid = BRepPrimAPI_MakeCone(axes(), 30.0, 15.0, 40.0, 2.0 * math.pi / 3.0).Shape()
    return face_of(solid, GeomAbs_Cone)


def sphere_face(lat0, lat1):
    solid = BRepPrimAPI_MakeSphere(axes(), 25.0, math.radians(lat0), math.radians(lat1), math.pi / 2.0).Shape()
    return face_of(solid, GeomAbs_Sphere)


def torus_face():
    solid = BRepPrimAPI_MakeTorus(axes(), 40.0, 10.0, math.radians(-60), math.radians(80), math.radians(100)).Shape()
    return face_of(solid, GeomAbs_Torus)


def revolution_face():
    pts = [(20, 0), (28, 10), (18, 25), (30, 40), (24, 50)]
    poles = Array1_gp_Pnt(1, len(pts))
    for i, (x, z) in enumerate(pts):
        poles.SetValue(i + 1, gp_Pnt(x, 0, z))
    knots = array1([0.0, 0.5, 1.0])
    mults = array1([4, 1, 4], Array1_int)
    curve = Geom_BSplineCurve(poles, knots, mults, 3)
    edge = BRepBuilderAPI_MakeEdge(curve).Edge()
    shape = BRepPrimAPI_MakeRevol(edge, gp_Ax1(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)), math.pi / 2.0).Shape()
    return face_of(shape, GeomAbs_SurfaceOfRevolution)


def extrusion_face():
    pts = [(0, 0), (20, 15), (45, -10), (70, 12), (90, 0)]
    poles = Array1_gp_Pnt(1, len(pts))
    for i, (x, y) in enumerate(pts):
        poles.SetValue(i + 1, gp_Pnt(x, y, 0))
    curve = Geom_BSplineCurve(poles, array1([0.0, 0.5, 1.0]), array1([4, 1, 4], Array1_int), 3)
    edge = BRepBuilderAPI_MakeEdge(curve).Edge()
    return face_of(BRepPrimAPI_MakePrism(edge, gp_Vec(0, 12, 40)).Shape(), GeomAbs_SurfaceOfExtrusion)


def extrusion_arc_face():
    ellipse = gp_Elips(gp_Ax2(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1), gp_Dir(1, 0, 0)), 30.0, 18.0)
    edge = BRepBuilderAPI_MakeEdge(ellipse, 0.0, math.radians(200)).Edge()
    return face_of(BRepPrimAPI_MakePrism(edge, gp_Vec(10, 0, 35)).Shape(), GeomAbs_SurfaceOfExtrusion)


def rectangle_wire(z, x0, y0, x1, y1):
    p = BRepBuilderAPI_MakePolygon()
    for x, y in [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]:
        p.Add(gp_Pnt(x, y, z))
    p.Close()
    return p.Wire()


def edges_of(shape):
    ex = TopExp_Explorer(shape, TopAbs_EDGE)
    out = []
    while ex.More():
        out.append(TopoDS.Edge(ex.Current()))
        ex.Next()
    return out


def mould_cavity():
    """The block with its drafted, filleted cavity on a freeform floor."""
    length, width, height, depth, margin = 160.0, 120.0, 60.0, 35.0, 25.0
    draft = math.radians(7.0)
    floor_z = height - depth
    # The cavity's tool: a drafted loft from below the floor to above the
    # top, cut by the half space above the freeform floor.
    top, bottom = height + 5.0, floor_z - 10.0
    grow = lambda z: (z - floor_z) * math.tan(draft)
    loft = BRepOffsetAPI_ThruSections(True, True)
    for z in (bottom, top):
        g = grow(z)
        loft.AddWire(rectangle_wire(z, margin - g, margin - g, length - margin + g, width - margin + g))
    loft.Build()
    n = 6
    pts = Array2_gp_Pnt(1, n, 1, n)
    for i in range(n):
        for j in range(n):
            x = -10.0 + (length + 20.0) * i / (n - 1)
            y = -10.0 + (width + 20.0) * j / (n - 1)
            pts.SetValue(i + 1, j + 1, gp_Pnt(x, y, floor_z + 4.0 * math.sin(x / 40.0) * math.cos(y / 35.0)))
    floor = BRepBuilderAPI_MakeFace(GeomAPI_PointsToBSplineSurface(pts, 3, 3).Surface(), 1e-6).Face()
    above = BRepPrimAPI_MakeHalfSpace(floor, gp_Pnt(length / 2, width / 2, height + 50.0)).Solid()
    tool = BRepAlgoAPI_Common(loft.Shape(), above).Shape()
    part = BRepAlgoAPI_Cut(BRepPrimAPI_MakeBox(gp_Pnt(0, 0, 0), length, width, height).Shape(), tool).Shape()

    def in_cavity(p):
        return margin - 8 < p.X() < length - margin + 8 and margin - 8 < p.Y() < width - margin + 8

    def fillet(shape, radius, chosen):
        f = BRepFilletAPI_MakeFillet(shape)
        for e in edges_of(shape):
            c = BRepAdaptor_Curve(e)
            a, b = c.Value(c.FirstParameter()), c.Value(c.LastParameter())
            mid = c.Value(0.5 * (c.FirstParameter() + c.LastParameter()))
            if in_cavity(mid) and chosen(a, b, mid):
                f.Add(radius, e)
        f.Build()
        if not f.IsDone():
            raise RuntimeError(f"fillet of {radius} mm failed")
        return f.Shape()

    part = fillet(part, 10.0, lambda a, b, mid: abs(a.Z() - b.Z()) > 10.0 and mid.Z() < height - 0.1)
    return fillet(part, 6.0, lambda a, b, mid: mid.Z() < floor_z + 6.0)


def bspline_patch_surface():
    """A bicubic B-spline over 100 x 80 mm (clamped, one interior knot)."""
    poles = Array2_gp_Pnt(1, 5, 1, 5)
    for i in range(5):
        for j in range(5):
            poles.SetValue(i + 1, j + 1, gp_Pnt(25.0 * i, 20.0 * j, 8.0 * math.sin(i) * math.cos(j)))
    knots = array1([0.0, 0.5, 1.0])
    mults = array1([4, 1, 4], Array1_int)
    return Geom_BSplineSurface(poles, knots, knots, mults, mults, 3, 3)


def offset_bspline_face():
    return BRepBuilderAPI_MakeFace(Geom_OffsetSurface(bspline_patch_surface(), 3.0), 0.1, 0.9, 0.1, 0.9, 1e-7).Face()


def offset_cylinder_face():
    cylinder = Geom_CylindricalSurface(gp_Ax3(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)), 20.0)
    return BRepBuilderAPI_MakeFace(Geom_OffsetSurface(cylinder, 2.5), 0.0, 2.0, 0.0, 30.0, 1e-7).Face()


def offset_sphere_face():
    sphere = Geom_SphericalSurface(gp_Ax3(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)), 25.0)
    return BRepBuilderAPI_MakeFace(Geom_OffsetSurface(sphere, -5.0), 0.3, 1.8, -0.4, 0.9, 1e-7).Face()


def offset_cone_face():
    cone = Geom_ConicalSurface(gp_Ax3(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)), math.atan(15.0 / 40.0), 30.0)
    return BRepBuilderAPI_MakeFace(Geom_OffsetSurface(cone, 2.0), 0.0, 2.0, -10.0, 30.0, 1e-7).Face()


def offset_torus_face():
    torus = Geom_ToroidalSurface(gp_Ax3(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)), 40.0, 10.0)
    return BRepBuilderAPI_MakeFace(Geom_OffsetSurface(torus, -2.0), 0.2, 1.6, -1.0, 1.2, 1e-7).Face()


def periodic_bspline_face():
    """A closed wavy tube, periodic in u (8 poles round it), its u range
    not starting at a knot."""
    poles = Array2_gp_Pnt(1, 8, 1, 4)
    for i in range(8):
        for j in range(4):
            t = 2.0 * math.pi * i / 8
            r = 20.0 + 3.0 * math.cos(3.0 * t)
            poles.SetValue(i + 1, j + 1, gp_Pnt(r * math.cos(t), r * math.sin(t), 10.0 * j + 2.0 * math.sin(t + j)))
    ku, mu = array1([float(i) for i in range(9)]), array1([1] * 9, Array1_int)
    kv, mv = array1([0.0, 1.0]), array1([4, 4], Array1_int)
    surface = Geom_BSplineSurface(poles, ku, kv, mu, mv, 3, 3, True, False)
    return BRepBuilderAPI_MakeFace(surface, 0.5, 6.5, 0.0, 1.0, 1e-7).Face()


def more_parts(out):
    out.mkdir(parents=True, exist_ok=True)
    parts = {"mould_cavity": mould_cavity()}
    manifest = {}
    for name, shape in parts.items():
        write(shape, out / f"{name}.step")
        faces = []
        ex = TopExp_Explorer(shape, TopAbs_FACE)
        while ex.More():
            faces.append(area(ex.Current()))
            ex.Next()
        manifest[name] = {"file": f"{name}.step", "face_areas_mm2": faces}
    (out / "more_parts.json").write_text(json.dumps(manifest, indent=2, sort_keys=True) + "\n")


def area(face):
    props = GProp_GProps()
    BRepGProp.SurfaceProperties_s(face, props)
    return props.Mass()


def write(face, path, unit="MM", pcurves=True):
    Interface_Static.SetCVal_s("write.step.unit", unit)
    Interface_Static.SetIVal_s("write.surfacecurve.mode", 1 if pcurves else 0)
    w = STEPControl_Writer()
    w.Transfer(face, STEPControl_AsIs)
    if w.Write(str(path)) != IFSelect_RetDone:
        raise RuntimeError(f"writing {path} failed")


def main(out):
    out.mkdir(parents=True, exist_ok=True)
    reversed_face = freeform_face(True)
    reversed_face.Reverse()
    parts = {
        "freeform": (freeform_face(False), {}),
        "freeform_nopcurves": (freeform_face(False), {"pcurves": False}),
        "rational_reversed": (reversed_face, {}),
        "plane_hole": (plane_face(), {}),
        "plane_hole_inch": (plane_face(), {"unit": "INCH"}),
        "cylinder": (cylinder_face(), {}),
        "cone": (cone_face(), {}),
        "sphere_zone": (sphere_face(-30, 45), {}),
        "sphere_pole": (sphere_face(30, 90), {}),
        "torus": (torus_face(), {}),
        "revolution": (revolution_face(), {}),
        "extrusion": (extrusion_face(), {}),
        "extrusion_arc": (extrusion_arc_face(), {}),
        "offset_bspline": (offset_bspline_face(), {}),
        "offset_cylinder": (offset_cylinder_face(), {}),
        "offset_torus": (offset_torus_face(), {}),
        "offset_sphere": (offset_sphere_face(), {}),
        "offset_cone": (offset_cone_face(), {}),
        "periodic_bspline": (periodic_bspline_face(), {}),
    }
    manifest = {}
    for name, (face, options) in parts.items():
        write(face, out / f"{name}.step", **options)
        manifest[name] = {"file": f"{name}.step", "area_mm2": area(face)}
    (out / "parts.json").write_text(json.dumps(manifest, indent=2, sort_keys=True) + "\n")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--more":
        more_parts(Path(sys.argv[2] if len(sys.argv) > 2 else "."))
    else:
        main(Path(sys.argv[1] if len(sys.argv) > 1 else "."))
