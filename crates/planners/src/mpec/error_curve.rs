//! The MPEC error curve of a torus cutter and the lead-angle search
//! (docs/methods.md, "The error curve" and "The lead angle", which correct
//! the published method).
//!
//! Everything here works in the tool's second reference frame at a drive point
//! P1: x along the feed e1, y across it along e2 = e3 x e1, z along the surface
//! normal e3 (tool side). The part surface is given to the core as a height
//! field z = h(x, y) over the tangent plane ([`LocalHeight`]); the planner
//! supplies the real NURBS surface, the tests a quadric.
//!
//! The torus (tube-centre circle radius R0 = R - r, corner radius r) is the
//! union of spheres of radius r centred on c(psi). With the rotation phi = 0
//! and lead angle theta the centres are
//!   c(psi) = (-R0 cos(theta) (1 - cos psi), R0 sin psi, r + m + R0 sin(theta) (1 - cos psi)),
//! m being the height left at the middle of the strip (+delta for MPEC). As the
//! tool moves along the feed, sphere psi cuts the cross-section offset y with
//! its lowest point, which lies at the sphere's own feed coordinate cx(psi);
//! the error there is that point's height minus the part at (cx(psi), y).

use toolpath_kernel::numeric::{brent_min, Bracket};
use toolpath_kernel::tools::CutterShape;

/// The part surface as a height field over the tangent plane at the drive point.
pub trait LocalHeight {
    /// Height h(x, y) along e3 and its slopes (dh/dx, dh/dy).
    fn height(&self, x: f64, y: f64) -> (f64, f64, f64);
}

/// Second-order model z = 1/2 (kxx x^2 + 2 kxy x y + kyy y^2): the exact part
/// for the reference quadric, and the planner's fast first guess.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quadric {
    pub kxx: f64,
    pub kxy: f64,
    pub kyy: f64,
}

impl LocalHeight for Quadric {
    fn height(&self, x: f64, y: f64) -> (f64, f64, f64) {
        (
            0.5 * (self.kxx * x * x + 2.0 * self.kxy * x * y + self.kyy * y * y),
            self.kxx * x + self.kxy * y,
            self.kxy * x + self.kyy * y,
        )
    }
}

/// One tool position in the local frame: lead angle `theta` and the middle height `m`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Position {
    pub theta: f64,
    pub middle: f64,
    /// Rotation phi about e3 before the lead (the paper's first angle; 0 by default).
    pub phi: f64,
}

/// Sphere centre c(psi) in the local frame (rotated by phi about e3).
#[inline]
pub fn sphere_centre(tool: CutterShape, pos: Position, psi: f64) -> [f64; 3] {
    Pose::new(tool, pos).centre(psi)
}

/// A [`Position`] with its trigonometry done once (the error curve evaluates
/// thousands of sphere centres per position).
#[derive(Clone, Copy, Debug)]
struct Pose {
    r0: f64,
    r: f64,
    /// R0 cos(theta), R0 sin(theta), r + middle.
    r0c: f64,
    r0s: f64,
    base: f64,
    /// sin, cos of phi; None when phi = 0.
    phi: Option<(f64, f64)>,
}

impl Pose {
    #[inline]
    fn new(tool: CutterShape, pos: Position) -> Self {
        let (st, ct) = pos.theta.sin_cos();
        Self {
            r0: tool.tube_radius(),
            r: tool.corner_radius,
            r0c: tool.tube_radius() * ct,
            r0s: tool.tube_radius() * st,
            base: tool.corner_radius + pos.middle,
            phi: (pos.phi != 0.0).then(|| pos.phi.sin_cos()),
        }
    }

    /// The flat bottom: its centre (the tool tip) and two orthonormal
    /// directions in its plane (along the lead, across), in the local frame.
    fn disc(&self) -> ([f64; 3], [f64; 3], [f64; 3]) {
        let (st, ct) = (self.r0s / self.r0, self.r0c / self.r0);
        // Tube-circle centre (-R0 cos, 0, r + m + R0 sin), axis (sin, 0, cos).
        let tip = [
            -self.r0c - self.r * st,
            0.0,
            self.base + self.r0s - self.r * ct,
        ];
        let d1 = [ct, 0.0, -st];
        let turn = |v: [f64; 3]| match self.phi {
            None => v,
            Some((sp, cp)) => [v[0] * cp - v[1] * sp, v[0] * sp + v[1] * cp, v[2]],
        };
        (turn(tip), turn(d1), turn([0.0, 1.0, 0.0]))
    }

    #[inline]
    fn centre(&self, psi: f64) -> [f64; 3] {
        let (s, c) = psi.sin_cos();
        let (x, y) = (-self.r0c * (1.0 - c), self.r0 * s);
        let z = self.base + self.r0s * (1.0 - c);
        match self.phi {
            None => [x, y, z],
            Some((sp, cp)) => [x * cp - y * sp, x * sp + y * cp, z],
        }
    }
}

/// Tool tip (centre of the bottom face) and axis in the local frame.
pub(crate) fn tip_and_axis(tool: CutterShape, pos: Position) -> ([f64; 3], [f64; 3]) {
    let (st, ct) = pos.theta.sin_cos();
    let (sp, cp) = pos.phi.sin_cos();
    // Tube-centre circle centre = C2 - R0 o', o' = (cos, 0, -sin); tip = centre - r axis.
    let centre = [
        -tool.tube_radius() * ct,
        0.0,
        tool.corner_radius + pos.middle + tool.tube_radius() * st,
    ];
    let axis = [st, 0.0, ct];
    let tip = [
        centre[0] - tool.corner_radius * axis[0],
        0.0,
        centre[2] - tool.corner_radius * axis[2],
    ];
    (
        [tip[0] * cp, tip[0] * sp, tip[2]],
        [axis[0] * cp, axis[0] * sp, axis[2]],
    )
}

/// Error of sphere `psi` at cross offset `y` (None where the sphere does not
/// reach y): the smallest vertical gap between the sphere's section at y (a
/// circle of radius rho in the x-z plane) and the part along the feed. It lies
/// at the characteristic point x = cx(psi) when the part is level along the
/// feed there, and behind or ahead of it by rho dh/dx / sqrt(1 + (dh/dx)^2)
/// where the part slopes along the feed (the rear of a tool following a
/// concave feed curve). Evaluating only at cx, as the method is usually
/// stated, misses gouges of about r (dh/dx)^2 / 2 (docs/methods.md, "The
/// error curve"; the swept-tool check in tests/mpec.rs finds them).
#[inline]
fn sphere_error(pose: &Pose, h: &dyn LocalHeight, psi: f64, y: f64) -> Option<f64> {
    let c = pose.centre(psi);
    let t = y - c[1];
    let rho2 = pose.r * pose.r - t * t;
    if rho2 < 0.0 {
        return None;
    }
    let rho = rho2.sqrt();
    let mut x = c[0];
    let mut best = f64::INFINITY;
    for _ in 0..4 {
        let (z, hx, _) = h.height(x, y);
        let dx = x - c[0];
        best = best.min(c[2] - (rho2 - dx * dx).max(0.0).sqrt() - z);
        let next = c[0] + rho * hx / (1.0 + hx * hx).sqrt();
        if (next - x).abs() < 1e-9 {
            break;
        }
        x = next;
    }
    Some(best)
}

/// Smallest vertical gap between sphere `psi` and the part: its closest point
/// sits at (c - r grad h / sqrt(1 + |grad h|^2)) below the centre; a fast
/// fixed point because the slope changes little over r.
fn sphere_clearance(pose: &Pose, h: &dyn LocalHeight, psi: f64) -> f64 {
    let c = pose.centre(psi);
    let (mut x, mut y) = (c[0], c[1]);
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let (z, hx, hy) = h.height(x, y);
        let (dx, dy) = (x - c[0], y - c[1]);
        best = best.min(c[2] - (pose.r * pose.r - dx * dx - dy * dy).max(0.0).sqrt() - z);
        let k = pose.r / (1.0 + hx * hx + hy * hy).sqrt();
        let (nx, ny) = (c[0] + k * hx, c[1] + k * hy);
        if (nx - x).abs() + (ny - y).abs() < 1e-9 {
            break;
        }
        x = nx;
        y = ny;
    }
    best
}

/// Abscissa tolerance of the minimisations over psi (radians): the error
/// curves are parabolic there with curvature below ~1 mm/rad^2, so the value
/// is exact to ~1e-8 mm.
const PSI_TOL: f64 = 1e-4;

/// Number of samples around the tube-centre circle before refinement (5 degrees).
const PSI_SAMPLES: usize = 72;
const PSI_STEP: f64 = std::f64::consts::TAU / PSI_SAMPLES as f64;

/// Lowest point of the whole error curve: min over psi of the sphere clearance.
/// Returns (error, psi at the minimum).
pub(crate) fn min_error(tool: CutterShape, pos: Position, h: &dyn LocalHeight) -> (f64, f64) {
    let pose = Pose::new(tool, pos);
    let cands = minimum_candidates(&pose, h);
    refine_minimum(&pose, h, &cands)
}

/// The sampled local minima of the sphere clearance around the circle (the
/// two dips of the "W" and, on concave feed curves, the heel).
fn minimum_candidates(pose: &Pose, h: &dyn LocalHeight) -> Vec<f64> {
    let vals: Vec<f64> = (0..PSI_SAMPLES)
        .map(|i| sphere_clearance(pose, h, -std::f64::consts::PI + PSI_STEP * i as f64))
        .collect();
    let mut out = Vec::new();
    for i in 0..PSI_SAMPLES {
        let prev = vals[(i + PSI_SAMPLES - 1) % PSI_SAMPLES];
        let next = vals[(i + 1) % PSI_SAMPLES];
        if vals[i] <= prev && vals[i] <= next {
            out.push(-std::f64::consts::PI + PSI_STEP * i as f64);
        }
    }
    out
}

/// Refinement of each candidate within one sample step; then the flat
/// bottom's own lowest point where it is lower still ([`disc_clearance`]).
fn refine_minimum(pose: &Pose, h: &dyn LocalHeight, cands: &[f64]) -> (f64, f64) {
    let mut best = (f64::INFINITY, 0.0);
    for &c in cands {
        let (psi, v) = brent_min(c - PSI_STEP, c + PSI_STEP, PSI_TOL, |p| {
            sphere_clearance(pose, h, p)
        });
        if v < best.0 {
            best = (v, psi);
        }
    }
    let disc = disc_clearance(pose, h);
    if disc < best.0 - DISC_MARGIN {
        best.0 = disc;
    }
    best
}

/// How far the flat bottom must dip below the tube's lowest point before it
/// counts, mm: on a part it touches only at its rim the two agree to
/// rounding, and the tube's value is kept.
const DISC_MARGIN: f64 = 1e-9;

/// Rings and spokes of the flat bottom's sampling before refinement.
const DISC_RINGS: usize = 4;
const DISC_SPOKES: usize = 12;

/// Smallest vertical gap between the flat bottom (the disc of radius R0 in
/// the tip plane) and the part. The tube's spheres cover the disc's rim;
/// inside it the gap is lowest where the part bulges towards the tool
/// within the footprint (h minus the tip plane has a maximum there: an S-
/// shaped feed curve, concave at the contact and convex behind it, lifts the
/// part under the middle of the bottom). Sampled on rings and spokes, then
/// Newton on the gap's gradient (Hessian by differences of the slopes),
/// kept inside the disc.
fn disc_clearance(pose: &Pose, h: &dyn LocalHeight) -> f64 {
    if pose.r0.is_nan() || pose.r0 <= 0.0 {
        return f64::INFINITY;
    }
    let (tip, d1, d2) = pose.disc();
    let point = |a: f64, b: f64| {
        [
            tip[0] + a * d1[0] + b * d2[0],
            tip[1] + a * d1[1] + b * d2[1],
            tip[2] + a * d1[2] + b * d2[2],
        ]
    };
    // Gap and its gradient in disc coordinates (a, b).
    let gap = |a: f64, b: f64| {
        let p = point(a, b);
        let (z, hx, hy) = h.height(p[0], p[1]);
        let ga = d1[2] - hx * d1[0] - hy * d1[1];
        let gb = d2[2] - hx * d2[0] - hy * d2[1];
        (p[2] - z, ga, gb)
    };
    let r0 = pose.r0;
    let mut best = (gap(0.0, 0.0).0, 0.0, 0.0);
    for ring in 1..=DISC_RINGS {
        let rho = r0 * ring as f64 / (DISC_RINGS + 1) as f64;
        for spoke in 0..DISC_SPOKES {
            let (s, c) = (std::f64::consts::TAU * spoke as f64 / DISC_SPOKES as f64).sin_cos();
            let (a, b) = (rho * c, rho * s);
            let v = gap(a, b).0;
            if v < best.0 {
                best = (v, a, b);
            }
        }
    }
    let (mut a, mut b) = (best.1, best.2);
    let step = 1e-3 * r0;
    for _ in 0..6 {
        let (_, ga, gb) = gap(a, b);
        let (_, ga_a, gb_a) = gap(a + step, b);
        let (_, ga_b, gb_b) = gap(a, b + step);
        let (haa, hab, hbb) = (
            (ga_a - ga) / step,
            0.5 * ((gb_a - gb) + (ga_b - ga)) / step,
            (gb_b - gb) / step,
        );
        let det = haa * hbb - hab * hab;
        if !(haa > 0.0 && det > 0.0) {
            break;
        }
        let (da, db) = ((hbb * ga - hab * gb) / det, (haa * gb - hab * ga) / det);
        let (mut na, mut nb) = (a - da, b - db);
        let rho = na.hypot(nb);
        if rho > r0 {
            (na, nb) = (na * r0 / rho, nb * r0 / rho);
        }
        let v = gap(na, nb).0;
        if v.is_nan() || v >= best.0 {
            break;
        }
        best.0 = v;
        (a, b) = (na, nb);
        if da.abs() + db.abs() < 1e-7 {
            break;
        }
    }
    best.0
}

/// The error curve E(y): min over the spheres that reach y (front and back
/// halves of the tube circle) of the sphere's lowest point minus the part.
/// `f64::INFINITY` beyond the tool (|y| >= R0 + r).
#[cfg(test)]
pub(crate) fn error_at(tool: CutterShape, pos: Position, h: &dyn LocalHeight, y: f64) -> f64 {
    pose_error_at(&Pose::new(tool, pos), h, y)
}

fn pose_error_at(pose: &Pose, h: &dyn LocalHeight, y: f64) -> f64 {
    pose_error_and_sphere(pose, h, y).0
}

/// [`pose_error_at`] and the sphere psi that gives it (NaN beyond the tool).
fn pose_error_and_sphere(pose: &Pose, h: &dyn LocalHeight, y: f64) -> (f64, f64) {
    let lo = ((y - pose.r) / pose.r0).clamp(-1.0, 1.0).asin();
    let hi = ((y + pose.r) / pose.r0).clamp(-1.0, 1.0).asin();
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
        return (f64::INFINITY, f64::NAN);
    }
    let f = |psi: f64| sphere_error(pose, h, psi, y).unwrap_or(f64::INFINITY);
    let mut best = (f64::INFINITY, f64::NAN);
    // Front branch psi in [lo, hi], back branch pi - psi (same cy, further back).
    for back in [false, true] {
        let map = |s: f64| if back { std::f64::consts::PI - s } else { s };
        const N: usize = 6;
        let step = (hi - lo) / N as f64;
        let mut arg = (f64::INFINITY, lo);
        for i in 0..=N {
            let s = lo + step * i as f64;
            let v = f(map(s));
            if v < arg.0 {
                arg = (v, s);
            }
        }
        let a = (arg.1 - step).max(lo);
        let b = (arg.1 + step).min(hi);
        let (s_min, v) = brent_min(a, b, PSI_TOL, |s| f(map(s)));
        for (value, at) in [(v, s_min), (arg.0, arg.1)] {
            if value < best.0 {
                best = (value, map(at));
            }
        }
    }
    best
}

/// How far behind the drive point, along the feed, the strip between
/// `y_left` and `y_right` is finished, mm: the lowest points of the spheres
/// that form the error curve there (sampled at 9 offsets) lie up to this far
/// back, plus the corner radius. The heel forms the strip where the part
/// rises behind the contact (a concave feed curve), up to 2 R0 + r back; a
/// run-out past the far edge must carry the tool that far for the last
/// sections of the face to be cut as planned.
pub(crate) fn strip_trailing_reach(
    tool: CutterShape,
    pos: Position,
    h: &dyn LocalHeight,
    y_left: f64,
    y_right: f64,
) -> f64 {
    let pose = Pose::new(tool, pos);
    const SAMPLES: usize = 9;
    let mut reach: f64 = 0.0;
    for k in 0..SAMPLES {
        let y = y_left + (y_right - y_left) * k as f64 / (SAMPLES - 1) as f64;
        let (_, psi) = pose_error_and_sphere(&pose, h, y);
        if psi.is_finite() {
            // The local frame's x is the feed (the side tilt is in c already).
            reach = reach.max(-pose.centre(psi)[0]);
        }
    }
    reach + pose.r
}

/// Spacing of the scan for the outermost crossing, as a fraction of the tool's reach.
const SCAN_STEPS: usize = 21;

/// Largest spacing of the check that no crossing lies further out than the
/// one found near a neighbour's, mm.
const OUTWARD_CHECK_MM: f64 = 5.0;

/// Cross offsets of the outermost crossings of `level` by the error curve,
/// (y_left, y_right) with y_left <= 0 <= y_right when the middle is below
/// `level`; `None` when the curve never gets below `level`. With the
/// neighbouring drive point's crossings `hint`, a bracket of +-0.25 mm
/// around each, checked to have nothing below `level` further out, replaces
/// the scan from the tool's edge.
fn outer_crossings_near(
    tool: CutterShape,
    pos: Position,
    h: &dyn LocalHeight,
    level: f64,
    hint: Option<(f64, f64)>,
) -> Option<(f64, f64)> {
    let pose = Pose::new(tool, pos);
    let reach = tool.tube_radius() + tool.corner_radius;
    let side = |sign: f64, hint: Option<f64>| -> Option<f64> {
        // g > 0: above the level (outside the strip).
        let g = |t: f64| pose_error_at(&pose, h, sign * t) - level;
        if let Some(t0) = hint.map(f64::abs).filter(|t| *t > 0.0 && *t < reach) {
            let (a, b) = ((t0 - 0.25).max(0.0), (t0 + 0.25).min(reach));
            let (ga, gb) = (g(a), g(b));
            if ga <= 0.0 && gb > 0.0 {
                let n = ((reach - b) / OUTWARD_CHECK_MM).ceil().max(1.0) as usize;
                if (1..=n).all(|i| g(b + (reach - b) * i as f64 / n as f64) > 0.0) {
                    return Some(sign * crossing(a, ga, b, gb, g));
                }
            }
        }
        // Scan inwards from the tool's outer edge for the first point at or
        // below `level`, then solve between it and the previous (outer) sample.
        let step = reach / SCAN_STEPS as f64;
        let (mut outer, mut g_outer) = (reach, f64::INFINITY);
        for i in 1..=SCAN_STEPS {
            let t = reach - step * i as f64;
            let gt = g(t);
            if gt <= 0.0 {
                return Some(sign * crossing(t, gt, outer, g_outer, g));
            }
            (outer, g_outer) = (t, gt);
        }
        None
    };
    // The strip is the run around the middle where the error stays within
    // the level: on a lopsided curve (a twisted part) it can rise above it
    // between the middle and the outermost crossing, and the strip then
    // ends at the first such rise, sampled every <= 2 mm (at least
    // INNER_CHECKS samples) and allowing the height fit's accuracy, level / 50.
    let inner = |sign: f64, y: f64| -> f64 {
        let g = |t: f64| pose_error_at(&pose, h, sign * t) - level;
        let outer = y.abs();
        let n = ((outer / INNER_CHECK_MM).ceil() as usize).max(INNER_CHECKS);
        let mut prev = (0.0, f64::NEG_INFINITY);
        for i in 1..n {
            let t = outer * i as f64 / n as f64;
            let gt = g(t);
            if gt > level.abs() / 50.0 {
                return sign
                    * if prev.1 <= 0.0 {
                        crossing(prev.0, prev.1.max(-level.abs()), t, gt, g)
                    } else {
                        prev.0
                    };
            }
            prev = (t, gt);
        }
        y
    };
    let (l, r) = match hint {
        Some((l, r)) => (Some(l), Some(r)),
        None => (None, None),
    };
    let (l, r) = (side(-1.0, l)?, side(1.0, r)?);
    Some((inner(-1.0, l), inner(1.0, r)))
}

/// Largest spacing of the check that the error stays within the level
/// between the middle and the outermost crossing, mm.
const INNER_CHECK_MM: f64 = 2.0;

/// Fewest samples of that check per side.
const INNER_CHECKS: usize = 4;

/// The crossing of g = 0 between a (g <= 0) and b (g > 0, possibly infinite),
/// by the shared Illinois bracket (docs/methods.md, "One root finder";
/// bisection while g(b) is not finite).
/// Returns the inner end once within 1e-9 mm of the level or 1e-6 mm of the
/// crossing.
fn crossing(a: f64, ga: f64, b: f64, gb: f64, g: impl Fn(f64) -> f64) -> f64 {
    let mut br = Bracket::new(a, ga, b, gb);
    for _ in 0..60 {
        if br.f_neg > -1e-9 || br.width() < 1e-6 {
            break;
        }
        let m = br.trial();
        br.narrow(m, g(m));
    }
    br.neg
}

/// How a drive point was positioned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// A "W" forms; middle at +delta, dips touching -delta (or the widest W at lead 0).
    Ok,
    /// No usable "W" (cross-section convex or flat towards the tool, or its
    /// strip on one side narrower than the conventional one): conventional
    /// position used.
    NotApplicable,
    /// No position holds the band (concave tighter than the torus at any
    /// lead): the tool is lifted until its lowest error is -delta; the strip
    /// is where it still comes within +delta, possibly none.
    Lifted,
}

/// Positioning result at one drive point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Solution {
    pub status: Status,
    pub pos: Position,
    /// Outermost +delta crossings of the error curve (local y), left < right.
    pub y_left: f64,
    pub y_right: f64,
    /// Lowest point of the error curve at the chosen lead.
    pub min_error: f64,
}

impl Solution {
    pub fn strip_width(&self) -> f64 {
        self.y_right - self.y_left
    }
}

/// Why a drive point cannot be positioned.
#[derive(Clone, Debug, PartialEq)]
pub enum SolveError {
    /// Even at `theta_max` the error curve dips below -delta.
    TooCurved { theta_max: f64, min_error: f64 },
    /// No +delta crossing: the tool never comes within the band (should not happen on valid input).
    NoStrip,
}

/// Settings of the lead-angle search.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeadSearch {
    /// Smallest lead angle (radians), usually 0 or the job's lead angle.
    pub theta_min: f64,
    /// Largest lead angle tried before giving up (radians).
    pub theta_max: f64,
    /// Stop when the bracket is narrower than this (radians).
    pub theta_tol: f64,
    /// Previous point's lead, to start from a narrow bracket.
    pub hint: Option<f64>,
    /// Previous point's strip edges (y_left, y_right), to find the new ones near them.
    pub strip_hint: Option<(f64, f64)>,
    /// Fixed rotation about e3 (radians).
    pub phi: f64,
    /// Kept clear of -delta on the gouge side, mm (the conventional
    /// position's [`CONVENTIONAL_MARGIN`]).
    pub gouge_margin: f64,
    /// Largest error of a fitted height field at its samples, mm (0 for
    /// exact heights): taken off both sides of the band, so that the real
    /// part stays within it where the fit lies high or low.
    pub fit_error: f64,
}

impl Default for LeadSearch {
    fn default() -> Self {
        Self {
            theta_min: 0.0,
            theta_max: 60f64.to_radians(),
            theta_tol: 2e-6,
            hint: None,
            strip_hint: None,
            phi: 0.0,
            gouge_margin: 0.0,
            fit_error: 0.0,
        }
    }
}

/// Smallest lead angle in [theta_min, theta_max] with min_error >= floor
/// (the error curve's dips rise monotonically with the lead), and the error
/// curve's lowest point there. The dips are tracked from one sampling of the
/// whole circle; the result is checked with a fresh sampling and the search
/// repeated with it if a new minimum turned up.
fn bisect_lead(
    tool: CutterShape,
    h: &dyn LocalHeight,
    middle: f64,
    floor: f64,
    s: &LeadSearch,
) -> Result<(f64, f64), SolveError> {
    let at = |theta: f64| {
        Pose::new(
            tool,
            Position {
                theta,
                middle,
                phi: s.phi,
            },
        )
    };
    let start = s
        .hint
        .unwrap_or(s.theta_min)
        .clamp(s.theta_min, s.theta_max);
    let mut cands = minimum_candidates(&at(start), h);
    for _ in 0..3 {
        let margin = |theta: f64| refine_minimum(&at(theta), h, &cands).0 - floor;
        let theta = smallest_lead(s, margin);
        let verify_at = theta.unwrap_or(s.theta_max);
        let pose = at(verify_at);
        let fresh = minimum_candidates(&pose, h);
        let full = refine_minimum(&pose, h, &fresh).0;
        match theta {
            Some(t) if full >= floor - 1e-9 => return Ok((t, full)),
            None if full < floor => {
                return Err(SolveError::TooCurved {
                    theta_max: s.theta_max,
                    min_error: full,
                })
            }
            _ => {
                cands.extend(fresh);
                cands.sort_by(f64::total_cmp);
                cands.dedup();
            }
        }
    }
    // Candidates kept changing: full sampling at each step.
    let full = |theta: f64| {
        let pose = at(theta);
        refine_minimum(&pose, h, &minimum_candidates(&pose, h)).0
    };
    match smallest_lead(s, |theta| full(theta) - floor) {
        Some(t) => Ok((t, full(t))),
        None => Err(SolveError::TooCurved {
            theta_max: s.theta_max,
            min_error: full(s.theta_max),
        }),
    }
}

/// Smallest theta with `margin(theta) >= 0` (margin assumed increasing), or
/// None if even theta_max fails: a bracket (narrow around the hint when there
/// is one), then regula falsi (Illinois) on the smooth margin, ending on the
/// valid side within `theta_tol` or 1e-9 mm of zero margin.
fn smallest_lead(s: &LeadSearch, margin: impl Fn(f64) -> f64) -> Option<f64> {
    let m_min = margin(s.theta_min);
    if m_min >= 0.0 {
        return Some(s.theta_min);
    }
    let (mut lo, mut hi) = (s.theta_min, s.theta_max);
    let (mut m_lo, mut m_hi) = (m_min, f64::NAN);
    if let Some(hint) = s.hint {
        // A narrow bracket around the neighbour's lead, widened until valid.
        let mut w = 1e-3;
        loop {
            let a = (hint - w).max(s.theta_min);
            let b = (hint + w).min(s.theta_max);
            let ma = if a == s.theta_min { m_min } else { margin(a) };
            if ma < 0.0 {
                let mb = margin(b);
                if mb >= 0.0 {
                    (lo, hi, m_lo, m_hi) = (a, b, ma, mb);
                    break;
                }
            }
            if a == s.theta_min && b == s.theta_max {
                break;
            }
            w *= 4.0;
        }
    }
    if m_hi.is_nan() {
        m_hi = margin(hi);
    }
    if m_hi < 0.0 {
        return None;
    }
    // The margin rises with the lead: the smallest lead with a margin >= 0
    // is the bracket's positive end once the bracket is within tolerance.
    let mut br = Bracket::new(lo, m_lo, hi, m_hi);
    for _ in 0..100 {
        if br.width() <= s.theta_tol || br.f_pos < 1e-9 {
            break;
        }
        let mid = br.trial_clamped(0.01);
        br.narrow(mid, margin(mid));
    }
    Some(br.pos)
}

/// Positions the tool at one drive point.
///
/// `kappa_across` is the part's normal curvature across the feed at P1
/// (kappa(e2) > 0: concave towards the tool). A "W" forms only then: the tool's
/// own cross-section curvature at lead theta, about sin(theta) / R0, goes to 0
/// with theta, so some lead makes the part curve up faster than the tool. MPEC:
/// middle at +delta, and the smallest lead whose dips stay at or above -delta,
/// found by regula falsi (Illinois) on a bracket of the lead (see
/// `smallest_lead`). Otherwise (convex or flat across) the conventional
/// position ([`solve_conventional`]).
pub fn solve(
    tool: CutterShape,
    h: &dyn LocalHeight,
    kappa_across: f64,
    delta: f64,
    search: &LeadSearch,
) -> Result<Solution, SolveError> {
    if kappa_across > 1e-9 {
        solve_at(tool, h, Status::Ok, delta - search.fit_error, delta, search)
    } else {
        solve_conventional(tool, h, delta, search)
    }
}

/// The conventional position: the tool touches P1 (middle 0), the lead is the
/// smallest one >= theta_min that keeps the error >= -(1 -
/// [`CONVENTIONAL_MARGIN`]) delta (rear gouging), and the strip is where the
/// scallop stays below +delta.
pub fn solve_conventional(
    tool: CutterShape,
    h: &dyn LocalHeight,
    delta: f64,
    search: &LeadSearch,
) -> Result<Solution, SolveError> {
    let search = LeadSearch {
        gouge_margin: search.gouge_margin.max(CONVENTIONAL_MARGIN * delta),
        ..*search
    };
    solve_at(tool, h, Status::NotApplicable, 0.0, delta, &search)
}

/// Share of delta the conventional position keeps clear of -delta. Its
/// error curve is that of one pose, from the characteristic points of a
/// part seen as unchanged along the feed; where the part twists and turns
/// under a small tool the swept tool goes a little lower between poses
/// than the one pose's curve shows, by less than this share on the faces
/// tested (docs/methods.md, "Where MPEC does not apply"; tests/step_import.rs,
/// `mpec_plans_each_step_sample_face_within_its_band`).
pub(crate) const CONVENTIONAL_MARGIN: f64 = 0.1;

fn solve_at(
    tool: CutterShape,
    h: &dyn LocalHeight,
    status: Status,
    middle: f64,
    delta: f64,
    search: &LeadSearch,
) -> Result<Solution, SolveError> {
    let (theta, lowest) = bisect_lead(
        tool,
        h,
        middle,
        search.gouge_margin + search.fit_error - delta,
        search,
    )?;
    let pos = Position {
        theta,
        middle,
        phi: search.phi,
    };
    let (y_left, y_right) =
        outer_crossings_near(tool, pos, h, delta - search.fit_error, search.strip_hint)
            .ok_or(SolveError::NoStrip)?;
    Ok(Solution {
        status,
        pos,
        y_left,
        y_right,
        min_error: lowest,
    })
}

/// Leads sampled by [`solve_lifted`] between theta_min and theta_max.
const LIFT_LEADS: usize = 12;

/// The safe position where no lead holds the band: of [`LIFT_LEADS`] + 1
/// leads from theta_min to theta_max, the one whose error curve at middle 0
/// dips least, with the tool raised along the normal until its lowest error
/// is -delta (the error curve moves with the middle one for one). Never
/// gouges beyond -delta; leaves more than +delta where the part is tighter
/// than the tool, which the simulator reports. The strip is where the error
/// still comes within +delta (none: width 0).
pub fn solve_lifted(
    tool: CutterShape,
    h: &dyn LocalHeight,
    delta: f64,
    search: &LeadSearch,
) -> Solution {
    let mut best = (search.theta_min, f64::NEG_INFINITY);
    for i in 0..=LIFT_LEADS {
        let theta =
            search.theta_min + (search.theta_max - search.theta_min) * i as f64 / LIFT_LEADS as f64;
        let pos = Position {
            theta,
            middle: 0.0,
            phi: search.phi,
        };
        let (lowest, _) = min_error(tool, pos, h);
        if lowest.is_finite() && lowest > best.1 {
            best = (theta, lowest);
        }
    }
    let lowest = if best.1.is_finite() { best.1 } else { 0.0 };
    let middle = (search.gouge_margin + search.fit_error - delta - lowest).max(0.0);
    let pos = Position {
        theta: best.0,
        middle,
        phi: search.phi,
    };
    // A strip must hold the band from its drive point out: none where the
    // lifted tool leaves more than +delta at the drive point itself.
    let level = delta - search.fit_error;
    let (y_left, y_right) = if pose_error_at(&Pose::new(tool, pos), h, 0.0) <= level {
        outer_crossings_near(tool, pos, h, level, None).unwrap_or((0.0, 0.0))
    } else {
        (0.0, 0.0)
    };
    Solution {
        status: Status::Lifted,
        pos,
        y_left,
        y_right,
        min_error: lowest + middle,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const D63R6: (f64, f64) = (31.5, 6.0);

    fn tool() -> CutterShape {
        CutterShape::torus(D63R6.0, D63R6.1)
    }

    /// The reference of docs/methods.md, "The lead angle": kf = 0,
    /// kc = 1/1198, delta = 0.01.
    #[test]
    fn quadric_reference_lead_and_width() {
        let h = Quadric {
            kxx: 0.0,
            kxy: 0.0,
            kyy: 1.0 / 1198.0,
        };
        let s = solve(tool(), &h, h.kyy, 0.01, &LeadSearch::default()).unwrap();
        assert_eq!(s.status, Status::Ok);
        let lead_deg = s.pos.theta.to_degrees();
        assert!((lead_deg - 0.8938).abs() < 0.01, "lead {lead_deg}");
        let w = s.strip_width();
        assert!((w - 45.62).abs() < 0.01 * 45.62, "width {w}");
        // The dips touch -delta and the middle sits at +delta.
        assert!((s.min_error + 0.01).abs() < 1e-5, "{}", s.min_error);
        let mid = error_at(tool(), s.pos, &h, 0.0);
        assert!((mid - 0.01).abs() < 1e-6, "{mid}");
    }

    /// Directly sampled error curve (dense psi grid, no minimiser): the W
    /// shape and the +delta crossings agree with the solver's.
    #[test]
    fn error_curve_matches_dense_sampling() {
        let h = Quadric {
            kxx: -1.0 / 800.0,
            kxy: 0.0,
            kyy: 1.0 / 900.0,
        };
        let s = solve(tool(), &h, h.kyy, 0.01, &LeadSearch::default()).unwrap();
        let t = tool();
        // Dense psi grid and, for each sphere, a dense run of feed offsets
        // around its characteristic point.
        let dense = |y: f64| {
            let mut best = f64::INFINITY;
            for i in 0..3000 {
                let psi = -std::f64::consts::PI + std::f64::consts::TAU * i as f64 / 3000.0;
                let c = sphere_centre(t, s.pos, psi);
                let q = t.corner_radius * t.corner_radius - (y - c[1]).powi(2);
                if q < 0.0 {
                    continue;
                }
                for k in -50..=50 {
                    let dx = 0.02 * k as f64;
                    if dx * dx <= q {
                        best = best.min(c[2] - (q - dx * dx).sqrt() - h.height(c[0] + dx, y).0);
                    }
                }
            }
            best
        };
        let mut lowest = f64::INFINITY;
        for i in 0..=124 {
            let y = -31.0 + 62.0 * i as f64 / 124.0;
            let e = dense(y);
            lowest = lowest.min(e);
            assert!(
                (e - error_at(t, s.pos, &h, y)).abs() < 2e-4,
                "y {y}: dense {e}, solver {}",
                error_at(t, s.pos, &h, y)
            );
            if y > s.y_left + 0.05 && y < s.y_right - 0.05 {
                assert!((-0.01 - 1e-5..=0.01 + 1e-6).contains(&e), "y {y}: {e}");
            }
        }
        assert!((lowest + 0.01).abs() < 2e-4, "{lowest}");
        assert!(dense(s.y_right + 0.1) > 0.01 && dense(s.y_left - 0.1) > 0.01);
    }

    #[test]
    fn convex_across_is_not_applicable() {
        let h = Quadric {
            kxx: 0.0,
            kxy: 0.0,
            kyy: -1.0 / 1198.0,
        };
        let s = solve(tool(), &h, h.kyy, 0.01, &LeadSearch::default()).unwrap();
        assert_eq!(s.status, Status::NotApplicable);
        // Conventional position: touches at the middle, scallop <= delta inside the strip.
        assert!(error_at(tool(), s.pos, &h, 0.0).abs() < 1e-9);
        assert!(s.min_error >= -1e-9);
        assert!(s.strip_width() > 0.0 && s.strip_width() < 2.0 * 31.5);
    }

    #[test]
    fn too_curved_is_an_error() {
        let h = Quadric {
            kxx: 0.0,
            kxy: 0.0,
            kyy: 1.0 / 5.0,
        };
        assert!(matches!(
            solve(tool(), &h, h.kyy, 0.01, &LeadSearch::default()),
            Err(SolveError::TooCurved { .. })
        ));
    }

    /// A dome under the middle of the flat bottom (the part behind the
    /// contact of an S-shaped feed curve): the lowest gap is inside the
    /// bottom, not on the tube; brute force over a dense sampling of the
    /// whole lower surface (tube spheres and bottom disc) agrees.
    #[test]
    fn min_error_sees_the_flat_bottom() {
        struct Dome {
            centre: [f64; 2],
            top: f64,
            spread: f64,
        }
        impl LocalHeight for Dome {
            fn height(&self, x: f64, y: f64) -> (f64, f64, f64) {
                let (dx, dy) = (x - self.centre[0], y - self.centre[1]);
                let k = self.top / (self.spread * self.spread);
                (
                    self.top - k * (dx * dx + dy * dy),
                    -2.0 * k * dx,
                    -2.0 * k * dy,
                )
            }
        }
        let t = tool();
        for (theta, phi) in [(0.0, 0.0), (0.03, 0.0), (0.05, 0.4)] {
            let pos = Position {
                theta,
                middle: 0.0,
                phi,
            };
            let (tip, axis) = tip_and_axis(t, pos);
            let dome = Dome {
                centre: [tip[0] + 3.0, tip[1] - 2.0],
                top: 0.5,
                spread: 60.0,
            };
            let gap = |p: [f64; 3]| p[2] - dome.height(p[0], p[1]).0;
            let mut brute = f64::INFINITY;
            // The bottom disc: radius R0 about the tip, normal to the axis.
            let a = nalgebra::Vector3::from(axis);
            let d1 = (nalgebra::Vector3::x() - a * a.x).normalize();
            let d2 = a.cross(&d1);
            let r0 = t.tube_radius();
            for i in 0..=200 {
                let rho = r0 * i as f64 / 200.0;
                for j in 0..720 {
                    let (sa, ca) = (std::f64::consts::TAU * j as f64 / 720.0).sin_cos();
                    let p = nalgebra::Vector3::from(tip) + (d1 * ca + d2 * sa) * rho;
                    brute = brute.min(gap([p.x, p.y, p.z]));
                }
            }
            // The tube: spheres on the tube circle, their lower halves.
            for i in 0..360 {
                let psi = std::f64::consts::TAU * i as f64 / 360.0;
                let c = sphere_centre(t, pos, psi);
                for j in 0..=40 {
                    let polar = std::f64::consts::FRAC_PI_2 * j as f64 / 40.0;
                    for k in 0..36 {
                        let az = std::f64::consts::TAU * k as f64 / 36.0;
                        let p = [
                            c[0] + t.corner_radius * polar.sin() * az.cos(),
                            c[1] + t.corner_radius * polar.sin() * az.sin(),
                            c[2] - t.corner_radius * polar.cos(),
                        ];
                        brute = brute.min(gap(p));
                    }
                }
            }
            let (lowest, _) = min_error(t, pos, &dome);
            assert!(
                (lowest - brute).abs() < 2e-4,
                "theta {theta} phi {phi}: min_error {lowest} brute force {brute}"
            );
        }
    }
}
