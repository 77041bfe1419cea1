//! Golden-section search: the minimum of a unimodal function over a bracket,
//! the bracket shrunk by the golden ratio each step. The safe reference the
//! faster minimisers ([`super::bracket_min`], [`super::brent_min`]) are
//! measured against, and the scallop simulator's reference refinement.

/// Golden ratio minus one, 1 / phi.
const G: f64 = 0.618_033_988_749_894_9;

/// The lowest value of the unimodal `f` seen while golden-section search
/// narrows [lo, hi] (ends given with their values, lo < hi) until narrower
/// than `tol`, ends included; at most 80 steps (a bracket shrinks by 1e-16
/// in 77).
pub fn golden_min(
    mut f: impl FnMut(f64) -> f64,
    (mut lo, f_lo): (f64, f64),
    (mut hi, f_hi): (f64, f64),
    tol: f64,
) -> f64 {
    let mut x1 = hi - G * (hi - lo);
    let mut x2 = lo + G * (hi - lo);
    let mut f1 = f(x1);
    let mut f2 = f(x2);
    for _ in 0..80 {
        if hi - lo <= tol {
            break;
        }
        if f1 <= f2 {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - G * (hi - lo);
            f1 = f(x1);
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + G * (hi - lo);
            f2 = f(x2);
        }
    }
    f_lo.min(f_hi).min(f1).min(f2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::XorShift;

    /// Convex functions with the minimum value 0 at a random point of a
    /// random bracket (smooth, kinked, flat-bottomed by a power, at an end):
    /// the result is a value of f, never below the minimum, and within the
    /// bracket's final width times the steepest slope near the minimum.
    #[test]
    fn minimum_within_the_tolerance_on_random_convex_functions() {
        let mut rng = XorShift(0x5851_f42d_4c95_7f2d);
        for case in 0..5000 {
            let lo = 10.0 * (rng.unit() - 0.5);
            let hi = lo + 0.01 + 5.0 * rng.unit();
            // A quarter of the minima at the ends of the bracket.
            let m = match case % 8 {
                0 => lo,
                1 => hi,
                _ => lo + (hi - lo) * rng.unit(),
            };
            let (sl, sr) = (0.1 + 3.0 * rng.unit(), 0.1 + 3.0 * rng.unit());
            let kind = case % 3;
            let f = |x: f64| {
                let d = x - m;
                match kind {
                    0 => (-sl * d).max(sr * d),
                    1 => sl * d * d,
                    _ => sr * d.abs().powf(1.5),
                }
            };
            let tol = 1e-3 * rng.unit() + 1e-9;
            let got = golden_min(f, (lo, f(lo)), (hi, f(hi)), tol);
            // Slope bound over one bracket width around m.
            let slope = match kind {
                0 => sl.max(sr),
                1 => 2.0 * sl * (hi - lo),
                _ => 1.5 * sr * (hi - lo).sqrt(),
            };
            assert!(got >= 0.0, "case {case}: {got} below the minimum");
            assert!(
                got <= slope * tol * 1.01 + 1e-15,
                "case {case} kind {kind}: {got:e} with tolerance {tol:e}"
            );
        }
    }

    /// The bracket shrinks by 1 / phi per evaluation: from width 1 to 1e-6
    /// in 29 steps, plus the two first points.
    #[test]
    fn evaluations_follow_the_golden_ratio() {
        let mut calls = 0;
        let f = |x: f64| {
            calls += 1;
            (x - 0.3).abs()
        };
        let got = golden_min(f, (0.0, 0.3), (1.0, 0.7), 1e-6);
        assert!(got <= 1e-6, "{got:e}");
        assert_eq!(calls, 2 + 29);
    }
}
