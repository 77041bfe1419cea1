//! Exact refinement of the deepest / nearest point of a face: minimise
//! f(u, v) = sd(S(u, v)), a tool part's signed distance at the face's point,
//! from a sample, staying in the domain and inside the trim.
//!
//! Four stages, each accepting only points on the face that lower f, so the
//! value returned is attained (a real point of the face) and never below the
//! true minimum:
//!
//! 1. Newton on the exact second-order model: gradient J^T g and Hessian
//!    J^T H_sd J + sum_k g_k S_xy^k (g, H_sd the signed distance's gradient
//!    and Hessian, [`SdfJet`], J = [S_u S_v]), Levenberg damping where it is
//!    not positive definite, a trust radius in mm, backtracking. Outside the
//!    tool the distance to a convex solid is smooth, so this ends the search.
//! 2. Inside the tool the signed distance is the largest of the elements'
//!    branches -d_k (see [`Profile::inside_piece`](crate::Profile)), with a
//!    kink where two are equal (the medial axis: the rims of a flat end or of
//!    a holder segment). SQP on min max(f_i, f_j) for the two largest:
//!    Newton on l g_i + (1 - l) g_j = 0, f_i = f_j in (u, v, l), the
//!    Lagrangian's Hessian made convex along the kink, and each trial step
//!    put back onto the kink (a second-order correction) before it is judged.
//! 3. A minimum on a curved trim: projected descent along the trim, whose
//!    tangent is found from the inside test on a small circle round the point.
//! 4. A compass search (8 directions) down to 1e-9 mm steps for what is left.

use crate::assembly::{Pose, SdfJet, ToolAssembly, ToolPart};
use crate::face::{Face, FaceDerivs};
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use std::cell::Cell;

/// The refined point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Refined {
    pub u: f64,
    pub v: f64,
    pub point: Vector3<f64>,
    pub distance: f64,
}

/// Newton iterations at most, per stage.
const NEWTON_ITERATIONS: usize = 40;
/// Trim-walk steps at most.
const WALK_STEPS: usize = 80;
/// Compass-search evaluations at most.
const COMPASS_EVALUATIONS: usize = 400;
/// Steps below this on the surface (mm) end a search.
const STEP_MM: f64 = 1e-9;

/// A point of the face with its value.
#[derive(Clone, Copy, Debug)]
struct At {
    u: f64,
    v: f64,
    f: f64,
    p: Vector3<f64>,
}

struct Problem<'a> {
    face: &'a dyn Face,
    tool: &'a ToolAssembly,
    pose: &'a Pose,
    part: ToolPart,
    dom: ([f64; 2], [f64; 2]),
    /// Set when a trial point fell outside the trim.
    met_trim: Cell<bool>,
}

impl Problem<'_> {
    fn clamp(&self, u: f64, v: f64) -> (f64, f64) {
        (
            u.clamp(self.dom.0[0], self.dom.0[1]),
            v.clamp(self.dom.1[0], self.dom.1[1]),
        )
    }

    fn inside(&self, u: f64, v: f64) -> bool {
        let (u, v) = self.clamp(u, v);
        self.face.inside(u, v)
    }

    /// f at (u, v) clamped into the domain, `None` off the face.
    fn value(&self, u: f64, v: f64) -> Option<At> {
        let (u, v) = self.clamp(u, v);
        if !self.face.inside(u, v) {
            self.met_trim.set(true);
            return None;
        }
        let p = self.face.point(u, v);
        let f = self.tool.signed_distance(self.pose, self.part, &p);
        f.is_finite().then_some(At { u, v, f, p })
    }

    /// A candidate that lowers f, if it does.
    fn better(&self, at: &At, u: f64, v: f64) -> Option<At> {
        self.value(u, v).filter(|c| c.f < at.f)
    }
}

/// Minimises the signed distance of `part` over the face from (u, v) (a
/// point on the face); `trust_mm` is the largest Newton step on the surface
/// (the sample's cover radius is a good one).
pub fn refine(
    face: &dyn Face,
    tool: &ToolAssembly,
    pose: &Pose,
    part: ToolPart,
    (u, v): (f64, f64),
    trust_mm: f64,
) -> Refined {
    let pb = Problem {
        face,
        tool,
        pose,
        part,
        dom: face.domain(),
        met_trim: Cell::new(false),
    };
    let start = pb.value(u, v).unwrap_or_else(|| {
        // A start the caller took from the face lies on it; be safe anyway.
        let p = face.point(u, v);
        At {
            u,
            v,
            f: tool.signed_distance(pose, part, &p),
            p,
        }
    });
    let trust = trust_mm.max(1e-6);
    let (mut at, polish) = newton(&pb, start, trust);
    if at.f < 0.0 {
        at = kink_newton(&pb, at, trust);
    }
    if pb.met_trim.get() {
        at = reach_trim(&pb, at, trust);
        at = trim_walk(&pb, at, polish.max(1e-4));
    }
    let at = compass(&pb, at, polish);
    Refined {
        u: at.u,
        v: at.v,
        point: at.p,
        distance: at.f,
    }
}

/// Gradient and Hessian of f in (u, v) from the face's derivatives and the
/// distance's jet (chain rule to second order).
fn model(d: &FaceDerivs, jet: &SdfJet) -> (Vector2<f64>, Matrix2<f64>) {
    let g = Vector2::new(jet.gradient.dot(&d.su), jet.gradient.dot(&d.sv));
    let hs = &jet.hessian;
    let huv = d.su.dot(&(hs * d.sv)) + jet.gradient.dot(&d.suv);
    let h = Matrix2::new(
        d.su.dot(&(hs * d.su)) + jet.gradient.dot(&d.suu),
        huv,
        huv,
        d.sv.dot(&(hs * d.sv)) + jet.gradient.dot(&d.svv),
    );
    (g, h)
}

/// The first fundamental form: lengths in mm of (du, dv).
fn metric(d: &FaceDerivs) -> Matrix2<f64> {
    let f = d.su.dot(&d.sv);
    Matrix2::new(d.su.dot(&d.su), f, f, d.sv.dot(&d.sv))
}

fn length_mm(m: &Matrix2<f64>, s: &Vector2<f64>) -> f64 {
    (s.transpose() * m * s)[(0, 0)].max(0.0).sqrt()
}

/// Stage 1; returns the point and where the compass search should start:
/// the last move after convergence, the trust radius after a stall.
fn newton(pb: &Problem, mut at: At, mut trust: f64) -> (At, f64) {
    let mut polish = trust;
    for _ in 0..NEWTON_ITERATIONS {
        let d = pb.face.derivatives(at.u, at.v);
        let jet = pb.tool.jet(pb.pose, pb.part, &d.p);
        let (g, h) = model(&d, &jet);
        let m = metric(&d);
        if g.norm() <= 1e-15 * m.trace().sqrt() {
            polish = polish.min(1e-6);
            break;
        }
        let mut s = bounded_step(pb, &at, &h, &m, &g);
        let mm = length_mm(&m, &s);
        if mm > trust {
            s *= trust / mm;
        }
        let slope = g.dot(&s).min(0.0);
        let mut t = 1.0;
        let mut moved = None;
        for _ in 0..30 {
            if let Some(c) = pb.better(&at, at.u + t * s[0], at.v + t * s[1]) {
                if c.f <= at.f + 1e-4 * t * slope {
                    moved = Some((c.p - at.p).norm());
                    at = c;
                    break;
                }
            }
            t *= 0.5;
        }
        match moved {
            Some(dist) if dist > STEP_MM => {
                trust = (2.0 * dist).max(0.5 * trust).max(1e-6);
                polish = (4.0 * dist).max(1e-7);
            }
            Some(_) => {
                polish = 1e-7;
                break;
            }
            None => {
                polish = mm.min(trust).max(1e-7);
                break;
            }
        }
    }
    (at, polish)
}

/// The damped Newton step, with a parameter on a bound of the domain that
/// the step would cross held there (the reduced step in the other one):
/// projected Newton for the domain's box.
fn bounded_step(
    pb: &Problem,
    at: &At,
    h: &Matrix2<f64>,
    m: &Matrix2<f64>,
    g: &Vector2<f64>,
) -> Vector2<f64> {
    let s = damped_step(h, m, g);
    let bounds = [(at.u, pb.dom.0), (at.v, pb.dom.1)];
    let out = |k: usize, step: f64| {
        let (x, [lo, hi]) = bounds[k];
        (x <= lo && step < 0.0) || (x >= hi && step > 0.0)
    };
    let (out_u, out_v) = (out(0, s[0]), out(1, s[1]));
    if !out_u && !out_v {
        return s;
    }
    let mut r = Vector2::zeros();
    for (k, held) in [(0, out_u), (1, out_v)] {
        let other = 1 - k;
        if held && !(out_u && out_v) {
            // One dimension left: Newton if convex, else a metric-scaled
            // gradient step.
            let (hh, mm, gg) = (h[(other, other)], m[(other, other)], g[other]);
            let step = if hh > 0.0 {
                -gg / hh
            } else {
                -gg / mm.max(1e-300)
            };
            if !out(other, step) {
                r[other] = step;
            }
        }
    }
    r
}

/// Newton step with Levenberg damping by multiples of the metric until the
/// model is convex; the metric-scaled gradient step if that fails.
fn damped_step(h: &Matrix2<f64>, m: &Matrix2<f64>, g: &Vector2<f64>) -> Vector2<f64> {
    match convexified(h, m).and_then(|a| a.try_inverse()) {
        Some(inv) => -(inv * g),
        None => -g / m.trace().max(1e-300),
    }
}

/// `h` plus the least multiple of the metric (by factors of 10 from 1e-6 of
/// their ratio) that makes it positive definite.
fn convexified(h: &Matrix2<f64>, m: &Matrix2<f64>) -> Option<Matrix2<f64>> {
    let scale = m.trace().max(1e-300);
    let mut lambda = 0.0;
    for _ in 0..60 {
        let a = h + m * lambda;
        if a[(0, 0)] > 0.0 && a.determinant() > 0.0 {
            return Some(a);
        }
        lambda = if lambda == 0.0 {
            1e-6 * h.norm().max(1e-12) / scale
        } else {
            lambda * 10.0
        };
    }
    None
}

/// Stage 2: Newton on the optimality system of the two largest inside
/// branches, while it lowers f.
fn kink_newton(pb: &Problem, mut at: At, trust: f64) -> At {
    let mut jets = Vec::new();
    let mut lambda: Option<f64> = None;
    for _ in 0..NEWTON_ITERATIONS {
        if at.f >= 0.0 {
            break;
        }
        let d = pb.face.derivatives(at.u, at.v);
        pb.tool.inside_jets(pb.pose, pb.part, &d.p, &mut jets);
        let Some((i, j)) = top_two(&jets) else {
            break;
        };
        let ((gi, hi), (gj, hj)) = (model(&d, &jets[i]), model(&d, &jets[j]));
        let dg = gi - gj;
        let l = lambda.unwrap_or_else(|| {
            let den = dg.norm_squared();
            if den > 0.0 {
                (-gj.dot(&dg) / den).clamp(0.0, 1.0)
            } else {
                0.5
            }
        });
        // Convexified along the kink (across it the branches' equality
        // holds the step): the SQP direction of the two-branch maximum.
        let m = metric(&d);
        let hl = convex_along(&(hi * l + hj * (1.0 - l)), &m, &dg);
        let gl = gi * l + gj * (1.0 - l);
        let rhs = -Vector3::new(gl[0], gl[1], jets[i].value - jets[j].value);
        let Some(step) = kkt_step(pb, &at, &hl, &dg, rhs) else {
            break;
        };
        let mut s = Vector2::new(step[0], step[1]);
        let mm = length_mm(&m, &s);
        if mm > trust {
            s *= trust / mm;
        }
        let mut t = 1.0;
        let mut accepted = None;
        for _ in 0..20 {
            // Back onto the kink before judging the step (the second-order
            // correction: the kink curves, and a step along its tangent
            // leaves it by the square of the step).
            let q = Vector2::new(at.u + t * s[0], at.v + t * s[1]);
            let q = onto_kink(pb, q, (i, j), &mut jets);
            if let Some(c) = pb.better(&at, q[0], q[1]) {
                accepted = Some(c);
                break;
            }
            t *= 0.5;
        }
        let Some(c) = accepted else {
            break;
        };
        let moved = (c.p - at.p).norm();
        at = c;
        lambda = Some((l + t * step[2]).clamp(0.0, 1.0));
        if moved <= STEP_MM {
            break;
        }
    }
    at
}

/// `h` plus the multiple of the metric that makes its curvature along the
/// kink's tangent (perpendicular to `dg`) positive, if it is not.
fn convex_along(h: &Matrix2<f64>, m: &Matrix2<f64>, dg: &Vector2<f64>) -> Matrix2<f64> {
    let tangent = Vector2::new(-dg[1], dg[0]);
    let tmt = (tangent.transpose() * m * tangent)[(0, 0)];
    if tmt <= 0.0 {
        return *h;
    }
    let q = (tangent.transpose() * h * tangent)[(0, 0)];
    let floor = 1e-8 * (h.norm() + 1e-12) * tmt / m.trace().max(1e-300);
    if q >= floor {
        *h
    } else {
        h + m * ((floor - q) / tmt)
    }
}

/// Two Gauss-Newton steps on f_i - f_j = 0 from `q`, along the difference
/// of the branches' gradients: back onto the kink.
fn onto_kink(
    pb: &Problem,
    mut q: Vector2<f64>,
    (i, j): (usize, usize),
    jets: &mut Vec<SdfJet>,
) -> Vector2<f64> {
    for _ in 0..2 {
        let (u, v) = pb.clamp(q[0], q[1]);
        let d = pb.face.derivatives(u, v);
        pb.tool.inside_jets(pb.pose, pb.part, &d.p, jets);
        let (gi, _) = model(&d, &jets[i]);
        let (gj, _) = model(&d, &jets[j]);
        let dg = gi - gj;
        let n2 = dg.norm_squared();
        if n2 <= 0.0 {
            break;
        }
        q = Vector2::new(u, v) - dg * ((jets[i].value - jets[j].value) / n2);
    }
    q
}

/// The step of the two-branch optimality system in (u, v, l); a parameter
/// on a bound of the domain that the step would cross is held there (its
/// stationarity row replaced by du = 0 or dv = 0: the bound's multiplier
/// takes it up).
fn kkt_step(
    pb: &Problem,
    at: &At,
    hl: &Matrix2<f64>,
    dg: &Vector2<f64>,
    rhs: Vector3<f64>,
) -> Option<Vector3<f64>> {
    let mut fixed = [false; 2];
    let bounds = [(at.u, pb.dom.0), (at.v, pb.dom.1)];
    for _ in 0..3 {
        let mut kkt = Matrix3::new(
            hl[(0, 0)],
            hl[(0, 1)],
            dg[0],
            hl[(1, 0)],
            hl[(1, 1)],
            dg[1],
            dg[0],
            dg[1],
            0.0,
        );
        let mut b = rhs;
        for k in 0..2 {
            if fixed[k] {
                kkt.row_mut(k).copy_from(&Vector3::ith(k, 1.0).transpose());
                b[k] = 0.0;
            }
        }
        let step = kkt.lu().solve(&b)?;
        let mut changed = false;
        for (k, &(x, [lo, hi])) in bounds.iter().enumerate() {
            if !fixed[k] && ((x <= lo && step[k] < 0.0) || (x >= hi && step[k] > 0.0)) {
                fixed[k] = true;
                changed = true;
            }
        }
        if !changed {
            return Some(step);
        }
    }
    None
}

/// Indices of the two largest values (the first on ties).
fn top_two(jets: &[SdfJet]) -> Option<(usize, usize)> {
    if jets.len() < 2 {
        return None;
    }
    let mut idx: Vec<usize> = (0..jets.len()).collect();
    idx.sort_by(|&a, &b| jets[b].value.total_cmp(&jets[a].value).then(a.cmp(&b)));
    Some((idx[0], idx[1]))
}

/// Stage 3's start: along steepest descent (in the metric) to the trim, the
/// last point on the face within `trust` mm, if it lowers f.
fn reach_trim(pb: &Problem, at: At, trust: f64) -> At {
    let d = pb.face.derivatives(at.u, at.v);
    let m = metric(&d);
    let jet = pb.tool.jet(pb.pose, pb.part, &d.p);
    let (g, _) = model(&d, &jet);
    let Some(inv) = m.try_inverse() else {
        return at;
    };
    let s = -(inv * g);
    let mm = length_mm(&m, &s);
    if mm <= 0.0 {
        return at;
    }
    let s = s * (trust / mm);
    let start = Vector2::new(at.u, at.v);
    let end = start + s;
    if pb.inside(end[0], end[1]) {
        return at;
    }
    let (mut a, mut b) = (0.0, 1.0);
    for _ in 0..40 {
        let mid = 0.5 * (a + b);
        let p = start + s * mid;
        if pb.inside(p[0], p[1]) {
            a = mid;
        } else {
            b = mid;
        }
    }
    let p = start + s * a;
    pb.better(&at, p[0], p[1]).unwrap_or(at)
}

/// Stage 3: descent along the trim from a point next to it, `h` the first
/// step in mm.
fn trim_walk(pb: &Problem, mut at: At, mut h: f64) -> At {
    for _ in 0..WALK_STEPS {
        if h <= STEP_MM {
            break;
        }
        let d = pb.face.derivatives(at.u, at.v);
        let m = metric(&d);
        let Some((tangent, inward)) = trim_frame(pb, &at, &m, h) else {
            break;
        };
        let jet = pb.tool.jet(pb.pose, pb.part, &d.p);
        let (g, _) = model(&d, &jet);
        let dir = if g.dot(&tangent) > 0.0 {
            -tangent
        } else {
            tangent
        };
        let q = Vector2::new(at.u, at.v) + dir * h;
        match project_to_trim(pb, q, inward * h).and_then(|b| pb.better(&at, b[0], b[1])) {
            Some(c) => {
                at = c;
                h *= 1.5;
            }
            None => h *= 0.5,
        }
    }
    at
}

/// The trim's unit tangent and inward normal (in (u, v), unit in mm) near
/// `at`, from where the inside test changes on a circle of `radius_mm`
/// round it; `None` unless the circle crosses the trim exactly twice.
fn trim_frame(
    pb: &Problem,
    at: &At,
    m: &Matrix2<f64>,
    radius_mm: f64,
) -> Option<(Vector2<f64>, Vector2<f64>)> {
    const ANGLES: usize = 16;
    let (su, sv) = (m[(0, 0)].sqrt().max(1e-300), m[(1, 1)].sqrt().max(1e-300));
    let centre = Vector2::new(at.u, at.v);
    let on_circle = |a: f64| centre + Vector2::new(a.cos() / su, a.sin() / sv) * radius_mm;
    let step = std::f64::consts::TAU / ANGLES as f64;
    let inside: Vec<bool> = (0..ANGLES)
        .map(|k| {
            let p = on_circle(k as f64 * step);
            pb.inside(p[0], p[1])
        })
        .collect();
    let mut crossings = Vec::new();
    for k in 0..ANGLES {
        if inside[k] != inside[(k + 1) % ANGLES] {
            let (mut lo, mut hi) = (k as f64 * step, (k + 1) as f64 * step);
            for _ in 0..14 {
                let mid = 0.5 * (lo + hi);
                let p = on_circle(mid);
                if pb.inside(p[0], p[1]) == inside[k] {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            crossings.push(on_circle(0.5 * (lo + hi)));
        }
    }
    if crossings.len() != 2 {
        return None;
    }
    let chord = crossings[1] - crossings[0];
    let n_mm = length_mm(m, &chord);
    if n_mm <= 0.0 {
        return None;
    }
    let tangent = chord / n_mm;
    // The normal, perpendicular in the metric, pointing to the inside.
    let normal = Matrix2::new(0.0, -1.0, 1.0, 0.0) * (m * tangent);
    let normal = normal / length_mm(m, &normal).max(1e-300);
    let probe = centre + normal * radius_mm;
    let inward = if pb.inside(probe[0], probe[1]) {
        normal
    } else {
        -normal
    };
    Some((tangent, inward))
}

/// The point of the trim reached from `q` along `inward` (or against it):
/// the last point on the face, by bisection to 1e-3 of the step.
fn project_to_trim(pb: &Problem, q: Vector2<f64>, inward: Vector2<f64>) -> Option<Vector2<f64>> {
    let start_in = pb.inside(q[0], q[1]);
    // Walk outwards from an inside point, inwards from an outside one.
    let dir = if start_in { -inward } else { inward };
    let mut far = None;
    for k in 1..=8 {
        let p = q + dir * (0.5 * k as f64);
        if pb.inside(p[0], p[1]) != start_in {
            far = Some(p);
            break;
        }
    }
    let far = far?;
    let (mut a, mut b) = (q, far);
    for _ in 0..12 {
        let mid = (a + b) * 0.5;
        if pb.inside(mid[0], mid[1]) == start_in {
            a = mid;
        } else {
            b = mid;
        }
    }
    Some(if start_in { a } else { b })
}

/// Stage 4: compass search from `best` along +-u, +-v and the diagonals,
/// halving the step when none improves, until a step is below [`STEP_MM`].
fn compass(pb: &Problem, mut best: At, start_mm: f64) -> At {
    let d = pb.face.derivatives(best.u, best.v);
    let (su, sv) = (d.su.norm().max(1e-300), d.sv.norm().max(1e-300));
    let mut h = start_mm.max(1e-6);
    let mut evaluations = 0;
    let r = std::f64::consts::FRAC_1_SQRT_2;
    let dirs = [
        (1.0, 0.0),
        (-1.0, 0.0),
        (0.0, 1.0),
        (0.0, -1.0),
        (r, r),
        (-r, -r),
        (r, -r),
        (-r, r),
    ];
    while h > STEP_MM && evaluations < COMPASS_EVALUATIONS {
        let (hu, hv) = (h / su, h / sv);
        let mut improved = false;
        for (du, dv) in dirs {
            evaluations += 1;
            if let Some(c) = pb.better(&best, best.u + du * hu, best.v + dv * hv) {
                best = c;
                improved = true;
                break;
            }
        }
        // Pattern search: a success doubles the step, a failure halves it.
        h *= if improved { 2.0 } else { 0.5 };
    }
    best
}
