"""An independent check of planned tool poses against the exact Open CASCADE
solid of a part: how deep the cutter enters the part through the faces being
machined (gouge) and through every other face (the check faces), and the
clearance of every shank and holder segment to the part, per pose of the
result's passes and of its links. It shares nothing with the planner.

Measures. For a posed tool segment T (tool_assembly.py: its exact signed
distance sd_T, closed form) and a face F of the part, the oracle finds
m(T, F) = min over the points p of F of sd_T(p): positive, the clearance
between T and F; negative, -m is how deep F lies inside T (a cutter whose
side is pushed 0.5 mm into a wall reads -0.5; a corner cut reads less than
the cutter's reach below the face, at most the segment's inner radius).
Where the cutter cuts, `material_depth` also measures how far it reaches
below the part's surface: the largest distance to the nearest face sample
of the cutter's boundary points inside the solid (within the covering
radius; this is the figure that exceeds the cutter's radius when a run-in
plunges into a wall). A segment wholly inside the material (no face near
it) is found by classifying its axis's middle point and reads minus that
point's depth below the surface (`buried`).

Search. sd_T is 1-Lipschitz, so samples of the faces (face_samples.py,
covering radius rho per face) bound it: the smallest sample value s of a
face gives s - rho <= m <= s. Samples are grouped into cells of a few mm;
per pose a KD-tree (scipy cKDTree) over the cells' centres finds the cells
near the segment, a cell is opened only when its centre's value minus its
radius is below band + rho, and faces whose samples may come below the band
(`exact_band`) are refined: the smallest sd_T over the exact surface
S(u, v) (Nelder-Mead in (u, v) from the best samples, restarted once, its
end kept where IntTools_FClass2d puts it on the face) and over the exact
edge curves (bounded Brent from the best edge samples). Faces are refined in
order of their sample value and skipped once s - rho cannot beat the best
refined value. Within the band a figure is exact to the optimiser's
tolerance (about 1e-4 mm; the self-tests hold it to 1e-3 mm against
constructions, BRepExtrema and a brute force over a fine tessellation);
beyond the band the reported clearance is the lower bound s - rho
(`exact` false). BRepExtrema_DistShapeShape between the segment's primitive
solids and the part (`extrema_clearance`) gives positive clearances
independently; at tens of milliseconds a call it is too slow for every pose.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from OCP.BRepClass3d import BRepClass3d_SolidClassifier
from OCP.BRepExtrema import BRepExtrema_DistShapeShape
from OCP.gp import gp_Pnt
from OCP.TopAbs import TopAbs_IN
from scipy.optimize import minimize_scalar
from scipy.spatial import cKDTree

from face_samples import Cells, sample_faces
from tool_assembly import ToolAssembly

DEFAULT_SPACING = 0.5  # mm between face samples
DEFAULT_BAND = 1.0  # mm: clearances below it are exact
CELL_SIZE = 3.0  # mm, the coarse cells
MAX_SEEDS = 3  # refinement starts per face and pose
MATERIAL_FROM_MM = 0.01  # a cut this deep gets its material depth measured
SEED_SEPARATION = 4.0  # spacings between refinement starts


@dataclass
class SegmentCheck:
    """One segment against one group of faces at one pose: the smallest
    signed distance `value` (mm), the face where it is (`face`, a face id or
    None), whether it is exact (within the band) and whether the segment lies
    wholly inside the material."""

    value: float
    face: int | None
    exact: bool
    buried: bool = False


@dataclass
class MaterialDepth:
    """How far a posed segment reaches into the material: the largest
    distance below the part's surface of the segment's boundary points
    inside the solid (`depth`, mm, 0 if none; within rho, as the nearest
    sample's distance), and the face nearest to that point."""

    depth: float
    face: int | None


@dataclass
class PoseCheck:
    """A pose's checks: the cutter against the machined faces (`gouge`) and
    against the check faces (`check`), and each holder segment against all
    faces (`holder`, by segment name)."""

    gouge: SegmentCheck
    check: SegmentCheck
    holder: dict = field(default_factory=dict)
    material: MaterialDepth | None = None  # the cutter's, where it cuts

    @property
    def gouge_mm(self):
        return max(0.0, -self.gouge.value)

    @property
    def check_depth_mm(self):
        return max(0.0, -self.check.value)


class PartOracle:
    """The exact part (a solid and its faces by id) and its face samples."""

    def __init__(self, solid, faces, spacing=DEFAULT_SPACING, exact_band=DEFAULT_BAND, cell_size=CELL_SIZE, face_spacing=None):
        self.solid = solid
        self.face_ids = sorted(faces)
        self.samples = sample_faces(faces, spacing, face_spacing)
        self.rho = float(self.samples.rho.max())  # the largest covering radius
        self.band = exact_band
        self.cells = Cells.of(self.samples.points, cell_size)
        self.cell_tree = cKDTree(self.cells.rep)
        self.sample_tree = cKDTree(self.samples.points)
        self.classifier = BRepClass3d_SolidClassifier(solid)
        self._index = {fid: k for k, fid in enumerate(self.face_ids)}

    @staticmethod
    def from_step(path, **kw):
        """The solid of a STEP file, faces named by their ADVANCED_FACE ids."""
        from cavities import read_step_faces

        solid, faces = read_step_faces(path)
        return PartOracle(solid, faces, **kw)

    @staticmethod
    def from_shape(shape, **kw):
        """A shape's faces numbered 1, 2, ... in explorer order."""
        from cavities import faces_of

        return PartOracle(shape, {k + 1: f for k, f in enumerate(faces_of(shape))}, **kw)

    # -- the search --------------------------------------------------------

    def _near_samples(self, seg, tip, axis):
        """Indices of the samples of every cell that may hold a sample value
        below band + rho, and a lower bound of every other sample's value."""
        a = np.asarray(axis, float)
        length = seg.z1 - seg.z0
        n = max(1, math.ceil(length / max(seg.radius, 1e-3)))
        h = length / n
        centres = np.asarray(tip, float) + np.outer(seg.z0 + h * (np.arange(n) + 0.5), a)
        cover = math.hypot(seg.radius, h / 2.0) + float(self.cells.radius.max())
        reach = cover + self.band + self.rho
        found = self.cell_tree.query_ball_point(centres, reach)
        cells = np.unique(np.concatenate([np.asarray(f, np.int64) for f in found]))
        if len(cells) == 0:
            return np.zeros(0, np.int64), reach - cover
        low = seg.sd(self.cells.rep[cells], tip, axis) - self.cells.radius[cells]
        near = low < self.band + self.rho
        far = min(float(low[~near].min()) if (~near).any() else math.inf, reach - cover)
        return self.cells.members(cells[near]), far

    def _evaluate(self, seg, tip, axis):
        """The samples near a posed segment (idx), their signed distances
        (vals), and a lower bound (far) of every other sample's value."""
        idx, far = self._near_samples(seg, tip, axis)
        return idx, seg.sd(self.samples.points[idx], tip, axis), far

    def check_segment(self, seg, tip, axis, face_ids=None):
        """`SegmentCheck` of a posed segment against the faces `face_ids`
        (default: all)."""
        tip = np.asarray(tip, float)
        axis = np.asarray(axis, float) / np.linalg.norm(axis)
        return self._check(seg, tip, axis, *self._evaluate(seg, tip, axis), face_ids)

    def _check(self, seg, tip, axis, idx, vals, far, face_ids=None):
        near_any = len(idx) > 0
        if face_ids is not None:
            allowed = np.zeros(len(self.face_ids), bool)
            allowed[[self._index[f] for f in face_ids]] = True
            keep = allowed[self.samples.face[idx]]
            idx, vals = idx[keep], vals[keep]
        if len(idx) == 0:
            if near_any:
                # Other faces come near; these are all beyond the band.
                return SegmentCheck(far - self.rho, None, False)
            got = self._far_or_buried(seg, tip, axis, far)
            if got.buried and face_ids is not None and got.face not in set(face_ids):
                return SegmentCheck(far - self.rho, None, False)
            return got
        faces = self.samples.face[idx]
        rho = self.samples.rho[idx]
        # Each face's best sample, best first: refine while a face may still
        # hold a value below both the best refined one and the band.
        order = np.lexsort((vals, faces))
        first = order[np.concatenate([[True], faces[order][1:] != faces[order][:-1]])]
        first = first[np.argsort(vals[first], kind="stable")]
        best, best_face = math.inf, None
        lower = far - self.rho
        for j in first:
            sel = faces == faces[j]
            if vals[j] - rho[j] >= min(best, self.band):
                lower = min(lower, float(vals[j] - rho[j]))
                continue
            v = self._refine(seg, tip, axis, int(faces[j]), idx[sel], vals[sel])
            if v < best:
                best, best_face = v, self.face_ids[int(faces[j])]
        if best < self.band:
            return SegmentCheck(best, best_face, True)
        if best_face is None:
            return SegmentCheck(lower, self.face_ids[int(faces[first[0]])], False)
        return SegmentCheck(min(best, lower), best_face, False)

    def _far_or_buried(self, seg, tip, axis, far):
        """No face near the segment: it is clear, or wholly in the material
        (its axis's middle point inside the solid)."""
        mid = tip + 0.5 * (seg.z0 + seg.z1) * axis
        depth, k = self.sample_tree.query(mid)
        # Well out along the nearest sample's outward normal, the point is
        # outside (near a convex edge too); anywhere else the solid
        # classifier decides.
        off = float(np.dot(mid - self.samples.points[k], self.samples.normals[k]))
        if off > 0.5 * depth or not self.inside(mid):
            return SegmentCheck(far - self.rho, None, False)
        return SegmentCheck(-float(depth), self.face_ids[int(self.samples.face[k])], False, True)

    def inside(self, point, tol=1e-7):
        """Whether a point is inside the solid (BRepClass3d_SolidClassifier)."""
        self.classifier.Perform(gp_Pnt(*map(float, point)), tol)
        return self.classifier.State() == TopAbs_IN

    # -- exact refinement ---------------------------------------------------

    def _seeds(self, idx, vals):
        """The samples of a face where a refinement starts, best first: the
        best sample, then the best of those farther than SEED_SEPARATION
        spacings from every seed so far, among those within rho of the best,
        at most MAX_SEEDS; and the best grid sample among them if all those
        are edge samples."""
        k = int(self.samples.face[idx[0]])
        best = float(vals.min())
        cand = np.flatnonzero(vals <= best + float(self.samples.rho[idx[0]]))
        cand = cand[np.argsort(vals[cand], kind="stable")]
        pts = self.samples.points[idx[cand]]
        sep2 = (SEED_SEPARATION * self.samples.faces[k].spacing) ** 2
        interior = cand[self.samples.edge[idx[cand]] < 0]
        seeds = []
        while len(cand) and len(seeds) < MAX_SEEDS:
            seeds.append(int(idx[cand[0]]))
            far = np.einsum("ij,ij->i", pts - pts[0], pts - pts[0]) > sep2
            cand, pts = cand[far], pts[far]
        # Edge samples lie twice as dense as the grid and often win; the
        # face's best grid sample starts a 2-D search all the same.
        if len(interior) and all(self.samples.edge[s] >= 0 for s in seeds):
            seeds.append(int(idx[interior[0]]))
        return seeds

    def _refine(self, seg, tip, axis, k, idx, vals):
        """The smallest sd of the segment over face k near its best samples:
        never above the best sample's value (samples are points of the face).
        Nelder-Mead runs on the surface within the face's (u, v) box and its
        end point is classified (IntTools_FClass2d is the costly call, not
        made at every step). An end off the face means the surface goes on
        lower beyond the trim: the face's lowest values are then on its
        boundary, refined along the face's best two edges; only if that finds
        nothing below the start, Nelder-Mead runs again with every step
        classified."""
        ctx = self.samples.faces[k]
        tip_t, axis_t = tuple(tip), tuple(axis)
        sd = seg.sd_function(tip, axis)
        value = ctx.surface.Value
        best = float(vals.min())
        penalty = best + 1e3
        u0, u1, v0, v1 = ctx.bounds

        def in_box(u, v):
            if not (u0 <= u <= u1 and v0 <= v <= v1):
                return penalty
            p = value(u, v)
            return sd(p.X(), p.Y(), p.Z())

        def on_face(u, v):
            if not (u0 <= u <= u1 and v0 <= v <= v1) or not ctx.inside(u, v):
                return penalty
            p = value(u, v)
            return sd(p.X(), p.Y(), p.Z())

        edges_done = False
        for s in self._seeds(idx, vals):
            e = int(self.samples.edge[s])
            if e >= 0:
                best = min(best, self._refine_edge(seg, tip_t, axis_t, e, float(self.samples.t[s])))
                continue
            u, v = (float(x) for x in self.samples.uv[s])
            f, ru, rv = nelder_mead_2d(in_box, u, v, ctx.steps, ctx.spacing)
            # Nelder-Mead can stall in a narrow valley of a stretched (u, v)
            # map: one restart from its end with a fresh simplex.
            f, ru, rv = min((f, ru, rv), nelder_mead_2d(in_box, ru, rv, (0.1 * ctx.steps[0], 0.1 * ctx.steps[1]), 0.1 * ctx.spacing))
            if f < 0.0:
                # Inside the segment sd is the distance to its nearest side:
                # its largest depth is often on a ridge, where a shrunken
                # simplex stalls; restart with a full-size one.
                f, ru, rv = min((f, ru, rv), nelder_mead_2d(in_box, ru, rv, ctx.steps, ctx.spacing))
            if ctx.inside(ru, rv):
                best = min(best, f)
                continue
            start = float(vals[np.flatnonzero(idx == s)[0]])
            if not edges_done:
                best = min(best, self._refine_best_edges(seg, tip_t, axis_t, idx, vals))
                edges_done = True
            if best >= start:
                best = min(best, nelder_mead_2d(on_face, u, v, ctx.steps, ctx.spacing)[0])
        return best

    def _refine_best_edges(self, seg, tip, axis, idx, vals, count=2):
        """`_refine_edge` from the best sample of each of the `count` best
        edges among the samples idx."""
        on_edge = np.flatnonzero(self.samples.edge[idx] >= 0)
        best, seen = math.inf, set()
        for j in on_edge[np.argsort(vals[on_edge], kind="stable")]:
            e = int(self.samples.edge[idx[j]])
            if e in seen:
                continue
            seen.add(e)
            best = min(best, self._refine_edge(seg, tip, axis, e, float(self.samples.t[idx[j]])))
            if len(seen) == count:
                break
        return best

    def _refine_edge(self, seg, tip, axis, e, t):
        ec = self.samples.edges[e]
        a = max(ec.bounds[0], t - 2.0 * ec.step)
        b = min(ec.bounds[1], t + 2.0 * ec.step)
        r = minimize_scalar(
            lambda s: seg.sd_scalar(ec.point(s), tip, axis),
            bounds=(a, b),
            method="bounded",
            options={"xatol": 1e-10 * max(abs(ec.step), 1e-12)},
        )
        return min(float(r.fun), seg.sd_scalar(ec.point(a), tip, axis), seg.sd_scalar(ec.point(b), tip, axis))

    # -- poses ---------------------------------------------------------------

    def check_pose(self, tool, tip, axis, machined_faces, check_faces=None):
        """`PoseCheck` of one pose of a `ToolAssembly`. Check faces default to
        every face not machined."""
        machined = sorted(machined_faces)
        checks = sorted(check_faces) if check_faces is not None else [f for f in self.face_ids if f not in set(machined)]
        tip = np.asarray(tip, float)
        axis = np.asarray(axis, float) / np.linalg.norm(axis)
        near = self._evaluate(tool.cutter, tip, axis)
        gouge = self._check(tool.cutter, tip, axis, *near, machined) if machined else SegmentCheck(math.inf, None, False)
        check = self._check(tool.cutter, tip, axis, *near, checks) if checks else SegmentCheck(math.inf, None, False)
        holder = {s.name: self.check_segment(s, tip, axis) for s in tool.holder}
        material = None
        if min(gouge.value, check.value) < -MATERIAL_FROM_MM:
            material = self.material_depth(tool.cutter, tip, axis)
        return PoseCheck(gouge, check, holder, material)

    def material_depth(self, seg, tip, axis, step=1.0):
        """`MaterialDepth` of a posed segment: its boundary sampled every
        `step` mm (segment.boundary_points); a point is inside where it lies
        behind its nearest sample's outward normal by more than half its
        distance, else the solid classifier decides. Points within their
        nearest sample's covering radius are left out (no deeper than it)."""
        axis = np.asarray(axis, float) / np.linalg.norm(axis)
        pts = seg.boundary_points(tip, axis, step)
        dist, k = self.sample_tree.query(pts)
        deep = dist > self.samples.rho[k]
        pts, dist, k = pts[deep], dist[deep], k[deep]
        off = np.einsum("ij,ij->i", pts - self.samples.points[k], self.samples.normals[k])
        inside = off < -0.5 * dist
        for j in np.flatnonzero(np.abs(off) <= 0.5 * dist):
            inside[j] = self.inside(pts[j])
        if not inside.any():
            return MaterialDepth(0.0, None)
        j = int(np.flatnonzero(inside)[np.argmax(dist[inside])])
        return MaterialDepth(float(dist[j]), self.face_ids[int(self.samples.face[k[j]])])

    def extrema_clearance(self, seg, tip, axis, shape=None):
        """BRepExtrema_DistShapeShape between the posed segment's primitive
        solids and the part (or `shape`): the exact clearance when positive,
        0 when they touch or overlap."""
        target = shape if shape is not None else self.solid
        return min(BRepExtrema_DistShapeShape(s, target).Value() for s in seg.solids(tip, axis))

    def on_faces(self, point, face_ids, tol=1e-3):
        """Whether a point lies on one of the faces within `tol` mm: the
        nearest exact face point (BRepExtrema from a vertex to the face)
        among the faces of its nearby samples."""
        from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeVertex

        near = self.sample_tree.query_ball_point(np.asarray(point, float), self.rho + tol)
        ks = {int(self.samples.face[j]) for j in near} & {self._index[f] for f in face_ids}
        if not ks:
            return False
        v = BRepBuilderAPI_MakeVertex(gp_Pnt(*map(float, point))).Vertex()
        return any(BRepExtrema_DistShapeShape(v, self.samples.faces[k].face).Value() <= tol for k in ks)


def nelder_mead_2d(f, u, v, steps, spacing, tol_mm=3e-4, tol_f=1e-7, max_iter=400):
    """The smallest value of f(u, v) found by Nelder-Mead from (u, v), the
    first simplex one grid step each way, and where: (f, u, v). It stops when
    the simplex is within `tol_mm` (steps scaled to `spacing` mm) and its
    values within `tol_f`."""
    du, dv = steps
    pts = [[f(u, v), u, v], [f(u + du, v), u + du, v], [f(u, v + dv), u, v + dv]]
    for _ in range(max_iter):
        pts.sort(key=lambda p: p[0])
        (f0, u0, v0), (f1, u1, v1), (fw, uw, vw) = pts
        size = max(math.hypot((u1 - u0) / du, (v1 - v0) / dv), math.hypot((uw - u0) / du, (vw - v0) / dv)) * spacing
        if size < tol_mm and fw - f0 < tol_f:
            break
        cu, cv = 0.5 * (u0 + u1), 0.5 * (v0 + v1)
        ru, rv = 2.0 * cu - uw, 2.0 * cv - vw
        fr = f(ru, rv)
        if fr < f0:
            eu, ev = 3.0 * cu - 2.0 * uw, 3.0 * cv - 2.0 * vw
            fe = f(eu, ev)
            pts[2] = [fe, eu, ev] if fe < fr else [fr, ru, rv]
        elif fr < f1:
            pts[2] = [fr, ru, rv]
        else:
            if fr < fw:
                ku, kv = 0.5 * (cu + ru), 0.5 * (cv + rv)
            else:
                ku, kv = 0.5 * (cu + uw), 0.5 * (cv + vw)
            fk = f(ku, kv)
            if fk < min(fr, fw):
                pts[2] = [fk, ku, kv]
            else:
                for p in pts[1:]:
                    p[1], p[2] = 0.5 * (u0 + p[1]), 0.5 * (v0 + p[2])
                    p[0] = f(p[1], p[2])
    return tuple(min(pts, key=lambda p: p[0]))


def tool_from_job(job_tool, holder=None, flute_length=None):
    """A `ToolAssembly` from a job's `tool`, optionally with a holder stack and
    flute length added (today's jobs carry neither)."""
    t = dict(job_tool)
    if holder is not None:
        t["holder"] = holder
    if flute_length is not None:
        t.pop("length", None)
        t["flute_length"] = flute_length
    return ToolAssembly.from_json(t)


# -- results ------------------------------------------------------------------

NOISE_MM = 1e-9  # numerical noise of a clearance at contact
LINK_MAX_STEP_MM = 1.0  # a link's tip moves at most this between samples
LINK_MAX_STEP_DEG = 1.0  # and its axis turns at most this


def result_poses(result):
    """The cutting poses of a `toolpath plan` result, in pass order: arrays
    tip (n, 3) (`cl`), axis (n, 3), cc (n, 3), and (pass, point) indices (n, 2)."""
    tips, axes, ccs, where = [], [], [], []
    for k, p in enumerate(result.get("passes", [])):
        for m, q in enumerate(p["points"]):
            tips.append(q["cl"])
            axes.append(q["axis"])
            ccs.append(q.get("cc", q["cl"]))
            where.append((k, m))
    return (
        np.array(tips, float).reshape(-1, 3),
        np.array(axes, float).reshape(-1, 3),
        np.array(ccs, float).reshape(-1, 3),
        np.array(where, np.int64).reshape(-1, 2),
    )


class LinksMissing(LookupError):
    """The result carries no `links`."""


def result_links(result):
    """The link poses of a result: a list (one per link) of (tips (n, 3),
    axes (n, 3)). A link is a list of poses or an object with `poses`; a pose
    is an object with `tip` (or `cl`) and `axis`, in the workpiece frame."""
    if "links" not in result:
        raise LinksMissing(
            "the result has no `links` (the workpiece-frame tool tip and axis of every retract, "
            "rapid, reorientation and approach between passes); there is nothing to check"
        )
    out = []
    for k, link in enumerate(result["links"]):
        poses = link.get("poses", link.get("points")) if isinstance(link, dict) else link
        if not isinstance(poses, list):
            raise ValueError(f"links[{k}]: must be a list of poses or an object with `poses`")
        tips, axes = [], []
        for m, q in enumerate(poses):
            tip = q.get("tip", q.get("cl")) if isinstance(q, dict) else None
            if tip is None or "axis" not in q:
                raise ValueError(f"links[{k}].poses[{m}]: needs `tip` (or `cl`) and `axis`")
            tips.append(tip)
            axes.append(q["axis"])
        out.append((np.array(tips, float).reshape(-1, 3), np.array(axes, float).reshape(-1, 3)))
    return out


def link_sampling_faults(links, max_mm=LINK_MAX_STEP_MM, max_deg=LINK_MAX_STEP_DEG):
    """Steps between consecutive link poses longer than `max_mm` or turning
    the axis by more than `max_deg`: (link, pose, mm, deg) each."""
    faults = []
    for k, (tips, axes) in enumerate(links):
        a = axes / np.linalg.norm(axes, axis=1)[:, None]
        step = np.linalg.norm(np.diff(tips, axis=0), axis=1)
        turn = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", a[1:], a[:-1]), -1.0, 1.0)))
        for m in np.flatnonzero((step > max_mm + 1e-9) | (turn > max_deg + 1e-9)):
            faults.append((k, int(m) + 1, float(step[m]), float(turn[m])))
    return faults


class CcOnFaces:
    """Whether contact points lie on given faces: the point projected onto
    each nearby face's surface (GeomAPI_ProjectPointOnSurf) within `tol` mm,
    at (u, v) inside the face (IntTools_FClass2d)."""

    def __init__(self, oracle, face_ids, tol=1e-3):
        from OCP.BRep import BRep_Tool

        self.oracle = oracle
        self.tol = tol
        self.ks = {oracle._index[f] for f in face_ids}
        self.surfaces = {k: BRep_Tool.Surface_s(oracle.samples.faces[k].face) for k in self.ks}

    def __call__(self, point):
        from OCP.GeomAPI import GeomAPI_ProjectPointOnSurf

        o = self.oracle
        near = o.sample_tree.query_ball_point(np.asarray(point, float), o.rho + self.tol)
        for k in {int(o.samples.face[j]) for j in near} & self.ks:
            proj = GeomAPI_ProjectPointOnSurf(gp_Pnt(*map(float, point)), self.surfaces[k])
            if proj.NbPoints() and proj.LowerDistance() <= self.tol:
                u, v = proj.LowerDistanceParameters()
                if o.samples.faces[k].inside(u, v):
                    return True
        return False


@dataclass
class ResultCheck:
    """Every pose of a result checked: `poses` (PoseCheck per cutting pose),
    `where` (pass, point), `cc_on_face`, and `links` (per link, per pose,
    a SegmentCheck by segment name) or `links_skipped` (why none were
    checked). A cutter cuts where it is deeper than `tolerance` into a face
    (0.01 mm: a figure within numerical noise of contact is no cut); a
    holder segment collides where its clearance is below `holder_clearance`
    (numerical noise of 1e-9 mm allowed)."""

    poses: list
    where: np.ndarray
    cc_on_face: np.ndarray
    tool: object
    tolerance: float
    holder_clearance: float = 0.0
    links: list | None = None
    links_skipped: str | None = None
    link_faults: list = field(default_factory=list)

    def summary(self):
        """The figures, JSON-ready."""
        tol = self.tolerance
        depth = np.array([p.check_depth_mm for p in self.poses])
        gouge = np.array([p.gouge_mm for p in self.poses])
        cut = depth > tol
        out = {
            "poses": len(self.poses),
            "poses_cc_on_face": int(self.cc_on_face.sum()),
            "poses_cc_off_face": int((~self.cc_on_face).sum()),
            "check_cut_poses": int(cut.sum()),
            "check_cut_over_1mm": int((depth > 1.0).sum()),
            "check_cut_cc_on_face": int((cut & self.cc_on_face).sum()),
            "check_cut_cc_off_face": int((cut & ~self.cc_on_face).sum()),
            "max_check_depth_mm": float(depth.max()) if len(depth) else 0.0,
            "gouge_poses": int((gouge > tol).sum()),
            "max_gouge_mm": float(gouge.max()) if len(gouge) else 0.0,
            "inexact_figures": int(sum(not p.check.exact and p.check.value < 0 for p in self.poses)),
        }
        if len(depth) and depth.max() > 0:
            j = int(depth.argmax())
            out["deepest"] = {
                "pass": int(self.where[j][0]),
                "point": int(self.where[j][1]),
                "face": self.poses[j].check.face,
                "depth_mm": float(depth[j]),
            }
        cut_faces = {}
        for p in self.poses:
            if p.check_depth_mm > tol:
                cut_faces[str(p.check.face)] = cut_faces.get(str(p.check.face), 0) + 1
        out["check_cut_by_face"] = dict(sorted(cut_faces.items()))
        mat = np.array([p.material.depth if p.material else 0.0 for p in self.poses])
        out["max_material_depth_mm"] = float(mat.max()) if len(mat) else 0.0
        out["material_depth_over_1mm"] = int((mat > 1.0).sum())
        if len(mat) and mat.max() > 0:
            j = int(mat.argmax())
            out["deepest_material"] = {
                "pass": int(self.where[j][0]),
                "point": int(self.where[j][1]),
                "face": self.poses[j].material.face,
                "depth_mm": float(mat[j]),
            }
        holder = {}
        for seg in self.tool.holder:
            vals = np.array([p.holder[seg.name].value for p in self.poses])
            j = int(vals.argmin()) if len(vals) else None
            holder[seg.name] = {
                "min_clearance_mm": float(vals[j]) if len(vals) else None,
                "min_clearance_exact": bool(self.poses[j].holder[seg.name].exact) if len(vals) else None,
                "collision_poses": int((vals < self.holder_clearance - NOISE_MM).sum()),
                "buried_poses": int(sum(p.holder[seg.name].buried for p in self.poses)),
            }
        out["holder"] = holder
        out["links"] = self._links_summary()
        return out

    def _links_summary(self):
        if self.links is None:
            return {"skipped": self.links_skipped}
        flat = [c for link in self.links for c in link]
        out = {"links": len(self.links), "poses": len(flat), "sampling_faults": len(self.link_faults)}
        for seg in self.tool.segments:
            vals = np.array([c[seg.name].value for c in flat])
            limit = -self.tolerance if seg.is_cutter else self.holder_clearance - NOISE_MM
            out[seg.name] = {"min_clearance_mm": float(vals.min()) if len(vals) else None, "collision_poses": int((vals < limit).sum())}
        return out


def check_result(oracle, result, tool, machined_faces, check_faces=None, tolerance=0.01, holder_clearance=0.0, progress=None):
    """Checks every cutting pose and every link pose of a `toolpath plan`
    result against the part. `tool` is a ToolAssembly; `machined_faces` the
    job's faces; check faces default to all others."""
    tips, axes, ccs, where = result_poses(result)
    on_face = CcOnFaces(oracle, machined_faces)
    poses, cc_on = [], []
    for j in range(len(tips)):
        poses.append(oracle.check_pose(tool, tips[j], axes[j], machined_faces, check_faces))
        cc_on.append(on_face(ccs[j]))
        if progress and j % 500 == 0:
            progress(j, len(tips))
    out = ResultCheck(poses, where, np.array(cc_on, bool), tool, tolerance, holder_clearance)
    try:
        links = result_links(result)
    except LinksMissing as e:
        out.links_skipped = str(e)
        return out
    out.link_faults = link_sampling_faults(links)
    out.links = [[{s.name: oracle.check_segment(s, t, a) for s in tool.segments} for t, a in zip(lt, la)] for lt, la in links]
    return out
