//! Degenerate points of the strip-width tensor field (docs/methods.md,
//! "Degenerate points"): where the field is isotropic, e = f = 0 with e, f the
//! deviator of S = L^-1 H L^-T in the orthonormal Cholesky frame (the paper's
//! literal "T12 = T21" is not sufficient). Found by sign changes of e and f
//! over a grid, then Newton; classified by delta = a d - b c (Delmarcelle) with
//! the derivatives taken in the orthonormal frame; separatrix directions from
//! the cubic d x^3 + (c + 2b) x^2 + (2a - d) x - c = 0, keeping the half-rays
//! along which the feed (major eigenvector) is radial.

use crate::strip_width::field::deviator;
use nalgebra::{Matrix2, Point3, Vector2, Vector3};
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::{LocalGeometry, NurbsSurface};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Trisector,
    Wedge,
}

impl Kind {
    pub fn name(self) -> &'static str {
        match self {
            Kind::Trisector => "trisector",
            Kind::Wedge => "wedge",
        }
    }
}

#[derive(Clone, Debug)]
pub struct DegeneratePoint {
    pub uv: Vector2<f64>,
    pub xyz: Point3<f64>,
    pub kind: Kind,
    /// delta = a d - b c, which classifies the point (the tests report it).
    #[allow(dead_code)]
    pub delta: f64,
    /// Unit 3-D tangents of the separatrices leaving the point (half-rays
    /// along which the feed is radial), with their parameter-space directions.
    pub separatrices: Vec<(Vector3<f64>, Vector2<f64>)>,
}

/// What the analysis found.
#[derive(Clone, Debug)]
pub(crate) struct Analysis {
    pub points: Vec<DegeneratePoint>,
    /// The field is isotropic everywhere (plane, sphere): every point is
    /// degenerate and no feed direction is preferred.
    pub everywhere: bool,
}

/// Deviator (e, f) at (u, v); `None` where the surface is singular.
fn ef(surface: &NurbsSurface, u: f64, v: f64) -> Option<Vector2<f64>> {
    let g = LocalGeometry::at(surface, u, v)?;
    let (e, f, _) = deviator(&g)?;
    Some(Vector2::new(e, f))
}

/// Field magnitude below which the whole surface counts as isotropic, 1/mm
/// (a curvature difference of 1e-9 1/mm: radii beyond 1000 km).
const ISOTROPIC: f64 = 1e-9;

/// Finds and classifies the degenerate points. `grid` cells per direction.
pub(crate) fn find(surface: &NurbsSurface, grid: usize) -> Result<Analysis> {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let n = grid.max(4);
    let (du, dv) = ((u1 - u0) / n as f64, (v1 - v0) / n as f64);
    let mut vals = vec![Vector2::zeros(); (n + 1) * (n + 1)];
    let mut scale = 0.0f64;
    for i in 0..=n {
        for j in 0..=n {
            let (u, v) = (u0 + i as f64 * du, v0 + j as f64 * dv);
            let val = ef(surface, u, v).ok_or_else(|| {
                Error::planning(format!(
                    "the surface is singular at uv ({u:.4}, {v:.4}): no normal there"
                ))
            })?;
            scale = scale.max(val.norm());
            vals[i * (n + 1) + j] = val;
        }
    }
    if scale < ISOTROPIC {
        return Ok(Analysis {
            points: Vec::new(),
            everywhere: true,
        });
    }
    let at = |i: usize, j: usize| vals[i * (n + 1) + j];
    let mut points: Vec<DegeneratePoint> = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let c = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
            let straddles = |k: usize| {
                let lo = c.iter().map(|x| x[k]).fold(f64::INFINITY, f64::min);
                let hi = c.iter().map(|x| x[k]).fold(f64::NEG_INFINITY, f64::max);
                lo <= 0.0 && hi >= 0.0
            };
            if !(straddles(0) && straddles(1)) {
                continue;
            }
            let start = Vector2::new(u0 + (i as f64 + 0.5) * du, v0 + (j as f64 + 0.5) * dv);
            let Some(uv) = newton(surface, start, (du, dv), scale) else {
                continue;
            };
            // Keep roots in (or at the edge of) this cell; neighbours find theirs.
            let (ci, cj) = ((uv.x - u0) / du, (uv.y - v0) / dv);
            if ci < i as f64 - 0.5
                || ci > i as f64 + 1.5
                || cj < j as f64 - 0.5
                || cj > j as f64 + 1.5
            {
                continue;
            }
            let dup = points.iter().any(|p| {
                ((p.uv.x - uv.x) / du).abs() < 0.05 && ((p.uv.y - uv.y) / dv).abs() < 0.05
            });
            if dup {
                continue;
            }
            if let Some(p) = classify(surface, uv, (du, dv)) {
                points.push(p);
            }
        }
    }
    points.sort_by(|a, b| a.uv.x.total_cmp(&b.uv.x).then(a.uv.y.total_cmp(&b.uv.y)));
    Ok(Analysis {
        points,
        everywhere: false,
    })
}

/// Newton on (e, f)(u, v) = 0 with a finite-difference Jacobian, clamped to
/// the domain. `None` when it does not converge (no root near `start`).
fn newton(
    surface: &NurbsSurface,
    start: Vector2<f64>,
    cell: (f64, f64),
    scale: f64,
) -> Option<Vector2<f64>> {
    let mut uv = start;
    for _ in 0..40 {
        let val = ef(surface, uv.x, uv.y)?;
        if val.norm() <= 1e-13 * scale {
            return Some(uv);
        }
        let j = jacobian(surface, uv, cell)?;
        let step = j.try_inverse()? * val;
        // Damp steps longer than a cell: a root further away belongs to another cell.
        let len = ((step.x / cell.0).powi(2) + (step.y / cell.1).powi(2)).sqrt();
        let damp = if len > 1.0 { 1.0 / len } else { 1.0 };
        let (u, v) = surface.clamp_uv(uv.x - step.x * damp, uv.y - step.y * damp);
        let next = Vector2::new(u, v);
        if ((next - uv).x / cell.0).abs() < 1e-10 && ((next - uv).y / cell.1).abs() < 1e-10 {
            let val = ef(surface, next.x, next.y)?;
            return (val.norm() <= 1e-8 * scale).then_some(next);
        }
        uv = next;
    }
    let val = ef(surface, uv.x, uv.y)?;
    (val.norm() <= 1e-8 * scale).then_some(uv)
}

/// d(e, f)/d(u, v) by central differences (one-sided at the domain edges).
fn jacobian(surface: &NurbsSurface, uv: Vector2<f64>, cell: (f64, f64)) -> Option<Matrix2<f64>> {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let hu = 1e-3 * cell.0;
    let hv = 1e-3 * cell.1;
    let (ua, ub) = ((uv.x - hu).max(u0), (uv.x + hu).min(u1));
    let (va, vb) = ((uv.y - hv).max(v0), (uv.y + hv).min(v1));
    let d_u = (ef(surface, ub, uv.y)? - ef(surface, ua, uv.y)?) / (ub - ua);
    let d_v = (ef(surface, uv.x, vb)? - ef(surface, uv.x, va)?) / (vb - va);
    Some(Matrix2::new(d_u.x, d_v.x, d_u.y, d_v.y))
}

/// Classification and separatrix directions at a root.
fn classify(surface: &NurbsSurface, uv: Vector2<f64>, cell: (f64, f64)) -> Option<DegeneratePoint> {
    let g = LocalGeometry::at(surface, uv.x, uv.y)?;
    let (_, _, li) = deviator(&g)?;
    let j = jacobian(surface, uv, cell)?;
    // Derivatives in the orthonormal frame y: uv = L^-T y, so grad_y = L^-1 grad_uv.
    let grad_e = li * Vector2::new(j[(0, 0)], j[(0, 1)]);
    let grad_f = li * Vector2::new(j[(1, 0)], j[(1, 1)]);
    let (a, b, c, d) = (grad_e.x, grad_e.y, grad_f.x, grad_f.y);
    let delta = a * d - b * c;
    let kind = if delta < 0.0 {
        Kind::Trisector
    } else {
        Kind::Wedge
    };
    let mut separatrices = Vec::new();
    for theta in cubic_angles(a, b, c, d) {
        for th in [theta, theta + std::f64::consts::PI] {
            let (s, co) = th.sin_cos();
            let e = a * co + b * s;
            let f = c * co + d * s;
            // Feed radial: (e, f) a positive multiple of (cos 2th, sin 2th).
            let along = e * (2.0 * th).cos() + f * (2.0 * th).sin();
            if along > 0.0 {
                let t_uv = li.transpose() * Vector2::new(co, s);
                let t3 = g.uv_to_tangent(t_uv);
                let len = t3.norm();
                if len > 0.0 {
                    separatrices.push((t3 / len, t_uv / len));
                }
            }
        }
    }
    Some(DegeneratePoint {
        uv,
        xyz: g.point(),
        kind,
        delta,
        separatrices,
    })
}

/// Angles theta in [0, pi) with x = tan(theta) a real root of
/// d x^3 + (c + 2b) x^2 + (2a - d) x - c = 0 (theta = pi/2 when the cubic
/// loses its leading term). Solved in the angle instead of x, so that
/// vertical directions are not lost: g(th) = e sin 2th - f cos 2th on the
/// unit ray, whose zeros over [0, pi) are the same directions.
fn cubic_angles(a: f64, b: f64, c: f64, d: f64) -> Vec<f64> {
    let g = |th: f64| {
        let (s, co) = th.sin_cos();
        let e = a * co + b * s;
        let f = c * co + d * s;
        e * (2.0 * th).sin() - f * (2.0 * th).cos()
    };
    const N: usize = 720;
    let mut roots = Vec::new();
    let pi = std::f64::consts::PI;
    // The grid is shifted by half a step so that a root at 0 (= pi) is interior.
    let at = |k: usize| pi * (k as f64 - 0.5) / N as f64;
    let mut prev = g(at(0));
    for k in 1..=N {
        let th = at(k);
        let cur = g(th);
        if prev * cur <= 0.0 && (prev != 0.0 || cur != 0.0) {
            let (mut lo, mut hi) = (at(k - 1), th);
            let glo = prev;
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if g(mid) * glo > 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            let r = (0.5 * (lo + hi)).rem_euclid(pi);
            if !roots.iter().any(|&q: &f64| (q - r).abs() < 1e-9) {
                roots.push(r);
            }
        }
        prev = cur;
    }
    roots
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_surfaces;

    fn angle_deg(v: Vector3<f64>) -> f64 {
        v.y.atan2(v.x).to_degrees().rem_euclid(360.0)
    }

    #[test]
    fn cubic_angles_agree_with_the_tangent_cubic() {
        // Independent: roots of the cubic in x = tan(theta) from its coefficients.
        let (a, b, c, d) = (-3.0, 0.7, 0.4, 2.0);
        for th in cubic_angles(a, b, c, d) {
            let x = th.tan();
            let p = d * x.powi(3) + (c + 2.0 * b) * x * x + (2.0 * a - d) * x - c;
            let scale = 1.0 + x.abs().powi(3) * d.abs();
            assert!(p.abs() / scale < 1e-9, "{th} {p}");
        }
        assert_eq!(cubic_angles(a, b, c, d).len(), 3);
    }

    #[test]
    fn monkey_saddle_has_one_trisector_with_separatrices_at_60_180_300() {
        for (offset, warp) in [([0.0, 0.0], 0.0), ([137.0, -41.0], 0.35)] {
            let s = test_surfaces::monkey_saddle(offset, warp);
            let a = find(&s, 32).unwrap();
            assert!(!a.everywhere);
            assert_eq!(a.points.len(), 1, "{:?}", a.points);
            let p = &a.points[0];
            assert_eq!(p.kind, Kind::Trisector);
            let dist = ((p.xyz.x - offset[0]).powi(2) + (p.xyz.y - offset[1]).powi(2)).sqrt();
            assert!(dist < 0.5, "trisector at {:?}", p.xyz);
            let mut angles: Vec<f64> = p.separatrices.iter().map(|(t, _)| angle_deg(*t)).collect();
            angles.sort_by(f64::total_cmp);
            assert_eq!(angles.len(), 3, "{angles:?}");
            for (got, want) in angles.iter().zip([60.0, 180.0, 300.0]) {
                assert!((got - want).abs() < 1.0, "{angles:?}");
            }
        }
    }

    #[test]
    fn plane_is_degenerate_everywhere_and_cylinder_nowhere() {
        let a = find(&test_surfaces::sheared_plane(), 16).unwrap();
        assert!(a.everywhere && a.points.is_empty());
        let a = find(&test_surfaces::concave_cylinder(100.0, 100.0), 16).unwrap();
        assert!(!a.everywhere && a.points.is_empty());
    }

    #[test]
    fn wedge_is_classified_as_wedge() {
        // z = x^3/3 + x y^2 ... a lemon/star family: e ~ x, f ~ y gives delta > 0.
        let s = test_surfaces::fit(
            3,
            3,
            test_surfaces::clamped(3, &[]),
            test_surfaces::clamped(3, &[]),
            |u, v| {
                let (x, y) = (100.0 * u - 50.0, 100.0 * v - 50.0);
                [
                    x,
                    y,
                    0.002 * (x * x + y * y) + 1e-5 * (x * x * x + x * y * y),
                ]
            },
        );
        let a = find(&s, 32).unwrap();
        assert_eq!(a.points.len(), 1);
        assert_eq!(a.points[0].kind, Kind::Wedge, "delta {}", a.points[0].delta);
    }
}
