//! The machining-strip-width tensor field of a flat-end (or ball) cutter with a
//! fixed lead angle and zero side tilt (methods.md A), and the exact strip
//! width of one pass from the cutter's real profile.
//!
//! - Tensor: H = 1/2 (K_b G - D), K_b = sin(lambda) / R. The optimal feed is the
//!   eigenvector of the generalised problem H t = mu G t with the largest mu,
//!   computed from G^-1 H (the right eigenvectors of H G^-1 are covectors G t:
//!   the paper's trap, visible only on non-orthonormal parametrisations).
//! - Width: the flat bottom edge swept along the feed has the elliptic
//!   silhouette y = R sin(phi), z = R sin(lambda) (1 - cos phi). Each edge point
//!   sits R (1 - cos phi) cos(lambda) behind the contact, where the surface has
//!   already curved along the feed; that height is subtracted. The surface
//!   across the feed is its osculating circle (curvature kappa_cross), and the
//!   residual is measured along the circle's normal; the half-width is the arc
//!   length on the surface up to where the residual reaches the scallop h.
//!   This replaces the quadratic estimate W2, which is 6-27 % too wide.

use crate::error::{Error, Result};
use crate::formats::Job;
use crate::geometry::{LocalGeometry, NurbsSurface};
use crate::tools::Tool;
use nalgebra::{Matrix2, Point3, Vector2, Vector3};

/// The cutter as the strip-width model sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cutter {
    pub radius: f64,
    /// Lead angle lambda, radians (0 for the ball, whose profile does not depend on it).
    pub lead: f64,
    pub ball: bool,
}

/// Normal curvatures of the surface in the frame of a pass: `feed` along the
/// travel direction t, `cross` along c = n x t, `twist` = II(t, c).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Curvatures {
    pub feed: f64,
    pub twist: f64,
    pub cross: f64,
}

/// Why a width cannot be given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum WidthError {
    /// The cutter cuts below the surface by `depth` mm at the contact.
    Gouge { depth: f64 },
}

/// Residual left within this fraction of h below zero still counts as touching,
/// not gouging (round-off where the cutter and surface curvatures match).
const GOUGE_SLACK: f64 = 1e-3;

impl Cutter {
    /// The cutter of a milling job (flat-end or ball). A negative lead angle is
    /// rejected: the heel would cut.
    pub fn from_job(job: &Job) -> Result<Self> {
        let lead = job.lead_angle();
        match job.tool {
            Tool::FlatEnd { radius, .. } => {
                if lead < 0.0 {
                    return Err(Error::invalid(
                        "lead_angle_deg",
                        format!(
                            "{} deg: a flat-end cutter needs a lead angle >= 0 (the heel would cut)",
                            job.lead_angle_deg.unwrap_or(0.0)
                        ),
                    ));
                }
                Ok(Self {
                    radius,
                    lead,
                    ball: false,
                })
            }
            Tool::Ball { radius, .. } => Ok(Self {
                radius,
                lead: 0.0,
                ball: true,
            }),
            other => Err(Error::invalid(
                "tool.kind",
                format!(
                    "strategy {} plans flat-end and ball cutters, not a {} tool",
                    job.strategy.name(),
                    other.kind()
                ),
            )),
        }
    }

    /// Effective curvature of the cutting profile across the feed: sin(lambda)/R
    /// for the flat end, 1/R for the ball.
    pub fn k_b(&self) -> f64 {
        if self.ball {
            1.0 / self.radius
        } else {
            self.lead.sin() / self.radius
        }
    }

    /// Tool pose for contact `cc` with unit normal `n` and unit travel
    /// direction `t` (tangent): (cl = tool tip, unit axis). The flat end is
    /// tilted by lambda about the cross-feed so that its front bottom edge
    /// touches cc and the heel is lifted: axis = cos(l) n + sin(l) t and the
    /// centre of the bottom disc is cc - R d with d = cos(l) t - sin(l) n.
    pub fn pose(
        &self,
        cc: Point3<f64>,
        n: Vector3<f64>,
        t: Vector3<f64>,
    ) -> (Point3<f64>, Vector3<f64>) {
        if self.ball {
            // Tip = ball centre - R axis, axis along the normal.
            return (cc, n);
        }
        let (s, c) = self.lead.sin_cos();
        let axis = n * c + t * s;
        let d = t * c - n * s;
        (cc - d * self.radius, axis)
    }

    /// Edge point at parameter phi in 0..=pi/2 in the local frame of the contact:
    /// (x along the feed, |y| across it, z along the normal); `lead_sc` is
    /// (sin, cos) of the lead angle (computed once per width).
    fn edge(&self, phi: f64, lead_sc: (f64, f64)) -> (f64, f64, f64) {
        let (s, c) = phi.sin_cos();
        let r = self.radius;
        if self.ball {
            (0.0, r * s, r * (1.0 - c))
        } else {
            let one_minus = if phi < 1e-4 { 0.5 * phi * phi } else { 1.0 - c };
            (-r * one_minus * lead_sc.1, r * s, r * lead_sc.0 * one_minus)
        }
    }

    /// Edge point at phi on side `side` and the surface height under it,
    /// in the contact's frame: (|y|, y, z of the edge above the surface
    /// along the feed).
    fn edge_over_surface(
        &self,
        phi: f64,
        side: f64,
        k: Curvatures,
        lead_sc: (f64, f64),
    ) -> (f64, f64, f64) {
        let (x, ya, z0) = self.edge(phi, lead_sc);
        let y = side * ya;
        // Height of the surface under the edge point from its curvature along
        // the feed and its twist (the point is behind the contact).
        let z = z0 - 0.5 * k.feed * x * x - k.twist * x * y;
        (ya, y, z)
    }

    /// Residual height from the contact at edge parameter phi, on side
    /// `side` (+1 towards n x t, -1 away).
    fn residual(&self, phi: f64, side: f64, k: Curvatures, lead_sc: (f64, f64)) -> f64 {
        let (_, y, z) = self.edge_over_surface(phi, side, k, lead_sc);
        let kc = k.cross;
        let q = kc * kc * (y * y + z * z) - 2.0 * kc * z;
        let root = (1.0 + q).max(0.0).sqrt();
        (2.0 * z - kc * (y * y + z * z)) / (1.0 + root)
    }

    /// Surface arc length across the feed from the contact to under the
    /// edge point at phi.
    fn arc(&self, phi: f64, side: f64, k: Curvatures, lead_sc: (f64, f64)) -> f64 {
        let (ya, _, z) = self.edge_over_surface(phi, side, k, lead_sc);
        let kc = k.cross;
        if kc.abs() < 1e-12 {
            ya
        } else {
            (kc * ya).atan2(1.0 - kc * z) / kc
        }
    }

    /// Half-width of a pass on side `side` (+1 towards n x t) for scallop `h`:
    /// the arc length on the surface from the contact to where the residual
    /// reaches h. Limited to the cutter radius where the residual stays below h.
    pub fn half_width(
        &self,
        h: f64,
        k: Curvatures,
        side: f64,
    ) -> std::result::Result<f64, WidthError> {
        const SAMPLES: usize = 24;
        let top = std::f64::consts::FRAC_PI_2;
        let lead_sc = self.lead.sin_cos();
        let (mut prev, mut f_prev) = (0.0, -h);
        for i in 1..=SAMPLES {
            let phi = top * i as f64 / SAMPLES as f64;
            let r = self.residual(phi, side, k, lead_sc);
            if r < -GOUGE_SLACK * h {
                return Err(WidthError::Gouge { depth: -r });
            }
            if r >= h {
                let at = crossing(
                    |phi| self.residual(phi, side, k, lead_sc) - h,
                    (prev, f_prev),
                    (phi, r - h),
                );
                return Ok(self.arc(at, side, k, lead_sc));
            }
            (prev, f_prev) = (phi, r - h);
        }
        Ok(self.arc(top, side, k, lead_sc))
    }

    /// Full strip width (both sides) for scallop h.
    pub fn strip_width(&self, h: f64, k: Curvatures) -> std::result::Result<f64, WidthError> {
        Ok(self.half_width(h, k, 1.0)? + self.half_width(h, k, -1.0)?)
    }

    /// Largest depth (mm) by which the bottom disc dips below the local
    /// quadric of the surface at a contact, 0 when it stays clear. The disc
    /// height above the tangent plane is -x tan(lambda) over its projected
    /// ellipse; the surface is 1/2 (kf x^2 + 2 tw x y + kc y^2).
    pub fn disc_gouge(&self, k: Curvatures) -> f64 {
        if self.ball {
            let worst = k.feed.max(k.cross) + k.twist.abs();
            return if worst > 1.0 / self.radius {
                (worst * self.radius - 1.0) * self.radius
            } else {
                0.0
            };
        }
        let (s, c) = self.lead.sin_cos();
        let r = self.radius;
        let mut depth = 0.0f64;
        for i in 1..=4 {
            let rho = r * i as f64 / 4.0;
            for j in 0..32 {
                let a = std::f64::consts::TAU * j as f64 / 32.0;
                let x = (rho * a.cos() - r) * c;
                let y = rho * a.sin();
                let disc = -x * s / c;
                let surf = 0.5 * (k.feed * x * x + 2.0 * k.twist * x * y + k.cross * y * y);
                depth = depth.max(surf - disc);
            }
        }
        depth
    }
}

/// Normal curvatures at `g` in the frame of the unit tangent `t` (3-D).
pub fn curvatures_along(g: &LocalGeometry, t: Vector3<f64>) -> Curvatures {
    let c = g.n.cross(&t);
    let tu = g.tangent_to_uv(t);
    let cu = g.tangent_to_uv(c);
    let ii = |a: Vector2<f64>, b: Vector2<f64>| (a.transpose() * g.second * b)[0];
    let i1 = |a: Vector2<f64>| (a.transpose() * g.first * a)[0];
    let (nt, nc) = (i1(tu).sqrt(), i1(cu).sqrt());
    Curvatures {
        feed: ii(tu, tu) / (nt * nt),
        twist: ii(tu, cu) / (nt * nc),
        cross: ii(cu, cu) / (nc * nc),
    }
}

/// The strip-width tensor H = 1/2 (K_b G - D) in parameter coordinates.
pub fn tensor_h(g: &LocalGeometry, k_b: f64) -> Matrix2<f64> {
    (g.first * k_b - g.second) * 0.5
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
pub struct FieldSample {
    /// Optimal feed (largest mu) in parameter space, scaled to a unit 3-D tangent.
    pub feed_uv: Vector2<f64>,
    /// Unit 3-D feed and cross-feed (n x feed).
    pub feed: Vector3<f64>,
    pub cross: Vector3<f64>,
    /// Generalised eigenvalues, mu_feed >= mu_cross.
    pub mu_feed: f64,
    pub mu_cross: f64,
}

/// Optimal feed from the generalised eigenproblem H t = mu G t, solved as the
/// right eigenvector of G^-1 H (a vector, not the covector G t). `None` where
/// the two eigenvalues coincide (a degenerate point: every direction is optimal).
pub fn feed_at(g: &LocalGeometry, k_b: f64) -> Option<FieldSample> {
    let gi = g.first.try_inverse()?;
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
        cross: g.n.cross(&feed),
        mu_feed: mu,
        mu_cross: mean - disc,
    })
}

/// Deviator of the field in the orthonormal Cholesky frame of the tangent
/// plane: S = L^-1 H L^-T, e = (S11 - S22)/2, f = S12. Degenerate points are
/// where e = f = 0 (T = mu I), independent of K_b. The major eigenvector of S
/// (the feed) is at angle atan2(f, e)/2 in that frame; a frame vector y maps
/// to the parameter-space direction L^-T y.
pub fn deviator(g: &LocalGeometry) -> Option<(f64, f64, Matrix2<f64>)> {
    let li = cholesky_inverse(&g.first)?;
    // K_b only shifts S by a multiple of I, so it does not enter e and f.
    let s = li * tensor_h(g, 0.0) * li.transpose();
    Some((
        0.5 * (s[(0, 0)] - s[(1, 1)]),
        0.5 * (s[(0, 1)] + s[(1, 0)]),
        li,
    ))
}

/// The widest single-pass strip width at a point (over the feed directions;
/// the principal directions are its stationary points, so both are tried) and
/// the feed that gives it.
pub fn max_strip_width(
    cutter: &Cutter,
    h: f64,
    g: &LocalGeometry,
) -> std::result::Result<(f64, Vector3<f64>), WidthError> {
    let mut best: Option<(f64, Vector3<f64>)> = None;
    let mut err = None;
    for t in [g.dir_min, g.dir_max] {
        match cutter.strip_width(h, curvatures_along(g, t)) {
            Ok(w) => {
                if best.is_none_or(|(bw, _)| w > bw) {
                    best = Some((w, t));
                }
            }
            Err(e) => err = Some(e),
        }
    }
    match (best, err) {
        (Some(b), _) => Ok(b),
        (None, Some(e)) => Err(e),
        (None, None) => Err(WidthError::Gouge { depth: 0.0 }),
    }
}

/// The planning error for a cutter that gouges at `uv` with curvature `kappa`
/// across the feed.
pub fn gouge_error(cutter: &Cutter, uv: [f64; 2], kappa: f64, depth: f64) -> Error {
    let r = cutter.radius;
    let need = if cutter.ball || kappa * r >= 1.0 {
        format!(
            "no lead angle avoids gouging (concave radius {:.3} mm is smaller than the cutter radius {r} mm): use a smaller tool",
            1.0 / kappa.max(1e-300)
        )
    } else {
        format!(
            "a lead angle of at least {:.2} deg is needed (lead_angle_deg is {:.2})",
            (kappa * r).asin().to_degrees(),
            cutter.lead.to_degrees()
        )
    };
    Error::planning(format!(
        "tool too large for the curvature at uv ({:.4}, {:.4}): the cutter dips {depth:.4} mm below the surface (concave curvature {kappa:.5} 1/mm across the feed, the cutter's effective curvature is {:.5} 1/mm); {need}",
        uv[0],
        uv[1],
        cutter.k_b()
    ))
}

/// Gauss-Legendre nodes and weights on [0, 1], 3 points.
const GAUSS3: [(f64, f64); 3] = [
    (0.112_701_665_379_258_3, 5.0 / 18.0),
    (0.5, 8.0 / 18.0),
    (0.887_298_334_620_741_7, 5.0 / 18.0),
];

/// [`path_length_lower_bound`] of a milling job at its own scallop, on the
/// grid every strip-width planner reports it with.
pub fn job_path_length_lower_bound(
    job: &Job,
    surface: &NurbsSurface,
    cutter: &Cutter,
) -> Result<f64> {
    path_length_lower_bound(surface, cutter, job.scallop()?, super::LOWER_BOUND_CELLS)
}

/// Lower bound of the path length for scallop h: the integral over the
/// surface of dA / w_max(p). No set of passes can be shorter, since each unit
/// of length clears at most w_max of area. `cells` per parameter direction.
pub fn path_length_lower_bound(
    surface: &NurbsSurface,
    cutter: &Cutter,
    h: f64,
    cells: usize,
) -> Result<f64> {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let (du, dv) = ((u1 - u0) / cells as f64, (v1 - v0) / cells as f64);
    let mut total = 0.0;
    for i in 0..cells {
        for j in 0..cells {
            for &(a, wa) in &GAUSS3 {
                for &(b, wb) in &GAUSS3 {
                    let (u, v) = (u0 + (i as f64 + a) * du, v0 + (j as f64 + b) * dv);
                    let Some(g) = LocalGeometry::at(surface, u, v) else {
                        continue;
                    };
                    let w = match max_strip_width(cutter, h, &g) {
                        Ok((w, _)) => w,
                        Err(WidthError::Gouge { depth }) => {
                            return Err(gouge_error(cutter, [u, v], g.k_max, depth));
                        }
                    };
                    total += wa * wb * du * dv * g.area_element() / w;
                }
            }
        }
    }
    Ok(total)
}

/// Root of `f` between `a` (f < 0) and `b` (f >= 0) by the Illinois
/// variant of regula falsi: superlinear on the smooth residual profile,
/// bracketed like bisection (to 1e-13 rad).
fn crossing(f: impl Fn(f64) -> f64, a: (f64, f64), b: (f64, f64)) -> f64 {
    let ((mut x0, mut f0), (mut x1, mut f1)) = (a, b);
    let mut side = 0i8;
    for _ in 0..64 {
        if (x1 - x0).abs() < 1e-13 {
            break;
        }
        let x = if f1 != f0 {
            (x0 * f1 - x1 * f0) / (f1 - f0)
        } else {
            0.5 * (x0 + x1)
        };
        let x = if x > x0.min(x1) && x < x0.max(x1) {
            x
        } else {
            0.5 * (x0 + x1)
        };
        let fx = f(x);
        if fx == 0.0 {
            return x;
        }
        if fx < 0.0 {
            (x0, f0) = (x, fx);
            if side == -1 {
                f1 *= 0.5;
            }
            side = -1;
        } else {
            (x1, f1) = (x, fx);
            if side == 1 {
                f0 *= 0.5;
            }
            side = 1;
        }
    }
    0.5 * (x0 + x1)
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: f64 = 2.5;
    const H: f64 = 0.05;

    fn flat() -> Cutter {
        Cutter {
            radius: R,
            lead: 5f64.to_radians(),
            ball: false,
        }
    }

    /// Independent reference: the swept disc of a tilted flat end, sampled as
    /// a point cloud, against a flat or cylindrical surface across the feed.
    /// For each lateral offset the lowest disc point over all positions along
    /// the feed gives the cut profile; the width is where it reaches h above
    /// the surface (measured along the normal of the cross-section circle).
    fn brute_force_width(rho: Option<f64>) -> f64 {
        let lam = 5f64.to_radians();
        let (s, c) = lam.sin_cos();
        let n = 40000;
        let mut best = 0.0f64;
        // Lateral bins of the swept silhouette: the disc edge is the lowest.
        for i in 0..=n {
            let phi = std::f64::consts::PI * i as f64 / n as f64 - std::f64::consts::FRAC_PI_2;
            // Disc edge in tool frame, disc centre at the origin, axis tilted by lam.
            let (ex, ey) = (R * phi.cos(), R * phi.sin());
            // World: x along feed, z up; contact at the front (ex = R) is the lowest.
            let z = -ex * s + R * s; // height above the contact plane
            let y = ey;
            let _ = c;
            let resid = match rho {
                None => z,
                Some(rho) => rho - (y * y + (rho - z) * (rho - z)).sqrt(),
            };
            if resid <= H {
                let arc = match rho {
                    None => y.abs(),
                    Some(rho) => rho * y.abs().atan2(rho - z),
                };
                best = best.max(arc);
            }
        }
        2.0 * best
    }

    #[test]
    fn plane_width_matches_the_closed_form() {
        let k = Curvatures {
            feed: 0.0,
            twist: 0.0,
            cross: 0.0,
        };
        let w = flat().strip_width(H, k).unwrap();
        let lam = 5f64.to_radians();
        let exact = 2.0 * R * (1.0 - (1.0 - H / (R * lam.sin())).powi(2)).sqrt();
        assert!((w - 3.18704).abs() / 3.18704 < 0.005, "{w}");
        assert!((w - exact).abs() < 1e-6, "{w} vs {exact}");
        assert!((w - brute_force_width(None)).abs() < 2e-3, "{w}");
        // The quadratic estimate is wider: the reason it is not used.
        let w2 = 2.0 * (2.0 * H / flat().k_b()).sqrt();
        assert!((w2 - 3.38729).abs() < 1e-4 && w2 > w * 1.06);
    }

    #[test]
    fn concave_cylinder_width_matches_methods_reference() {
        let k = Curvatures {
            feed: 0.0,
            twist: 0.0,
            cross: 0.01,
        };
        let w = flat().strip_width(H, k).unwrap();
        assert!((w - 3.58875).abs() / 3.58875 < 0.005, "{w}");
        assert!((w - brute_force_width(Some(100.0))).abs() < 2e-3, "{w}");
    }

    #[test]
    fn convex_surfaces_give_narrower_strips_and_tool_radius_caps() {
        let w = |cross| {
            flat()
                .strip_width(
                    H,
                    Curvatures {
                        feed: 0.0,
                        twist: 0.0,
                        cross,
                    },
                )
                .unwrap()
        };
        assert!(w(-0.01) < w(0.0) && w(0.0) < w(0.01) && w(0.01) < w(0.03));
        // Nearly matching curvature: wider still, but never beyond the cutter.
        assert!(w(0.0345) > w(0.03) && w(0.0345) <= 2.0 * R * 1.01);
    }

    #[test]
    fn too_concave_gouges() {
        let k = Curvatures {
            feed: 0.0,
            twist: 0.0,
            cross: 0.05,
        };
        assert!(matches!(
            flat().strip_width(H, k),
            Err(WidthError::Gouge { .. })
        ));
        assert!(flat().disc_gouge(k) > 0.0);
        let ok = Curvatures {
            feed: 0.01,
            twist: 0.0,
            cross: 0.01,
        };
        assert_eq!(flat().disc_gouge(ok), 0.0);
    }

    #[test]
    fn pose_puts_the_lowest_disc_point_on_cc() {
        let c = flat();
        let n = Vector3::new(0.0, 0.3, 1.0).normalize();
        let t = Vector3::new(1.0, 0.0, 0.0);
        let cc = Point3::new(1.0, 2.0, 3.0);
        let (cl, axis) = c.pose(cc, n, t);
        assert!((axis.norm() - 1.0).abs() < 1e-12);
        assert!((axis.dot(&t) - 5f64.to_radians().sin()).abs() < 1e-12);
        // Disc: cl + R (cos a e1 + sin a e2), e1, e2 perpendicular to the axis.
        let e2 = axis.cross(&t).normalize();
        let e1 = e2.cross(&axis);
        let mut lowest = (f64::INFINITY, Point3::origin());
        for i in 0..3600 {
            let a = std::f64::consts::TAU * i as f64 / 3600.0;
            let p = cl + (e1 * a.cos() + e2 * a.sin()) * R;
            let hgt = (p - cc).dot(&n);
            if hgt < lowest.0 {
                lowest = (hgt, p);
            }
        }
        assert!(
            lowest.0.abs() < 1e-9 && (lowest.1 - cc).norm() < 1e-2,
            "{lowest:?}"
        );
    }

    /// Feed = minimum normal curvature direction, found by brute force over
    /// 3-D tangent directions from the closed-form paraboloid, on a sheared
    /// (non-orthogonal) parametrisation where the covector mix-up shows.
    #[test]
    fn feed_is_the_min_curvature_direction_on_a_sheared_parametrisation() {
        let (a, b) = (0.002, 0.008);
        let s = crate::planners::test_surfaces::sheared_paraboloid(a, b);
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
            let m = tensor_h(&g, k_b) * g.first.try_inverse().unwrap();
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

    #[test]
    fn lower_bound_of_a_plane_is_area_over_width() {
        let s = crate::planners::test_surfaces::sheared_plane();
        let lb = path_length_lower_bound(&s, &flat(), H, 8).unwrap();
        assert!((lb - 10000.0 / 3.18704).abs() / lb < 1e-3, "{lb}");
    }
}
