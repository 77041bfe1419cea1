//! Test surfaces for the belt planners, built here independently of the
//! built-in samples: exact B-spline interpolants of analytic height fields.
#![allow(dead_code)]

use nalgebra::{DMatrix, DVector};
use toolpath_planner::geometry::NurbsSurface;

/// Clamped uniform knot vector for `n` control points of degree `p` on [0, 1].
pub fn clamped_knots(n: usize, p: usize) -> Vec<f64> {
    let inner = n - p;
    let mut k = vec![0.0; p + 1];
    for i in 1..inner {
        k.push(i as f64 / inner as f64);
    }
    k.extend(std::iter::repeat_n(1.0, p + 1));
    k
}

/// B-spline basis function N_{i,p}(t) by the Cox-de Boor recursion.
fn basis(knots: &[f64], i: usize, p: usize, t: f64) -> f64 {
    if p == 0 {
        let last = knots[knots.len() - 1];
        let inside = knots[i] <= t
            && (t < knots[i + 1] || (t == last && knots[i + 1] == last && knots[i] < last));
        return if inside { 1.0 } else { 0.0 };
    }
    let mut s = 0.0;
    let d1 = knots[i + p] - knots[i];
    if d1 > 0.0 {
        s += (t - knots[i]) / d1 * basis(knots, i, p - 1, t);
    }
    let d2 = knots[i + p + 1] - knots[i + 1];
    if d2 > 0.0 {
        s += (knots[i + p + 1] - t) / d2 * basis(knots, i + 1, p - 1, t);
    }
    s
}

/// Greville abscissae of a knot vector.
pub fn greville(knots: &[f64], n: usize, p: usize) -> Vec<f64> {
    (0..n)
        .map(|i| knots[i + 1..=i + p].iter().sum::<f64>() / p as f64)
        .collect()
}

/// Control values of the cubic interpolant of `f` at the Greville abscissae
/// of `n` clamped uniform knots on [0, 1].
pub fn interpolate(f: impl Fn(f64) -> f64, n: usize) -> Vec<f64> {
    let p = 3;
    let knots = clamped_knots(n, p);
    let g = greville(&knots, n, p);
    let a = DMatrix::from_fn(n, n, |r, c| basis(&knots, c, p, g[r]));
    let b = DVector::from_iterator(n, g.iter().map(|&t| f(t)));
    let x = a.lu().solve(&b).expect("interpolation system is regular");
    x.iter().copied().collect()
}

/// z = 5 sin(2 pi x / 100) on [0, 100]^2 (docs/methods.md, "Belt references"):
/// u along x, v along y.
pub fn sine_wave() -> NurbsSurface {
    let n = 61;
    let knots = clamped_knots(n, 3);
    let g = greville(&knots, n, 3);
    let z = interpolate(|t| 5.0 * (2.0 * std::f64::consts::PI * t).sin(), n);
    let cps: Vec<Vec<[f64; 3]>> = (0..n)
        .map(|i| vec![[100.0 * g[i], 0.0, z[i]], [100.0 * g[i], 100.0, z[i]]])
        .collect();
    NurbsSurface::new(3, 1, knots, vec![0.0, 0.0, 1.0, 1.0], &cps, None).expect("valid sine wave")
}

/// Egg crate z = a cos(2 pi x / period) cos(2 pi y / period) on [0, size]^2.
pub fn egg_crate(a: f64, period: f64, size: f64) -> NurbsSurface {
    let n = 41;
    let knots = clamped_knots(n, 3);
    let g = greville(&knots, n, 3);
    let c = interpolate(
        |t| (2.0 * std::f64::consts::PI * t * size / period).cos(),
        n,
    );
    let cps: Vec<Vec<[f64; 3]>> = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| [size * g[i], size * g[j], a * c[i] * c[j]])
                .collect()
        })
        .collect();
    NurbsSurface::new(3, 3, knots.clone(), knots, &cps, None).expect("valid egg crate")
}

/// A developable blade (a general cone): the cubic root section `root` at
/// y = 0 ruled towards `apex`, the tip section being the root scaled by
/// `taper` towards the apex.
pub fn cone_blade(root: [[f64; 3]; 4], apex: [f64; 3], taper: f64) -> NurbsSurface {
    let cps: Vec<Vec<[f64; 3]>> = root
        .iter()
        .map(|p| {
            let tip = std::array::from_fn(|k| apex[k] + taper * (p[k] - apex[k]));
            vec![*p, tip]
        })
        .collect();
    NurbsSurface::new(
        3,
        1,
        clamped_knots(4, 3),
        vec![0.0, 0.0, 1.0, 1.0],
        &cps,
        None,
    )
    .expect("valid blade")
}

/// A flatter blade than the built-in turbine_blade (chord 100 -> 70 mm over
/// 120 mm, camber 12 mm).
pub fn flat_blade() -> NurbsSurface {
    cone_blade(
        [
            [0.0, 0.0, 0.0],
            [30.0, 0.0, 12.0],
            [70.0, 0.0, 10.0],
            [100.0, 0.0, 0.0],
        ],
        [50.0, 400.0, 0.0],
        0.7,
    )
}

/// Flat 100 x 100 square at z = 0.
pub fn flat() -> NurbsSurface {
    let cps = vec![
        vec![[0.0, 0.0, 0.0], [0.0, 100.0, 0.0]],
        vec![[100.0, 0.0, 0.0], [100.0, 100.0, 0.0]],
    ];
    NurbsSurface::new(
        1,
        1,
        vec![0.0, 0.0, 1.0, 1.0],
        vec![0.0, 0.0, 1.0, 1.0],
        &cps,
        None,
    )
    .expect("valid plane")
}
