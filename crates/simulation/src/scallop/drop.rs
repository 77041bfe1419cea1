//! The drop of the tool along one motion at one sample's line: the exact
//! cutter at the interpolated pose, the flat end's closed form expanded in
//! the motion parameter, the tip-plane bound, and the flat end's rim kinks
//! (docs/methods.md, "Swept cutter and residual").

use super::motion::Motion;
use super::simulator::Simulator;
use nalgebra::Vector3;
use toolpath_kernel::numeric::Bracket;
use toolpath_kernel::tools::cutter_shape::radial_interval;

/// The drop of the tool along one motion at one sample's line p + t n, as a
/// function of the motion parameter s. For a flat end the pose's products
/// with the line are expanded in s once (the unnormalised axis is linear in
/// s, its squared length quadratic), so each drop is the closed form of
/// [`CutterShape::lowest_hit`] from a few scalars: two square roots and three
/// divisions instead of the pose's vectors. Other cutters evaluate the pose.
pub(super) struct SweepLine<'a> {
    pub(super) sim: &'a Simulator<'a>,
    pub(super) seg: &'a Motion,
    p: &'a Vector3<f64>,
    n: &'a Vector3<f64>,
    pub(super) flat: bool,
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
    pub(super) kinks: bool,
}

impl<'a> SweepLine<'a> {
    /// The line's products with the motion, only those the tip-plane bound
    /// needs (`z`, `na`); [`Self::complete`] adds the rest before any drop.
    pub(super) fn new(
        sim: &'a Simulator<'a>,
        seg: &'a Motion,
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
    pub(super) fn complete(mut self) -> Self {
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
    pub(super) fn plane_bound(&self) -> f64 {
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

    pub(super) fn drop(&self, s: f64) -> f64 {
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
    pub(super) fn kink_first(&self, k: usize, tol: f64) -> Option<f64> {
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
        let mut br = Bracket::new(a, ga, b, gb);
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
    /// tolerance, the stopping rule of
    /// [`bracket_min`](toolpath_kernel::numeric::bracket_min)). `None` otherwise:
    /// the caller searches.
    pub(super) fn kink_min(&self, known: &[(f64, f64)], tol: f64) -> Option<f64> {
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

impl Simulator<'_> {
    pub(super) fn drop_at(&self, seg: &Motion, s: f64, p: &Vector3<f64>, n: &Vector3<f64>) -> f64 {
        let (tip, axis) = seg.pose(s);
        self.cutter
            .lowest_hit(&tip, &axis, p, n, -self.depth, self.cap)
            .unwrap_or(f64::INFINITY)
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{random_motions, Rng};
    use super::*;
    use toolpath_kernel::rng::XorShift;
    use toolpath_kernel::tools::Tool;

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
        for seg in &sim.motions {
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
}
