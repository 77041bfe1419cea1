"""Points on the faces of an Open CASCADE solid, dense enough that every point
of every face lies within a known covering radius of a sample, with outward
normals, grouped into cells for a coarse-to-fine search.

Each face is sampled on a grid of its (u, v) box, the grid's steps chosen from
the largest speed |S_u|, |S_v| found on a 17 x 17 probe grid (times 1.25) so
that neighbouring samples are at most `spacing` mm apart (planes and
cylinders: their constant speeds, no margin); a grid point is kept where
`IntTools_FClass2d` puts it IN or ON the face. Every edge is sampled at most
spacing / 2 apart along its 3-D curve (the same speed rule), once for each
face it bounds, so that a face point next to its boundary is near a sample
too. Covering radius: every point of a grid cell is within `spacing` of one
of its corners; if that corner is off the face, the face's boundary crosses
the way to it, and an edge sample lies within spacing / 4 of that crossing:
`COVERING * spacing` with COVERING = 1.25.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from OCP.BRepAdaptor import BRepAdaptor_Curve, BRepAdaptor_Curve2d, BRepAdaptor_Surface
from OCP.GeomAbs import GeomAbs_Cylinder, GeomAbs_Plane
from OCP.gp import gp_Pnt, gp_Pnt2d, gp_Vec
from OCP.IntTools import IntTools_FClass2d
from OCP.TopAbs import TopAbs_EDGE, TopAbs_IN, TopAbs_ON, TopAbs_REVERSED
from OCP.TopExp import TopExp_Explorer
from OCP.TopoDS import TopoDS

CLASSIFY_TOL = 1e-7  # (u, v) tolerance of IntTools_FClass2d
SPEED_MARGIN = 1.25  # over the largest speed seen on the probe grid (curved surfaces)
PROBE = 17  # probe grid for the speeds, per direction
COVERING = 1.25  # covering radius of the samples, in spacings (module doc)


@dataclass
class FaceContext:
    """What the refinement needs of one face."""

    face_id: int
    face: object  # TopoDS_Face
    surface: object  # BRepAdaptor_Surface
    classifier: object  # IntTools_FClass2d
    bounds: tuple  # u0, u1, v0, v1
    steps: tuple  # du, dv of its grid
    reversed: bool
    spacing: float  # mm between its samples, and their covering radius

    def inside(self, u, v):
        return self.classifier.Perform(gp_Pnt2d(u, v)) in (TopAbs_IN, TopAbs_ON)

    def point(self, u, v):
        p = self.surface.Value(u, v)
        return (p.X(), p.Y(), p.Z())

    def coords(self, u, v):
        """S(u, v) as a gp_Pnt (no tuple built)."""
        return self.surface.Value(u, v)

    def normal(self, u, v):
        p, du, dv = gp_Pnt(), gp_Vec(), gp_Vec()
        self.surface.D1(u, v, p, du, dv)
        n = du.Crossed(dv)
        m = n.Magnitude()
        if m < 1e-14:
            return (0.0, 0.0, 0.0)
        s = -1.0 / m if self.reversed else 1.0 / m
        return (n.X() * s, n.Y() * s, n.Z() * s)


@dataclass
class EdgeContext:
    edge: object  # TopoDS_Edge
    curve: object  # BRepAdaptor_Curve
    bounds: tuple  # first, last
    step: float  # parameter step of its samples

    def point(self, t):
        p = self.curve.Value(t)
        return (p.X(), p.Y(), p.Z())


@dataclass
class Samples:
    """Samples of the faces: `points`, outward `normals`, `face` (index into
    `faces`), `uv` (interior samples) or `edge` and `t` (edge samples,
    `edge` -1 for interior ones), `rho` (the covering radius of the
    sample's face)."""

    points: np.ndarray
    normals: np.ndarray
    face: np.ndarray
    uv: np.ndarray
    edge: np.ndarray
    t: np.ndarray
    rho: np.ndarray
    faces: list  # FaceContext per face index
    edges: list  # EdgeContext per edge index


def _speeds(ad, bounds):
    u0, u1, v0, v1 = bounds
    su = sv = 0.0
    p, du, dv = gp_Pnt(), gp_Vec(), gp_Vec()
    for i in range(PROBE):
        for j in range(PROBE):
            ad.D1(u0 + (u1 - u0) * i / (PROBE - 1), v0 + (v1 - v0) * j / (PROBE - 1), p, du, dv)
            su, sv = max(su, du.Magnitude()), max(sv, dv.Magnitude())
    return su, sv


def _curve_speed(curve, a, b):
    """The largest |C'(t)| on 65 probe points, times SPEED_MARGIN."""
    p, d = gp_Pnt(), gp_Vec()
    top = 0.0
    for i in range(65):
        curve.D1(a + (b - a) * i / 64, p, d)
        top = max(top, d.Magnitude())
    return SPEED_MARGIN * top


def face_context(face_id, face, spacing):
    ad = BRepAdaptor_Surface(face)
    bounds = (ad.FirstUParameter(), ad.LastUParameter(), ad.FirstVParameter(), ad.LastVParameter())
    su, sv = _speeds(ad, bounds)
    # Planes and cylinders have constant speeds along u and v: no margin.
    margin = 1.0 if ad.GetType() in (GeomAbs_Plane, GeomAbs_Cylinder) else SPEED_MARGIN
    nu = max(2, math.ceil(margin * su * (bounds[1] - bounds[0]) / spacing) + 1)
    nv = max(2, math.ceil(margin * sv * (bounds[3] - bounds[2]) / spacing) + 1)
    steps = ((bounds[1] - bounds[0]) / (nu - 1), (bounds[3] - bounds[2]) / (nv - 1))
    cls = IntTools_FClass2d(face, CLASSIFY_TOL)
    return FaceContext(face_id, face, ad, cls, bounds, steps, face.Orientation() == TopAbs_REVERSED, spacing)


def _face_grid(ctx):
    u0, u1, v0, v1 = ctx.bounds
    nu = round((u1 - u0) / ctx.steps[0]) + 1
    nv = round((v1 - v0) / ctx.steps[1]) + 1
    pts, nrm, uvs = [], [], []
    p, du, dv = gp_Pnt(), gp_Vec(), gp_Vec()
    for u in np.linspace(u0, u1, nu):
        for v in np.linspace(v0, v1, nv):
            if not ctx.inside(u, v):
                continue
            ctx.surface.D1(u, v, p, du, dv)
            n = du.Crossed(dv)
            m = n.Magnitude()
            s = 0.0 if m < 1e-14 else (-1.0 / m if ctx.reversed else 1.0 / m)
            pts.append((p.X(), p.Y(), p.Z()))
            nrm.append((n.X() * s, n.Y() * s, n.Z() * s))
            uvs.append((u, v))
    return pts, nrm, uvs


def _edges_of(face):
    out = []
    ex = TopExp_Explorer(face, TopAbs_EDGE)
    while ex.More():
        e = TopoDS.Edge(ex.Current())
        if not any(e.IsSame(o) for o in out):
            out.append(e)
        ex.Next()
    return out


def _bounds(face, edge):
    return any(e.IsSame(edge) for e in _edges_of(face))


def sample_faces(faces, spacing, face_spacing=None):
    """Samples of `faces` ({id: TopoDS_Face}), in ascending id order, every
    `spacing` mm (`face_spacing`: {id: mm} for some faces)."""
    ids = sorted(faces)
    face_spacing = face_spacing or {}
    ctxs = [face_context(i, faces[i], face_spacing.get(i, spacing)) for i in ids]
    pts, nrm, fidx, uvs, eidx, ts = [], [], [], [], [], []
    edges = []
    for k, ctx in enumerate(ctxs):
        p, n, uv = _face_grid(ctx)
        pts += p
        nrm += n
        uvs += uv
        fidx += [k] * len(p)
        eidx += [-1] * len(p)
        ts += [0.0] * len(p)
        for e in _edges_of(ctx.face):
            j = next((m for m, o in enumerate(edges) if o.edge.IsSame(e)), None)
            if j is None:
                curve = BRepAdaptor_Curve(e)
                a, b = curve.FirstParameter(), curve.LastParameter()
                # Each edge at half the finest spacing of the faces it bounds.
                step = 0.5 * min(face_spacing.get(i, spacing) for i in ids if _bounds(faces[i], e))
                n_t = max(2, math.ceil(_curve_speed(curve, a, b) * (b - a) / step) + 1)
                edges.append(EdgeContext(e, curve, (a, b), (b - a) / (n_t - 1)))
                j = len(edges) - 1
            ec = edges[j]
            c2d = BRepAdaptor_Curve2d(e, ctx.face)
            n_t = round((ec.bounds[1] - ec.bounds[0]) / ec.step) + 1
            for t in np.linspace(ec.bounds[0], ec.bounds[1], n_t):
                uv2 = c2d.Value(t)
                pts.append(ec.point(t))
                nrm.append(ctx.normal(uv2.X(), uv2.Y()))
                uvs.append((uv2.X(), uv2.Y()))
                fidx.append(k)
                eidx.append(j)
                ts.append(t)
    fidx = np.array(fidx, np.int64)
    return Samples(
        rho=COVERING * np.array([c.spacing for c in ctxs])[fidx] if len(fidx) else np.zeros(0),
        points=np.array(pts, float),
        normals=np.array(nrm, float),
        face=fidx,
        uv=np.array(uvs, float),
        edge=np.array(eidx, np.int64),
        t=np.array(ts, float),
        faces=ctxs,
        edges=edges,
    )


@dataclass
class Cells:
    """Samples grouped by a cubic grid of `size` mm: `rep` (the cell's mean
    point), `radius` (its farthest member from `rep`), members
    `order[start[c]:start[c + 1]]`."""

    rep: np.ndarray
    radius: np.ndarray
    order: np.ndarray
    start: np.ndarray

    @staticmethod
    def of(points, size):
        keys = np.floor(points / size).astype(np.int64)
        _, inverse = np.unique(keys, axis=0, return_inverse=True)
        inverse = inverse.ravel()
        order = np.argsort(inverse, kind="stable")
        counts = np.bincount(inverse)
        start = np.concatenate([[0], np.cumsum(counts)])
        rep = np.zeros((len(counts), 3))
        np.add.at(rep, inverse, points)
        rep /= counts[:, None]
        radius = np.zeros(len(counts))
        np.maximum.at(radius, inverse, np.linalg.norm(points - rep[inverse], axis=1))
        return Cells(rep, radius, order, start)

    def members(self, cells):
        """Sample indices of the given cells."""
        if len(cells) == 0:
            return np.zeros(0, np.int64)
        lo, hi = self.start[cells], self.start[cells + 1]
        n = hi - lo
        offs = np.repeat(lo - np.concatenate([[0], np.cumsum(n)[:-1]]), n)
        return self.order[np.arange(n.sum()) + offs]
