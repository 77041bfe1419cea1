//! Exact refinement of the deepest / nearest point of a face: minimise
//! f(u, v) = sd(S(u, v)), the tool part's signed distance at the face's
//! point, from a sample, staying in the domain and inside the trim.
//!
//! Newton's method on the exact second-order model: gradient J^T g and
//! Hessian J^T H_sd J + sum_k g_k S_xy^k, with g, H_sd the signed distance's
//! gradient and Hessian ([`SdfJet`](crate::SdfJet)) and J = [S_u S_v];
//! Levenberg damping where the Hessian is not positive definite, a trust
//! radius in mm, and a backtracking line search that only accepts decrease
//! and points on the face. The distance has kinks (the medial axis inside
//! the tool, the rims of a flat end, the trim) where Newton stalls, so a
//! compass search polishes the result down to 1e-9 mm steps. The value
//! returned is attained (a real point of the face), never below the true
//! minimum.

use crate::assembly::{Pose, ToolAssembly, ToolPart};
use crate::face::Face;
use nalgebra::{Matrix2, Vector2, Vector3};

/// The refined point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Refined {
    pub u: f64,
    pub v: f64,
    pub point: Vector3<f64>,
    pub distance: f64,
}

/// Newton iterations at most.
const NEWTON_ITERATIONS: usize = 40;
/// Compass-search evaluations at most.
const COMPASS_EVALUATIONS: usize = 400;
/// Steps below this on the surface (mm) end the search.
const STEP_MM: f64 = 1e-9;

struct Problem<'a> {
    face: &'a dyn Face,
    tool: &'a ToolAssembly,
    pose: &'a Pose,
    part: ToolPart,
    dom: ([f64; 2], [f64; 2]),
}

impl Problem<'_> {
    /// f at (u, v) clamped into the domain, `None` off the face.
    fn value(&self, u: f64, v: f64) -> Option<(f64, f64, f64, Vector3<f64>)> {
        let u = u.clamp(self.dom.0[0], self.dom.0[1]);
        let v = v.clamp(self.dom.1[0], self.dom.1[1]);
        if !self.face.inside(u, v) {
            return None;
        }
        let p = self.face.point(u, v);
        let f = self.tool.signed_distance(self.pose, self.part, &p);
        f.is_finite().then_some((u, v, f, p))
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
    };
    let (mut u, mut v, mut f, mut p) = match pb.value(u, v) {
        Some(x) => x,
        // A start the caller took from the face lies on it; be safe anyway.
        None => {
            let p = face.point(u, v);
            (u, v, tool.signed_distance(pose, part, &p), p)
        }
    };
    let mut trust = trust_mm.max(1e-6);
    // Where the compass search starts: the last Newton move after
    // convergence (a smooth minimum), the trust radius after a stall (a kink).
    let mut polish = trust;
    for _ in 0..NEWTON_ITERATIONS {
        let Some((du, dv, slope, step_mm)) = newton_step(&pb, u, v, trust) else {
            polish = polish.min(1e-6);
            break;
        };
        let mut t = 1.0;
        let mut moved = None;
        for _ in 0..30 {
            if let Some((nu, nv, nf, np)) = pb.value(u + t * du, v + t * dv) {
                if nf <= f + 1e-4 * t * slope.min(0.0) && nf < f {
                    moved = Some((np - p).norm());
                    (u, v, f, p) = (nu, nv, nf, np);
                    break;
                }
            }
            t *= 0.5;
        }
        match moved {
            Some(m) if m > STEP_MM => {
                trust = (2.0 * m).max(0.5 * trust).max(1e-6);
                polish = (4.0 * m).max(1e-7);
            }
            Some(_) => {
                polish = 1e-7;
                break;
            }
            None => {
                polish = step_mm.clamp(1e-7, trust);
                break;
            }
        }
    }
    let (u, v, f, p) = compass(&pb, (u, v, f, p), polish);
    Refined {
        u,
        v,
        point: p,
        distance: f,
    }
}

/// The damped Newton step (du, dv) at (u, v), scaled to at most `trust` mm
/// on the surface, the directional derivative of f along it and its length
/// in mm; `None` at a stationary point.
fn newton_step(pb: &Problem, u: f64, v: f64, trust: f64) -> Option<(f64, f64, f64, f64)> {
    let d = pb.face.derivatives(u, v);
    let jet = pb.tool.jet(pb.pose, pb.part, &d.p);
    let g = Vector2::new(jet.gradient.dot(&d.su), jet.gradient.dot(&d.sv));
    let hs = &jet.hessian;
    let h = Matrix2::new(
        d.su.dot(&(hs * d.su)) + jet.gradient.dot(&d.suu),
        d.su.dot(&(hs * d.sv)) + jet.gradient.dot(&d.suv),
        d.sv.dot(&(hs * d.su)) + jet.gradient.dot(&d.suv),
        d.sv.dot(&(hs * d.sv)) + jet.gradient.dot(&d.svv),
    );
    let metric = Matrix2::new(
        d.su.dot(&d.su),
        d.su.dot(&d.sv),
        d.su.dot(&d.sv),
        d.sv.dot(&d.sv),
    );
    if g.norm() <= 1e-15 * metric.trace().sqrt() {
        return None;
    }
    // Levenberg: add a multiple of the metric until the model is convex.
    let scale = metric.trace().max(1e-300);
    let mut lambda = 0.0;
    let mut step = None;
    for _ in 0..60 {
        let m = h + metric * lambda;
        if m[(0, 0)] > 0.0 && m.determinant() > 0.0 {
            step = m.try_inverse().map(|inv| -(inv * g));
            if step.is_some() {
                break;
            }
        }
        lambda = if lambda == 0.0 {
            1e-6 * h.norm().max(1e-12) / scale
        } else {
            lambda * 10.0
        };
    }
    let mut s = step.unwrap_or(-g / scale);
    let mm = (s.transpose() * metric * s)[(0, 0)].max(0.0).sqrt();
    if mm > trust {
        s *= trust / mm;
    }
    Some((s[0], s[1], g.dot(&s), mm.min(trust)))
}

/// Compass search from `best`: steps along +-u and +-v, halved when none
/// improves, until a step is below [`STEP_MM`] on the surface.
fn compass(
    pb: &Problem,
    mut best: (f64, f64, f64, Vector3<f64>),
    start_mm: f64,
) -> (f64, f64, f64, Vector3<f64>) {
    let d = pb.face.derivatives(best.0, best.1);
    let (su, sv) = (d.su.norm().max(1e-300), d.sv.norm().max(1e-300));
    let mut h = start_mm.max(1e-6);
    let mut evaluations = 0;
    while h > STEP_MM && evaluations < COMPASS_EVALUATIONS {
        let (hu, hv) = (h / su, h / sv);
        let mut improved = false;
        for (du, dv) in [(hu, 0.0), (-hu, 0.0), (0.0, hv), (0.0, -hv)] {
            evaluations += 1;
            if let Some(c) = pb.value(best.0 + du, best.1 + dv) {
                if c.2 < best.2 {
                    best = c;
                    improved = true;
                    break;
                }
            }
        }
        if !improved {
            h *= 0.5;
        }
    }
    best
}
