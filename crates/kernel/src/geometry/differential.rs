//! Differential geometry of a surface point: first and second fundamental
//! forms, principal curvatures and directions, umbilics.
//!
//! Convention (docs/methods.md, "Conventions"): n = normalize(S_u x S_v) points
//! to the tool side and the normal curvature kappa(t) = S_tt . n is positive
//! where the surface is concave towards the tool.

use super::nurbs::{NurbsSurface, SurfaceDerivs};
use nalgebra::{Matrix2, Point3, Vector2, Vector3};

/// Everything the planners need about the surface at one (u, v).
#[derive(Clone, Copy, Debug)]
pub struct LocalGeometry {
    /// The point, its derivatives, the unit normal and both fundamental forms.
    pub forms: FundamentalForms,
    /// Principal curvatures, `k_min <= k_max`.
    pub k_min: f64,
    pub k_max: f64,
    /// Principal directions as unit 3-D tangents (undefined at umbilics: any tangent).
    pub dir_min: Vector3<f64>,
    pub dir_max: Vector3<f64>,
    /// The same directions in parameter space (not normalised in uv; they map to unit tangents).
    pub dir_min_uv: Vector2<f64>,
    pub dir_max_uv: Vector2<f64>,
}

/// The unit normal and both fundamental forms at one (u, v), without the
/// principal curvatures: what a pass contact needs (the normal, curvatures
/// along given directions, 3-D tangents mapped to (u, v)). [`LocalGeometry`]
/// holds one, so it is `None` exactly where `LocalGeometry::at` is.
#[derive(Clone, Copy, Debug)]
pub struct FundamentalForms {
    pub uv: Vector2<f64>,
    pub derivs: SurfaceDerivs,
    /// Unit normal, normalize(S_u x S_v).
    pub n: Vector3<f64>,
    /// First fundamental form [[E, F], [F, G]].
    pub first: Matrix2<f64>,
    /// Second fundamental form [[L, M], [M, N]] with respect to `n`.
    pub second: Matrix2<f64>,
}

impl FundamentalForms {
    /// Returns `None` where the parametrisation is singular (S_u x S_v = 0).
    pub fn at(surface: &NurbsSurface, u: f64, v: f64) -> Option<Self> {
        let (u, v) = surface.clamp_uv(u, v);
        Self::from_derivs(Vector2::new(u, v), surface.derivs(u, v))
    }

    pub fn from_derivs(uv: Vector2<f64>, d: SurfaceDerivs) -> Option<Self> {
        Self::with_cholesky(uv, d).map(|(forms, _)| forms)
    }

    /// The forms and the Cholesky factor G = C C^T as (c11, c21, c22), all
    /// > 0 on the diagonal (else `None`: a singular parametrisation).
    #[inline(always)]
    fn with_cholesky(uv: Vector2<f64>, d: SurfaceDerivs) -> Option<(Self, [f64; 3])> {
        let cross = d.su.cross(&d.sv);
        let len = cross.norm();
        let scale = d.su.norm() * d.sv.norm();
        if !len.is_finite() || len <= 1e-12 * scale || scale.is_nan() {
            return None;
        }
        let n = cross / len;
        let e = d.su.dot(&d.su);
        let f = d.su.dot(&d.sv);
        let g = d.sv.dot(&d.sv);
        let l = d.suu.dot(&n);
        let m = d.suv.dot(&n);
        let nn = d.svv.dot(&n);
        let first = Matrix2::new(e, f, f, g);
        let second = Matrix2::new(l, m, m, nn);
        let c11 = e.sqrt();
        let c21 = f / c11;
        // C's last diagonal entry sqrt(G - c21^2) must be > 0.
        let rest = g - c21 * c21;
        if rest.is_nan() || rest <= 0.0 {
            return None;
        }
        let c22 = rest.sqrt();
        let forms = Self {
            uv,
            derivs: d,
            n,
            first,
            second,
        };
        Some((forms, [c11, c21, c22]))
    }

    pub fn point(&self) -> Point3<f64> {
        self.derivs.p
    }

    /// [`LocalGeometry::tangent_to_uv`].
    pub fn tangent_to_uv(&self, t: Vector3<f64>) -> Vector2<f64> {
        tangent_to_uv(&self.derivs.su, &self.derivs.sv, &self.first, t)
    }
}

impl LocalGeometry {
    /// Returns `None` where the parametrisation is singular (S_u x S_v = 0).
    pub fn at(surface: &NurbsSurface, u: f64, v: f64) -> Option<Self> {
        let (u, v) = surface.clamp_uv(u, v);
        Self::from_derivs(Vector2::new(u, v), surface.derivs(u, v))
    }

    pub fn from_derivs(uv: Vector2<f64>, d: SurfaceDerivs) -> Option<Self> {
        let (forms, [c11, c21, c22]) = FundamentalForms::with_cholesky(uv, d)?;
        // Symmetric reduction with G = C C^T (Cholesky): S = C^-1 D C^-T has the
        // principal curvatures as eigenvalues; t = C^-T y maps eigenvectors back
        // (docs/methods.md, "Principal curvatures").
        // C^-1 = [[1/c11, 0], [-c21/(c11 c22), 1/c22]]
        let ci = Matrix2::new(1.0 / c11, 0.0, -c21 / (c11 * c22), 1.0 / c22);
        let s = ci * forms.second * ci.transpose();
        let (k_min, k_max, y_min, y_max) = sym_eigen2(s);
        let cit = ci.transpose();
        let dir_min_uv = cit * y_min;
        let dir_max_uv = cit * y_max;
        let dir_min = (d.su * dir_min_uv.x + d.sv * dir_min_uv.y).normalize();
        let dir_max = (d.su * dir_max_uv.x + d.sv * dir_max_uv.y).normalize();
        Some(Self {
            forms,
            k_min,
            k_max,
            dir_min,
            dir_max,
            dir_min_uv,
            dir_max_uv,
        })
    }

    pub fn point(&self) -> Point3<f64> {
        self.forms.point()
    }
    pub fn mean_curvature(&self) -> f64 {
        0.5 * (self.k_min + self.k_max)
    }
    pub fn gaussian_curvature(&self) -> f64 {
        self.k_min * self.k_max
    }
    /// Normal curvature in the direction of the parameter-space vector `t`.
    pub fn normal_curvature_uv(&self, t: Vector2<f64>) -> f64 {
        let f = &self.forms;
        (t.transpose() * f.second * t)[0] / (t.transpose() * f.first * t)[0]
    }
    /// Normal curvature in the direction of a 3-D tangent (projected onto the tangent plane).
    pub fn normal_curvature(&self, t: Vector3<f64>) -> f64 {
        self.normal_curvature_uv(self.tangent_to_uv(t))
    }
    /// Maps a 3-D vector to the parameter-space direction of its tangent-plane projection.
    pub fn tangent_to_uv(&self, t: Vector3<f64>) -> Vector2<f64> {
        self.forms.tangent_to_uv(t)
    }
    /// Maps a parameter-space direction to its 3-D tangent vector.
    pub fn uv_to_tangent(&self, t: Vector2<f64>) -> Vector3<f64> {
        let d = &self.forms.derivs;
        d.su * t.x + d.sv * t.y
    }
    /// Umbilic test: |k_max - k_min| below `tol` (absolute, 1/mm).
    pub fn is_umbilic(&self, tol: f64) -> bool {
        (self.k_max - self.k_min).abs() <= tol
    }
    /// Area element sqrt(EG - F^2).
    pub fn area_element(&self) -> f64 {
        self.forms.first.determinant().max(0.0).sqrt()
    }
}

/// The tangent plane at one (u, v) from first derivatives only: what a walk
/// on the surface needs (the normal, and 3-D tangents mapped to (u, v)).
/// Its fields are the bits [`LocalGeometry`] holds for them, and it is `None`
/// exactly where `LocalGeometry::at` is: the first derivatives of the
/// evaluation are the same whatever its order.
#[derive(Clone, Copy, Debug)]
pub struct TangentFrame {
    pub su: Vector3<f64>,
    pub sv: Vector3<f64>,
    /// Unit normal, normalize(S_u x S_v).
    pub n: Vector3<f64>,
    /// First fundamental form [[E, F], [F, G]].
    pub first: Matrix2<f64>,
}

impl TangentFrame {
    pub fn at(surface: &NurbsSurface, u: f64, v: f64) -> Option<Self> {
        // The evaluation clamps (u, v) into the domain itself.
        let d = surface.first_derivs(u, v);
        // The singularity tests of `LocalGeometry::from_derivs`.
        let cross = d.su.cross(&d.sv);
        let len = cross.norm();
        let scale = d.su.norm() * d.sv.norm();
        if !len.is_finite() || len <= 1e-12 * scale || scale.is_nan() {
            return None;
        }
        let e = d.su.dot(&d.su);
        let f = d.su.dot(&d.sv);
        let g = d.sv.dot(&d.sv);
        let c11 = e.sqrt();
        let c21 = f / c11;
        // Cholesky's sqrt(G - c21^2) > 0, as in `LocalGeometry`.
        let rest = g - c21 * c21;
        if rest.is_nan() || rest <= 0.0 {
            return None;
        }
        Some(Self {
            su: d.su,
            sv: d.sv,
            n: cross / len,
            first: Matrix2::new(e, f, f, g),
        })
    }

    /// [`LocalGeometry::tangent_to_uv`].
    pub fn tangent_to_uv(&self, t: Vector3<f64>) -> Vector2<f64> {
        tangent_to_uv(&self.su, &self.sv, &self.first, t)
    }
}

/// The uv direction of a 3-D tangent `t` at a point with derivatives `su`,
/// `sv` and first fundamental form `first`: G^-1 (t . S_u, t . S_v) (the
/// dot products unchanged where G is singular).
#[inline]
fn tangent_to_uv(
    su: &Vector3<f64>,
    sv: &Vector3<f64>,
    first: &Matrix2<f64>,
    t: Vector3<f64>,
) -> Vector2<f64> {
    let rhs = Vector2::new(t.dot(su), t.dot(sv));
    first.try_inverse().map(|gi| gi * rhs).unwrap_or(rhs)
}

/// Eigen-decomposition of a symmetric 2x2 matrix: (lambda_min, lambda_max,
/// unit eigenvector for min, unit eigenvector for max).
pub(crate) fn sym_eigen2(s: Matrix2<f64>) -> (f64, f64, Vector2<f64>, Vector2<f64>) {
    let a = s[(0, 0)];
    let b = 0.5 * (s[(0, 1)] + s[(1, 0)]);
    let c = s[(1, 1)];
    let mean = 0.5 * (a + c);
    let half_diff = 0.5 * (a - c);
    let r = half_diff.hypot(b);
    let (lmin, lmax) = (mean - r, mean + r);
    // Angle of the max eigenvector: 2 phi = atan2(2b, a - c); stable at r = 0 (gives phi = 0).
    let phi = 0.5 * b.atan2(half_diff);
    let vmax = Vector2::new(phi.cos(), phi.sin());
    let vmin = Vector2::new(-phi.sin(), phi.cos());
    (lmin, lmax, vmin, vmax)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Quarter of a cylinder of radius r about the x axis, as an exact rational surface.
    fn quarter_cylinder(r: f64) -> NurbsSurface {
        let w = std::f64::consts::FRAC_1_SQRT_2;
        let arc = [
            ([0.0, -r, 0.0], 1.0),
            ([0.0, -r, -r], w),
            ([0.0, 0.0, -r], 1.0),
        ];
        let cps: Vec<Vec<[f64; 3]>> = (0..2)
            .map(|i| {
                arc.iter()
                    .map(|(p, _)| [50.0 * i as f64, p[1], p[2]])
                    .collect()
            })
            .collect();
        let ws: Vec<Vec<f64>> = (0..2)
            .map(|_| arc.iter().map(|(_, w)| *w).collect())
            .collect();
        NurbsSurface::new(
            1,
            2,
            vec![0., 0., 1., 1.],
            vec![0., 0., 0., 1., 1., 1.],
            &cps,
            Some(&ws),
        )
        .unwrap()
    }

    #[test]
    fn tangent_frame_holds_the_bits_of_local_geometry() {
        // A rational surface, a bicubic one and a cone with a collapsed edge
        // (where both give None or the off-pole derivatives).
        let cyl = quarter_cylinder(100.0);
        let cps: Vec<Vec<[f64; 3]>> = (0..5)
            .map(|i| {
                (0..6)
                    .map(|j| {
                        let (x, y) = (i as f64 * 20.0, j as f64 * 15.0);
                        [
                            x,
                            y,
                            (0.07 * x).sin() * 8.0 + (0.11 * y).cos() * 5.0 + 0.01 * x * y,
                        ]
                    })
                    .collect()
            })
            .collect();
        let bicubic = NurbsSurface::new(
            3,
            3,
            vec![0., 0., 0., 0., 0.4, 1., 1., 1., 1.],
            vec![0., 0., 0., 0., 0.3, 0.6, 1., 1., 1., 1.],
            &cps,
            None,
        )
        .unwrap();
        let apex: Vec<Vec<[f64; 3]>> = (0..2)
            .map(|i| {
                (0..3)
                    .map(|j| {
                        let r = 30.0 * i as f64;
                        [
                            r * j as f64 * 0.5,
                            r * (1.0 - 0.5 * j as f64),
                            -20.0 * i as f64,
                        ]
                    })
                    .collect()
            })
            .collect();
        let cone = NurbsSurface::new(
            1,
            2,
            vec![0., 0., 1., 1.],
            vec![0., 0., 0., 1., 1., 1.],
            &apex,
            None,
        )
        .unwrap();
        let mut none = 0;
        for s in [&cyl, &bicubic, &cone] {
            for i in 0..=40 {
                for j in 0..=40 {
                    let (u, v) = (i as f64 / 40.0 - 0.01, j as f64 / 40.0);
                    let g = LocalGeometry::at(s, u, v);
                    let f = TangentFrame::at(s, u, v);
                    assert_eq!(g.is_some(), f.is_some(), "({u}, {v})");
                    let (Some(g), Some(f)) = (g, f) else {
                        none += 1;
                        continue;
                    };
                    assert_eq!(
                        (
                            g.forms.derivs.su,
                            g.forms.derivs.sv,
                            g.forms.n,
                            g.forms.first
                        ),
                        (f.su, f.sv, f.n, f.first)
                    );
                    let t = Vector3::new(0.3, -0.7, 0.2 + u);
                    assert_eq!(g.tangent_to_uv(t), f.tangent_to_uv(t));
                }
            }
        }
        assert!(none < 100, "{none}");
    }

    #[test]
    fn cylinder_curvatures_are_exact() {
        let r = 100.0;
        let s = quarter_cylinder(r);
        for &(u, v) in &[(0.1, 0.2), (0.5, 0.5), (0.9, 0.77), (0.0, 1.0)] {
            let g = LocalGeometry::at(&s, u, v).unwrap();
            let p = g.point();
            assert!(((p.y * p.y + p.z * p.z).sqrt() - r).abs() < 1e-9);
            let ks = [g.k_min.abs(), g.k_max.abs()];
            assert!(ks.iter().any(|k| (k - 1.0 / r).abs() < 1e-12), "{ks:?}");
            assert!(ks.iter().any(|k| k.abs() < 1e-12), "{ks:?}");
            // The zero-curvature direction is the axis.
            let dir = if g.k_min.abs() < 1e-12 {
                g.dir_min
            } else {
                g.dir_max
            };
            assert!((dir.x.abs() - 1.0).abs() < 1e-9);
        }
    }
}
