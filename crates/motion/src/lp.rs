//! The stage problem of reachability analysis: a linear program in two
//! variables, x = s_dot^2 and u = s_ddot, over a handful of half-planes.
//!
//! Eliminating u (Fourier-Motzkin) is exact here: u is feasible for x iff
//! every lower bound on u lies below every upper bound, and each such pair is
//! one half-line in x. With m rows that costs at most (m/2)^2 pairs, which for
//! a few joints is less work than a randomised (Seidel) solver's set-up, and
//! it has no random order: the same input gives the same bits.

/// The half-plane a x + b u <= c.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Row {
    pub a: f64,
    pub b: f64,
    pub c: f64,
}

/// Relative slack on the pair inequalities: rounding in the products must not
/// turn the always-feasible x = 0 infeasible.
const SLACK: f64 = 1e-12;

/// The interval of x in [lo, hi] for which some u meets every row, or `None`
/// when it is empty.
pub fn x_interval(rows: &[Row], lo: f64, hi: f64) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (lo, hi);
    let mut bound = |k: f64, r: f64| {
        // k x <= r
        let tol = SLACK * r.abs().max(1.0);
        if k > 0.0 {
            hi = hi.min((r + tol) / k);
        } else if k < 0.0 {
            lo = lo.max((r + tol) / k);
        } else if r < -tol {
            hi = f64::NEG_INFINITY;
        }
    };
    let mut upper = [Row {
        a: 0.0,
        b: 0.0,
        c: 0.0,
    }; 64];
    let mut n_upper = 0;
    for r in rows.iter().filter(|r| r.b > 0.0) {
        if n_upper == upper.len() {
            break;
        }
        upper[n_upper] = *r;
        n_upper += 1;
    }
    for p in rows {
        if p.b == 0.0 {
            bound(p.a, p.c);
            continue;
        }
        if p.b > 0.0 {
            continue;
        }
        // p is a lower bound on u (b < 0); pair it with every upper bound.
        for m in &upper[..n_upper] {
            // (c_p - a_p x) / b_p <= (c_m - a_m x) / b_m, times b_m (-b_p) > 0.
            bound(m.b * p.a - p.b * m.a, m.b * p.c - p.b * m.c);
        }
    }
    (lo <= hi).then_some((lo, hi))
}

/// The bounds on u that the rows with b != 0 give at fixed `x`: the interval
/// of feasible u when lower <= upper (rows with b = 0 do not involve u).
pub fn u_range(rows: &[Row], x: f64) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    for r in rows {
        let rhs = r.c - r.a * x;
        if r.b > 0.0 {
            hi = hi.min(rhs / r.b);
        } else if r.b < 0.0 {
            lo = lo.max(rhs / r.b);
        }
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Independent: an LP optimum lies on a vertex, so enumerate every
    /// intersection of two boundary lines (rows and the box x = lo, x = hi),
    /// keep the feasible ones, and take their smallest and largest x.
    fn vertices(rows: &[Row], lo: f64, hi: f64) -> Option<(f64, f64)> {
        let mut lines: Vec<Row> = rows.to_vec();
        lines.push(Row {
            a: 1.0,
            b: 0.0,
            c: hi,
        });
        lines.push(Row {
            a: -1.0,
            b: 0.0,
            c: -lo,
        });
        let feasible = |x: f64, u: f64| {
            x >= lo - 1e-9 && x <= hi + 1e-9 && rows.iter().all(|r| r.a * x + r.b * u <= r.c + 1e-9)
        };
        let (mut xl, mut xh) = (f64::INFINITY, f64::NEG_INFINITY);
        for (i, p) in lines.iter().enumerate() {
            for q in &lines[i + 1..] {
                let det = p.a * q.b - p.b * q.a;
                if det.abs() < 1e-12 {
                    continue;
                }
                let x = (p.c * q.b - p.b * q.c) / det;
                let u = (p.a * q.c - p.c * q.a) / det;
                if feasible(x, u) {
                    xl = xl.min(x);
                    xh = xh.max(x);
                }
            }
        }
        (xl <= xh).then_some((xl, xh))
    }

    #[test]
    fn feasible_x_matches_a_grid_search_on_random_rows() {
        // A small LCG: deterministic rows without a dependency.
        let mut seed = 12345u64;
        let mut rnd = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        let mut checked = 0;
        for _ in 0..60 {
            let mut rows = Vec::new();
            for _ in 0..4 {
                let (a, b) = (rnd() * 3.0, rnd() * 2.0);
                let c = 1.0 + rnd().abs() * 4.0;
                rows.push(Row { a, b, c });
                rows.push(Row { a: -a, b: -b, c });
            }
            let got = x_interval(&rows, 0.0, 10.0);
            let want = vertices(&rows, 0.0, 10.0);
            match (got, want) {
                (Some(g), Some(w)) => {
                    assert!(
                        (g.0 - w.0).abs() < 1e-9 && (g.1 - w.1).abs() < 1e-9,
                        "{g:?} {w:?}"
                    );
                    checked += 1;
                }
                (None, None) => {}
                other => panic!("{other:?} for {rows:?}"),
            }
        }
        assert!(checked > 40);
    }

    #[test]
    fn u_range_of_a_box() {
        let rows = [
            Row {
                a: 1.0,
                b: 1.0,
                c: 3.0,
            },
            Row {
                a: 0.0,
                b: -1.0,
                c: 1.0,
            },
        ];
        assert_eq!(u_range(&rows, 1.0), (-1.0, 2.0));
        assert_eq!(u_range(&rows, 5.0), (-1.0, -2.0));
    }
}
