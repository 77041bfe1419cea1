//! Roots of a function of one variable: a bracket narrowed by regula falsi
//! with the Illinois modification, and Newton's iteration kept inside such a
//! bracket. Both are superlinear on smooth functions, yet never leave the
//! bracket, so they are as safe as bisection (docs/methods.md, "One root
//! finder"). Callers choose when to stop: the strip-width crossing, the
//! plane-section edge crossings, MPEC's strip edges and pass advance and the
//! simulator's rim crossing each need a different tolerance.

/// A bracket of a root of f: f(neg) <= 0 < f(pos). The ends may lie either
/// way round on the axis.
#[derive(Clone, Copy, Debug)]
pub struct Bracket {
    pub neg: f64,
    pub f_neg: f64,
    pub pos: f64,
    pub f_pos: f64,
    /// -1: the last trial replaced `neg`, 1: `pos`, 0: none yet.
    side: i8,
}

impl Bracket {
    /// A bracket from two ends whose values have opposite signs (either order);
    /// the end whose value is <= 0 becomes `neg`.
    pub fn new(a: f64, fa: f64, b: f64, fb: f64) -> Self {
        let ((neg, f_neg), (pos, f_pos)) = if fa <= 0.0 {
            ((a, fa), (b, fb))
        } else {
            ((b, fb), (a, fa))
        };
        Self {
            neg,
            f_neg,
            pos,
            f_pos,
            side: 0,
        }
    }

    /// Distance between the ends.
    pub fn width(&self) -> f64 {
        (self.pos - self.neg).abs()
    }

    /// The next trial point: where the chord between the ends crosses zero,
    /// or the midpoint when that is not strictly inside the bracket (equal or
    /// non-finite values at the ends).
    pub fn trial(&self) -> f64 {
        let (a, fa, b, fb) = (self.neg, self.f_neg, self.pos, self.f_pos);
        let x = (a * fb - b * fa) / (fb - fa);
        if x > a.min(b) && x < a.max(b) {
            x
        } else {
            0.5 * (a + b)
        }
    }

    /// The chord's crossing kept at least the fraction `keep` of the bracket
    /// away from either end, measured from `pos`: a guard for functions whose
    /// chord lands next to one end for many steps.
    pub fn trial_clamped(&self, keep: f64) -> f64 {
        let w = (self.f_pos / (self.f_pos - self.f_neg)).clamp(keep, 1.0 - keep);
        self.pos - w * (self.pos - self.neg)
    }

    /// Replaces the end on the trial point's side of the root by (x, f(x)).
    /// When the same end is replaced twice running, the other end's value is
    /// halved (Illinois), so the bracket closes from both sides.
    pub fn narrow(&mut self, x: f64, fx: f64) {
        if fx <= 0.0 {
            (self.neg, self.f_neg) = (x, fx);
            if self.side == -1 {
                self.f_pos *= 0.5;
            }
            self.side = -1;
        } else {
            (self.pos, self.f_pos) = (x, fx);
            if self.side == 1 {
                self.f_neg *= 0.5;
            }
            self.side = 1;
        }
    }

    /// The midpoint of the ends.
    pub fn mid(&self) -> f64 {
        0.5 * (self.neg + self.pos)
    }
}

/// A root of `f` in the bracket (a, fa), (b, fb) (values of opposite signs),
/// once the bracket is narrower than `x_tol` or a trial hits zero exactly; at
/// most `max_iter` evaluations.
pub fn illinois_root(
    f: impl Fn(f64) -> f64,
    (a, fa): (f64, f64),
    (b, fb): (f64, f64),
    x_tol: f64,
    max_iter: usize,
) -> f64 {
    let mut br = Bracket::new(a, fa, b, fb);
    for _ in 0..max_iter {
        if br.width() < x_tol {
            break;
        }
        let x = br.trial();
        let fx = f(x);
        if fx == 0.0 {
            return x;
        }
        br.narrow(x, fx);
    }
    br.mid()
}

/// A root of `f` (value and derivative) in the bracket (a, fa), (b, fb)
/// (values of opposite signs) by Newton's iteration kept inside the bracket:
/// it starts at `start` (the chord's crossing where that is `None` or not
/// strictly inside the bracket) and every evaluation narrows the bracket; a Newton step that would leave it (a derivative that is zero, of
/// the wrong sign or not finite) is replaced by the bracket's Illinois trial.
/// Returns the end of the first Newton step shorter than `step_tol` (near a
/// simple root its error is then about f'' / (2 f') times the step squared),
/// a trial where f is exactly zero, or after `max_iter` evaluations the
/// bracket's midpoint.
pub fn newton_root(
    f: impl Fn(f64) -> (f64, f64),
    (a, fa): (f64, f64),
    (b, fb): (f64, f64),
    start: Option<f64>,
    step_tol: f64,
    max_iter: usize,
) -> f64 {
    let mut br = Bracket::new(a, fa, b, fb);
    let mut x = match start {
        Some(x) if x > a.min(b) && x < a.max(b) => x,
        _ => br.trial(),
    };
    for _ in 0..max_iter {
        let (fx, dfx) = f(x);
        if fx == 0.0 {
            return x;
        }
        br.narrow(x, fx);
        let next = x - fx / dfx;
        let (lo, hi) = (br.neg.min(br.pos), br.neg.max(br.pos));
        // The comparisons are false for NaN: a failed step takes the trial.
        if (next - x).abs() < step_tol && next >= lo && next <= hi {
            return next;
        }
        x = if next > lo && next < hi {
            next
        } else {
            br.trial()
        };
    }
    br.mid()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_roots_of_smooth_and_kinked_functions() {
        // Exact roots: cube root of 2, pi/4 for cos - sin, 0.3 for a kink.
        type Case<'a> = (&'a dyn Fn(f64) -> f64, f64, f64, f64);
        let cases: [Case; 3] = [
            (&|x: f64| x * x * x - 2.0, 0.0, 3.0, 2f64.cbrt()),
            (
                &|x: f64| x.sin() - x.cos(),
                1.5,
                0.0,
                std::f64::consts::FRAC_PI_4,
            ),
            (
                &|x: f64| (x - 0.3).abs().sqrt() * (x - 0.3).signum(),
                -1.0,
                1.0,
                0.3,
            ),
        ];
        for (f, a, b, root) in cases {
            let x = illinois_root(f, (a, f(a)), (b, f(b)), 1e-13, 200);
            assert!((x - root).abs() < 1e-9, "{x} vs {root}");
        }
    }

    #[test]
    fn converges_faster_than_bisection_on_a_smooth_function() {
        use std::cell::Cell;
        let calls = Cell::new(0);
        let f = |x: f64| {
            calls.set(calls.get() + 1);
            x.exp() - 3.0
        };
        let x = illinois_root(f, (0.0, f(0.0)), (2.0, f(2.0)), 1e-13, 200);
        assert!((x - 3f64.ln()).abs() < 1e-12);
        // Bisection needs about 44 halvings from width 2 to 1e-13.
        assert!(calls.get() < 25, "{} evaluations", calls.get());
    }

    #[test]
    fn trial_stays_inside_the_bracket() {
        let br = Bracket::new(1.0, 5.0, 0.0, 5.0);
        assert_eq!(br.trial(), 0.5);
        let br = Bracket::new(0.0, -1.0, 1.0, f64::INFINITY);
        assert_eq!(br.trial(), 0.5);
    }

    #[test]
    fn newton_finds_roots_to_the_last_bits_in_few_steps() {
        use std::cell::Cell;
        // Exact roots: cube root of 2, ln 3, pi/4 for cos - sin; and a
        // derivative of the wrong sign (the bracket's trial takes over).
        type Case<'a> = (&'a dyn Fn(f64) -> (f64, f64), f64, f64, f64, usize);
        let cases: [Case; 4] = [
            (
                &|x: f64| (x * x * x - 2.0, 3.0 * x * x),
                0.0,
                3.0,
                2f64.cbrt(),
                12,
            ),
            (&|x: f64| (x.exp() - 3.0, x.exp()), 0.0, 2.0, 3f64.ln(), 8),
            (
                &|x: f64| (x.sin() - x.cos(), x.cos() + x.sin()),
                1.5,
                0.0,
                std::f64::consts::FRAC_PI_4,
                8,
            ),
            (&|x: f64| (x - 0.3, -1.0), -1.0, 1.0, 0.3, 64),
        ];
        for (f, a, b, root, most) in cases {
            let calls = Cell::new(0);
            let g = |x: f64| {
                calls.set(calls.get() + 1);
                f(x)
            };
            let x = newton_root(g, (a, f(a).0), (b, f(b).0), None, 1e-8, 64);
            assert!(
                (x - root).abs() <= 4.0 * f64::EPSILON * root.abs(),
                "{x} vs {root}"
            );
            assert!(calls.get() <= most, "{} evaluations", calls.get());
        }
    }

    /// Increasing functions with a known simple root r in a random bracket
    /// (a cubic with a linear term, an exponential, a root of the form
    /// (x - r) |x - r|): both solvers find r to their tolerance, and never
    /// leave the bracket.
    #[test]
    fn roots_of_random_increasing_functions() {
        let mut rng = crate::rng::XorShift(0x1405_7b7e_f767_814f);
        for case in 0..3000 {
            let a = 10.0 * (rng.unit() - 0.5);
            let b = a + 0.01 + 10.0 * rng.unit();
            let r = a + (b - a) * (0.01 + 0.98 * rng.unit());
            let (c, d) = (0.1 + 5.0 * rng.unit(), 0.01 + 2.0 * rng.unit());
            let kind = case % 3;
            let f = |x: f64| -> (f64, f64) {
                let t = x - r;
                match kind {
                    0 => (c * t * t * t + d * t, 3.0 * c * t * t + d),
                    1 => (d * (c * t).exp_m1(), d * c * (c * t).exp()),
                    _ => (c * t * t.abs() + d * t, 2.0 * c * t.abs() + d),
                }
            };
            let value = |x: f64| f(x).0;
            // Either way round.
            let (lo, hi) = if case % 2 == 0 { (a, b) } else { (b, a) };
            let x = illinois_root(value, (lo, value(lo)), (hi, value(hi)), 1e-12, 400);
            assert!((x - r).abs() <= 1e-9, "case {case}: illinois {x} vs {r}");
            let x = newton_root(f, (lo, value(lo)), (hi, value(hi)), None, 1e-10, 200);
            assert!((x - r).abs() <= 1e-9, "case {case}: newton {x} vs {r}");
            assert!(x >= a && x <= b, "case {case}: {x} left the bracket");
        }
    }
}
