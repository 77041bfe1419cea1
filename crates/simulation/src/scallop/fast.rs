//! The fast path's minimum of the drop along a motion: the same scan and
//! refinement as the reference, cut short where the drop's convexity in the
//! motion parameter proves a motion cannot lower the residual, with the flat
//! end's rim kink solved for where it is the minimum (docs/methods.md,
//! "Swept cutter and residual").

use super::drop::SweepLine;
use super::motion::Motion;
use super::scan::{edge, scan, slope, Scanned, CONVEXITY_SLACK_MM, NONE, SWEEP_TOL_MM};
use super::simulator::Simulator;
use nalgebra::Vector3;
use toolpath_kernel::numeric::bracket_min;

impl Simulator<'_> {
    /// Lowest drop of the tool swept along `seg` at the line p + t n, or some
    /// value >= `cutoff` when the drop cannot go below `cutoff`.
    ///
    /// The same scan and refinement as the reference (`reference.rs`), cut short
    /// by the convexity of the drop in the motion parameter (docs/methods.md,
    /// "Scallop simulator"): once the scanned drop rises it keeps rising, so
    /// the scan stops there (and where the line leaves the tool's reach); a
    /// secant through two scanned drops bounds the drop beyond them from below,
    /// so a motion that cannot beat `cutoff` is left before its refinement.
    /// Before any of that, a motion whose tip plane stays at or above `cutoff`
    /// along the line ([`SweepLine::plane_bound`], exact) is left unscanned.
    pub(super) fn sweep_min(
        &self,
        seg: &Motion,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        cutoff: f64,
    ) -> f64 {
        let line = SweepLine::new(self, seg, p, n);
        let bound = line.plane_bound();
        if bound >= cutoff {
            return f64::INFINITY;
        }
        let mut line = line.complete();
        line.kinks = line.flat && bound.is_finite() && seg.travel > 0.0;
        let k = self.scan_steps(seg);
        if line.kinks {
            if let Some(f) = line.kink_first(k, SWEEP_TOL_MM / seg.travel) {
                return f;
            }
        }
        let s_close = self.closest_position(seg, p, n);
        match scan(|s| line.drop(s), k, s_close, Some(cutoff)) {
            Some(scanned) => Self::refine_scanned(&line, scanned, cutoff),
            None => f64::INFINITY,
        }
    }

    /// The minimum of the drop from the fast scan's best position and its
    /// neighbours, or infinity once the convexity bounds show it cannot beat
    /// `cutoff`: probes one tolerance to each side pick the side to search
    /// (the reach edge, [`bracket_min`] on one side, or both sides).
    fn refine_scanned(line: &SweepLine, scanned: Scanned, cutoff: f64) -> f64 {
        let Scanned { best, left, right } = scanned;
        if !best.1.is_finite() {
            return best.1;
        }
        if convexity_low(&scanned) >= cutoff + CONVEXITY_SLACK_MM {
            return f64::INFINITY;
        }
        let seg = line.seg;
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
                return Self::edge_minimum(line, best, left.0, right, tol, cutoff);
            }
            (false, true) if right.1 == f64::INFINITY && left.1.is_finite() => {
                return Self::edge_minimum(line, best, right.0, left, tol, cutoff);
            }
            (true, false) => return Self::refine_fast(line, best, (left, NONE), probes),
            (false, true) => return Self::refine_fast(line, best, (NONE, right), probes),
            _ => {}
        }
        // The drop rises both ways from the best scanned position (or falls
        // both ways, off convexity): a flat end's certified rim kink next to
        // it, else the reference's golden section over both neighbours, which
        // finds the same minimum as the reference where a turning axis gives
        // the drop two.
        if line.kinks {
            let (known, count) = known_drops([left, probes[0], best, probes[1], right]);
            if let Some(f) = line.kink_min(&known[..count], tol) {
                return f;
            }
        }
        // On the expanded drop: the reference's positions, its drops to rounding.
        Self::refine_bracket(seg, |s| line.drop(s), scanned)
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
        let (known, count) = known_drops(pts);
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
        let (known, count) = known_drops(pts);
        bracket_min(|s| line.drop(s), &known[..count], tol, 200)
    }
}

/// The lowest the convex drop can be off the scanned positions: left of the
/// best position it lies above the secant through the best and its right
/// neighbour, right of it above the one through its left neighbour (an
/// unscanned side has nothing to bound).
fn convexity_low(&Scanned { best, left, right }: &Scanned) -> f64 {
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
    low_left.min(low_right)
}

/// The points of `pts` (in order of s) with a finite drop and an s above
/// the previous one kept, packed at the front: the known drops a minimiser
/// starts from, and their count.
fn known_drops<const N: usize>(pts: [(f64, f64); N]) -> ([(f64, f64); N], usize) {
    let mut known = [(0.0, 0.0); N];
    let mut count = 0;
    for q in pts {
        if q.1.is_finite() && !q.0.is_nan() && (count == 0 || q.0 > known[count - 1].0) {
            known[count] = q;
            count += 1;
        }
    }
    (known, count)
}

#[cfg(test)]
mod tests {
    use super::super::scan::SWEEP_TOL_MM;
    use super::super::test_support::{brute_min, random_motions, Rng};
    use super::*;
    use toolpath_kernel::rng::XorShift;
    use toolpath_kernel::tools::Tool;

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
        for seg in &sim.motions {
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
                        want = want.min(brute_min(drop, end.min(s_i), end.max(s_i)));
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
                            .min(brute_min(drop, a.min(s_i), a.max(s_i)));
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
