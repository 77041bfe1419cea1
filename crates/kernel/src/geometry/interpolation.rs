//! Tensor-product B-spline interpolation of height fields z = f(x, y) on a
//! rectangle. Used to build the sample surfaces: polynomials up to the spline
//! degree are reproduced exactly (to rounding), smooth functions with the usual
//! O(h^(p+1)) error.
//!
//! The parametrisation is linear, x = x0 + (x1 - x0) u, y = y0 + (y1 - y0) v on
//! [0, 1]^2: the x and y control coordinates are the Greville abscissae, which
//! B-splines reproduce exactly (linear precision). Only z is interpolated, at
//! the Greville abscissae (Schoenberg-Whitney holds, so the system is regular).

use super::nurbs::{basis_functions, NurbsSurface, MAX_DEGREE};
use crate::error::{Error, Result};
use nalgebra::DMatrix;

/// Clamped uniform knot vector on [0, 1] with `spans` equal spans.
pub fn clamped_uniform_knots(degree: usize, spans: usize) -> Vec<f64> {
    let mut k = vec![0.0; degree + 1];
    k.extend((1..spans).map(|i| i as f64 / spans as f64));
    k.extend(std::iter::repeat_n(1.0, degree + 1));
    k
}

/// Greville abscissae (knot averages) of a knot vector for `degree`.
pub fn greville(degree: usize, knots: &[f64]) -> Vec<f64> {
    let count = knots.len() - degree - 1;
    (0..count)
        .map(|i| knots[i + 1..=i + degree].iter().sum::<f64>() / degree as f64)
        .collect()
}

/// Collocation matrix B[k][i] = N_i(t_k).
fn collocation(degree: usize, knots: &[f64], sites: &[f64]) -> DMatrix<f64> {
    let n = sites.len();
    let mut b = DMatrix::zeros(n, n);
    for (k, &t) in sites.iter().enumerate() {
        let (span, basis) = basis_functions(degree, knots, t);
        for j in 0..=degree {
            b[(k, span - degree + j)] = basis[j];
        }
    }
    b
}

/// Interpolates `f` over `[x0, x1] x [y0, y1]` with a B-spline of the given
/// degrees and numbers of uniform spans. u runs along x, v along y, so the
/// normal S_u x S_v points to +z.
pub fn interpolate_height_field(
    f: impl Fn(f64, f64) -> f64,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
    (degree_u, spans_u): (usize, usize),
    (degree_v, spans_v): (usize, usize),
) -> Result<NurbsSurface> {
    for (name, d, s) in [("u", degree_u, spans_u), ("v", degree_v, spans_v)] {
        if d == 0 || d > MAX_DEGREE {
            return Err(Error::invalid(
                format!("degree_{name}"),
                format!("must be in 1..={MAX_DEGREE}"),
            ));
        }
        if s == 0 {
            return Err(Error::invalid(
                format!("spans_{name}"),
                "must be at least 1",
            ));
        }
    }
    if !(x1 > x0 && y1 > y0 && [x0, x1, y0, y1].iter().all(|x| x.is_finite())) {
        return Err(Error::invalid("range", "needs finite x0 < x1 and y0 < y1"));
    }
    let ku = clamped_uniform_knots(degree_u, spans_u);
    let kv = clamped_uniform_knots(degree_v, spans_v);
    // x and y are linear in u and v: exact at the Greville abscissae, only z needs solving.
    let gu = greville(degree_u, &ku);
    let gv = greville(degree_v, &kv);
    let xs: Vec<f64> = gu.iter().map(|u| x0 + (x1 - x0) * u).collect();
    let ys: Vec<f64> = gv.iter().map(|v| y0 + (y1 - y0) * v).collect();
    let z = solve_tensor(degree_u, &ku, &gu, degree_v, &kv, &gv, |i, j| {
        f(xs[i], ys[j])
    })?;
    let cps: Vec<Vec<[f64; 3]>> = (0..xs.len())
        .map(|i| (0..ys.len()).map(|j| [xs[i], ys[j], z[(i, j)]]).collect())
        .collect();
    NurbsSurface::new(degree_u, degree_v, ku, kv, &cps, None)
}

/// Interpolates a parametric surface `f(u, v)` with a (non-rational) B-spline
/// on the given knot vectors (any valid ones, uniform or not): the result
/// agrees with `f` at the Greville abscissae, and equals `f` wherever `f` is a
/// polynomial of degree <= (degree_u, degree_v) in each span.
pub fn interpolate_surface(
    f: impl Fn(f64, f64) -> [f64; 3],
    degree_u: usize,
    knots_u: Vec<f64>,
    degree_v: usize,
    knots_v: Vec<f64>,
) -> Result<NurbsSurface> {
    // Validate the knot vectors through a throw-away surface of the right size.
    for (name, d, k) in [("u", degree_u, &knots_u), ("v", degree_v, &knots_v)] {
        if d == 0 || d > MAX_DEGREE || k.len() < 2 * d + 2 {
            return Err(Error::invalid(
                format!("knots_{name}"),
                format!("too short for degree {d}"),
            ));
        }
    }
    let (cu, cv) = (knots_u.len() - degree_u - 1, knots_v.len() - degree_v - 1);
    let probe: Vec<Vec<[f64; 3]>> = vec![vec![[0.0; 3]; cv]; cu];
    NurbsSurface::new(
        degree_u,
        degree_v,
        knots_u.clone(),
        knots_v.clone(),
        &probe,
        None,
    )?;
    let gu = greville(degree_u, &knots_u);
    let gv = greville(degree_v, &knots_v);
    let samples: Vec<Vec<[f64; 3]>> = gu
        .iter()
        .map(|&u| gv.iter().map(|&v| f(u, v)).collect())
        .collect();
    let coords = (0..3)
        .map(|c| {
            solve_tensor(degree_u, &knots_u, &gu, degree_v, &knots_v, &gv, |i, j| {
                samples[i][j][c]
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let cps: Vec<Vec<[f64; 3]>> = (0..cu)
        .map(|i| {
            (0..cv)
                .map(|j| [coords[0][(i, j)], coords[1][(i, j)], coords[2][(i, j)]])
                .collect()
        })
        .collect();
    NurbsSurface::new(degree_u, degree_v, knots_u, knots_v, &cps, None)
}

/// Control values C with sum_ij N_i(u_k) N_j(v_l) C_ij = values(k, l):
/// C = Bu^-1 F Bv^-T, solved one direction at a time.
fn solve_tensor(
    degree_u: usize,
    knots_u: &[f64],
    sites_u: &[f64],
    degree_v: usize,
    knots_v: &[f64],
    sites_v: &[f64],
    values: impl Fn(usize, usize) -> f64,
) -> Result<DMatrix<f64>> {
    let f = DMatrix::from_fn(sites_u.len(), sites_v.len(), values);
    if f.iter().any(|z| !z.is_finite()) {
        return Err(Error::invalid(
            "f",
            "the interpolated function returned a non-finite value",
        ));
    }
    let singular = || Error::invalid("knots", "collocation matrix is singular");
    let bu = collocation(degree_u, knots_u, sites_u).lu();
    let bv = collocation(degree_v, knots_v, sites_v).lu();
    let x = bu.solve(&f).ok_or_else(singular)?;
    let ct = bv.solve(&x.transpose()).ok_or_else(singular)?;
    Ok(ct.transpose())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reproduces_cubic_polynomials_exactly() {
        let f = |x: f64, y: f64| 0.3 * x * x * x - 2.0 * x * y * y + y - 4.0;
        let s = interpolate_height_field(f, (-2.0, 3.0), (1.0, 2.0), (3, 4), (3, 2)).unwrap();
        for i in 0..=13 {
            for j in 0..=11 {
                let (u, v) = (i as f64 / 13.0, j as f64 / 11.0);
                let p = s.point(u, v);
                assert!((p.x - (-2.0 + 5.0 * u)).abs() < 1e-12);
                assert!((p.y - (1.0 + v)).abs() < 1e-12);
                assert!(
                    (p.z - f(p.x, p.y)).abs() < 1e-11,
                    "{} vs {}",
                    p.z,
                    f(p.x, p.y)
                );
            }
        }
    }

    #[test]
    fn greville_of_clamped_cubic() {
        let k = clamped_uniform_knots(3, 2);
        assert_eq!(k, vec![0., 0., 0., 0., 0.5, 1., 1., 1., 1.]);
        let g = greville(3, &k);
        let want = [0.0, 1.0 / 6.0, 0.5, 5.0 / 6.0, 1.0];
        assert!(
            g.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-15),
            "{g:?}"
        );
    }
}
