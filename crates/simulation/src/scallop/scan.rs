//! The scan of the drop along a motion and the refinement around its best
//! position, shared by the fast and the reference simulators: the drop at
//! sub-positions no further apart than R/8 (and where the line passes
//! closest to the axis), then the edge of the tool's reach by bisection and
//! golden section between the best position's neighbours to
//! [`SWEEP_TOL_MM`] of motion.

use super::motion::Motion;
use super::simulator::Simulator;
use nalgebra::Vector3;
use toolpath_kernel::numeric::golden_min;

/// The fast residual relies on the drop being convex in the motion parameter,
/// which holds exactly for a translating tool; a turning axis bends it
/// slightly, far less than this slack on real plans (tests/scallop_accuracy.rs
/// holds the fast map within 1e-4 mm of `run_reference`). A motion is only
/// left unrefined when the convexity bounds put it this far above the lowest
/// drop found so far.
pub(super) const CONVEXITY_SLACK_MM: f64 = 5e-3;

/// Motion parameter resolution of the sweep refinement, mm.
pub(super) const SWEEP_TOL_MM: f64 = 1e-5;

/// Bisects between `s_in` (drop finite) and `s_out` (line misses the tool)
/// for the last position that still hits; returns it with its drop.
pub(super) fn edge(
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
pub(super) fn slope(a: (f64, f64), b: (f64, f64)) -> f64 {
    if a.1.is_finite() && b.1.is_finite() {
        (b.1 - a.1) / (b.0 - a.0)
    } else {
        f64::NAN
    }
}

impl Simulator<'_> {
    /// Motion parameter where the line passes closest to the tool axis at the
    /// corner height: near the edge of a tool's reach the line meets the moving
    /// tool only over a short stretch around it, so the scan includes it.
    pub(super) fn closest_position(&self, seg: &Motion, p: &Vector3<f64>, n: &Vector3<f64>) -> f64 {
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

    /// Refines the minimum of the drop around the best scanned position
    /// `best` = (s, drop), given its scanned neighbours (`s` NaN: none, drop
    /// infinite: the line misses the tool there): the edge of the tool's reach
    /// by bisection, then golden-section search to [`SWEEP_TOL_MM`].
    pub(super) fn refine_bracket(
        seg: &Motion,
        drop: impl Fn(f64) -> f64,
        Scanned { best, left, right }: Scanned,
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
        best.min(golden_min(drop, (lo, f_lo), (hi, f_hi), tol))
    }

    /// Sub-positions scanned along `seg`: its travel over the scan step,
    /// at least 1, at most 4096.
    pub(super) fn scan_steps(&self, seg: &Motion) -> usize {
        ((seg.travel / self.scan_step).ceil() as usize).clamp(1, 4096)
    }
}

/// No scanned position: `s` NaN, the drop infinite.
pub(super) const NONE: (f64, f64) = (f64::NAN, f64::INFINITY);

/// The best scanned position along a motion and its neighbours in the scan
/// order, as (s, drop): `s` NaN where there is none, the drop infinite where
/// the line misses the tool.
#[derive(Clone, Copy, Debug)]
pub(super) struct Scanned {
    pub(super) best: (f64, f64),
    pub(super) left: (f64, f64),
    pub(super) right: (f64, f64),
}

/// The scan of `drop` over the motion: at s = i / k for i = 0..=k, and at
/// `s_close` in its place in the order. Without a `cutoff` (the reference)
/// every position is scanned. With one (the fast path) the scan relies on
/// the drop's convexity: it stops where the drop rises (past the minimum)
/// or the line leaves the tool's reach after a hit, and gives `None` once
/// the secant through the last two falling drops bounds the rest of the
/// motion [`CONVEXITY_SLACK_MM`] above the cutoff: it cannot lower it.
pub(super) fn scan(
    drop: impl Fn(f64) -> f64,
    k: usize,
    s_close: f64,
    cutoff: Option<f64>,
) -> Option<Scanned> {
    let ds = 1.0 / k as f64;
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
        let h = drop(s);
        if h < best.1 {
            best = (s, h);
            left = prev;
            right = NONE;
            right_pending = true;
        } else if right_pending {
            right = (s, h);
            right_pending = false;
        }
        if let Some(cutoff) = cutoff {
            if prev.1.is_finite() && (!h.is_finite() || h > prev.1) {
                // Past the minimum, or out of the tool's reach for good.
                break;
            }
            if prev2.1.is_finite() && prev.1.is_finite() && h <= prev.1 {
                // Drops falling: nothing before `prev` is below prev.1, nothing after
                // it below the secant through prev2 and prev.
                let slope = (prev.1 - prev2.1) / (prev.0 - prev2.0);
                if prev.1 + slope.min(0.0) * (1.0 - prev.0) >= cutoff + CONVEXITY_SLACK_MM {
                    return None;
                }
            }
        }
        prev2 = prev;
        prev = (s, h);
    }
    Some(Scanned { best, left, right })
}
