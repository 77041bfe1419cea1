//! What the unit tests of the simulator share: reproducible random numbers
//! and random flat-end motions, and a brute-force minimum.

use nalgebra::Vector3;
use toolpath_formats::{Job, Pass, PathPoint, PlanResult};
use toolpath_kernel::numeric::golden_min;
use toolpath_kernel::rng::XorShift;

/// Pseudo-random numbers in [-1, 1) (xorshift), for reproducible cases.
pub(super) struct Rng(pub(super) XorShift);
impl Rng {
    /// The next number in [-1, 1).
    pub(super) fn next(&mut self) -> f64 {
        2.0 * self.0.unit() - 1.0
    }
    /// A random unit vector (z where the draw is near zero).
    pub(super) fn unit(&mut self) -> Vector3<f64> {
        Vector3::new(self.next(), self.next(), self.next())
            .try_normalize(1e-3)
            .unwrap_or(Vector3::z())
    }
}

/// Minimum of the convex `f` over [lo, hi] by golden section to 1e-13.
pub(super) fn brute_min(f: impl Fn(f64) -> f64, lo: f64, hi: f64) -> f64 {
    golden_min(&f, (lo, f(lo)), (hi, f(hi)), 1e-13)
}

/// Random flat-end motions (half of them turning) as a simulator.
pub(super) fn random_motions(rng: &mut Rng, count: usize, turn: f64) -> (Job, PlanResult) {
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
