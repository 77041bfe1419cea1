//! Surfaces of the high degrees CAD writes (10 to `MAX_DEGREE`), rational
//! or not, on one span or several: their points against de Boor's
//! algorithm on the homogeneous control net (which shares nothing with the
//! evaluator's basis functions), their first and second derivatives
//! against central differences of those points.

use nalgebra::Vector3;
use toolpath_kernel::geometry::nurbs::MAX_DEGREE;
use toolpath_kernel::geometry::NurbsSurface;

/// xorshift64* ([`toolpath_kernel::rng::XorShiftStar`]): a fixed, seeded sequence.
struct Rng(u64);
impl Rng {
    /// The next number in [0, 1).
    fn next(&mut self) -> f64 {
        let mut g = toolpath_kernel::rng::XorShiftStar(self.0);
        let x = g.unit();
        self.0 = g.0;
        x
    }
    fn below(&mut self, n: usize) -> usize {
        ((self.next() * n as f64) as usize).min(n - 1)
    }
}

/// Point of a rational tensor B-spline by de Boor's algorithm on the
/// homogeneous points (along v on each row of the span, then along u):
/// an evaluation that shares nothing with A2.3's basis functions.
fn de_boor_point(s: &NurbsSurface, u: f64, v: f64) -> [f64; 3] {
    fn de_boor(p: usize, knots: &[f64], pts: &[[f64; 4]], t: f64) -> [f64; 4] {
        let n = pts.len();
        let mut k = p;
        while k + 1 < n && knots[k + 1] <= t {
            k += 1;
        }
        let mut d: Vec<[f64; 4]> = (0..=p).map(|j| pts[j + k - p]).collect();
        for r in 1..=p {
            for j in (r..=p).rev() {
                let i = j + k - p;
                let a = (t - knots[i]) / (knots[i + p + 1 - r] - knots[i]);
                let prev = d[j - 1];
                for (c, x) in d[j].iter_mut().enumerate() {
                    *x = (1.0 - a) * prev[c] + a * *x;
                }
            }
        }
        d[p]
    }
    let homogeneous = |i: usize, j: usize| {
        let (p, w) = (s.control_point(i, j), s.weight(i, j));
        [p[0] * w, p[1] * w, p[2] * w, w]
    };
    let rows: Vec<[f64; 4]> = (0..s.count_u())
        .map(|i| {
            let row: Vec<[f64; 4]> = (0..s.count_v()).map(|j| homogeneous(i, j)).collect();
            de_boor(s.degree_v(), s.knots_v(), &row, v)
        })
        .collect();
    let h = de_boor(s.degree_u(), s.knots_u(), &rows, u);
    [h[0] / h[3], h[1] / h[3], h[2] / h[3]]
}

#[test]
fn high_degree_surfaces_agree_with_de_boor_and_finite_differences() {
    let mut rng = Rng(0x5eed_0fde_6202_5a17);
    let mut tested = [false; MAX_DEGREE + 1];
    for case in 0..48 {
        // Every degree from 10 to MAX_DEGREE in u, the other direction
        // low or high; a third of the cases on a single span (Bezier).
        let pu = 10 + case % (MAX_DEGREE - 9);
        let pv = [1, 3, 7, 12, MAX_DEGREE][case % 5];
        tested[pu] = true;
        let spans = |rng: &mut Rng| if case % 3 == 0 { 0 } else { 1 + rng.below(3) };
        let (cu, cv) = (pu + 1 + spans(&mut rng), pv + 1 + spans(&mut rng));
        // Clamped, simple interior knots (the surface is C^(p-1), smooth
        // under the difference stencils), spans within 10 x of each other.
        let knots = |rng: &mut Rng, p: usize, count: usize| {
            let (a, len) = (100.0 * rng.next() - 50.0, 0.5 + 50.0 * rng.next());
            let mut t: Vec<f64> = vec![0.0];
            for _ in 0..count - p {
                t.push(t.last().unwrap() + 1.0 + 9.0 * rng.next());
            }
            let end = *t.last().unwrap();
            let mut k = vec![a; p];
            k.extend(t.iter().map(|x| a + len * x / end));
            let last = *k.last().unwrap();
            k.extend(std::iter::repeat_n(last, p));
            k
        };
        let ku = knots(&mut rng, pu, cu);
        let kv = knots(&mut rng, pv, cv);
        let cps: Vec<Vec<[f64; 3]>> = (0..cu)
            .map(|i| {
                (0..cv)
                    .map(|j| {
                        [
                            5.0 * i as f64 + rng.next(),
                            5.0 * j as f64 + rng.next(),
                            20.0 * rng.next(),
                        ]
                    })
                    .collect()
            })
            .collect();
        let w: Vec<Vec<f64>> = (0..cu)
            .map(|_| (0..cv).map(|_| 0.5 + rng.next()).collect())
            .collect();
        let s = NurbsSurface::new(
            pu,
            pv,
            ku,
            kv,
            &cps,
            (case % 2 == 0).then_some(w.as_slice()),
        )
        .unwrap();
        let ((u0, u1), (v0, v1)) = s.domain();
        for _ in 0..20 {
            let (u, v) = (
                u0 + (u1 - u0) * (0.05 + 0.9 * rng.next()),
                v0 + (v1 - v0) * (0.05 + 0.9 * rng.next()),
            );
            let d = s.derivs(u, v);
            let p = de_boor_point(&s, u, v);
            let err = (d.p.coords - Vector3::from(p)).norm();
            assert!(
                err <= 1e-9,
                "case {case} ({pu}, {pv}) at ({u}, {v}): point off by {err}"
            );
            // Central differences of the de Boor points, O(h^2); the
            // step's share of the domain balances truncation against
            // rounding (1e-16 / h^2 in the second derivatives).
            let (hu, hv) = (1e-4 * (u1 - u0), 1e-4 * (v1 - v0));
            let at = |du: f64, dv: f64| Vector3::from(de_boor_point(&s, u + du, v + dv));
            let c = at(0.0, 0.0);
            let fd = [
                (d.su, (at(hu, 0.0) - at(-hu, 0.0)) / (2.0 * hu), hu),
                (d.sv, (at(0.0, hv) - at(0.0, -hv)) / (2.0 * hv), hv),
                (
                    d.suu,
                    (at(hu, 0.0) - c * 2.0 + at(-hu, 0.0)) / (hu * hu),
                    hu,
                ),
                (
                    d.svv,
                    (at(0.0, hv) - c * 2.0 + at(0.0, -hv)) / (hv * hv),
                    hv,
                ),
                (
                    d.suv,
                    (at(hu, hv) - at(hu, -hv) - at(-hu, hv) + at(-hu, -hv)) / (4.0 * hu * hv),
                    hu.min(hv),
                ),
            ];
            for (k, (got, want, _)) in fd.iter().enumerate() {
                let err = (got - want).norm() / want.norm().max(1.0);
                assert!(
                    err <= 1e-3,
                    "case {case} ({pu}, {pv}) at ({u}, {v}) derivative {k}: {got:?} vs {want:?}"
                );
            }
        }
    }
    assert!(tested[10..].iter().all(|&t| t), "a degree was never tested");
}
