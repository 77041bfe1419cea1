"""Writes the STEP parts of the import tests with Open CASCADE (cadquery-ocp)
and their exact face areas (BRepGProp), as `parts.json` beside them.

    python3 tests/python/make_step_parts.py OUT_DIR

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
  the xy plane swept along (10, 0, 35).
"""

import json
import math
import sys
from pathlib import Path

from OCP.BRepBuilderAPI import (
    BRepBuilderAPI_MakeEdge,
    BRepBuilderAPI_MakeFace,
    BRepBuilderAPI_MakeWire,
)
from OCP.BRepGProp import BRepGProp
from OCP.BRepLib import BRepLib
from OCP.BRepPrimAPI import (
    BRepPrimAPI_MakeCone,
    BRepPrimAPI_MakePrism,
    BRepPrimAPI_MakeCylinder,
    BRepPrimAPI_MakeRevol,
    BRepPrimAPI_MakeSphere,
    BRepPrimAPI_MakeTorus,
)
from OCP.Geom import Geom_BSplineCurve
from OCP.collections import Array1_double, Array1_int, Array2_double, Array2_gp_Pnt
from OCP.Geom import Geom_BSplineSurface
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
from OCP.gp import gp_Ax1, gp_Ax2, gp_Ax22d, gp_Dir, gp_Dir2d, gp_Elips, gp_Pnt, gp_Pnt2d, gp_Vec
from OCP.GProp import GProp_GProps
from OCP.IFSelect import IFSelect_RetDone
from OCP.Interface import Interface_Static
from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer
from OCP.TopAbs import TopAbs_FACE
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
    }
    manifest = {}
    for name, (face, options) in parts.items():
        write(face, out / f"{name}.step", **options)
        manifest[name] = {"file": f"{name}.step", "area_mm2": area(face)}
    (out / "parts.json").write_text(json.dumps(manifest, indent=2, sort_keys=True) + "\n")


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "."))
