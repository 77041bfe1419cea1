//! Scallop simulator: the residual material height left on a surface by a
//! milling result (flat-end, ball or torus cutter), from the exact cutter
//! solid swept along the passes (docs/methods.md, "Swept cutter and residual").
//!
//! The surface is sampled on a uv grid (cell centres, each with its area).
//! At a sample `p` with tool-side unit normal `n`, the residual is the lowest
//! `t` such that `p + t n` lies in the swept tool volume: positive = material
//! left (scallop), negative = the tool cut below the surface (gouge). Between
//! consecutive points of a pass the tool moves linearly (tip interpolated,
//! axis interpolated and normalised). A sample the swept tool does not reach
//! within `cap` = the tool radius above it is uncovered.
//!
//! Per sample and pass segment, the drop of the exact cutter solid
//! ([`CutterShape::lowest_hit`]) is scanned at sub-positions no further apart
//! than R/8 along the motion, then the minimum is refined by golden-section
//! search around the best sub-position (the swept solid of a convex cutter
//! along a straight motion is convex, so the drop is unimodal in the motion
//! parameter); where the line leaves the tool between two sub-positions (the
//! sharp rim of a flat-end), the edge is located by bisection first. The
//! motion parameter is resolved to 1e-5 mm, far below the 0.002 mm the
//! planners are checked to. Reported maxima/minima are refined the same way
//! in (u, v) by a compass search from the grid's best local extrema, so the
//! max scallop is not limited by the grid spacing.

use crate::error::{Error, Result};
use crate::formats::PlanResult;
use crate::geometry::NurbsSurface;
use crate::tools::{CutterShape, Tool};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Simulation settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScallopSettings {
    /// Grid spacing on the surface, mm. `<= 0` (the default) means automatic:
    /// R/8 for cutter radius R (0.3125 mm for R = 2.5), made coarser if the
    /// surface would need more than [`AUTO_MAX_SAMPLES`] samples.
    pub resolution_mm: f64,
}

impl Default for ScallopSettings {
    fn default() -> Self {
        Self { resolution_mm: 0.0 }
    }
}

impl ScallopSettings {
    /// Settings with a given spacing, or automatic for `None` (a job's `simulation_resolution`).
    pub fn with_resolution(resolution_mm: Option<f64>) -> Self {
        Self {
            resolution_mm: resolution_mm.unwrap_or(0.0),
        }
    }
}

/// Automatic resolution never asks for more samples than this.
pub const AUTO_MAX_SAMPLES: usize = 1_000_000;
/// An explicit resolution may ask for at most this many samples.
pub const MAX_SAMPLES: usize = 16_000_000;

/// Residual height over the surface grid. Sample `k = i * nv + j`, `i` along u
/// (cell centres). `residual[k]` is `None` where the tool never came within the
/// cap (uncovered).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResidualMap {
    pub nu: usize,
    pub nv: usize,
    pub uv: Vec<[f64; 2]>,
    pub xyz: Vec<[f64; 3]>,
    pub residual: Vec<Option<f64>>,
}

/// What the simulator found.
#[derive(Clone, Debug, PartialEq)]
pub struct ScallopReport {
    /// Highest residual over the machined (covered) area, mm (0 when nothing is covered).
    pub max_scallop_mm: f64,
    /// Deepest cut below the surface, mm, >= 0.
    pub max_gouge_mm: f64,
    /// Surface area the tool never reached, mm^2.
    pub uncovered_area_mm2: f64,
    /// Surface area the tool reached, mm^2.
    pub machined_area_mm2: f64,
    /// Grid spacing actually used, mm.
    pub resolution_mm: f64,
    pub map: ResidualMap,
}

/// Simulates `result` (a milling result with `cl`/`axis` per point) on `surface`.
pub fn simulate(
    surface: &NurbsSurface,
    tool: &Tool,
    result: &PlanResult,
    settings: &ScallopSettings,
) -> Result<ScallopReport> {
    let sim = Simulator::new(surface, tool, result)?;
    sim.run(settings)
}

/// One straight tool motion between two consecutive points of a pass.
#[derive(Clone, Copy, Debug)]
struct Segment {
    tip0: Vector3<f64>,
    tip1: Vector3<f64>,
    axis0: Vector3<f64>,
    axis1: Vector3<f64>,
    /// Largest distance a tool point (within the reach) moves, mm.
    travel: f64,
    /// Axis segment of the tool half-way along the motion, for quick rejection.
    mid_tip: Vector3<f64>,
    mid_top: Vector3<f64>,
    /// How far the swept axis strays from the mid axis, mm.
    margin: f64,
}

impl Segment {
    fn pose(&self, s: f64) -> (Vector3<f64>, Vector3<f64>) {
        let tip = self.tip0 + (self.tip1 - self.tip0) * s;
        let axis = (self.axis0 * (1.0 - s) + self.axis1 * s)
            .try_normalize(1e-12)
            .unwrap_or(self.axis0);
        (tip, axis)
    }
}

/// Uniform 3-D grid of cells listing the segments whose swept box meets them.
struct Buckets {
    origin: Vector3<f64>,
    cell: f64,
    dims: [usize; 3],
    /// CSR: segments of cell c are items[offsets[c]..offsets[c + 1]].
    offsets: Vec<u32>,
    items: Vec<u32>,
}

const MAX_CELLS: usize = 4_000_000;

impl Buckets {
    fn new(boxes: &[(Vector3<f64>, Vector3<f64>)], cell: f64) -> Self {
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        for (a, b) in boxes {
            lo = lo.inf(a);
            hi = hi.sup(b);
        }
        if boxes.is_empty() {
            lo = Vector3::zeros();
            hi = Vector3::zeros();
        }
        let mut cell = cell;
        let dims_for = |cell: f64| -> [usize; 3] {
            let d = |k: usize| (((hi[k] - lo[k]) / cell).floor() as usize).saturating_add(1);
            [d(0), d(1), d(2)]
        };
        let mut dims = dims_for(cell);
        while dims.iter().map(|&d| d as f64).product::<f64>() > MAX_CELLS as f64 {
            cell *= 1.5;
            dims = dims_for(cell);
        }
        let ncell = dims[0] * dims[1] * dims[2];
        let mut counts = vec![0u32; ncell + 1];
        let range = |a: &Vector3<f64>, b: &Vector3<f64>| -> [(usize, usize); 3] {
            let mut r = [(0, 0); 3];
            for k in 0..3 {
                let i0 = (((a[k] - lo[k]) / cell).floor().max(0.0) as usize).min(dims[k] - 1);
                let i1 = (((b[k] - lo[k]) / cell).floor().max(0.0) as usize).min(dims[k] - 1);
                r[k] = (i0, i1);
            }
            r
        };
        let index = |i: usize, j: usize, k: usize| (i * dims[1] + j) * dims[2] + k;
        for (a, b) in boxes {
            let r = range(a, b);
            for i in r[0].0..=r[0].1 {
                for j in r[1].0..=r[1].1 {
                    for k in r[2].0..=r[2].1 {
                        counts[index(i, j, k) + 1] += 1;
                    }
                }
            }
        }
        for c in 0..ncell {
            counts[c + 1] += counts[c];
        }
        let offsets = counts;
        let mut fill = offsets.clone();
        let mut items = vec![0u32; offsets[ncell] as usize];
        for (id, (a, b)) in boxes.iter().enumerate() {
            let r = range(a, b);
            for i in r[0].0..=r[0].1 {
                for j in r[1].0..=r[1].1 {
                    for k in r[2].0..=r[2].1 {
                        let c = index(i, j, k);
                        items[fill[c] as usize] = id as u32;
                        fill[c] += 1;
                    }
                }
            }
        }
        Self {
            origin: lo,
            cell,
            dims,
            offsets,
            items,
        }
    }

    /// Appends the ids of segments in cells meeting the box [a, b] (unsorted, with repeats).
    fn query(&self, a: &Vector3<f64>, b: &Vector3<f64>, out: &mut Vec<u32>) {
        let mut r = [(0usize, 0usize); 3];
        for k in 0..3 {
            let f0 = (a[k] - self.origin[k]) / self.cell;
            let f1 = (b[k] - self.origin[k]) / self.cell;
            if f1 < 0.0 || f0 >= self.dims[k] as f64 {
                return;
            }
            r[k] = (
                f0.floor().max(0.0) as usize,
                (f1.floor() as usize).min(self.dims[k] - 1),
            );
        }
        for i in r[0].0..=r[0].1 {
            for j in r[1].0..=r[1].1 {
                for k in r[2].0..=r[2].1 {
                    let c = (i * self.dims[1] + j) * self.dims[2] + k;
                    out.extend_from_slice(
                        &self.items[self.offsets[c] as usize..self.offsets[c + 1] as usize],
                    );
                }
            }
        }
    }
}

/// The swept tool of one result, ready to be queried at surface points.
pub struct Simulator<'a> {
    surface: &'a NurbsSurface,
    cutter: CutterShape,
    segments: Vec<Segment>,
    buckets: Buckets,
    /// Residuals above this are "not reached" (the tool radius).
    cap: f64,
    /// Gouges are searched to this depth below the surface (the tool diameter);
    /// deeper ones are reported as this depth.
    depth: f64,
    /// Largest spacing of the sub-positions scanned along a motion, mm.
    scan_step: f64,
}

/// A surface sample: point, unit tool-side normal, area weight (`None` where the normal is undefined).
type Frame = Option<(Vector3<f64>, Vector3<f64>, f64)>;

/// Motion parameter resolution of the sweep refinement, mm.
const SWEEP_TOL_MM: f64 = 1e-5;

fn vec3(a: [f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}

fn finite3(a: &[f64; 3]) -> bool {
    a.iter().all(|x| x.is_finite())
}

impl<'a> Simulator<'a> {
    /// Checks the result's tool positions and builds the spatial index.
    pub fn new(surface: &'a NurbsSurface, tool: &Tool, result: &PlanResult) -> Result<Self> {
        let cutter = CutterShape::from_tool(tool)?;
        let big_r = cutter.radius;
        let len = cutter.length;
        let mut segments = Vec::new();
        for (i, pass) in result.passes.iter().enumerate() {
            let mut poses = Vec::with_capacity(pass.points.len());
            for (j, q) in pass.points.iter().enumerate() {
                let field = |f: &str| format!("passes[{i}].points[{j}].{f}");
                if !finite3(&q.cl) {
                    return Err(Error::invalid(field("cl"), "is not a finite point"));
                }
                if !finite3(&q.axis) {
                    return Err(Error::invalid(field("axis"), "is not a finite vector"));
                }
                let axis = vec3(q.axis).try_normalize(1e-12).ok_or_else(|| {
                    Error::invalid(
                        field("axis"),
                        "is a zero vector: the tool axis must be a unit vector",
                    )
                })?;
                poses.push((vec3(q.cl), axis));
            }
            let mut push =
                |(tip0, axis0): (Vector3<f64>, Vector3<f64>),
                 (tip1, axis1): (Vector3<f64>, Vector3<f64>)| {
                    let angle = axis0.angle(&axis1);
                    let reach = len.hypot(big_r);
                    let travel = (tip1 - tip0).norm() + reach * angle;
                    let mid = (axis0 + axis1).try_normalize(1e-12).unwrap_or(axis0);
                    let mid_tip = (tip0 + tip1) * 0.5;
                    let top0 = tip0 + axis0 * len;
                    let top1 = tip1 + axis1 * len;
                    let chord = (axis0 + axis1).norm() * 0.5;
                    let margin = 0.5 * (tip1 - tip0).norm().max((top1 - top0).norm())
                        + len * (1.0 - chord)
                        + 1e-9 * reach;
                    segments.push(Segment {
                        tip0,
                        tip1,
                        axis0,
                        axis1,
                        travel,
                        mid_tip,
                        mid_top: mid_tip + mid * len,
                        margin,
                    });
                };
            match poses.len() {
                0 => {}
                1 => push(poses[0], poses[0]),
                _ => {
                    for w in poses.windows(2) {
                        push(w[0], w[1]);
                    }
                }
            }
        }
        let boxes: Vec<_> = segments
            .iter()
            .map(|s| {
                let pad = Vector3::repeat(big_r * 1.01 + s.margin);
                let pts = [
                    s.tip0,
                    s.tip1,
                    s.tip0 + s.axis0 * len,
                    s.tip1 + s.axis1 * len,
                    s.mid_tip,
                    s.mid_top,
                ];
                let mut lo = pts[0];
                let mut hi = pts[0];
                for p in &pts[1..] {
                    lo = lo.inf(p);
                    hi = hi.sup(p);
                }
                (lo - pad, hi + pad)
            })
            .collect();
        let buckets = Buckets::new(&boxes, 2.0 * big_r);
        Ok(Self {
            surface,
            cutter,
            segments,
            buckets,
            cap: big_r,
            depth: 2.0 * big_r,
            scan_step: big_r / 8.0,
        })
    }

    fn drop_at(&self, seg: &Segment, s: f64, p: &Vector3<f64>, n: &Vector3<f64>) -> f64 {
        let (tip, axis) = seg.pose(s);
        self.cutter
            .lowest_hit(&tip, &axis, p, n, -self.depth, self.cap)
            .unwrap_or(f64::INFINITY)
    }

    /// Lowest drop of the tool swept along `seg` at the line p + t n.
    fn sweep_min(&self, seg: &Segment, p: &Vector3<f64>, n: &Vector3<f64>) -> f64 {
        let k = ((seg.travel / self.scan_step).ceil() as usize).clamp(1, 4096);
        let ds = 1.0 / k as f64;
        // Near the edge of a tool's reach the line meets the moving tool only
        // over a short stretch centred where it passes closest to the axis
        // (at the corner height): scan that position too so it is not missed.
        let corner = self.cutter.corner_radius;
        let w0 = seg.tip0 + seg.axis0 * corner - p;
        let w1 = seg.tip1 + seg.axis1 * corner - p;
        let (w0, dw) = (w0 - n * w0.dot(n), (w1 - w0) - n * (w1 - w0).dot(n));
        let dd = dw.norm_squared();
        let s_close = if dd > 1e-30 {
            (-w0.dot(&dw) / dd).clamp(0.0, 1.0)
        } else {
            0.0
        };
        // Scan: (s, drop) of the best position and of its neighbours in the scan order.
        let mut best = (f64::NAN, f64::INFINITY);
        let mut left = (f64::NAN, f64::INFINITY);
        let mut right = (f64::NAN, f64::INFINITY);
        let mut prev = (f64::NAN, f64::INFINITY);
        let mut right_pending = false;
        let mut extra = Some(s_close);
        let mut i = 0;
        while i <= k {
            let grid = i as f64 * ds;
            let s = match extra {
                Some(e) if e < grid => {
                    extra = None;
                    e
                }
                Some(e) if e == grid => {
                    extra = None;
                    i += 1;
                    grid
                }
                _ => {
                    i += 1;
                    grid
                }
            };
            let h = self.drop_at(seg, s, p, n);
            if h < best.1 {
                best = (s, h);
                left = prev;
                right = (f64::NAN, f64::INFINITY);
                right_pending = true;
            } else if right_pending {
                right = (s, h);
                right_pending = false;
            }
            prev = (s, h);
        }
        if !best.1.is_finite() || seg.travel <= 0.0 {
            return best.1;
        }
        let tol = SWEEP_TOL_MM / seg.travel;
        let (s_best, mut best) = best;
        // Bracket [lo, hi] of finite drops around the best scanned position.
        let (mut lo, mut f_lo) = (s_best, best);
        if !left.0.is_nan() {
            (lo, f_lo) = if left.1.is_finite() {
                left
            } else {
                self.edge(seg, p, n, s_best, best, left.0, tol)
            };
        }
        let (mut hi, mut f_hi) = (s_best, best);
        if !right.0.is_nan() {
            (hi, f_hi) = if right.1.is_finite() {
                right
            } else {
                self.edge(seg, p, n, s_best, best, right.0, tol)
            };
        }
        best = best.min(f_lo).min(f_hi);
        // Golden-section search on the (unimodal) drop over [lo, hi].
        const G: f64 = 0.618_033_988_749_894_9;
        let mut x1 = hi - G * (hi - lo);
        let mut x2 = lo + G * (hi - lo);
        let mut f1 = self.drop_at(seg, x1, p, n);
        let mut f2 = self.drop_at(seg, x2, p, n);
        for _ in 0..80 {
            if hi - lo <= tol {
                break;
            }
            if f1 <= f2 {
                hi = x2;
                x2 = x1;
                f2 = f1;
                x1 = hi - G * (hi - lo);
                f1 = self.drop_at(seg, x1, p, n);
            } else {
                lo = x1;
                x1 = x2;
                f1 = f2;
                x2 = lo + G * (hi - lo);
                f2 = self.drop_at(seg, x2, p, n);
            }
        }
        best.min(f1).min(f2)
    }

    /// Bisects between `s_in` (drop finite) and `s_out` (line misses the tool)
    /// for the last position that still hits; returns it with its drop.
    #[allow(clippy::too_many_arguments)]
    fn edge(
        &self,
        seg: &Segment,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        mut s_in: f64,
        mut f_in: f64,
        mut s_out: f64,
        tol: f64,
    ) -> (f64, f64) {
        for _ in 0..80 {
            if (s_out - s_in).abs() <= tol * 0.1 {
                break;
            }
            let mid = 0.5 * (s_in + s_out);
            let f = self.drop_at(seg, mid, p, n);
            if f.is_finite() {
                s_in = mid;
                f_in = f;
            } else {
                s_out = mid;
            }
        }
        (s_in, f_in)
    }

    /// Residual at surface point `p` with tool-side unit normal `n`; `None` if uncovered.
    pub fn residual(
        &self,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        scratch: &mut Vec<u32>,
    ) -> Option<f64> {
        let a = p - n * self.depth;
        let b = p + n * self.cap;
        let pad = Vector3::repeat(1e-9);
        scratch.clear();
        self.buckets
            .query(&(a.inf(&b) - pad), &(a.sup(&b) + pad), scratch);
        scratch.sort_unstable();
        scratch.dedup();
        let reach = self.cutter.radius;
        let mut best = f64::INFINITY;
        for &id in scratch.iter() {
            let Some(seg) = self.segments.get(id as usize) else {
                continue;
            };
            if segment_distance(&a, &b, &seg.mid_tip, &seg.mid_top) > reach + seg.margin {
                continue;
            }
            // No point of the swept tool lies lower along n than this bound.
            let bound = self
                .cutter
                .support_low(&seg.tip0, &seg.axis0, p, n)
                .min(self.cutter.support_low(&seg.tip1, &seg.axis1, p, n))
                - 0.5 * seg.travel;
            if bound >= best {
                continue;
            }
            best = best.min(self.sweep_min(seg, p, n));
        }
        (best <= self.cap).then_some(best)
    }

    /// Residual at surface parameters (u, v) (clamped to the domain).
    pub fn residual_at(&self, u: f64, v: f64) -> Option<f64> {
        let (p, n, _) = self.sample(u, v)?;
        self.residual(&p, &n, &mut Vec::new())
    }

    /// Point, unit tool-side normal and area element at (u, v).
    fn sample(&self, u: f64, v: f64) -> Option<(Vector3<f64>, Vector3<f64>, f64)> {
        let d = self.surface.derivs(u, v);
        let cross = d.su.cross(&d.sv);
        let area = cross.norm();
        let n = cross.try_normalize(1e-300)?;
        Some((d.p.coords, n, area))
    }

    /// Samples the surface and builds the report.
    pub fn run(&self, settings: &ScallopSettings) -> Result<ScallopReport> {
        let ((u0, u1), (v0, v1)) = self.surface.domain();
        let (len_u, len_v) = extents(self.surface);
        let res = grid_resolution(settings, &self.cutter, len_u, len_v)?;
        let nu = ((len_u / res).ceil() as usize).max(2);
        let nv = ((len_v / res).ceil() as usize).max(2);
        let du = (u1 - u0) / nu as f64;
        let dv = (v1 - v0) / nv as f64;
        let total = nu * nv;

        // Samples, then residuals in parallel over fixed row chunks: each sample
        // is computed independently, so the result does not depend on threads.
        let mut uv = Vec::with_capacity(total);
        let mut xyz = Vec::with_capacity(total);
        let mut frames = Vec::with_capacity(total);
        for i in 0..nu {
            for j in 0..nv {
                let (u, v) = (u0 + (i as f64 + 0.5) * du, v0 + (j as f64 + 0.5) * dv);
                uv.push([u, v]);
                match self.sample(u, v) {
                    Some((p, n, area)) => {
                        xyz.push([p.x, p.y, p.z]);
                        frames.push(Some((p, n, area * du * dv)));
                    }
                    None => {
                        let p = self.surface.point(u, v);
                        xyz.push([p.x, p.y, p.z]);
                        frames.push(None);
                    }
                }
            }
        }
        let residual = self.residuals(&frames);

        let mut uncovered = 0.0;
        let mut machined = 0.0;
        let mut best_max: Option<(f64, usize)> = None;
        for (k, (f, r)) in frames.iter().zip(&residual).enumerate() {
            let Some((_, _, area)) = f else { continue };
            match r {
                Some(r) => {
                    machined += area;
                    if best_max.is_none_or(|(b, _)| *r > b) {
                        best_max = Some((*r, k));
                    }
                }
                None => uncovered += area,
            }
        }
        let map = ResidualMap {
            nu,
            nv,
            uv,
            xyz,
            residual,
        };
        let max_res = self.refine(&map, 1.0, du, dv);
        let min_res = self.refine(&map, -1.0, du, dv);
        Ok(ScallopReport {
            max_scallop_mm: max_res.map_or(0.0, |r| r.max(0.0)),
            max_gouge_mm: min_res.map_or(0.0, |r| (-r).max(0.0)),
            uncovered_area_mm2: uncovered,
            machined_area_mm2: machined,
            resolution_mm: res,
            map,
        })
    }

    fn residuals(&self, frames: &[Frame]) -> Vec<Option<f64>> {
        let chunk = frames
            .len()
            .div_ceil(crate::parallel::threads() * 8)
            .max(64);
        crate::parallel::map_chunks(frames, chunk, |frames| {
            let mut scratch = Vec::new();
            frames
                .iter()
                .map(|f| {
                    f.as_ref()
                        .and_then(|(p, n, _)| self.residual(p, n, &mut scratch))
                })
                .collect::<Vec<_>>()
        })
        .into_iter()
        .flatten()
        .collect()
    }

    /// Refines the grid's extreme residual (`sign` 1: max, -1: min) by compass
    /// search in (u, v) from its best local extrema; `None` if nothing is covered.
    fn refine(&self, map: &ResidualMap, sign: f64, du: f64, dv: f64) -> Option<f64> {
        const STARTS: usize = 24;
        let (nu, nv) = (map.nu, map.nv);
        let value = |k: usize| map.residual.get(k).copied().flatten().map(|r| sign * r);
        let mut extrema: Vec<(f64, usize)> = Vec::new();
        for i in 0..nu {
            for j in 0..nv {
                let k = i * nv + j;
                let Some(r) = value(k) else { continue };
                let mut is_max = true;
                for di in -1i64..=1 {
                    for dj in -1i64..=1 {
                        let (a, b) = (i as i64 + di, j as i64 + dj);
                        if (di, dj) == (0, 0) || a < 0 || b < 0 || a >= nu as i64 || b >= nv as i64
                        {
                            continue;
                        }
                        if let Some(o) = value(a as usize * nv + b as usize) {
                            if o > r {
                                is_max = false;
                            }
                        }
                    }
                }
                if is_max {
                    extrema.push((r, k));
                }
            }
        }
        extrema.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let grid_best = extrema.first().map(|e| e.0)?;
        if sign < 0.0 && grid_best <= 0.0 {
            // No gouge on the grid: nothing to refine.
            return Some(-grid_best);
        }
        let mut best = grid_best;
        let mut scratch = Vec::new();
        for &(r0, k) in extrema.iter().take(STARTS) {
            let Some(&[mut u, mut v]) = map.uv.get(k) else {
                continue;
            };
            let mut r = r0;
            let (mut su, mut sv) = (du, dv);
            for _ in 0..400 {
                if su < du * 1e-7 {
                    break;
                }
                let mut moved = None;
                for (a, b) in [
                    (1.0, 0.0),
                    (-1.0, 0.0),
                    (0.0, 1.0),
                    (0.0, -1.0),
                    (1.0, 1.0),
                    (1.0, -1.0),
                    (-1.0, 1.0),
                    (-1.0, -1.0),
                ] {
                    let (uu, vv) = self.surface.clamp_uv(u + a * su, v + b * sv);
                    let Some((p, n, _)) = self.sample(uu, vv) else {
                        continue;
                    };
                    if let Some(x) = self.residual(&p, &n, &mut scratch) {
                        if sign * x > r && moved.is_none_or(|(m, _, _)| sign * x > m) {
                            moved = Some((sign * x, uu, vv));
                        }
                    }
                }
                match moved {
                    Some((x, uu, vv)) => {
                        r = x;
                        u = uu;
                        v = vv;
                    }
                    None => {
                        su *= 0.5;
                        sv *= 0.5;
                    }
                }
            }
            best = best.max(r);
        }
        Some(sign * best)
    }
}

/// Largest arc lengths of the u- and v-isolines (sampled), mm.
fn extents(surface: &NurbsSurface) -> (f64, f64) {
    let ((u0, u1), (v0, v1)) = surface.domain();
    const LINES: usize = 9;
    const STEPS: usize = 64;
    let mut len_u: f64 = 0.0;
    let mut len_v: f64 = 0.0;
    for l in 0..LINES {
        let f = l as f64 / (LINES - 1) as f64;
        let (v, u) = (v0 + f * (v1 - v0), u0 + f * (u1 - u0));
        let mut a = 0.0;
        let mut b = 0.0;
        let mut pa = surface.point(u0, v);
        let mut pb = surface.point(u, v0);
        for s in 1..=STEPS {
            let g = s as f64 / STEPS as f64;
            let qa = surface.point(u0 + g * (u1 - u0), v);
            let qb = surface.point(u, v0 + g * (v1 - v0));
            a += (qa - pa).norm();
            b += (qb - pb).norm();
            pa = qa;
            pb = qb;
        }
        len_u = len_u.max(a);
        len_v = len_v.max(b);
    }
    (len_u, len_v)
}

fn grid_resolution(
    settings: &ScallopSettings,
    cutter: &CutterShape,
    len_u: f64,
    len_v: f64,
) -> Result<f64> {
    let r = settings.resolution_mm;
    if r.is_nan() || r.is_infinite() {
        return Err(Error::invalid(
            "simulation_resolution",
            format!("{r} is not a finite number"),
        ));
    }
    let count = |res: f64| (len_u / res).ceil().max(2.0) * (len_v / res).ceil().max(2.0);
    if r > 0.0 {
        let n = count(r);
        if n > MAX_SAMPLES as f64 {
            return Err(Error::invalid(
                "simulation_resolution",
                format!(
                    "{r} mm needs {n:.0} samples on this {len_u:.1} x {len_v:.1} mm surface, more than the limit {MAX_SAMPLES}"
                ),
            ));
        }
        return Ok(r);
    }
    let mut res = cutter.radius / 8.0;
    let n = count(res);
    if n > AUTO_MAX_SAMPLES as f64 {
        res *= (n / AUTO_MAX_SAMPLES as f64).sqrt() * 1.01;
    }
    Ok(res)
}

/// Distance between segments [p0, p1] and [q0, q1] (Ericson, Real-Time Collision Detection 5.1.9).
fn segment_distance(
    p0: &Vector3<f64>,
    p1: &Vector3<f64>,
    q0: &Vector3<f64>,
    q1: &Vector3<f64>,
) -> f64 {
    let d1 = p1 - p0;
    let d2 = q1 - q0;
    let r = p0 - q0;
    let a = d1.norm_squared();
    let e = d2.norm_squared();
    let f = d2.dot(&r);
    let (s, t);
    if a <= 1e-30 && e <= 1e-30 {
        return r.norm();
    }
    if a <= 1e-30 {
        s = 0.0;
        t = (f / e).clamp(0.0, 1.0);
    } else {
        let c = d1.dot(&r);
        if e <= 1e-30 {
            t = 0.0;
            s = (-c / a).clamp(0.0, 1.0);
        } else {
            let b = d1.dot(&d2);
            let denom = a * e - b * b;
            let mut s0 = if denom > 1e-30 {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t0 = (b * s0 + f) / e;
            if t0 < 0.0 {
                t0 = 0.0;
                s0 = (-c / a).clamp(0.0, 1.0);
            } else if t0 > 1.0 {
                t0 = 1.0;
                s0 = ((b - c) / a).clamp(0.0, 1.0);
            }
            s = s0;
            t = t0;
        }
    }
    ((p0 + d1 * s) - (q0 + d2 * t)).norm()
}
