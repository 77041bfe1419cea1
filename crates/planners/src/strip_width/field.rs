//! The strip-width tensor field (docs/methods.md, "The strip-width tensor and
//! its degenerate points"): H = 1/2 (K_b G - D), the optimal feed from the
//! generalised eigenproblem H t = mu G t, and its deviator, whose zeros are the
//! degenerate points.

use nalgebra::{Matrix2, Vector2, Vector3};
use toolpath_kernel::geometry::LocalGeometry;

/// The strip-width tensor H = 1/2 (K_b G - D) in parameter coordinates.
pub(crate) fn tensor_h(g: &LocalGeometry, k_b: f64) -> Matrix2<f64> {
    (g.forms.first * k_b - g.forms.second) * 0.5
}

/// Lower Cholesky factor inverse of G: L^-1 with G = L L^T.
fn cholesky_inverse(g: &Matrix2<f64>) -> Option<Matrix2<f64>> {
    let l11 = g[(0, 0)].sqrt();
    let l21 = g[(0, 1)] / l11;
    let l22 = (g[(1, 1)] - l21 * l21).max(0.0).sqrt();
    if l11.is_nan() || l22.is_nan() || l11 <= 0.0 || l22 <= 0.0 {
        return None;
    }
    Some(Matrix2::new(1.0 / l11, 0.0, -l21 / (l11 * l22), 1.0 / l22))
}

/// The field at one point.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FieldSample {
    /// Optimal feed (largest mu) in parameter space, scaled to a unit 3-D tangent.
    pub feed_uv: Vector2<f64>,
    /// Unit 3-D feed.
    pub feed: Vector3<f64>,
    /// Generalised eigenvalues, mu_feed >= mu_cross.
    pub mu_feed: f64,
    pub mu_cross: f64,
}

/// Optimal feed from the generalised eigenproblem H t = mu G t, solved as the
/// right eigenvector of G^-1 H (a vector, not the covector G t). `None` where
/// the two eigenvalues coincide (a degenerate point: every direction is optimal).
pub(crate) fn feed_at(g: &LocalGeometry, k_b: f64) -> Option<FieldSample> {
    let gi = g.forms.first.try_inverse()?;
    let m = gi * tensor_h(g, k_b);
    let (a, b, c, d) = (m[(0, 0)], m[(0, 1)], m[(1, 0)], m[(1, 1)]);
    let mean = 0.5 * (a + d);
    // G^-1 H is self-adjoint in the G inner product: its eigenvalues are real.
    let disc = (0.25 * (a - d) * (a - d) + b * c).max(0.0).sqrt();
    let scale = a.abs().max(b.abs()).max(c.abs()).max(d.abs()).max(1e-300);
    if disc <= 1e-12 * scale {
        return None;
    }
    let mu = mean + disc;
    // (M - mu I) t = 0: two candidate null vectors; take the better conditioned.
    let t1 = Vector2::new(b, mu - a);
    let t2 = Vector2::new(mu - d, c);
    let t = if t1.norm_squared() >= t2.norm_squared() {
        t1
    } else {
        t2
    };
    let t3 = g.uv_to_tangent(t);
    let len = t3.norm();
    if len.is_nan() || len <= 0.0 {
        return None;
    }
    let feed = t3 / len;
    Some(FieldSample {
        feed_uv: t / len,
        feed,
        mu_feed: mu,
        mu_cross: mean - disc,
    })
}

/// Deviator of the field in the orthonormal Cholesky frame of the tangent
/// plane: S = L^-1 H L^-T, e = (S11 - S22)/2, f = S12. Degenerate points are
/// where e = f = 0 (T = mu I), independent of K_b. The major eigenvector of S
/// (the feed) is at angle atan2(f, e)/2 in that frame; a frame vector y maps
/// to the parameter-space direction L^-T y.
pub(crate) fn deviator(g: &LocalGeometry) -> Option<(f64, f64, Matrix2<f64>)> {
    let li = cholesky_inverse(&g.forms.first)?;
    // K_b only shifts S by a multiple of I, so it does not enter e and f.
    let s = li * tensor_h(g, 0.0) * li.transpose();
    Some((
        0.5 * (s[(0, 0)] - s[(1, 1)]),
        0.5 * (s[(0, 1)] + s[(1, 0)]),
        li,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use toolpath_kernel::tools::LeadCutter;

    fn flat() -> LeadCutter {
        LeadCutter {
            radius: 2.5,
            lead: 5f64.to_radians(),
            ball: false,
        }
    }

    /// Feed = minimum normal curvature direction, found by brute force over
    /// 3-D tangent directions from the closed-form paraboloid, on a sheared
    /// (non-orthogonal) parametrisation where the covector mix-up shows.
    #[test]
    fn feed_is_the_min_curvature_direction_on_a_sheared_parametrisation() {
        let (a, b) = (0.002, 0.008);
        let s = crate::test_surfaces::sheared_paraboloid(a, b);
        let k_b = flat().k_b();
        let mut worst_trap = 0.0f64;
        for &(u, v) in &[(0.3, 0.4), (0.7, 0.2), (0.5, 0.5), (0.15, 0.85)] {
            let g = LocalGeometry::at(&s, u, v).unwrap();
            let p = g.point();
            let grad = Vector3::new(-2.0 * a * p.x, -2.0 * b * p.y, 1.0);
            let n = grad.normalize();
            let e1 = Vector3::new(1.0, 0.0, 0.0).cross(&n).cross(&n).normalize();
            let e2 = n.cross(&e1);
            let kappa = |t: Vector3<f64>| (2.0 * a * t.x * t.x + 2.0 * b * t.y * t.y) / grad.norm();
            let mut best = (f64::INFINITY, Vector3::zeros());
            for i in 0..18000 {
                let th = std::f64::consts::PI * i as f64 / 18000.0;
                let t = e1 * th.cos() + e2 * th.sin();
                if kappa(t) < best.0 {
                    best = (kappa(t), t);
                }
            }
            let f = feed_at(&g, k_b).unwrap();
            let angle = f.feed.dot(&best.1).abs().min(1.0).acos().to_degrees();
            assert!(angle < 0.05, "feed off by {angle} deg at ({u}, {v})");
            // mu_feed = 1/2 (K_b - kappa_min).
            assert!((f.mu_feed - 0.5 * (k_b - best.0)).abs() < 1e-9);
            // The deviator's major direction is the same line.
            let (e, ff, li) = deviator(&g).unwrap();
            let psi = 0.5 * ff.atan2(e);
            let t_uv = li.transpose() * Vector2::new(psi.cos(), psi.sin());
            let t3 = g.uv_to_tangent(t_uv).normalize();
            assert!(t3.dot(&best.1).abs() > (0.05f64).to_radians().cos());
            // The trap: a right eigenvector of H G^-1 used as a direction.
            let m = tensor_h(&g, k_b) * g.forms.first.try_inverse().unwrap();
            let (ma, mb, mc, md) = (m[(0, 0)], m[(0, 1)], m[(1, 0)], m[(1, 1)]);
            let mu = 0.5 * (ma + md) + (0.25 * (ma - md).powi(2) + mb * mc).sqrt();
            let wrong = g.uv_to_tangent(Vector2::new(mb, mu - ma)).normalize();
            worst_trap = worst_trap.max(wrong.dot(&best.1).abs().min(1.0).acos().to_degrees());
        }
        assert!(
            worst_trap > 1.0,
            "the sheared test surface must expose the covector trap ({worst_trap} deg)"
        );
    }
}
