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

use super::minimum::bracket_min;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use toolpath_formats::PlanResult;
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::NurbsSurface;
use toolpath_kernel::progress::{NoProgress, Progress};
use toolpath_kernel::tools::cutter_shape::radial_interval;
use toolpath_kernel::tools::{CutterShape, Tool};

/// Simulation settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScallopSettings {
    /// Grid spacing on the surface, mm. `<= 0` (the default) means automatic:
    /// R/8 for cutter radius R (0.3125 mm for R = 2.5), made coarser if the
    /// surface would need more than [`AUTO_MAX_SAMPLES`] samples.
    pub resolution_mm: f64,
    /// How many of the grid's highest local maxima (and lowest minima) are
    /// climbed to the extremum between the samples.
    pub peak_starts: usize,
}

/// Grid extrema refined by a plain verification ([`ScallopSettings::peak_starts`]).
pub const PEAK_STARTS: usize = 24;
/// Grid extrema refined while repair passes are added: a plan with narrow
/// peaks above h (pass defects on strongly anisotropic surfaces) can hide
/// one among hundreds of ridge maxima only just below h.
pub const DEEP_PEAK_STARTS: usize = 240;

impl Default for ScallopSettings {
    fn default() -> Self {
        Self {
            resolution_mm: 0.0,
            peak_starts: PEAK_STARTS,
        }
    }
}

impl ScallopSettings {
    /// Settings with a given spacing, or automatic for `None` (a job's `simulation_resolution`).
    pub fn with_resolution(resolution_mm: Option<f64>) -> Self {
        Self {
            resolution_mm: resolution_mm.unwrap_or(0.0),
            ..Self::default()
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
    /// Samples off a trimmed face (in a hole or outside the outer loop):
    /// not machined, not counted. Empty for an untrimmed surface.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub off_face: Vec<bool>,
}

impl ResidualMap {
    /// Whether sample `k` lies on the face (always, untrimmed).
    pub fn on_face(&self, k: usize) -> bool {
        !self.off_face.get(k).copied().unwrap_or(false)
    }
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
    /// The residual maxima refined between grid samples, highest first
    /// (climbed from the highest grid maxima): a narrow peak above h that
    /// no grid sample shows is located here.
    pub peaks: Vec<RefinedPeak>,
}

/// A residual maximum refined between the grid samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefinedPeak {
    pub uv: [f64; 2],
    pub xyz: [f64; 3],
    pub residual: f64,
}

/// Simulates `result` (a milling result with `cl`/`axis` per point) on `surface`.
pub fn simulate(
    surface: &NurbsSurface,
    tool: &Tool,
    result: &PlanResult,
    settings: &ScallopSettings,
) -> Result<ScallopReport> {
    simulate_checked(surface, tool, result, settings, &NoProgress)
}

/// [`simulate`], checking `progress` for a stop about every thousand samples.
pub fn simulate_checked(
    surface: &NurbsSurface,
    tool: &Tool,
    result: &PlanResult,
    settings: &ScallopSettings,
    progress: &dyn Progress,
) -> Result<ScallopReport> {
    progress.check()?;
    let sim = Simulator::new(surface, tool, result)?;
    sim.run_with(settings, Method::Fast, progress)
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
    /// mid_top - mid_tip, its squared length and the reciprocal, and
    /// (R + margin)^2: the reach test's per-motion constants.
    mid_d: Vector3<f64>,
    mid_dd: f64,
    mid_inv_dd: f64,
    reach2: f64,
    /// The sample-independent products of [`SweepLine`]: tip1 - tip0,
    /// axis1 - axis0, |axis(s)|^2's coefficients, (tip1 - tip0) . axis0,
    /// (tip1 - tip0) . (axis1 - axis0), |tip1 - tip0|^2.
    dt: Vector3<f64>,
    da: Vector3<f64>,
    q: [f64; 3],
    dt_a0: f64,
    dt_da: f64,
    dt_dt: f64,
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

/// The drop of the tool along one motion at one sample's line p + t n, as a
/// function of the motion parameter s. For a flat end the pose's products
/// with the line are expanded in s once (the unnormalised axis is linear in
/// s, its squared length quadratic), so each drop is the closed form of
/// [`CutterShape::lowest_hit`] from a few scalars: two square roots and three
/// divisions instead of the pose's vectors. Other cutters evaluate the pose.
struct SweepLine<'a> {
    sim: &'a Simulator<'a>,
    seg: &'a Segment,
    p: &'a Vector3<f64>,
    n: &'a Vector3<f64>,
    flat: bool,
    /// |axis0 + s (axis1 - axis0)|^2.
    q: [f64; 3],
    /// (p - tip(s)) . (axis0 + s (axis1 - axis0)).
    z: [f64; 3],
    /// n . (axis0 + s (axis1 - axis0)).
    na: [f64; 2],
    /// |p - tip(s)|^2.
    xx: [f64; 3],
    /// (p - tip(s)) . n.
    xn: [f64; 2],
    /// |n|^2.
    nn: f64,
    /// A flat end with n . axis > 0 along the motion (a finite
    /// [`Self::plane_bound`]): the rim kink can be solved for.
    kinks: bool,
}

impl<'a> SweepLine<'a> {
    /// The line's products with the motion, only those the tip-plane bound
    /// needs (`z`, `na`); [`Self::complete`] adds the rest before any drop.
    fn new(
        sim: &'a Simulator<'a>,
        seg: &'a Segment,
        p: &'a Vector3<f64>,
        n: &'a Vector3<f64>,
    ) -> Self {
        let flat = sim.cutter.corner_radius == 0.0;
        let d0 = p - seg.tip0;
        let (a0, da) = (&seg.axis0, &seg.da);
        Self {
            sim,
            seg,
            p,
            n,
            flat,
            q: seg.q,
            z: [d0.dot(a0), d0.dot(da) - seg.dt_a0, -seg.dt_da],
            na: [n.dot(a0), n.dot(da)],
            xx: [0.0; 3],
            xn: [0.0; 2],
            nn: 0.0,
            kinks: false,
        }
    }

    /// Adds the products only the drop needs (`xx`, `xn`, `nn`).
    fn complete(mut self) -> Self {
        let (p, n, seg) = (self.p, self.n, self.seg);
        let d0 = p - seg.tip0;
        self.xx = [d0.norm_squared(), -2.0 * d0.dot(&seg.dt), seg.dt_dt];
        self.xn = [d0.dot(n), -seg.dt.dot(n)];
        self.nn = n.norm_squared();
        self
    }

    /// A lower bound of the drop over the whole motion (s in [0, 1]), any
    /// cutter: every cutter lies above the plane through its tip across its
    /// axis, so at pose s the line can only meet it at t >= c(s) = -z(s) / na(s)
    /// (for n . axis > 0; the normalisation of the axis cancels). c is a
    /// quadratic over a linear function of s, its minimum at an end or where
    /// -z2 na1 s^2 - 2 z2 na0 s + (z0 na1 - z1 na0) = 0. Minus infinity where
    /// the line is within 0.06 deg of the tip plane somewhere along the motion
    /// (na linear in s, so checked at the ends), where rounding could matter.
    fn plane_bound(&self) -> f64 {
        let [na0, na1] = self.na;
        let [z0, z1, z2] = self.z;
        let (d0, d1) = (na0, na0 + na1);
        if !(d0 > 1e-3 && d1 > 1e-3) {
            return f64::NEG_INFINITY;
        }
        let c = |s: f64| -(z0 + s * (z1 + s * z2)) / (na0 + s * na1);
        let mut low = c(0.0).min(c(1.0));
        let (qa, qb, qc) = (-z2 * na1, -2.0 * z2 * na0, z0 * na1 - z1 * na0);
        let mut root = |s: f64| {
            if s > 0.0 && s < 1.0 {
                low = low.min(c(s));
            }
        };
        if qa.abs() > 1e-300 {
            let disc = qb * qb - 4.0 * qa * qc;
            if disc >= 0.0 {
                let r = disc.sqrt();
                root((-qb - r) / (2.0 * qa));
                root((-qb + r) / (2.0 * qa));
            }
        } else if qb.abs() > 1e-300 {
            root(-qc / qb);
        }
        // Rounding (terms of a few mm over na >= 1e-3): below 1e-11 mm.
        low - 1e-9
    }

    fn drop(&self, s: f64) -> f64 {
        let q = self.q[0] + s * (self.q[1] + s * self.q[2]);
        // The pose falls back to axis0 where the interpolated axis vanishes.
        if !self.flat || q.is_nan() || q <= 1e-24 {
            return self.sim.drop_at(self.seg, s, self.p, self.n);
        }
        let cutter = &self.sim.cutter;
        let inv = 1.0 / q.sqrt();
        let z0 = (self.z[0] + s * (self.z[1] + s * self.z[2])) * inv;
        let na = (self.na[0] + s * self.na[1]) * inv;
        let xx = self.xx[0] + s * (self.xx[1] + s * self.xx[2]);
        let xn = self.xn[0] + s * self.xn[1];
        // w0 = x0 - axis z0 and m = n - axis na, the parts across the axis.
        let mm = (self.nn - na * na).max(0.0);
        let ww = (xx - z0 * z0).max(0.0);
        let wm = xn - z0 * na;
        let big_r = cutter.radius;
        let Some((a, b)) = radial_interval(mm, wm, ww, big_r * big_r) else {
            return f64::INFINITY;
        };
        let (c, d) = if na.abs() <= 1e-15 {
            if (0.0..=cutter.length).contains(&z0) {
                (f64::NEG_INFINITY, f64::INFINITY)
            } else {
                return f64::INFINITY;
            }
        } else {
            let (lo, hi) = (-z0 / na, (cutter.length - z0) / na);
            (lo.min(hi), lo.max(hi))
        };
        let (entry, exit) = (a.max(c), b.min(d));
        if entry.is_nan() || entry > exit || entry > self.sim.cap {
            return f64::INFINITY;
        }
        if entry >= -self.sim.depth {
            return entry;
        }
        // The solid starts below the searched range: a hit only if it is still there.
        if exit >= -self.sim.depth {
            -self.sim.depth
        } else {
            f64::INFINITY
        }
    }
}

impl SweepLine<'_> {
    /// For a flat end, |X(s)|^2 - R^2 with X(s) the point where the line
    /// crosses the tip plane at pose s, taken from the tip (X is across the
    /// axis, so |X| is its distance from the axis): where it is <= 0 the line
    /// enters the tool through its bottom disc and the drop is the tip
    /// plane's c(s) = -z(s) / na(s) exactly, elsewhere the drop is above c(s)
    /// or infinite. Its roots are the rim crossings, the drop's kinks. Needs
    /// na > 0 along the motion (a finite [`Self::plane_bound`]).
    fn rim_gap(&self, s: f64) -> f64 {
        let na = self.na[0] + s * self.na[1];
        let c = -(self.z[0] + s * (self.z[1] + s * self.z[2])) / na;
        let xx = self.xx[0] + s * (self.xx[1] + s * self.xx[2]);
        let xn = self.xn[0] + s * self.xn[1];
        let big_r = self.sim.cutter.radius;
        xx + c * (2.0 * xn + c * self.nn) - big_r * big_r
    }

    /// The minimum of a flat end's drop along the whole motion when it lies
    /// at a rim kink, without scanning drops: the rim gap on the scan grid
    /// (`k` steps) brackets the rim crossings; with one or two, each is
    /// solved as in [`Self::kink_min`] and the lower kink drop is kept if the
    /// drop half a tolerance to each side is no lower (a local minimum of the
    /// convex drop is its minimum). `None` otherwise: the caller scans.
    fn kink_first(&self, k: usize, tol: f64) -> Option<f64> {
        let ds = 1.0 / k as f64;
        let mut prev = (0.0, self.rim_gap(0.0));
        let mut brackets = [((0.0, 0.0), (0.0, 0.0)); 2];
        let mut count = 0;
        for i in 1..=k {
            let s = if i == k { 1.0 } else { i as f64 * ds };
            let g = self.rim_gap(s);
            if !(g.is_finite() && prev.1.is_finite()) {
                return None;
            }
            if (g <= 0.0) != (prev.1 <= 0.0) {
                *brackets.get_mut(count)? = (prev, (s, g));
                count += 1;
            }
            prev = (s, g);
        }
        let mut best: Option<(f64, f64)> = None;
        for &((a, ga), (b, gb)) in &brackets[..count] {
            let s_k = self.rim_crossing(a, ga, b, gb, tol);
            let f_k = self.drop(s_k);
            if f_k.is_finite() && best.is_none_or(|q| f_k < q.1) {
                best = Some((s_k, f_k));
            }
        }
        let (s_k, f_k) = best?;
        // At an end of the motion there is nothing beyond it to check.
        let h = 0.5 * tol;
        let f_l = if s_k - h > 0.0 {
            self.drop(s_k - h)
        } else {
            f64::INFINITY
        };
        let f_r = if s_k + h < 1.0 {
            self.drop(s_k + h)
        } else {
            f64::INFINITY
        };
        (f_l >= f_k && f_r >= f_k).then_some(f_k)
    }

    /// The rim crossing between a and b (rim gaps ga, gb of opposite signs)
    /// by regula falsi (Illinois) to 1e-3 of `tol`, on the disc side (gap <= 0),
    /// where the drop is the tip plane's.
    fn rim_crossing(&self, a: f64, ga: f64, b: f64, gb: f64, tol: f64) -> f64 {
        let mut br = toolpath_kernel::geometry::numeric::Bracket::new(a, ga, b, gb);
        for _ in 0..60 {
            if br.width() <= 1e-3 * tol {
                break;
            }
            let x = br.trial();
            br.narrow(x, self.rim_gap(x));
        }
        br.neg
    }

    /// The minimum of a flat end's drop at a rim kink next to the lowest of
    /// the `known` drops (sorted by s, finite), when the kink is certified:
    /// the rim crossing between the lowest and a neighbour of the other side
    /// of the rim, solved by regula falsi (Illinois) on [`Self::rim_gap`] to
    /// 1e-3 of the tolerance, and the drop at it no higher than at half a
    /// tolerance to each side (so the convex drop has its minimum within one
    /// tolerance, the stopping rule of [`bracket_min`]). `None` otherwise:
    /// the caller searches as before.
    fn kink_min(&self, known: &[(f64, f64)], tol: f64) -> Option<f64> {
        let m = (1..known.len()).fold(0, |m, i| if known[i].1 < known[m].1 { i } else { m });
        let (s_m, f_m) = *known.get(m)?;
        let g_m = self.rim_gap(s_m);
        let mut best: Option<(f64, f64)> = None;
        for j in [m.wrapping_sub(1), m + 1] {
            let Some(&(s_j, _)) = known.get(j) else {
                continue;
            };
            let g_j = self.rim_gap(s_j);
            if (g_m <= 0.0) == (g_j <= 0.0) || !g_m.is_finite() || !g_j.is_finite() {
                continue;
            }
            let s_k = self.rim_crossing(s_m, g_m, s_j, g_j, tol);
            let f_k = self.drop(s_k);
            if f_k.is_finite() && best.is_none_or(|b| f_k < b.1) {
                best = Some((s_k, f_k));
            }
        }
        let (s_k, f_k) = best?;
        // A known end closer than half a tolerance stands for that side.
        let (first, last) = (known[0], known[known.len() - 1]);
        let h = 0.5 * tol;
        let f_l = if s_k - h > first.0 {
            self.drop(s_k - h)
        } else {
            first.1
        };
        let f_r = if s_k + h < last.0 {
            self.drop(s_k + h)
        } else {
            last.1
        };
        if f_l >= f_k && f_r >= f_k {
            Some(f_k.min(f_m))
        } else {
            None
        }
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
        self.visit(a, b, |ids| out.extend_from_slice(ids));
    }

    /// Calls `f` with the segment ids of every cell meeting the box [a, b].
    fn visit(&self, a: &Vector3<f64>, b: &Vector3<f64>, mut f: impl FnMut(&[u32])) {
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
                    f(&self.items[self.offsets[c] as usize..self.offsets[c + 1] as usize]);
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
    /// Box of each segment's swept tool (what the buckets index).
    boxes: Vec<(Vector3<f64>, Vector3<f64>)>,
    /// Residuals above this are "not reached" (the tool radius).
    cap: f64,
    /// Gouges are searched to this depth below the surface (the tool diameter);
    /// deeper ones are reported as this depth.
    depth: f64,
    /// Largest spacing of the sub-positions scanned along a motion, mm.
    scan_step: f64,
}

/// Bisects between `s_in` (drop finite) and `s_out` (line misses the tool)
/// for the last position that still hits; returns it with its drop.
fn edge(
    drop: impl Fn(f64) -> f64,
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
        let f = drop(mid);
        if f.is_finite() {
            s_in = mid;
            f_in = f;
        } else {
            s_out = mid;
        }
    }
    (s_in, f_in)
}

/// Slope of the drop between two scanned positions (NaN if either is missing or infinite).
fn slope(a: (f64, f64), b: (f64, f64)) -> f64 {
    if a.1.is_finite() && b.1.is_finite() {
        (b.1 - a.1) / (b.0 - a.0)
    } else {
        f64::NAN
    }
}

/// Per-thread working memory of the fast residual.
struct Scratch {
    ids: Vec<u32>,
    /// Per segment, the number of the last query that listed it.
    stamp: Vec<u32>,
    query: u32,
    /// The segment that gave the previous sample's residual.
    last_best: Option<u32>,
}

impl Scratch {
    fn new(segments: usize) -> Self {
        Self {
            ids: Vec::new(),
            stamp: vec![0; segments],
            query: 0,
            last_best: None,
        }
    }
}

/// A surface sample: point, unit tool-side normal, area weight (`None` where the normal is undefined).
type Frame = Option<(Vector3<f64>, Vector3<f64>, f64)>;

/// A sample's line p + t n over the searched range t in [-depth, cap], as
/// the segment a + s d (s in [0, 1]) with |d|^2 and its reciprocal: the
/// reach test's per-sample constants.
struct ReachLine {
    a: Vector3<f64>,
    d: Vector3<f64>,
    dd: f64,
    inv_dd: f64,
}

impl ReachLine {
    fn new(p: &Vector3<f64>, n: &Vector3<f64>, depth: f64, cap: f64) -> Self {
        let a = p - n * depth;
        let d = (p + n * cap) - a;
        let dd = d.norm_squared();
        Self {
            a,
            d,
            dd,
            inv_dd: 1.0 / dd,
        }
    }

    /// Squared distance from this segment to the motion's mid axis (the
    /// closest points of [`segment_distance`] with the per-segment and
    /// per-sample constants hoisted: one division instead of a square root
    /// and four).
    fn distance2_to_mid_axis(&self, seg: &Segment) -> f64 {
        let (e, d2) = (seg.mid_dd, &seg.mid_d);
        if !(self.dd > 1e-30 && e > 1e-30) {
            let d = segment_distance(&self.a, &(self.a + self.d), &seg.mid_tip, &seg.mid_top);
            return d * d;
        }
        let r = self.a - seg.mid_tip;
        let f = d2.dot(&r);
        let c = self.d.dot(&r);
        let b = self.d.dot(d2);
        let denom = self.dd * e - b * b;
        let mut s = if denom > 1e-30 {
            ((b * f - c * e) / denom).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let mut t = (b * s + f) * seg.mid_inv_dd;
        if t < 0.0 {
            t = 0.0;
            s = (-c * self.inv_dd).clamp(0.0, 1.0);
        } else if t > 1.0 {
            t = 1.0;
            s = ((b - c) * self.inv_dd).clamp(0.0, 1.0);
        }
        (r + self.d * s - d2 * t).norm_squared()
    }
}

/// The fast residual relies on the drop being convex in the motion parameter,
/// which holds exactly for a translating tool; a turning axis bends it
/// slightly, far less than this slack on real plans (tests/scallop_accuracy.rs
/// holds the fast map within 1e-4 mm of `run_reference`). A motion is only
/// left unrefined when the convexity bounds put it this far above the lowest
/// drop found so far.
const CONVEXITY_SLACK_MM: f64 = 5e-3;

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
                    let mid_top = mid_tip + mid * len;
                    let (dt, da) = (tip1 - tip0, axis1 - axis0);
                    let mid_d = mid_top - mid_tip;
                    let mid_dd = mid_d.norm_squared();
                    segments.push(Segment {
                        tip0,
                        tip1,
                        axis0,
                        axis1,
                        travel,
                        mid_tip,
                        mid_top,
                        margin,
                        mid_d,
                        mid_dd,
                        mid_inv_dd: 1.0 / mid_dd,
                        reach2: (big_r + margin) * (big_r + margin),
                        dt,
                        da,
                        q: [
                            axis0.norm_squared(),
                            2.0 * axis0.dot(&da),
                            da.norm_squared(),
                        ],
                        dt_a0: dt.dot(&axis0),
                        dt_da: dt.dot(&da),
                        dt_dt: dt.norm_squared(),
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
        let buckets = Buckets::new(&boxes, big_r);
        Ok(Self {
            surface,
            cutter,
            segments,
            buckets,
            boxes,
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

    /// Lowest drop of the tool swept along `seg` at the line p + t n, or some
    /// value >= `cutoff` when the drop cannot go below `cutoff`.
    ///
    /// The same scan and refinement as [`Self::sweep_min_reference`], cut short
    /// by the convexity of the drop in the motion parameter (docs/methods.md,
    /// "Scallop simulator"): once the scanned drop rises it keeps rising, so
    /// the scan stops there (and where the line leaves the tool's reach); a
    /// secant through two scanned drops bounds the drop beyond them from below,
    /// so a segment that cannot beat `cutoff` is left before its refinement.
    /// Before any of that, a motion whose tip plane stays at or above `cutoff`
    /// along the line ([`SweepLine::plane_bound`], exact) is left unscanned.
    fn sweep_min(&self, seg: &Segment, p: &Vector3<f64>, n: &Vector3<f64>, cutoff: f64) -> f64 {
        let line = SweepLine::new(self, seg, p, n);
        let bound = line.plane_bound();
        if bound >= cutoff {
            return f64::INFINITY;
        }
        let mut line = line.complete();
        line.kinks = line.flat && bound.is_finite() && seg.travel > 0.0;
        let k = ((seg.travel / self.scan_step).ceil() as usize).clamp(1, 4096);
        if line.kinks {
            if let Some(f) = line.kink_first(k, SWEEP_TOL_MM / seg.travel) {
                return f;
            }
        }
        let ds = 1.0 / k as f64;
        let s_close = self.closest_position(seg, p, n);
        const NONE: (f64, f64) = (f64::NAN, f64::INFINITY);
        let mut best = NONE;
        let mut left = NONE;
        let mut right = NONE;
        // The last two scanned positions, most recent last.
        let mut prev2 = NONE;
        let mut prev = NONE;
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
            let h = line.drop(s);
            if h < best.1 {
                best = (s, h);
                left = prev;
                right = NONE;
                right_pending = true;
            } else if right_pending {
                right = (s, h);
                right_pending = false;
            }
            if prev.1.is_finite() && (!h.is_finite() || h > prev.1) {
                // Past the minimum, or out of the tool's reach for good.
                break;
            }
            if prev2.1.is_finite() && prev.1.is_finite() && h <= prev.1 {
                // Drops falling: nothing before `prev` is below prev.1, nothing after
                // it below the secant through prev2 and prev.
                let slope = (prev.1 - prev2.1) / (prev.0 - prev2.0);
                if prev.1 + slope.min(0.0) * (1.0 - prev.0) >= cutoff + CONVEXITY_SLACK_MM {
                    return f64::INFINITY;
                }
            }
            prev2 = prev;
            prev = (s, h);
        }
        if !best.1.is_finite() {
            return best.1;
        }
        // The drop is convex: left of the best position it lies above the secant
        // through the best and its right neighbour, right of it above the one
        // through its left neighbour (an unscanned side has nothing to bound).
        let m_left = slope(left, best);
        let m_right = slope(best, right);
        let low_left = if left.0.is_nan() {
            best.1
        } else if m_right.is_nan() {
            f64::NEG_INFINITY
        } else {
            best.1 - m_right.max(0.0) * (best.0 - left.0)
        };
        let low_right = if right.0.is_nan() {
            best.1
        } else if m_left.is_nan() {
            f64::NEG_INFINITY
        } else {
            best.1 + m_left.min(0.0) * (right.0 - best.0)
        };
        if low_left.min(low_right) >= cutoff + CONVEXITY_SLACK_MM {
            return f64::INFINITY;
        }
        if seg.travel <= 0.0 {
            return best.1;
        }
        // Probe one tolerance step to each side: a drop that rises on both
        // sides (or leaves the tool's reach) has its minimum at the best position.
        let tol = SWEEP_TOL_MM / seg.travel;
        let probe = |side: (f64, f64)| {
            if side.0.is_nan() || (side.0 - best.0).abs() <= tol {
                return NONE;
            }
            let s = best.0 + tol.copysign(side.0 - best.0);
            (s, line.drop(s))
        };
        let probes = [probe(left), probe(right)];
        let (to_left, to_right) = (probes[0].1 < best.1, probes[1].1 < best.1);
        match (to_left, to_right) {
            (false, false) if best.1 >= cutoff + CONVEXITY_SLACK_MM => return best.1,
            (true, false) if left.1 == f64::INFINITY && right.1.is_finite() => {
                return Self::edge_minimum(&line, best, left.0, right, tol, cutoff);
            }
            (false, true) if right.1 == f64::INFINITY && left.1.is_finite() => {
                return Self::edge_minimum(&line, best, right.0, left, tol, cutoff);
            }
            (true, false) => return Self::refine_fast(&line, best, (left, NONE), probes),
            (false, true) => return Self::refine_fast(&line, best, (NONE, right), probes),
            _ => {}
        }
        // The drop rises both ways from the best scanned position (or falls
        // both ways, off convexity): a flat end's certified rim kink next to
        // it, else the reference's golden section over both neighbours, which
        // finds the same minimum as the reference where a turning axis gives
        // the drop two.
        if line.kinks {
            let mut known = [(0.0, 0.0); 5];
            let mut count = 0;
            for q in [left, probes[0], best, probes[1], right] {
                if q.1.is_finite() && !q.0.is_nan() && (count == 0 || q.0 > known[count - 1].0) {
                    known[count] = q;
                    count += 1;
                }
            }
            if let Some(f) = line.kink_min(&known[..count], tol) {
                return f;
            }
        }
        // On the expanded drop: the reference's positions, its drops to rounding.
        Self::refine_bracket(seg, |s| line.drop(s), best, left, right)
    }

    /// [`Self::refine_bracket`] with the minimum searched by
    /// [`bracket_min`] from every drop known around it (the scanned
    /// neighbours, the reach edges, the probes): the same bracket and the
    /// same stopping rule as the reference's golden section.
    fn refine_fast(
        line: &SweepLine,
        best: (f64, f64),
        (left, right): ((f64, f64), (f64, f64)),
        probes: [(f64, f64); 2],
    ) -> f64 {
        if !best.1.is_finite() || line.seg.travel <= 0.0 {
            return best.1;
        }
        let tol = SWEEP_TOL_MM / line.seg.travel;
        // A scanned neighbour where the line misses gives the reach edge.
        let end = |q: (f64, f64)| {
            if q.0.is_nan() || q.1.is_finite() {
                q
            } else {
                edge(|s| line.drop(s), best.0, best.1, q.0, tol)
            }
        };
        let mut pts = [end(left), probes[0], best, probes[1], end(right)];
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut known = [(0.0, 0.0); 5];
        let mut count = 0;
        for q in pts {
            if q.1.is_finite() && !q.0.is_nan() && (count == 0 || q.0 > known[count - 1].0) {
                known[count] = q;
                count += 1;
            }
        }
        if line.kinks {
            if let Some(f) = line.kink_min(&known[..count], tol) {
                return f;
            }
        }
        bracket_min(|s| line.drop(s), &known[..count], tol, 200)
    }

    /// Minimum of the drop between the edge of the tool's reach (between
    /// `s_out`, where the line misses, and `inner.0`) and the finite scanned
    /// drop `far` beyond `inner`, or infinity once it cannot beat `cutoff`.
    /// The edge is bisected as in [`edge`], each step checking the convexity
    /// bound of the drop past the last hit; a drop that rises from the edge
    /// has its minimum there, else [`bracket_min`] finishes it.
    fn edge_minimum(
        line: &SweepLine,
        inner: (f64, f64),
        mut s_out: f64,
        far: (f64, f64),
        tol: f64,
        cutoff: f64,
    ) -> f64 {
        let (mut s_in, mut f_in) = inner;
        // Between `inner` and `far` the drop lies above the secant through
        // `inner` and `far` (towards the edge) and above the one through the
        // last hit and `inner` (away from it).
        let rise_far = (far.1 - inner.1) / (far.0 - inner.0).abs();
        let low_inner = inner.1 - rise_far.max(0.0) * (inner.0 - s_out).abs();
        for _ in 0..80 {
            // Past the last hit, the drop lies above the secant through it and `far`.
            let rise = (far.1 - f_in) / (far.0 - s_in).abs();
            let low_edge = f_in - rise.max(0.0) * (s_in - s_out).abs();
            let low_far = if s_in == inner.0 {
                f64::NEG_INFINITY
            } else {
                let fall = (inner.1 - f_in) / (inner.0 - s_in).abs();
                inner.1 + fall.min(0.0) * (far.0 - inner.0).abs()
            };
            if low_edge.min(low_inner).min(low_far) >= cutoff + CONVEXITY_SLACK_MM {
                return f64::INFINITY;
            }
            if (s_out - s_in).abs() <= tol * 0.1 {
                break;
            }
            let mid = 0.5 * (s_in + s_out);
            let f = line.drop(mid);
            if f.is_finite() {
                s_in = mid;
                f_in = f;
            } else {
                s_out = mid;
            }
        }
        let step = if far.0 > s_in { tol } else { -tol };
        if (far.0 - s_in).abs() > tol && line.drop(s_in + step) >= f_in {
            return f_in.min(inner.1).min(far.1);
        }
        let mut pts = [(s_in, f_in), inner, far];
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut known = [(0.0, 0.0); 3];
        let mut count = 0;
        for q in pts {
            if q.1.is_finite() && (count == 0 || q.0 > known[count - 1].0) {
                known[count] = q;
                count += 1;
            }
        }
        bracket_min(|s| line.drop(s), &known[..count], tol, 200)
    }

    /// Motion parameter where the line passes closest to the tool axis at the
    /// corner height: near the edge of a tool's reach the line meets the moving
    /// tool only over a short stretch around it, so the scan includes it.
    fn closest_position(&self, seg: &Segment, p: &Vector3<f64>, n: &Vector3<f64>) -> f64 {
        let corner = self.cutter.corner_radius;
        let w0 = seg.tip0 + seg.axis0 * corner - p;
        let w1 = seg.tip1 + seg.axis1 * corner - p;
        let (w0, dw) = (w0 - n * w0.dot(n), (w1 - w0) - n * (w1 - w0).dot(n));
        let dd = dw.norm_squared();
        if dd > 1e-30 {
            (-w0.dot(&dw) / dd).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// Lowest drop of the tool swept along `seg` at the line p + t n: the
    /// whole scan, then the refinement around its best position (the exact
    /// reference the fast [`Self::sweep_min`] is tested against).
    fn sweep_min_reference(&self, seg: &Segment, p: &Vector3<f64>, n: &Vector3<f64>) -> f64 {
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
        Self::refine_bracket(seg, |s| self.drop_at(seg, s, p, n), best, left, right)
    }

    /// Refines the minimum of the drop around the best scanned position
    /// `best` = (s, drop), given its scanned neighbours (`s` NaN: none, drop
    /// infinite: the line misses the tool there): the edge of the tool's reach
    /// by bisection, then golden-section search to [`SWEEP_TOL_MM`].
    fn refine_bracket(
        seg: &Segment,
        drop: impl Fn(f64) -> f64,
        best: (f64, f64),
        left: (f64, f64),
        right: (f64, f64),
    ) -> f64 {
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
                edge(&drop, s_best, best, left.0, tol)
            };
        }
        let (mut hi, mut f_hi) = (s_best, best);
        if !right.0.is_nan() {
            (hi, f_hi) = if right.1.is_finite() {
                right
            } else {
                edge(&drop, s_best, best, right.0, tol)
            };
        }
        best = best.min(f_lo).min(f_hi);
        best.min(Self::golden(drop, (lo, f_lo), (hi, f_hi), tol))
    }

    /// Golden-section search for the minimum of the (unimodal) drop over
    /// [lo, hi] to `tol`; the lowest drop seen, ends included.
    fn golden(
        drop: impl Fn(f64) -> f64,
        (mut lo, f_lo): (f64, f64),
        (mut hi, f_hi): (f64, f64),
        tol: f64,
    ) -> f64 {
        const G: f64 = 0.618_033_988_749_894_9;
        let mut x1 = hi - G * (hi - lo);
        let mut x2 = lo + G * (hi - lo);
        let mut f1 = drop(x1);
        let mut f2 = drop(x2);
        for _ in 0..80 {
            if hi - lo <= tol {
                break;
            }
            if f1 <= f2 {
                hi = x2;
                x2 = x1;
                f2 = f1;
                x1 = hi - G * (hi - lo);
                f1 = drop(x1);
            } else {
                lo = x1;
                x1 = x2;
                f1 = f2;
                x2 = lo + G * (hi - lo);
                f2 = drop(x2);
            }
        }
        f_lo.min(f_hi).min(f1).min(f2)
    }

    /// Residual at surface point `p` with tool-side unit normal `n`; `None` if uncovered.
    pub fn residual(
        &self,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        scratch: &mut Vec<u32>,
    ) -> Option<f64> {
        self.candidates_sorted(p, n, scratch);
        self.residual_of(p, n, scratch).0
    }

    /// The exact reference of [`Self::residual`]: every candidate segment scanned
    /// and refined in full. Slow; kept for the accuracy tests and benches.
    #[doc(hidden)]
    pub fn residual_reference(
        &self,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        scratch: &mut Vec<u32>,
    ) -> Option<f64> {
        self.candidates_sorted(p, n, scratch);
        let line = ReachLine::new(p, n, self.depth, self.cap);
        let mut best = f64::INFINITY;
        for &id in scratch.iter() {
            let Some(seg) = self.segments.get(id as usize) else {
                continue;
            };
            if !self.may_reach(seg, &line, p, n, best) {
                continue;
            }
            best = best.min(self.sweep_min_reference(seg, p, n));
        }
        (best <= self.cap).then_some(best)
    }

    /// The box of the line p + t n over the searched range [-depth, cap].
    fn line_box(&self, p: &Vector3<f64>, n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
        let a = p - n * self.depth;
        let b = p + n * self.cap;
        let pad = Vector3::repeat(1e-9);
        (a.inf(&b) - pad, a.sup(&b) + pad)
    }

    /// Ids of the segments whose cells meet the line's box, sorted, once each.
    fn candidates_sorted(&self, p: &Vector3<f64>, n: &Vector3<f64>, out: &mut Vec<u32>) {
        let (lo, hi) = self.line_box(p, n);
        out.clear();
        self.buckets.query(&lo, &hi, out);
        out.sort_unstable();
        out.dedup();
    }

    /// Ids of the segments whose cells meet the line's box, once each (marked
    /// in a per-segment stamp array instead of sorted), the segment that was
    /// lowest at the previous sample first: neighbouring samples are mostly cut
    /// by the same motion, so its drop makes the cutoff for the others tight.
    fn candidates_stamped(&self, p: &Vector3<f64>, n: &Vector3<f64>, sc: &mut Scratch) {
        let (lo, hi) = self.line_box(p, n);
        self.collect_stamped(&lo, &hi, sc);
        if let Some(pos) = sc
            .last_best
            .and_then(|b| sc.ids.iter().position(|&id| id == b))
        {
            sc.ids.swap(0, pos);
        }
    }

    /// The segments of a tile of samples (their frames): those whose own box
    /// meets the box of all the tile's lines, once each, into `sc.ids`.
    fn tile_candidates<'f>(
        &self,
        frames: impl Iterator<Item = &'f (Vector3<f64>, Vector3<f64>, f64)> + Clone,
        sc: &mut Scratch,
    ) {
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        for (p, n, _) in frames.clone() {
            let (a, b) = self.line_box(p, n);
            lo = lo.inf(&a);
            hi = hi.sup(&b);
        }
        sc.ids.clear();
        if lo.x <= hi.x {
            self.collect_stamped(&lo, &hi, sc);
        }
        // Every line of the tile lies within `rho` of the mean line (the
        // distance to a segment is convex, so its ends bound it): a motion
        // whose axis stays further than R + margin + rho from the mean line
        // fails `may_reach` at every sample of the tile.
        let (mut pc, mut nc, mut count) = (Vector3::zeros(), Vector3::zeros(), 0.0);
        for (p, n, _) in frames.clone() {
            pc += p;
            nc += n;
            count += 1.0;
        }
        let Some(nc) = nc.try_normalize(1e-12) else {
            return;
        };
        pc /= count;
        let (a, b) = (pc - nc * self.depth, pc + nc * self.cap);
        let mut rho: f64 = 0.0;
        for (p, n, _) in frames {
            for q in [p - n * self.depth, p + n * self.cap] {
                rho = rho.max(segment_distance(&q, &q, &a, &b));
            }
        }
        rho += 1e-9 * (self.depth + self.cap);
        let (segments, radius) = (&self.segments, self.cutter.radius);
        let mean = ReachLine::new(&pc, &nc, self.depth, self.cap);
        sc.ids.retain(|&id| {
            segments.get(id as usize).is_some_and(|seg| {
                let reach = radius + seg.margin + rho;
                mean.distance2_to_mid_axis(seg) <= reach * reach
            })
        });
    }

    /// Ids of the segments whose own box meets [lo, hi], once each (marked in a
    /// per-segment stamp array instead of sorted), into `sc.ids`.
    fn collect_stamped(&self, lo: &Vector3<f64>, hi: &Vector3<f64>, sc: &mut Scratch) {
        sc.ids.clear();
        sc.query = sc.query.wrapping_add(1);
        if sc.query == 0 {
            sc.stamp.fill(0);
            sc.query = 1;
        }
        let (stamp, ids, query) = (&mut sc.stamp, &mut sc.ids, sc.query);
        let boxes = &self.boxes;
        self.buckets.visit(lo, hi, |cell| {
            for &id in cell {
                if let Some(m) = stamp.get_mut(id as usize) {
                    if *m != query {
                        *m = query;
                        // A cell is larger than both boxes: keep only the
                        // segments whose own box meets the line's.
                        if boxes
                            .get(id as usize)
                            .is_some_and(|(a, b)| boxes_meet(a, b, lo, hi))
                        {
                            ids.push(id);
                        }
                    }
                }
            }
        });
    }

    /// The fast residual of a sample of the tile whose candidates are in
    /// `sc.ids`: those whose box meets the sample's line box, the previous
    /// sample's lowest motion first.
    fn residual_in_tile(
        &self,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        sc: &mut Scratch,
    ) -> Option<f64> {
        let (lo, hi) = self.line_box(p, n);
        let meets = |id: u32| {
            self.boxes
                .get(id as usize)
                .is_some_and(|(a, b)| boxes_meet(a, b, &lo, &hi))
        };
        let first = sc.last_best.filter(|&b| meets(b));
        let line = ReachLine::new(p, n, self.depth, self.cap);
        let mut best = f64::INFINITY;
        let mut lowest = None;
        let rest = sc.ids.iter().copied().filter(|&id| Some(id) != first);
        for id in first.into_iter().chain(rest) {
            if Some(id) != first && !meets(id) {
                continue;
            }
            self.consider(id, &line, p, n, &mut best, &mut lowest);
        }
        if lowest.is_some() {
            sc.last_best = lowest;
        }
        (best <= self.cap).then_some(best)
    }

    /// Lowers `best` (and sets `lowest`) to the drop of motion `id` if below.
    fn consider(
        &self,
        id: u32,
        line: &ReachLine,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        best: &mut f64,
        lowest: &mut Option<u32>,
    ) {
        let Some(seg) = self.segments.get(id as usize) else {
            return;
        };
        if !self.may_reach(seg, line, p, n, *best) {
            return;
        }
        let h = self.sweep_min(seg, p, n, *best);
        if h < *best {
            *best = h;
            *lowest = Some(id);
        }
    }

    /// The fast residual with per-thread working memory.
    fn residual_fast(&self, p: &Vector3<f64>, n: &Vector3<f64>, sc: &mut Scratch) -> Option<f64> {
        self.candidates_stamped(p, n, sc);
        let (r, lowest) = self.residual_of(p, n, &sc.ids);
        if lowest.is_some() {
            sc.last_best = lowest;
        }
        r
    }

    /// Residual over the candidate segments `ids`, and the segment giving it.
    fn residual_of(
        &self,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        ids: &[u32],
    ) -> (Option<f64>, Option<u32>) {
        let line = ReachLine::new(p, n, self.depth, self.cap);
        let mut best = f64::INFINITY;
        let mut lowest = None;
        for &id in ids {
            self.consider(id, &line, p, n, &mut best, &mut lowest);
        }
        ((best <= self.cap).then_some(best), lowest)
    }

    /// Whether the tool swept along `seg` may reach the line p + t n below `best`.
    fn may_reach(
        &self,
        seg: &Segment,
        line: &ReachLine,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        best: f64,
    ) -> bool {
        if line.distance2_to_mid_axis(seg) > seg.reach2 {
            return false;
        }
        // No point of the swept tool lies lower along n than this bound.
        let bound = self
            .cutter
            .support_low(&seg.tip0, &seg.axis0, p, n)
            .min(self.cutter.support_low(&seg.tip1, &seg.axis1, p, n))
            - 0.5 * seg.travel;
        bound < best
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
        self.run_with(settings, Method::Fast, &NoProgress)
    }

    /// [`Self::run`] with the exact reference residual everywhere. Slow; kept
    /// for the accuracy tests and benches.
    #[doc(hidden)]
    pub fn run_reference(&self, settings: &ScallopSettings) -> Result<ScallopReport> {
        self.run_with(settings, Method::Reference, &NoProgress)
    }

    /// The report; `progress` is checked per chunk of samples, and a stop
    /// found in any chunk ends the run with it.
    fn run_with(
        &self,
        settings: &ScallopSettings,
        method: Method,
        progress: &dyn Progress,
    ) -> Result<ScallopReport> {
        let ((u0, u1), (v0, v1)) = self.surface.domain();
        let (len_u, len_v) = extents(self.surface);
        let res = grid_resolution(settings, &self.cutter, len_u, len_v)?;
        let nu = ((len_u / res).ceil() as usize).max(2);
        let nv = ((len_v / res).ceil() as usize).max(2);
        let du = (u1 - u0) / nu as f64;
        let dv = (v1 - v0) / nv as f64;

        let stop = std::sync::OnceLock::new();
        let (uv, xyz, mut frames) =
            self.sample_grid((u0, v0), (du, dv), (nu, nv), (progress, &stop));
        if let Some(e) = stop.into_inner() {
            return Err(e);
        }
        // Off a trimmed face nothing is machined or counted: those samples
        // get no frame, so no residual and no area.
        let off_face: Vec<bool> = match self.surface.trim() {
            Some(_) => uv
                .iter()
                .map(|p| !self.surface.in_face(p[0], p[1]))
                .collect(),
            None => Vec::new(),
        };
        for (f, off) in frames.iter_mut().zip(&off_face) {
            if *off {
                *f = None;
            }
        }
        let stop = std::sync::OnceLock::new();
        let residual = self.residuals(&frames, (nu, nv), method, (progress, &stop));
        if let Some(e) = stop.into_inner() {
            return Err(e);
        }

        let mut uncovered = 0.0;
        let mut machined = 0.0;
        for (f, r) in frames.iter().zip(&residual) {
            let Some((_, _, area)) = f else { continue };
            match r {
                Some(_) => machined += area,
                None => uncovered += area,
            }
        }
        let map = ResidualMap {
            nu,
            nv,
            uv,
            xyz,
            residual,
            off_face,
        };
        progress.check()?;
        let starts = settings.peak_starts;
        let (max_res, peaks) = self.refine(&map, 1.0, (du, dv), starts, method);
        progress.check()?;
        let (min_res, _) = self.refine(&map, -1.0, (du, dv), starts, method);
        Ok(ScallopReport {
            max_scallop_mm: max_res.map_or(0.0, |r| r.max(0.0)),
            max_gouge_mm: min_res.map_or(0.0, |r| (-r).max(0.0)),
            uncovered_area_mm2: uncovered,
            machined_area_mm2: machined,
            resolution_mm: res,
            map,
            peaks,
        })
    }

    /// The grid's cell centres: (u, v), points, and frames, in parallel over
    /// rows (each sample is independent, so the result does not depend on threads).
    /// A stop found by `check` is put in its cell and leaves the rest unsampled.
    #[allow(clippy::type_complexity)]
    fn sample_grid(
        &self,
        (u0, v0): (f64, f64),
        (du, dv): (f64, f64),
        (nu, nv): (usize, usize),
        (progress, stop): (&dyn Progress, &std::sync::OnceLock<Error>),
    ) -> (Vec<[f64; 2]>, Vec<[f64; 3]>, Vec<Frame>) {
        let rows: Vec<usize> = (0..nu).collect();
        let parts = toolpath_kernel::parallel::map_chunks(&rows, 4, |rows| {
            if stop.get().is_some() {
                return Vec::new();
            }
            if let Err(e) = progress.check() {
                let _ = stop.set(e);
                return Vec::new();
            }
            let mut out = Vec::with_capacity(rows.len() * nv);
            for &i in rows {
                for j in 0..nv {
                    let (u, v) = (u0 + (i as f64 + 0.5) * du, v0 + (j as f64 + 0.5) * dv);
                    let (p, frame) = match self.sample(u, v) {
                        Some((p, n, area)) => (p, Some((p, n, area * du * dv))),
                        None => (self.surface.point(u, v).coords, None),
                    };
                    out.push(([u, v], [p.x, p.y, p.z], frame));
                }
            }
            out
        });
        let total = nu * nv;
        let mut uv = Vec::with_capacity(total);
        let mut xyz = Vec::with_capacity(total);
        let mut frames = Vec::with_capacity(total);
        for (a, b, c) in parts.into_iter().flatten() {
            uv.push(a);
            xyz.push(b);
            frames.push(c);
        }
        (uv, xyz, frames)
    }

    /// Residuals of all samples (`nu` x `nv`, k = i nv + j), in parallel over
    /// tiles of TILE x TILE samples, a fixed number per task. The fast residual
    /// lists a tile's candidate motions once and carries the previous sample's
    /// lowest motion within a task, so tiles and tasks must not depend on the
    /// number of threads. A stop found by `check` is put in its cell and
    /// leaves the rest uncomputed.
    fn residuals(
        &self,
        frames: &[Frame],
        (nu, nv): (usize, usize),
        method: Method,
        (progress, stop): (&dyn Progress, &std::sync::OnceLock<Error>),
    ) -> Vec<Option<f64>> {
        const TILE: usize = 8;
        const TILES_PER_TASK: usize = 16;
        let tiles: Vec<(usize, usize)> = (0..nu)
            .step_by(TILE)
            .flat_map(|i| (0..nv).step_by(TILE).map(move |j| (i, j)))
            .collect();
        let parts = toolpath_kernel::parallel::map_chunks(&tiles, TILES_PER_TASK, |tiles| {
            if stop.get().is_some() {
                return Vec::new();
            }
            if let Err(e) = progress.check() {
                let _ = stop.set(e);
                return Vec::new();
            }
            let mut scratch = Scratch::new(self.segments.len());
            let mut out = Vec::with_capacity(tiles.len() * TILE * TILE);
            for &(i0, j0) in tiles {
                let ks = (i0..(i0 + TILE).min(nu))
                    .flat_map(|i| (j0..(j0 + TILE).min(nv)).map(move |j| i * nv + j));
                let frame = |k: usize| frames.get(k).and_then(|f| f.as_ref());
                if method == Method::Fast {
                    self.tile_candidates(ks.clone().filter_map(frame), &mut scratch);
                }
                for k in ks {
                    let r = frame(k).and_then(|(p, n, _)| match method {
                        Method::Fast => self.residual_in_tile(p, n, &mut scratch),
                        Method::Reference => self.residual_reference(p, n, &mut scratch.ids),
                    });
                    out.push((k, r));
                }
            }
            out
        });
        let mut residual = vec![None; frames.len()];
        for (k, r) in parts.into_iter().flatten() {
            if let Some(slot) = residual.get_mut(k) {
                *slot = r;
            }
        }
        residual
    }

    fn residual_by(
        &self,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        scratch: &mut Scratch,
        method: Method,
    ) -> Option<f64> {
        match method {
            Method::Fast => self.residual_fast(p, n, scratch),
            Method::Reference => self.residual_reference(p, n, &mut scratch.ids),
        }
    }

    /// Refines the grid's extreme residual (`sign` 1: max, -1: min) by compass
    /// search in (u, v) from its `starts` best local extrema, the starts in
    /// parallel; `None` if nothing is covered. Also the climbed extrema,
    /// most extreme first.
    fn refine(
        &self,
        map: &ResidualMap,
        sign: f64,
        (du, dv): (f64, f64),
        starts: usize,
        method: Method,
    ) -> (Option<f64>, Vec<RefinedPeak>) {
        let (nu, nv) = (map.nu, map.nv);
        let value = |k: usize| {
            map.residual
                .get(k)
                .copied()
                .flatten()
                .filter(|_| map.on_face(k))
                .map(|r| sign * r)
        };
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
        let Some(grid_best) = extrema.first().map(|e| e.0) else {
            return (None, Vec::new());
        };
        if sign < 0.0 && grid_best <= 0.0 {
            // No gouge on the grid: nothing to refine.
            return (Some(-grid_best), Vec::new());
        }
        extrema.truncate(starts);
        let climbed: Vec<RefinedPeak> =
            toolpath_kernel::parallel::map_chunks(&extrema, 1, |start| {
                let mut scratch = Scratch::new(self.segments.len());
                start
                    .iter()
                    .map(|&(r0, k)| self.climb(map, k, r0, sign, (du, dv), &mut scratch, method))
                    .collect::<Vec<_>>()
            })
            .into_iter()
            .flatten()
            .collect();
        let best = climbed.iter().map(|p| p.residual).fold(grid_best, f64::max);
        // A start without a sample position has no place to report.
        let mut peaks: Vec<RefinedPeak> = climbed
            .into_iter()
            .filter(|p| p.uv.iter().all(|x| x.is_finite()))
            .map(|p| RefinedPeak {
                residual: sign * p.residual,
                ..p
            })
            .collect();
        peaks.sort_by(|a, b| (sign * b.residual).total_cmp(&(sign * a.residual)));
        (Some(sign * best), peaks)
    }

    /// Compass search in (u, v) for the largest `sign * residual` from grid
    /// sample `k` (the peak's residual is `sign *` the true one).
    #[allow(clippy::too_many_arguments)]
    fn climb(
        &self,
        map: &ResidualMap,
        k: usize,
        r0: f64,
        sign: f64,
        (du, dv): (f64, f64),
        scratch: &mut Scratch,
        method: Method,
    ) -> RefinedPeak {
        let (Some(&[mut u, mut v]), Some(&xyz0)) = (map.uv.get(k), map.xyz.get(k)) else {
            return RefinedPeak {
                uv: [f64::NAN; 2],
                xyz: [f64::NAN; 3],
                residual: r0,
            };
        };
        let mut xyz = xyz0;
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
                if !self.surface.in_face(uu, vv) {
                    continue;
                }
                let Some((p, n, _)) = self.sample(uu, vv) else {
                    continue;
                };
                if let Some(x) = self.residual_by(&p, &n, scratch, method) {
                    if sign * x > r && moved.is_none_or(|(m, _, _, _)| sign * x > m) {
                        moved = Some((sign * x, uu, vv, p));
                    }
                }
            }
            match moved {
                Some((x, uu, vv, p)) => {
                    r = x;
                    u = uu;
                    v = vv;
                    xyz = [p.x, p.y, p.z];
                }
                None => {
                    su *= 0.5;
                    sv *= 0.5;
                }
            }
        }
        RefinedPeak {
            uv: [u, v],
            xyz,
            residual: r,
        }
    }
}

/// Which residual a run uses.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Method {
    Fast,
    Reference,
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

/// Checks a job's `simulation_resolution` on `surface` before any work: the
/// grid it asks for must stay within [`MAX_SAMPLES`].
pub fn check_resolution(surface: &NurbsSurface, resolution_mm: Option<f64>) -> Result<()> {
    match resolution_mm {
        Some(r) => {
            let (len_u, len_v) = extents(surface);
            fixed_resolution(r, len_u, len_v).map(|_| ())
        }
        None => Ok(()),
    }
}

/// A given grid resolution `r` > 0, refused when its grid on a surface of
/// `len_u` x `len_v` mm exceeds [`MAX_SAMPLES`].
fn fixed_resolution(r: f64, len_u: f64, len_v: f64) -> Result<f64> {
    let n = (len_u / r).ceil().max(2.0) * (len_v / r).ceil().max(2.0);
    if n.is_nan() || n > MAX_SAMPLES as f64 {
        return Err(Error::invalid(
            "simulation_resolution",
            format!(
                "{r} mm needs {n:.0} samples on this {len_u:.1} x {len_v:.1} mm surface, more than the limit {MAX_SAMPLES}"
            ),
        ));
    }
    Ok(r)
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
        return fixed_resolution(r, len_u, len_v);
    }
    let mut res = cutter.radius / 8.0;
    let n = count(res);
    if n > AUTO_MAX_SAMPLES as f64 {
        res *= (n / AUTO_MAX_SAMPLES as f64).sqrt() * 1.01;
    }
    Ok(res)
}

/// Whether the boxes [a, b] and [lo, hi] meet.
fn boxes_meet(a: &Vector3<f64>, b: &Vector3<f64>, lo: &Vector3<f64>, hi: &Vector3<f64>) -> bool {
    a.x <= hi.x && a.y <= hi.y && a.z <= hi.z && b.x >= lo.x && b.y >= lo.y && b.z >= lo.z
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

#[cfg(test)]
mod tests {
    use super::*;
    use toolpath_formats::{Job, Pass, PathPoint};
    use toolpath_kernel::rng::XorShift;

    /// Pseudo-random numbers in [-1, 1) (xorshift), for reproducible cases.
    struct Rng(XorShift);
    impl Rng {
        /// The next number in [-1, 1).
        fn next(&mut self) -> f64 {
            2.0 * self.0.unit() - 1.0
        }
        fn unit(&mut self) -> Vector3<f64> {
            Vector3::new(self.next(), self.next(), self.next())
                .try_normalize(1e-3)
                .unwrap_or(Vector3::z())
        }
    }

    /// The flat end's drop expanded in the motion parameter ([`SweepLine`])
    /// against the cutter's own `lowest_hit` at the interpolated pose, on
    /// translating and turning motions and on lines that meet the bottom
    /// disc, the side, the rim, start inside the tool below the searched
    /// range, or miss it; and the tip-plane bound below every drop.
    #[test]
    fn expanded_flat_end_drop_matches_the_cutter_at_the_pose() {
        let tool = Tool::FlatEnd {
            radius: 2.5,
            length: None,
        };
        let mut rng = Rng(XorShift(0x2545_f491_4f6c_dd1d));
        // Half the motions translate, half turn by up to about 20 deg.
        let (job, result) = random_motions(&mut rng, 40, 0.35);
        let sim = Simulator::new(job.surface().unwrap(), &tool, &result).unwrap();
        let (mut hits, mut misses, mut clamped, mut bounded) = (0, 0, 0, 0);
        for seg in &sim.segments {
            for _ in 0..200 {
                let p = seg.tip0
                    + Vector3::new(rng.next(), rng.next(), rng.next()) * 4.0
                    + seg.axis0 * 4.0 * (rng.next() + 1.0);
                let n = (Vector3::z() + rng.unit() * 0.5).normalize();
                let line = SweepLine::new(&sim, seg, &p, &n).complete();
                let bound = line.plane_bound();
                if bound.is_finite() {
                    bounded += 1;
                }
                for s in [0.0, 0.25 * (rng.next() + 1.0), 0.5, 1.0] {
                    let want = sim.drop_at(seg, s, &p, &n);
                    let got = line.drop(s);
                    assert!(bound <= want, "s {s}: bound {bound} above the drop {want}");
                    if want.is_finite() {
                        assert!(
                            (got - want).abs() <= 1e-9,
                            "s {s}: expanded {got} against {want}"
                        );
                        hits += 1;
                        if want == -sim.depth {
                            clamped += 1;
                        }
                    } else {
                        assert_eq!(got, want, "s {s}");
                        misses += 1;
                    }
                }
            }
        }
        assert!(
            hits > 5000 && misses > 5000 && clamped > 100 && bounded > 4000,
            "{hits} {misses} {clamped} {bounded}"
        );
    }

    /// Minimum of the convex `f` over [lo, hi] by golden section to 1e-13.
    fn golden_min(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> (f64, f64) {
        const G: f64 = 0.618_033_988_749_894_9;
        while hi - lo > 1e-13 {
            let (x1, x2) = (hi - G * (hi - lo), lo + G * (hi - lo));
            if f(x1) <= f(x2) {
                hi = x2;
            } else {
                lo = x1;
            }
        }
        let x = 0.5 * (lo + hi);
        (x, f(x))
    }

    /// Random flat-end motions (half of them turning) as a simulator.
    fn random_motions(rng: &mut Rng, count: usize, turn: f64) -> (Job, PlanResult) {
        let job = toolpath_samples::job("plane").unwrap();
        let mut result = PlanResult::new("test", "iso_parametric");
        for _ in 0..count {
            let tip = Vector3::new(rng.next(), rng.next(), rng.next()) * 3.0;
            let axis0 = (Vector3::z() + rng.unit() * 0.4).normalize();
            let turn = if rng.next() > 0.0 { turn } else { 0.0 };
            let axis1 = (axis0 + rng.unit() * turn).normalize();
            let tip1 = tip + rng.unit() * 2.0 * rng.next().abs();
            let point = |t: Vector3<f64>, a: Vector3<f64>| PathPoint {
                cl: [t.x, t.y, t.z],
                axis: [a.x, a.y, a.z],
                ..Default::default()
            };
            result.passes.push(Pass {
                region: 0,
                points: vec![point(tip, axis0), point(tip1, axis1)],
                min_strip_width: None,
            });
        }
        (job, result)
    }

    /// The reach test's squared distance between the sample's line and a
    /// motion's mid axis against a brute-force minimum of the distance
    /// between points of the two segments (nested golden sections: the
    /// squared distance is convex in both parameters), on random lines,
    /// lines nearly parallel to the axis and lines crossing it.
    #[test]
    fn reach_distance_matches_brute_force() {
        let mut rng = Rng(XorShift(0x9e37_79b9_7f4a_7c15));
        let (job, result) = random_motions(&mut rng, 30, 0.35);
        let tool = Tool::FlatEnd {
            radius: 2.5,
            length: None,
        };
        let sim = Simulator::new(job.surface().unwrap(), &tool, &result).unwrap();
        let (mut parallel, mut crossing) = (0, 0);
        for seg in &sim.segments {
            let axis = (seg.mid_top - seg.mid_tip).normalize();
            for case in 0..60 {
                let p = seg.mid_tip
                    + Vector3::new(rng.next(), rng.next(), rng.next()) * 6.0
                    + axis * 8.0 * rng.next();
                let n = match case % 3 {
                    0 => rng.unit(),
                    // Nearly parallel to the axis (either way).
                    1 => {
                        parallel += 1;
                        (axis * rng.next().signum() + rng.unit() * 1e-7).normalize()
                    }
                    // Through a point of the axis.
                    _ => {
                        crossing += 1;
                        let on =
                            seg.mid_tip + (seg.mid_top - seg.mid_tip) * (rng.next() + 1.0) * 0.5;
                        (on - p).try_normalize(1e-9).unwrap_or(Vector3::z())
                    }
                };
                let line = ReachLine::new(&p, &n, sim.depth, sim.cap);
                let got = line.distance2_to_mid_axis(seg);
                let (a, b) = (p - n * sim.depth, p + n * sim.cap);
                let at = |s: f64, t: f64| {
                    ((a + (b - a) * s) - (seg.mid_tip + (seg.mid_top - seg.mid_tip) * t))
                        .norm_squared()
                };
                let inner = |s: f64| golden_min(|t| at(s, t), 0.0, 1.0).1;
                let want = golden_min(inner, 0.0, 1.0).1;
                // Closest points of nearly parallel segments are
                // ill-conditioned: about 1e-8 of the squared distance.
                assert!(
                    (got - want).abs() <= 1e-7 * (1.0 + want),
                    "squared distance {got} against brute force {want}"
                );
                let old = segment_distance(&a, &b, &seg.mid_tip, &seg.mid_top);
                assert!((got.sqrt() - old).abs() <= 1e-7, "{got} against {old}");
            }
        }
        assert!(parallel > 500 && crossing > 500, "{parallel} {crossing}");
    }

    /// The flat end's rim kink ([`SweepLine::kink_min`]) and the fast sweep
    /// minimum against a brute-force minimum of the cutter's own drop at the
    /// interpolated pose (`lowest_hit`, 4001 positions along the motion, then
    /// golden section between the best one's neighbours), on translating
    /// motions (the drop is convex): a certified kink is the minimum to 1e-7
    /// mm and never below it; the fast minimum is never below it and within
    /// 1e-3 mm of it (its bound is the drop's slope times 1e-5 mm of motion,
    /// steep for lines close to the bottom disc's plane).
    #[test]
    fn flat_end_kink_and_sweep_minimum_match_brute_force() {
        let mut rng = Rng(XorShift(0x6a09_e667_f3bc_c909));
        let (job, result) = random_motions(&mut rng, 40, 0.0);
        let tool = Tool::FlatEnd {
            radius: 2.5,
            length: None,
        };
        let sim = Simulator::new(job.surface().unwrap(), &tool, &result).unwrap();
        let (mut kinks, mut compared) = (0, 0);
        for seg in &sim.segments {
            for _ in 0..150 {
                // Lines near the rim's sweep: through points about R from the
                // tip's path, mostly along the axis.
                let along = seg.tip0 + (seg.tip1 - seg.tip0) * (0.5 * (rng.next() + 1.0));
                let p =
                    along + rng.unit() * 2.5 * (1.0 + 0.2 * rng.next()) + seg.axis0 * rng.next();
                let n = (seg.axis0 + rng.unit() * 0.3).normalize();
                let k = 4000;
                let drops: Vec<f64> = (0..=k)
                    .map(|i| sim.drop_at(seg, i as f64 / k as f64, &p, &n))
                    .collect();
                let i = (0..=k).fold(0, |m, i| if drops[i] < drops[m] { i } else { m });
                if !drops[i].is_finite() {
                    continue;
                }
                let (lo, hi) = (
                    i.saturating_sub(1) as f64 / k as f64,
                    (i + 1).min(k) as f64 / k as f64,
                );
                // On each side of the best position: golden section between it
                // and the neighbour, or the reach edge (bisected to 1e-15)
                // where the neighbour misses: the drop is convex where it hits.
                let drop = |s: f64| sim.drop_at(seg, s, &p, &n);
                let mut want = drops[i];
                let s_i = i as f64 / k as f64;
                for end in [lo, hi] {
                    if end == s_i {
                        continue;
                    }
                    if drop(end).is_finite() {
                        want = want.min(golden_min(drop, end.min(s_i), end.max(s_i)).1);
                    } else {
                        let (mut a, mut b) = (s_i, end);
                        while (b - a).abs() > 1e-15 {
                            let mid = 0.5 * (a + b);
                            if drop(mid).is_finite() {
                                a = mid;
                            } else {
                                b = mid;
                            }
                        }
                        want = want
                            .min(drop(a))
                            .min(golden_min(drop, a.min(s_i), a.max(s_i)).1);
                    }
                }
                let fast = sim.sweep_min(seg, &p, &n, f64::INFINITY);
                let tol = SWEEP_TOL_MM / seg.travel.max(1e-300);
                assert!(
                    fast >= want - 1e-9,
                    "fast {fast} below the minimum {want} (best position {i} of {k}, drops {:?})",
                    &drops[i.saturating_sub(2)..(i + 3).min(k + 1)]
                );
                assert!(fast <= want + 1e-3, "fast {fast} against {want}");
                compared += 1;
                let line = SweepLine::new(&sim, seg, &p, &n);
                if !line.plane_bound().is_finite() {
                    continue;
                }
                let line = line.complete();
                // Known drops around the brute force's best: its neighbours.
                let known: Vec<(f64, f64)> = [lo, s_i, hi]
                    .iter()
                    .map(|&s| (s, line.drop(s)))
                    .filter(|q| q.1.is_finite())
                    .fold(Vec::new(), |mut v, q| {
                        if v.last().is_none_or(|l: &(f64, f64)| q.0 > l.0) {
                            v.push(q);
                        }
                        v
                    });
                if let Some(f) = line.kink_min(&known, tol) {
                    kinks += 1;
                    assert!(f >= want - 1e-9, "kink {f} below the minimum {want}");
                    assert!(f <= want + 1e-7, "kink {f} above the minimum {want}");
                }
            }
        }
        assert!(compared > 3000 && kinks > 200, "{compared} {kinks}");
    }
}
