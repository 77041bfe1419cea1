//! Point inversion: the closest point on a surface to a point in space
//! (docs/methods.md, "Point inversion and the surface past its edge").
//!
//! Minimises f(u, v) = 1/2 |S(u, v) - q|^2 over the parameter domain. Seeds come
//! from a coarse grid (a few per knot span); from the best seeds a projected
//! Newton iteration (Levenberg damping where the Hessian is not positive
//! definite, coordinates at a bound held fixed while the gradient pushes
//! outwards, backtracking on f) converges to a local minimum, so points
//! beyond the edge of the surface land exactly on the boundary.
//!
//! [`invert_in_frame`] is the other inversion the planners need: the
//! parameters of the surface point with given coordinates along two tangent
//! directions of a local frame (the part as a height field over a tangent
//! plane), on the surface continued past its edges ([`extended_derivs`]).

use super::nurbs::{NurbsSurface, SurfaceDerivs};
use nalgebra::{Matrix2, Point3, Vector2, Vector3};

/// Positions and derivatives of the surface, continued past its boundary by
/// the second-order Taylor expansion at the nearest boundary point, so that
/// tools overhanging the edge see a smooth continuation.
///
/// Past a collapsed boundary (a pole) the surface continues on the other
/// side of the pole instead ([`beyond_pole`]).
pub fn extended_derivs(surface: &NurbsSurface, u: f64, v: f64) -> SurfaceDerivs {
    if let Some(d) = beyond_pole(surface, u, v) {
        return d;
    }
    taylor_extended(surface, u, v)
}

/// Past a collapsed boundary at parameter c, the surface at c - t is the
/// surface at c + t turned half a turn about the pole's normal: parameter
/// lines through a pole are diameters, and the half turn is exact for a
/// surface of revolution and right to second order for any smooth surface
/// (the height over the tangent plane is even to that order). `None` away
/// from collapsed boundaries (docs/methods.md, "Degenerate boundaries").
pub(crate) fn beyond_pole(surface: &NurbsSurface, u: f64, v: f64) -> Option<SurfaceDerivs> {
    let c = surface.collapsed_boundaries();
    let ((u0, u1), (v0, v1)) = surface.domain();
    let mirror = |t: f64, lo: f64, hi: f64, at_lo: bool, at_hi: bool| -> Option<(f64, f64)> {
        if at_lo && t < lo {
            Some(((2.0 * lo - t).min(hi), lo))
        } else if at_hi && t > hi {
            Some(((2.0 * hi - t).max(lo), hi))
        } else {
            None
        }
    };
    let mu = mirror(u, u0, u1, c[0], c[1]);
    let mv = mirror(v, v0, v1, c[2], c[3]);
    if mu.is_none() && mv.is_none() {
        return None;
    }
    let (pu, su) = match mu {
        Some((m, pole)) => (pole, m),
        None => (u, u),
    };
    let (pv, sv) = match mv {
        Some((m, pole)) => (pole, m),
        None => (v, v),
    };
    // The pole and its normal (the limit of the neighbouring normals).
    let pole = surface.point(pu, pv);
    let n = surface.normal(pu, pv)?;
    let turn = |x: Vector3<f64>| n * (2.0 * n.dot(&x)) - x;
    let d = taylor_extended(surface, su, sv);
    let (fu, fv) = (
        if mu.is_some() { -1.0 } else { 1.0 },
        if mv.is_some() { -1.0 } else { 1.0 },
    );
    Some(SurfaceDerivs {
        p: pole + turn(d.p - pole),
        su: turn(d.su) * fu,
        sv: turn(d.sv) * fv,
        suu: turn(d.suu),
        suv: turn(d.suv) * (fu * fv),
        svv: turn(d.svv),
    })
}

fn taylor_extended(surface: &NurbsSurface, u: f64, v: f64) -> SurfaceDerivs {
    let (uc, vc) = surface.clamp_uv(u, v);
    let mut d = surface.derivs(uc, vc);
    let (du, dv) = (u - uc, v - vc);
    if du == 0.0 && dv == 0.0 {
        return d;
    }
    // On a surface with a pole the parameter lines near it bend sharply
    // within the surface (geodesic curvature 1 / distance to the pole): the
    // continuation keeps only the normal part of the second derivatives, so
    // it stays a graph over the tangent plane instead of curling round.
    if surface.collapsed_boundaries() != [false; 4] {
        if let Some(n) = d.su.cross(&d.sv).try_normalize(1e-300) {
            d.suu = n * d.suu.dot(&n);
            d.suv = n * d.suv.dot(&n);
            d.svv = n * d.svv.dot(&n);
        }
    }
    SurfaceDerivs {
        p: d.p
            + d.su * du
            + d.sv * dv
            + 0.5 * (d.suu * du * du + 2.0 * d.suv * du * dv + d.svv * dv * dv),
        su: d.su + d.suu * du + d.suv * dv,
        sv: d.sv + d.suv * du + d.svv * dv,
        ..d
    }
}

/// The point of the extended surface (see [`extended_derivs`]); plain
/// evaluation inside the domain.
pub fn extended_point(surface: &NurbsSurface, u: f64, v: f64) -> Point3<f64> {
    let (uc, vc) = surface.clamp_uv(u, v);
    if uc == u && vc == v {
        surface.point(u, v)
    } else {
        extended_derivs(surface, u, v).p
    }
}

/// A surface point found by [`invert_in_frame`].
#[derive(Clone, Copy, Debug)]
pub struct FramePoint {
    pub uv: Vector2<f64>,
    /// Derivatives there (on the extended surface).
    pub derivs: SurfaceDerivs,
    /// Height (S - origin) . e3 over the tangent plane.
    pub height: f64,
    /// Slopes of that height along e1 and e2.
    pub slope: [f64; 2],
}

/// The point of the (extended) surface whose offset from `origin` has
/// components `xy` along the orthonormal directions `e1`, `e2`: Newton on
/// (u, v) from `seed`, i.e. the surface hit by the line through
/// origin + x e1 + y e2 along e3 = e1 x e2. Converges where the surface is a
/// graph over the e1-e2 plane near the seed.
///
/// Where plain Newton does not converge (a seed at or next to a pole, where
/// the Jacobian is singular or nearly so and a full step overshoots onto the
/// continuation far past the edge), the target is reached by continuation:
/// damped Newton steps that must reduce the residual, along a path of
/// targets from the seed's own position to `xy` ([`invert_by_continuation`]).
pub fn invert_in_frame(
    surface: &NurbsSurface,
    origin: &Point3<f64>,
    e1: &Vector3<f64>,
    e2: &Vector3<f64>,
    xy: [f64; 2],
    seed: Vector2<f64>,
) -> FramePoint {
    let frame = InFrame {
        surface,
        origin,
        e1,
        e2,
    };
    let mut uv = seed;
    let mut d = extended_derivs(surface, uv.x, uv.y);
    for _ in 0..12 {
        let res = frame.residual(&d, xy);
        if res.norm() < 1e-10 {
            break;
        }
        let Some(ji) = frame.jacobian(&d).try_inverse() else {
            break;
        };
        uv -= ji * res;
        d = extended_derivs(surface, uv.x, uv.y);
    }
    let miss = frame.residual(&d, xy).norm();
    if miss.is_nan() || miss > CONVERGED_MM {
        let (uv2, d2) = invert_by_continuation(&frame, xy, seed);
        let miss2 = frame.residual(&d2, xy).norm();
        if miss2 < miss || !miss.is_finite() {
            (uv, d) = (uv2, d2);
        }
    }
    frame.found(uv, d)
}

/// A frame inversion's residual below which plain Newton has converged, mm.
const CONVERGED_MM: f64 = 1e-7;

/// The frame of [`invert_in_frame`].
struct InFrame<'a> {
    surface: &'a NurbsSurface,
    origin: &'a Point3<f64>,
    e1: &'a Vector3<f64>,
    e2: &'a Vector3<f64>,
}

impl InFrame<'_> {
    fn residual(&self, d: &SurfaceDerivs, xy: [f64; 2]) -> Vector2<f64> {
        let r = d.p - self.origin;
        Vector2::new(r.dot(self.e1) - xy[0], r.dot(self.e2) - xy[1])
    }

    fn jacobian(&self, d: &SurfaceDerivs) -> Matrix2<f64> {
        Matrix2::new(
            d.su.dot(self.e1),
            d.sv.dot(self.e1),
            d.su.dot(self.e2),
            d.sv.dot(self.e2),
        )
    }

    fn found(&self, uv: Vector2<f64>, d: SurfaceDerivs) -> FramePoint {
        let e3 = self.e1.cross(self.e2);
        // dh/dx, dh/dy: the parameter steps that move one unit along e1, e2.
        let slope = self
            .jacobian(&d)
            .try_inverse()
            .map(|ji| {
                let a = ji.column(0);
                let b = ji.column(1);
                [
                    (d.su * a.x + d.sv * a.y).dot(&e3),
                    (d.su * b.x + d.sv * b.y).dot(&e3),
                ]
            })
            .unwrap_or([0.0, 0.0]);
        FramePoint {
            uv,
            derivs: d,
            height: (d.p - self.origin).dot(&e3),
            slope,
        }
    }

    /// Damped Newton towards `xy` from (uv, d): Levenberg-Marquardt steps
    /// (the Jacobian may be singular at a pole), the damping raised tenfold
    /// until a step reduces the residual. Returns the last point and whether
    /// it converged.
    fn damped(
        &self,
        xy: [f64; 2],
        mut uv: Vector2<f64>,
        mut d: SurfaceDerivs,
    ) -> (Vector2<f64>, SurfaceDerivs, bool) {
        let mut res = self.residual(&d, xy);
        for _ in 0..40 {
            if res.norm() <= 0.1 * CONVERGED_MM {
                return (uv, d, true);
            }
            let j = self.jacobian(&d);
            let jtj = j.transpose() * j;
            let gradient = j.transpose() * res;
            let mut lambda = 1e-12 * jtj.trace().max(1e-300);
            let mut improved = false;
            for _ in 0..24 {
                let Some(inv) = (jtj + Matrix2::identity() * lambda).try_inverse() else {
                    lambda *= 10.0;
                    continue;
                };
                let trial = uv - inv * gradient;
                let dt = extended_derivs(self.surface, trial.x, trial.y);
                let rt = self.residual(&dt, xy);
                if rt.norm() < res.norm() {
                    (uv, d, res) = (trial, dt, rt);
                    improved = true;
                    break;
                }
                lambda *= 10.0;
            }
            if !improved {
                break;
            }
        }
        let ok = res.norm() <= CONVERGED_MM;
        (uv, d, ok)
    }
}

/// [`invert_in_frame`]'s fallback: damped Newton along 2^k equal steps
/// from the seed's own frame position to `xy` (k = 0..=6), each target
/// seeded by the last, until one run converges; the closest point found
/// otherwise.
fn invert_by_continuation(
    frame: &InFrame,
    xy: [f64; 2],
    seed: Vector2<f64>,
) -> (Vector2<f64>, SurfaceDerivs) {
    let d0 = extended_derivs(frame.surface, seed.x, seed.y);
    let start = frame.residual(&d0, [0.0, 0.0]);
    let mut best = (seed, d0, frame.residual(&d0, xy).norm());
    for k in 0..=6u32 {
        let n = 1usize << k;
        let (mut uv, mut d) = (seed, d0);
        let mut ok = true;
        for i in 1..=n {
            let f = i as f64 / n as f64;
            let target = [
                start.x + (xy[0] - start.x) * f,
                start.y + (xy[1] - start.y) * f,
            ];
            let (u2, d2, converged) = frame.damped(target, uv, d);
            (uv, d) = (u2, d2);
            if !converged && i < n {
                ok = false;
                break;
            }
        }
        let miss = frame.residual(&d, xy).norm();
        if miss < best.2 {
            best = (uv, d, miss);
        }
        if ok && miss <= CONVERGED_MM {
            break;
        }
    }
    (best.0, best.1)
}

/// Result of an inversion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosestPoint {
    /// Parameters of the closest point (inside the domain, possibly on its boundary).
    pub uv: Vector2<f64>,
    /// The closest point on the surface.
    pub point: Point3<f64>,
    /// Its distance from the query point, mm.
    pub distance: f64,
}

/// Number of grid seeds per direction: a few per knot span, within 8..=64.
fn seeds_per_direction(knots: &[f64], degree: usize) -> usize {
    let spans = knots.windows(2).filter(|w| w[1] > w[0]).count();
    (spans * (degree + 1)).clamp(8, 64)
}

/// Closest point on `surface` to `q` (global: grid seeds, then Newton from the best few).
pub fn closest_point(surface: &NurbsSurface, q: &Point3<f64>) -> ClosestPoint {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let nu = seeds_per_direction(surface.knots_u(), surface.degree_u());
    let nv = seeds_per_direction(surface.knots_v(), surface.degree_v());
    // Keep the best few seeds (sorted by distance, then index for determinism),
    // skipping seeds that coincide in space with a kept one: at a degenerate
    // edge (a pole, a collapsed row) they would all be the same start.
    const KEEP: usize = 4;
    let mut best: Vec<(f64, Vector2<f64>, Point3<f64>)> = Vec::with_capacity(KEEP + 1);
    let (lo, hi) = surface.bounding_box();
    let same = 1e-9 * (hi - lo).norm();
    for i in 0..=nu {
        let u = u0 + (u1 - u0) * i as f64 / nu as f64;
        for j in 0..=nv {
            let v = v0 + (v1 - v0) * j as f64 / nv as f64;
            let p = surface.point(u, v);
            let d2 = (p - q).norm_squared();
            if best.len() < KEEP || d2 < best[best.len() - 1].0 {
                if best.iter().any(|b| (b.2 - p).norm() <= same) {
                    continue;
                }
                let at = best.partition_point(|b| b.0 <= d2);
                best.insert(at, (d2, Vector2::new(u, v), p));
                best.truncate(KEEP);
            }
        }
    }
    let mut result: Option<ClosestPoint> = None;
    for (_, seed, _) in best {
        let c = closest_point_near(surface, q, seed);
        // On a closed surface the minimum may lie just across the seam: restart
        // from the matching point on the opposite edge when there is one.
        let mut tries = vec![c];
        for partner in seam_partners(surface, c.uv, same) {
            tries.push(closest_point_near(surface, q, partner));
        }
        for c in tries {
            if result.is_none_or(|r| c.distance < r.distance) {
                result = Some(c);
            }
        }
    }
    // `best` is never empty: the grid has at least 81 points.
    result.unwrap_or_else(|| closest_point_near(surface, q, Vector2::new(u0, v0)))
}

/// Parameters on the opposite edge that map to the same point as `uv` (closed surfaces).
fn seam_partners(surface: &NurbsSurface, uv: Vector2<f64>, same: f64) -> Vec<Vector2<f64>> {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let p = surface.point(uv.x, uv.y);
    let mut out = Vec::new();
    let mut candidates = Vec::new();
    if uv.x == u0 || uv.x == u1 {
        candidates.push(Vector2::new(u0 + u1 - uv.x, uv.y));
    }
    if uv.y == v0 || uv.y == v1 {
        candidates.push(Vector2::new(uv.x, v0 + v1 - uv.y));
    }
    for c in candidates {
        if (surface.point(c.x, c.y) - p).norm() <= same {
            out.push(c);
        }
    }
    out
}

/// Local inversion: Newton from `seed` (clamped into the domain). Use this to
/// follow a moving point when a nearby answer is known; it finds the local
/// minimum of the distance nearest to the seed.
pub fn closest_point_near(
    surface: &NurbsSurface,
    q: &Point3<f64>,
    seed: Vector2<f64>,
) -> ClosestPoint {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let lo = Vector2::new(u0, v0);
    let hi = Vector2::new(u1, v1);
    let span = hi - lo;
    let clamp = |x: Vector2<f64>| Vector2::new(x.x.clamp(u0, u1), x.y.clamp(v0, v1));
    let mut x = clamp(seed);
    let mut d = surface.derivs(x.x, x.y);
    let mut r = d.p - q;
    let mut f = 0.5 * r.norm_squared();
    let mut lambda = 0.0f64;
    for _ in 0..100 {
        let g = Vector2::new(d.su.dot(&r), d.sv.dot(&r));
        let h = Matrix2::new(
            d.su.dot(&d.su) + d.suu.dot(&r),
            d.su.dot(&d.sv) + d.suv.dot(&r),
            d.su.dot(&d.sv) + d.suv.dot(&r),
            d.sv.dot(&d.sv) + d.svv.dot(&r),
        );
        // Active set: a coordinate at a bound whose descent direction leaves the domain.
        let active = [
            (x.x <= u0 && g.x > 0.0) || (x.x >= u1 && g.x < 0.0),
            (x.y <= v0 && g.y > 0.0) || (x.y >= v1 && g.y < 0.0),
        ];
        let scale = h[(0, 0)].abs() + h[(1, 1)].abs() + 1e-300;
        let mut accepted = false;
        for _ in 0..40 {
            let step = newton_step(&h, &g, active, lambda * scale);
            let x_new = clamp(x + step);
            let dn = surface.derivs(x_new.x, x_new.y);
            let rn = dn.p - q;
            let f_new = 0.5 * rn.norm_squared();
            // Near the minimum f stops resolving the position (f changes at
            // rounding level long before the point settles): there, accept
            // steps that shrink the free gradient instead.
            let free_grad = |dd: &crate::geometry::SurfaceDerivs, rr: &nalgebra::Vector3<f64>| {
                let gx = if active[0] { 0.0 } else { dd.su.dot(rr) };
                let gy = if active[1] { 0.0 } else { dd.sv.dot(rr) };
                gx.hypot(gy)
            };
            let flat = f_new <= f * (1.0 + 1e-12) && free_grad(&dn, &rn) < free_grad(&d, &r);
            if f_new <= f || flat {
                let moved = x_new - x;
                x = x_new;
                d = dn;
                r = rn;
                let converged =
                    (moved.x / span.x).abs() + (moved.y / span.y).abs() <= 1e-14 || f_new < 1e-28;
                f = f_new;
                lambda = (lambda * 0.1).max(0.0);
                if lambda < 1e-12 {
                    lambda = 0.0;
                }
                accepted = true;
                if converged {
                    return finish(x, d.p, f);
                }
                break;
            }
            lambda = if lambda == 0.0 { 1e-6 } else { lambda * 10.0 };
        }
        if !accepted {
            break;
        }
    }
    finish(x, d.p, f)
}

fn finish(uv: Vector2<f64>, p: Point3<f64>, f: f64) -> ClosestPoint {
    ClosestPoint {
        uv,
        point: p,
        distance: (2.0 * f).sqrt(),
    }
}

/// Damped Newton step for the free coordinates (active ones stay put).
fn newton_step(
    h: &Matrix2<f64>,
    g: &Vector2<f64>,
    active: [bool; 2],
    damping: f64,
) -> Vector2<f64> {
    match active {
        [true, true] => Vector2::zeros(),
        [true, false] => Vector2::new(0.0, -g.y / positive(h[(1, 1)] + damping, damping)),
        [false, true] => Vector2::new(-g.x / positive(h[(0, 0)] + damping, damping), 0.0),
        [false, false] => {
            let hd = h + Matrix2::identity() * damping;
            let det = hd.determinant();
            // Positive definite: Newton. Otherwise a scaled gradient step (the damping grows until f drops).
            if hd[(0, 0)] > 0.0 && det > 1e-300 * hd[(0, 0)].abs() * hd[(1, 1)].abs() {
                -(Matrix2::new(hd[(1, 1)], -hd[(0, 1)], -hd[(1, 0)], hd[(0, 0)]) * g) / det
            } else {
                let s = h[(0, 0)].abs() + h[(1, 1)].abs() + damping;
                -g / s.max(1e-300)
            }
        }
    }
}

fn positive(x: f64, damping: f64) -> f64 {
    if x > 0.0 {
        x
    } else {
        x.abs() + damping + 1e-300
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::interpolation::interpolate_height_field;

    #[test]
    fn points_above_a_paraboloid_project_onto_it() {
        let s = interpolate_height_field(
            |x, y| 0.01 * (x * x + y * y),
            (-20.0, 20.0),
            (-20.0, 20.0),
            (3, 2),
            (3, 2),
        )
        .unwrap();
        let p = s.point(0.3, 0.7);
        let n = s.normal(0.3, 0.7).unwrap();
        let q = p + n * 2.0;
        let c = closest_point(&s, &q);
        assert!((c.uv - Vector2::new(0.3, 0.7)).norm() < 1e-10, "{:?}", c.uv);
        assert!((c.distance - 2.0).abs() < 1e-10);
    }

    #[test]
    fn points_beyond_the_edge_land_on_the_boundary() {
        let s = interpolate_height_field(
            |x, y| 0.1 * x + 0.05 * y,
            (0.0, 10.0),
            (0.0, 10.0),
            (3, 1),
            (3, 1),
        )
        .unwrap();
        let c = closest_point(&s, &Point3::new(15.0, 5.0, 1.25));
        assert!(
            (c.uv.x - 1.0).abs() < 1e-15 && c.uv.y > 0.0 && c.uv.y < 1.0,
            "{:?}",
            c.uv
        );
        let c = closest_point(&s, &Point3::new(-5.0, -5.0, 0.0));
        assert_eq!(c.uv, Vector2::new(0.0, 0.0));
    }
}
