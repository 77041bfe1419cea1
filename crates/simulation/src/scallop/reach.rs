//! Which motions can reach a sample's line: the distance from the line to
//! the motion's mid axis against the tool's radius and the motion's margin,
//! and the support bound of the swept tool along the line.

use super::motion::Motion;
use super::simulator::Simulator;
use nalgebra::Vector3;

/// A sample's line p + t n over the searched range t in [-depth, cap], as
/// the segment a + s d (s in [0, 1]) with |d|^2 and its reciprocal: the
/// reach test's per-sample constants.
pub(super) struct ReachLine {
    a: Vector3<f64>,
    d: Vector3<f64>,
    dd: f64,
    inv_dd: f64,
}

impl ReachLine {
    pub(super) fn new(p: &Vector3<f64>, n: &Vector3<f64>, depth: f64, cap: f64) -> Self {
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
    pub(super) fn distance2_to_mid_axis(&self, seg: &Motion) -> f64 {
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

impl Simulator<'_> {
    /// Whether the tool swept along `seg` may reach the line p + t n below `best`.
    pub(super) fn may_reach(
        &self,
        seg: &Motion,
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
}

/// Distance between motions [p0, p1] and [q0, q1] (Ericson, Real-Time Collision Detection 5.1.9).
pub(super) fn segment_distance(
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
    use super::super::test_support::{brute_min, random_motions, Rng};
    use super::*;
    use toolpath_kernel::rng::XorShift;
    use toolpath_kernel::tools::Tool;

    /// The reach test's squared distance between the sample's line and a
    /// motion's mid axis against a brute-force minimum of the distance
    /// between points of the two motions (nested golden sections: the
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
        for seg in &sim.motions {
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
                let inner = |s: f64| brute_min(|t| at(s, t), 0.0, 1.0);
                let want = brute_min(inner, 0.0, 1.0);
                // Closest points of nearly parallel motions are
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
}
