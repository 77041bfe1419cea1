"""The milling tool assembly as solids of revolution about the tool axis, and
its exact signed distance.

A tool is its cutter (flat end, ball or torus, up to the flute length) and a
stack of holder segments above it (the shank, collets, the holder body):
cylinders, or cones from `radius_bottom` to `radius_top`, in the JSON form of
a job's `tool`:

    {"kind": "flat_end", "radius": 5, "flute_length": 30,
     "holder": [{"length": 40, "radius": 5}, {"length": 60, "radius": 16}]}

Frame of a pose: `tip` (the job result's `cl`, the lowest point of the axis)
and the unit `axis` from the tip towards the spindle. A point p has the axial
coordinate z = (p - tip) . axis and the radial distance rho from the axis.

Signed distance: a solid of revolution about an axis is at the same distance
from p as its meridian profile is from (rho, z) in p's meridian half-plane
(rotating any point of the solid into that half-plane brings it nearer to p,
and the same holds for the complement), so the 3-D signed distance is the
2-D signed distance of the profile, in closed form: the distance to the
profile's boundary pieces (segments, and the cutter's corner arc), negative
inside. The axis itself is no boundary (the mirrored pieces on the other side
of the axis are farther from any point with rho >= 0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

DEFAULT_FLUTES_PER_RADIUS = 8.0  # a job without a flute length: 4 D, as `toolpath` reads it


class ToolError(ValueError):
    """A tool description that cannot be read, naming the field."""


@dataclass(frozen=True)
class Segment:
    """One solid of revolution of the assembly, from height z0 to z1 above
    the tip: the cutter (radius, bottom outer corner rounded by
    `corner_radius`: 0 flat end, = radius ball) or a holder frustum."""

    name: str
    z0: float
    z1: float
    radius_bottom: float
    radius_top: float
    corner_radius: float = 0.0
    is_cutter: bool = False

    @property
    def radius(self):
        return max(self.radius_bottom, self.radius_top)

    def local_sd(self, rho, z):
        """Signed distance of points at radial distance `rho` >= 0 and axial
        coordinate `z` (arrays), negative inside."""
        rho = np.asarray(rho, float)
        z = np.asarray(z, float)
        if self.is_cutter:
            return _cutter_sd(rho, z, self.z0, self.z1, self.radius_bottom, self.corner_radius)
        return _frustum_sd(rho, z, self.z0, self.z1, self.radius_bottom, self.radius_top)

    def local_sd_scalar(self, rho, z):
        """`local_sd` of one point, in plain floats (the refinement's inner loop)."""
        if self.is_cutter:
            return _cutter_sd_scalar(rho, z, self.z0, self.z1, self.radius_bottom, self.corner_radius)
        return _frustum_sd_scalar(rho, z, self.z0, self.z1, self.radius_bottom, self.radius_top)

    def sd(self, points, tip, axis):
        """Signed distance of 3-D points (n, 3) to the segment posed at tip/axis."""
        d = np.asarray(points, float) - np.asarray(tip, float)
        z = d @ np.asarray(axis, float)
        rho = np.sqrt(np.maximum(np.einsum("ij,ij->i", d, d) - z * z, 0.0))
        return self.local_sd(rho, z)

    def sd_scalar(self, p, tip, axis):
        dx, dy, dz = p[0] - tip[0], p[1] - tip[1], p[2] - tip[2]
        z = dx * axis[0] + dy * axis[1] + dz * axis[2]
        rho = math.sqrt(max(dx * dx + dy * dy + dz * dz - z * z, 0.0))
        return self.local_sd_scalar(rho, z)

    def sd_function(self, tip, axis):
        """`sd_scalar` of this pose as a function of one point (x, y, z),
        its constants bound once (the refinement calls it thousands of times)."""
        tx, ty, tz = (float(c) for c in tip)
        ax, ay, az = (float(c) for c in axis)
        local = _cutter_sd_scalar if self.is_cutter else _frustum_sd_scalar
        z0, z1, rb = self.z0, self.z1, self.radius_bottom
        last = self.corner_radius if self.is_cutter else self.radius_top
        sqrt = math.sqrt

        def sd(x, y, z):
            dx, dy, dz = x - tx, y - ty, z - tz
            h = dx * ax + dy * ay + dz * az
            r2 = dx * dx + dy * dy + dz * dz - h * h
            return local(sqrt(r2) if r2 > 0.0 else 0.0, h, z0, z1, rb, last)

        return sd

    def boundary_points(self, tip, axis, step):
        """Points of the posed segment's boundary at most about `step` mm
        apart: rings on its bottom disc, corner arc, side and top disc, and
        its axis."""
        prof = self._profile(step)
        a = np.asarray(axis, float) / np.linalg.norm(axis)
        e1 = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(a, e1)
        out = [np.asarray(tip, float) + np.outer(np.linspace(self.z0, self.z1, max(2, math.ceil((self.z1 - self.z0) / step) + 1)), a)]
        for r, z in prof:
            n = max(1, math.ceil(2.0 * math.pi * r / step))
            t = 2.0 * math.pi * np.arange(n) / n
            out.append(np.asarray(tip, float) + z * a + r * (np.outer(np.cos(t), e1) + np.outer(np.sin(t), e2)))
        return np.concatenate(out)

    def _profile(self, step):
        """(radius, height) of the rings of `boundary_points`."""
        pts = []
        if self.is_cutter:
            r, rc = self.radius_bottom, self.corner_radius
            c = r - rc
            pts += [(c * i / max(1, math.ceil(c / step)), self.z0) for i in range(1, max(1, math.ceil(c / step)) + 1)] if c > 0 else []
            m = max(1, math.ceil(0.5 * math.pi * rc / step)) if rc > 0 else 0
            pts += [
                (c + rc * math.sin(0.5 * math.pi * i / m), self.z0 + rc - rc * math.cos(0.5 * math.pi * i / m)) for i in range(1, m + 1)
            ]
            zs = np.linspace(self.z0 + rc, self.z1, max(2, math.ceil((self.z1 - self.z0 - rc) / step) + 1))
            pts += [(r, float(z)) for z in zs]
            pts += [(r * i / max(1, math.ceil(r / step)), self.z1) for i in range(1, max(1, math.ceil(r / step)))]
            return pts
        rb, rt = self.radius_bottom, self.radius_top
        n = max(2, math.ceil(math.hypot(rt - rb, self.z1 - self.z0) / step) + 1)
        pts += [(rb * i / max(1, math.ceil(rb / step)), self.z0) for i in range(1, max(1, math.ceil(rb / step)) + 1)]
        pts += [(rb + (rt - rb) * i / (n - 1), self.z0 + (self.z1 - self.z0) * i / (n - 1)) for i in range(1, n)]
        pts += [(rt * i / max(1, math.ceil(rt / step)), self.z1) for i in range(1, max(1, math.ceil(rt / step)))]
        return pts

    def solids(self, tip, axis):
        """The segment as Open CASCADE primitive solids whose union it is
        (for BRepExtrema): a cutter is a cylinder with a lower hemisphere
        (ball) or a disc cylinder and a quarter-section torus (torus)."""
        from OCP.BRepPrimAPI import BRepPrimAPI_MakeCone, BRepPrimAPI_MakeCylinder, BRepPrimAPI_MakeSphere, BRepPrimAPI_MakeTorus
        from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt

        a = np.asarray(axis, float) / np.linalg.norm(axis)

        def frame(h):
            p = np.asarray(tip, float) + h * a
            return gp_Ax2(gp_Pnt(*p), gp_Dir(*a))

        h = self.z1 - self.z0
        if not self.is_cutter:
            if abs(self.radius_bottom - self.radius_top) < 1e-12:
                return [BRepPrimAPI_MakeCylinder(frame(self.z0), self.radius_bottom, h).Shape()]
            return [BRepPrimAPI_MakeCone(frame(self.z0), self.radius_bottom, self.radius_top, h).Shape()]
        r, rc = self.radius_bottom, self.corner_radius
        c = r - rc
        out = [BRepPrimAPI_MakeCylinder(frame(self.z0 + rc), r, h - rc).Shape()] if h > rc else []
        if rc <= 0.0:
            return out
        if c <= 1e-12:
            out.append(BRepPrimAPI_MakeSphere(frame(self.z0 + rc), rc, -math.pi / 2.0, 0.0).Shape())
            return out
        out.append(BRepPrimAPI_MakeCylinder(frame(self.z0), c, rc).Shape())
        out.append(BRepPrimAPI_MakeTorus(frame(self.z0 + rc), c, rc, -math.pi / 2.0, 0.0).Shape())
        return out


def _segment_distance(px, pz, ax, az, bx, bz):
    """Distance of points (px, pz) to the segment (ax, az)-(bx, bz)."""
    dx, dz = bx - ax, bz - az
    l2 = dx * dx + dz * dz
    t = 0.0 if l2 == 0.0 else np.clip(((px - ax) * dx + (pz - az) * dz) / l2, 0.0, 1.0)
    return np.hypot(px - ax - t * dx, pz - az - t * dz)


def _cutter_sd(rho, z, z0, z1, r, rc):
    c = r - rc
    d = np.minimum(_segment_distance(rho, z, 0.0, z0, c, z0), _segment_distance(rho, z, r, z0 + rc, r, z1))
    d = np.minimum(d, _segment_distance(rho, z, 0.0, z1, r, z1))
    inside = (z >= z0) & (z <= z1) & (rho <= r)
    if rc > 0.0:
        ex, ez = rho - c, z - (z0 + rc)
        e = np.hypot(ex, ez)
        sector = (ex >= 0.0) & (ez <= 0.0)
        d = np.where(sector, np.minimum(d, np.abs(e - rc)), d)
        inside &= ~(sector & (e > rc))
    return np.where(inside, -d, d)


def _frustum_sd(rho, z, z0, z1, rb, rt):
    d = np.minimum(_segment_distance(rho, z, 0.0, z0, rb, z0), _segment_distance(rho, z, rb, z0, rt, z1))
    d = np.minimum(d, _segment_distance(rho, z, 0.0, z1, rt, z1))
    inside = (z >= z0) & (z <= z1) & (rho <= rb + (rt - rb) * (z - z0) / (z1 - z0))
    return np.where(inside, -d, d)


def _seg_scalar(px, pz, ax, az, bx, bz):
    dx, dz = bx - ax, bz - az
    l2 = dx * dx + dz * dz
    t = 0.0 if l2 == 0.0 else min(max(((px - ax) * dx + (pz - az) * dz) / l2, 0.0), 1.0)
    return math.hypot(px - ax - t * dx, pz - az - t * dz)


def _cutter_sd_scalar(rho, z, z0, z1, r, rc):
    c = r - rc
    zc = z0 + rc
    # bottom disc (rho <= c at z0), side (rho = r, zc..z1), top (z1)
    d = math.hypot(max(rho - c, 0.0), z - z0)
    d = min(d, math.hypot(rho - r, z - min(max(z, zc), z1)), math.hypot(max(rho - r, 0.0), z - z1))
    inside = z0 <= z <= z1 and rho <= r
    if rc > 0.0:
        ex, ez = rho - c, z - zc
        if ex >= 0.0 and ez <= 0.0:
            e = math.hypot(ex, ez)
            d = min(d, abs(e - rc))
            inside = inside and e <= rc
    return -d if inside else d


def _frustum_sd_scalar(rho, z, z0, z1, rb, rt):
    d = min(math.hypot(max(rho - rb, 0.0), z - z0), _seg_scalar(rho, z, rb, z0, rt, z1), math.hypot(max(rho - rt, 0.0), z - z1))
    inside = z0 <= z <= z1 and rho <= rb + (rt - rb) * (z - z0) / (z1 - z0)
    return -d if inside else d


def _positive(obj, key, where):
    if key not in obj:
        raise ToolError(f"{where}.{key}: is required")
    v = obj[key]
    if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v) or v <= 0:
        raise ToolError(f"{where}.{key}: must be a positive number, got {v!r}")
    return float(v)


@dataclass(frozen=True)
class ToolAssembly:
    """The cutter and the holder segments above it, bottom to top."""

    segments: tuple

    @property
    def cutter(self):
        return self.segments[0]

    @property
    def holder(self):
        return self.segments[1:]

    @staticmethod
    def from_json(tool, where="tool"):
        """Reads a job's `tool` (flute length: `flute_length`, or today's
        `length`; default 8 x radius)."""
        if not isinstance(tool, dict):
            raise ToolError(f"{where}: must be an object")
        kind = tool.get("kind")
        r = _positive(tool, "radius", where)
        if kind == "flat_end":
            rc = 0.0
        elif kind == "ball":
            rc = r
        elif kind == "torus":
            rc = _positive(tool, "corner_radius", where)
            if rc >= r:
                raise ToolError(f"{where}.corner_radius: must be below the radius {r}, got {rc}")
        else:
            raise ToolError(f"{where}.kind: must be flat_end, ball or torus, got {kind!r}")
        if "flute_length" in tool:
            length = _positive(tool, "flute_length", where)
        elif "length" in tool:
            length = _positive(tool, "length", where)
        else:
            length = DEFAULT_FLUTES_PER_RADIUS * r
        if length < rc:
            raise ToolError(f"{where}.flute_length: {length} is shorter than the corner radius {rc}")
        segments = [Segment("cutter", 0.0, length, r, r, rc, True)]
        z = length
        holder = tool.get("holder", [])
        if not isinstance(holder, list):
            raise ToolError(f"{where}.holder: must be a list of segments")
        for k, h in enumerate(holder):
            w = f"{where}.holder[{k}]"
            if not isinstance(h, dict):
                raise ToolError(f"{w}: must be an object")
            hl = _positive(h, "length", w)
            if "radius" in h:
                if "radius_bottom" in h or "radius_top" in h:
                    raise ToolError(f"{w}: give radius, or radius_bottom and radius_top, not both")
                rb = rt = _positive(h, "radius", w)
            else:
                rb, rt = _positive(h, "radius_bottom", w), _positive(h, "radius_top", w)
            segments.append(Segment(f"holder[{k}]", z, z + hl, rb, rt))
            z += hl
        return ToolAssembly(tuple(segments))

    def sd(self, points, tip, axis):
        """Signed distances (segments, n) of points to each posed segment."""
        return np.array([s.sd(points, tip, axis) for s in self.segments])
