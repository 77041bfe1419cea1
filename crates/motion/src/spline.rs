//! Natural cubic spline through vector-valued knots: C2 in the path
//! parameter, zero second derivative at both ends.
//!
//! Natural ends make the path straight where it starts and stops (a plunge
//! runs into its stop along its chord), and unlike not-a-knot ends they never
//! extrapolate the curvature of the end intervals. The same boundary
//! condition is what a peer (scipy's `CubicSpline(bc_type="natural")`)
//! builds, so both time the very same geometric path.

/// A spline of `dim` components through `knots.len()` knots.
#[derive(Clone, Debug, PartialEq)]
pub struct Spline {
    knots: Vec<f64>,
    dim: usize,
    /// Values at the knots, knot-major (`values[k * dim + j]`).
    values: Vec<f64>,
    /// Second derivatives at the knots, same layout.
    second: Vec<f64>,
}

/// Value and first three derivatives of one component at one parameter.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Jet {
    pub value: f64,
    pub d1: f64,
    pub d2: f64,
    pub d3: f64,
}

impl Spline {
    /// Interpolates `values` (one row of `dim` per knot) at strictly
    /// increasing `knots` (checked by the caller). Two knots give a line.
    pub fn new(knots: &[f64], values: &[Vec<f64>]) -> Self {
        let n = knots.len();
        let dim = values.first().map_or(0, |r| r.len());
        let flat: Vec<f64> = values.iter().flat_map(|r| r.iter().copied()).collect();
        let mut second = vec![0.0; n * dim];
        if n > 2 {
            solve_natural(knots, &flat, dim, &mut second);
        }
        Spline {
            knots: knots.to_vec(),
            dim,
            values: flat,
            second,
        }
    }

    pub fn dim(&self) -> usize {
        self.dim
    }

    pub fn knots(&self) -> &[f64] {
        &self.knots
    }

    /// Index of the interval [knots[k], knots[k + 1]] holding `s` (clamped).
    pub fn interval(&self, s: f64) -> usize {
        let n = self.knots.len();
        if n < 2 {
            return 0;
        }
        let k = self.knots.partition_point(|&x| x <= s);
        k.clamp(1, n - 1) - 1
    }

    /// Component `j` and its derivatives at `s` in interval `k`.
    pub fn jet_in(&self, k: usize, j: usize, s: f64) -> Jet {
        let d = self.dim;
        let (s0, s1) = (self.knots[k], self.knots[k + 1]);
        let h = s1 - s0;
        let (y0, y1) = (self.values[k * d + j], self.values[(k + 1) * d + j]);
        let (m0, m1) = (self.second[k * d + j], self.second[(k + 1) * d + j]);
        let a = s1 - s;
        let b = s - s0;
        let value = (m0 * a * a * a + m1 * b * b * b) / (6.0 * h)
            + (y0 / h - m0 * h / 6.0) * a
            + (y1 / h - m1 * h / 6.0) * b;
        let d1 = (-m0 * a * a + m1 * b * b) / (2.0 * h) + (y1 - y0) / h - (m1 - m0) * h / 6.0;
        let d2 = (m0 * a + m1 * b) / h;
        let d3 = (m1 - m0) / h;
        Jet { value, d1, d2, d3 }
    }

    /// All components at `s`: values, first, second and third derivatives.
    pub fn eval(&self, s: f64, out: &mut [Jet]) {
        let k = self.interval(s);
        for (j, o) in out.iter_mut().enumerate().take(self.dim) {
            *o = self.jet_in(k, j, s);
        }
    }

    /// The values of all components at `s`.
    pub fn values_at(&self, s: f64) -> Vec<f64> {
        let k = self.interval(s);
        (0..self.dim).map(|j| self.jet_in(k, j, s).value).collect()
    }
}

/// Second derivatives of the natural spline: the tridiagonal system
/// h[k-1] M[k-1] + 2 (h[k-1] + h[k]) M[k] + h[k] M[k+1] = 6 (slope[k] - slope[k-1])
/// for the inner knots, M = 0 at the ends (Thomas algorithm, one
/// factorisation for all components).
fn solve_natural(knots: &[f64], y: &[f64], dim: usize, m: &mut [f64]) {
    let n = knots.len();
    let inner = n - 2;
    let h: Vec<f64> = knots.windows(2).map(|w| w[1] - w[0]).collect();
    // Forward elimination of the (shared) matrix.
    let mut diag = vec![0.0; inner];
    let mut upper = vec![0.0; inner];
    for i in 0..inner {
        let (hl, hr) = (h[i], h[i + 1]);
        let mut dgi = 2.0 * (hl + hr);
        if i > 0 {
            dgi -= hl * upper[i - 1];
        }
        diag[i] = dgi;
        upper[i] = hr / dgi;
    }
    let mut rhs = vec![0.0; inner];
    for j in 0..dim {
        let yy = |k: usize| y[k * dim + j];
        for i in 0..inner {
            let k = i + 1;
            let r = 6.0 * ((yy(k + 1) - yy(k)) / h[k] - (yy(k) - yy(k - 1)) / h[k - 1]);
            rhs[i] = if i > 0 {
                (r - h[i] * rhs[i - 1]) / diag[i]
            } else {
                r / diag[i]
            };
        }
        for i in (0..inner).rev() {
            let next = if i + 1 < inner {
                m[(i + 2) * dim + j]
            } else {
                0.0
            };
            m[(i + 1) * dim + j] = rhs[i] - upper[i] * next;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reproduces_a_line_exactly_on_uneven_knots() {
        let knots = [0.0, 0.3, 1.0, 1.1, 2.5];
        let vals: Vec<Vec<f64>> = knots.iter().map(|&s| vec![2.0 * s - 1.0, 5.0]).collect();
        let sp = Spline::new(&knots, &vals);
        for i in 0..=50 {
            let s = 2.5 * i as f64 / 50.0;
            let k = sp.interval(s);
            let a = sp.jet_in(k, 0, s);
            assert!((a.value - (2.0 * s - 1.0)).abs() < 1e-12);
            assert!((a.d1 - 2.0).abs() < 1e-12 && a.d2.abs() < 1e-12);
            assert!(sp.jet_in(k, 1, s).d1.abs() < 1e-12);
        }
    }

    /// The natural spline of sin on [0, pi] (zero curvature at both ends, as
    /// sin has) converges at fourth order: checked against sin itself, and
    /// C2 continuity checked across every knot.
    #[test]
    fn interpolates_sine_to_fourth_order_and_is_c2() {
        let err = |n: usize| {
            let knots: Vec<f64> = (0..n)
                .map(|k| std::f64::consts::PI * k as f64 / (n - 1) as f64)
                .collect();
            let vals: Vec<Vec<f64>> = knots.iter().map(|s| vec![s.sin()]).collect();
            let sp = Spline::new(&knots, &vals);
            for (k, &s) in knots.iter().enumerate().take(n - 1).skip(1) {
                let l = sp.jet_in(k - 1, 0, s);
                let r = sp.jet_in(k, 0, s);
                assert!((l.value - r.value).abs() < 1e-12);
                assert!((l.d1 - r.d1).abs() < 1e-12);
                assert!((l.d2 - r.d2).abs() < 1e-10);
            }
            (0..1000)
                .map(|i| {
                    let s = std::f64::consts::PI * (i as f64 + 0.5) / 1000.0;
                    (sp.values_at(s)[0] - s.sin()).abs()
                })
                .fold(0.0, f64::max)
        };
        let (e1, e2) = (err(11), err(21));
        assert!(e1 < 1e-4, "{e1}");
        assert!(e1 / e2 > 12.0, "order: {e1} / {e2}");
    }
}
