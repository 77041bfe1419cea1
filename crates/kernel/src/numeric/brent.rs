//! Brent's minimisation of a function of one variable over a bracket
//! (Brent 1973, "Algorithms for Minimization without Derivatives", ch. 5):
//! parabolic steps through the three best points, golden section where a
//! parabola would not shrink the bracket. A handful of evaluations on the
//! smooth, locally parabolic functions MPEC's error curves are, where plain
//! golden section needs 12 to 16.

/// Golden-section fraction 2 - phi.
const C: f64 = 0.381_966_011_250_105_1;

/// Brent's minimisation of `f` on [a, b] (parabolic steps, golden-section
/// fallback) to an abscissa tolerance `tol` (plus 1e-12 of |x|); at most 60
/// steps. Returns (x, f(x)) of the lowest point found.
pub fn brent_min(a: f64, b: f64, tol: f64, mut f: impl FnMut(f64) -> f64) -> (f64, f64) {
    let (mut a, mut b) = (a.min(b), a.max(b));
    let mut x = a + C * (b - a);
    let (mut w, mut v) = (x, x);
    let mut fx = f(x);
    let (mut fw, mut fv) = (fx, fx);
    let (mut d, mut e) = (0.0f64, 0.0f64);
    for _ in 0..60 {
        let m = 0.5 * (a + b);
        let tol1 = tol + 1e-12 * x.abs();
        let tol2 = 2.0 * tol1;
        if (x - m).abs() <= tol2 - 0.5 * (b - a) {
            break;
        }
        let mut golden = true;
        if e.abs() > tol1 {
            // Parabola through x, w, v.
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            let e_old = e;
            if p.abs() < (0.5 * q * e_old).abs() && p > q * (a - x) && p < q * (b - x) {
                e = d;
                d = p / q;
                let u = x + d;
                if u - a < tol2 || b - u < tol2 {
                    d = if m >= x { tol1 } else { -tol1 };
                }
                golden = false;
            }
        }
        if golden {
            e = if x >= m { a - x } else { b - x };
            d = C * e;
        }
        let u = if d.abs() >= tol1 {
            x + d
        } else {
            x + tol1.copysign(d)
        };
        let fu = f(u);
        if fu <= fx {
            if u >= x {
                a = x;
            } else {
                b = x;
            }
            (v, fv) = (w, fw);
            (w, fw) = (x, fx);
            (x, fx) = (u, fu);
        } else {
            if u < x {
                a = u;
            } else {
                b = u;
            }
            if fu <= fw || w == x {
                (v, fv) = (w, fw);
                (w, fw) = (u, fu);
            } else if fu <= fv || v == x || v == w {
                (v, fv) = (u, fu);
            }
        }
    }
    (x, fx)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numeric::golden_min;
    use crate::rng::XorShift;

    /// Smooth unimodal functions with a known minimiser m inside a random
    /// bracket (a parabola, a parabola with a quartic term, a shifted cosh,
    /// and a function flat to fourth order): the minimiser to the tolerance,
    /// the value a value of f at it, against brute force (the lowest of
    /// 20001 samples) never worse than the sampling's own error; and on the
    /// parabolic ones in fewer evaluations than golden section.
    #[test]
    fn smooth_minima_to_the_tolerance_against_brute_force() {
        let mut rng = XorShift(0x2545_f491_4f6c_dd1d);
        let tol = 1e-6;
        let (mut ours, mut golden) = (0usize, 0usize);
        for case in 0..2000 {
            let a = 4.0 * (rng.unit() - 0.5);
            let b = a + 0.1 + 2.0 * rng.unit();
            let m = a + (b - a) * (0.05 + 0.9 * rng.unit());
            let (c, q, z) = (0.1 + 5.0 * rng.unit(), 3.0 * rng.unit(), rng.unit() - 0.5);
            let kind = case % 4;
            let f = |x: f64| {
                let d = x - m;
                z + match kind {
                    0 => c * d * d,
                    1 => c * d * d + q * d * d * d * d,
                    2 => (c * d).cosh() - 1.0,
                    _ => c * d * d * d * d,
                }
            };
            let mut calls = 0;
            let (x, fx) = brent_min(a, b, tol, |x| {
                calls += 1;
                f(x)
            });
            assert_eq!(fx, f(x), "case {case}: the value at the minimiser");
            // A function flat to fourth order pins its minimiser only to the
            // fourth root of the rounding of its values.
            let x_tol = if kind == 3 { 1e-3 } else { 3.0 * tol };
            assert!(
                (x - m).abs() <= x_tol,
                "case {case} kind {kind}: {x} vs {m}"
            );
            let n = 20_000;
            let brute = (0..=n)
                .map(|i| f(a + (b - a) * i as f64 / n as f64))
                .fold(f64::INFINITY, f64::min);
            // Within its tolerance the value is no further above the minimum
            // than f is that far from the minimiser.
            let slack = (f(m + x_tol) - z).max(f(m - x_tol) - z) + 1e-15;
            assert!(
                fx <= brute + slack,
                "case {case}: {fx} above brute force {brute}"
            );
            if kind < 2 {
                let mut g = 0;
                golden_min(
                    |x| {
                        g += 1;
                        f(x)
                    },
                    (a, f(a)),
                    (b, f(b)),
                    tol,
                );
                ours += calls;
                golden += g;
            }
        }
        assert!(
            (ours as f64) < 0.5 * golden as f64,
            "{ours} evaluations against golden section's {golden}"
        );
    }

    #[test]
    fn bracket_ends_in_either_order_and_minimum_at_an_end() {
        let f = |x: f64| (x - 0.25) * (x - 0.25);
        let (x, _) = brent_min(1.0, 0.0, 1e-8, f);
        assert!((x - 0.25).abs() < 3e-8, "{x}");
        // Increasing on the bracket: the minimum at its left end.
        let (x, fx) = brent_min(2.0, 3.0, 1e-8, |x| x);
        assert!((x - 2.0).abs() < 1e-7 && fx == x, "{x}");
    }
}
