//! The machining-strip-width tensor field of a flat-end (or ball) cutter with a
//! fixed lead angle and zero side tilt, and the exact strip width of one pass
//! from the cutter's real profile (docs/methods.md, "Strip width of a tilted
//! flat end" and "Feed direction field").
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
//!   The quadratic estimate W2 is not used: it is wider than the real strip
//!   (docs/methods.md, "Strip width of a tilted flat end";
//!   `plane_width_matches_the_closed_form`).

use crate::error::{Error, Result};
use crate::formats::Job;
use crate::geometry::numeric::newton_root;
use crate::geometry::{FundamentalForms, LocalGeometry};
use crate::tools::{LeadCutter, LeadCutterError};
use nalgebra::{Vector2, Vector3};
use std::sync::LazyLock;

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

/// The posed cutter of a milling job (flat-end or ball). A negative lead angle
/// is refused: the heel would cut.
pub fn cutter_of_job(job: &Job) -> Result<LeadCutter> {
    LeadCutter::from_tool(job.tool()?, job.lead_angle()).map_err(|e| match e {
        LeadCutterError::NegativeLead => Error::invalid(
            "lead_angle_deg",
            format!(
                "{} deg: a flat-end cutter needs a lead angle >= 0 (the heel would cut)",
                job.lead_angle_deg.unwrap_or(0.0)
            ),
        ),
        LeadCutterError::UnsupportedKind(kind) => Error::invalid(
            "tool.kind",
            format!(
                "strategy {} plans flat-end and ball cutters, not a {kind} tool",
                job.strategy.name()
            ),
        ),
    })
}

/// The strip-width model of the posed cutter.
impl LeadCutter {
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
        self.edge_over_surface_sc(phi, phi.sin_cos(), side, k, lead_sc)
    }

    /// [`Self::edge_over_surface`] with `phi_sc` = phi.sin_cos() given.
    fn edge_over_surface_sc(
        &self,
        phi: f64,
        phi_sc: (f64, f64),
        side: f64,
        k: Curvatures,
        lead_sc: (f64, f64),
    ) -> (f64, f64, f64) {
        let (x, ya, z0) = self.edge_sc(phi, phi_sc, lead_sc);
        let y = side * ya;
        // Height of the surface under the edge point from its curvature along
        // the feed and its twist (the point is behind the contact).
        let z = z0 - 0.5 * k.feed * x * x - k.twist * x * y;
        (ya, y, z)
    }

    /// Residual height from the contact at edge parameter phi, on side
    /// `side` (+1 towards n x t, -1 away), with `phi_sc` = phi.sin_cos().
    fn residual_sc(
        &self,
        phi: f64,
        phi_sc: (f64, f64),
        side: f64,
        k: Curvatures,
        lead_sc: (f64, f64),
    ) -> f64 {
        let (_, y, z) = self.edge_over_surface_sc(phi, phi_sc, side, k, lead_sc);
        let kc = k.cross;
        let q = kc * kc * (y * y + z * z) - 2.0 * kc * z;
        let root = (1.0 + q).max(0.0).sqrt();
        (2.0 * z - kc * (y * y + z * z)) / (1.0 + root)
    }

    /// The edge point of [`Self::edge_over_surface`] in the half-angle
    /// parameter t = tan(phi / 2), where sin phi = 2 t / (1 + t^2) and
    /// 1 - cos phi = 2 t^2 / (1 + t^2): no trigonometry, and no cancellation
    /// near the contact. With the derivatives in t:
    /// ((|y|, y, z), (d|y|, dy, dz)).
    fn edge_over_surface_half_angle(
        &self,
        t: f64,
        side: f64,
        k: Curvatures,
        lead_sc: (f64, f64),
    ) -> ([f64; 3], [f64; 3]) {
        let d = 1.0 / (1.0 + t * t);
        let (s, c, one_minus) = (2.0 * t * d, (1.0 - t * t) * d, 2.0 * t * t * d);
        // dphi/dt = 2 / (1 + t^2).
        let (ds, d_one_minus) = (2.0 * c * d, 2.0 * s * d);
        let r = self.radius;
        let (x, dx, z0, dz0) = if self.ball {
            (0.0, 0.0, r * one_minus, r * d_one_minus)
        } else {
            let (sl, cl) = lead_sc;
            (
                -r * one_minus * cl,
                -r * d_one_minus * cl,
                r * sl * one_minus,
                r * sl * d_one_minus,
            )
        };
        let (ya, dya) = (r * s, r * ds);
        let (y, dy) = (side * ya, side * dya);
        let z = z0 - 0.5 * k.feed * x * x - k.twist * x * y;
        let dz = dz0 - k.feed * x * dx - k.twist * (dx * y + x * dy);
        ([ya, y, z], [dya, dy, dz])
    }

    /// [`Self::residual_sc`] at half-angle t (see
    /// [`Self::edge_over_surface_half_angle`]) and its derivative in t:
    /// with rho^2 = 1 + kappa_c^2 (y^2 + z^2) - 2 kappa_c z the residual is
    /// (1 - rho) / kappa_c, so its derivative is (z' - kappa_c (y y' + z z')) / rho.
    fn residual_half_angle(
        &self,
        t: f64,
        side: f64,
        k: Curvatures,
        lead_sc: (f64, f64),
    ) -> (f64, f64) {
        let ([_, y, z], [_, dy, dz]) = self.edge_over_surface_half_angle(t, side, k, lead_sc);
        let kc = k.cross;
        let q = kc * kc * (y * y + z * z) - 2.0 * kc * z;
        let root = (1.0 + q).max(0.0).sqrt();
        let residual = (2.0 * z - kc * (y * y + z * z)) / (1.0 + root);
        (residual, (dz - kc * (y * dy + z * dz)) / root)
    }

    /// Surface arc length across the feed from the contact to under the
    /// edge point at phi.
    fn arc(&self, phi: f64, side: f64, k: Curvatures, lead_sc: (f64, f64)) -> f64 {
        let (ya, _, z) = self.edge_over_surface(phi, side, k, lead_sc);
        arc_to(ya, z, k.cross)
    }

    /// [`Self::arc`] at half-angle t.
    fn arc_half_angle(&self, t: f64, side: f64, k: Curvatures, lead_sc: (f64, f64)) -> f64 {
        let ([ya, _, z], _) = self.edge_over_surface_half_angle(t, side, k, lead_sc);
        arc_to(ya, z, k.cross)
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
        let top = std::f64::consts::FRAC_PI_2;
        let lead_sc = self.lead.sin_cos();
        let (mut prev, mut f_prev) = (0.0, -h);
        let mut before: Option<(f64, f64)> = None;
        for &(phi, phi_sc, t) in EDGE_SAMPLES.iter().skip(1) {
            let r = self.residual_sc(phi, phi_sc, side, k, lead_sc);
            if r < -GOUGE_SLACK * h {
                return Err(WidthError::Gouge { depth: -r });
            }
            if r >= h {
                // Newton in the half-angle t (no trigonometry per step) until
                // a step is below 1e-8: the residual profile is smooth, so the
                // root is then exact to the last bits, after about 2 steps
                // from the inverse quadratic through the last three samples.
                let start = before
                    .map(|(t0, f0)| inverse_quadratic([(t0, f0), (prev, f_prev), (t, r - h)]));
                let at = newton_root(
                    |t| {
                        let (r, dr) = self.residual_half_angle(t, side, k, lead_sc);
                        (r - h, dr)
                    },
                    (prev, f_prev),
                    (t, r - h),
                    start,
                    1e-8,
                    64,
                );
                return Ok(self.arc_half_angle(at, side, k, lead_sc));
            }
            before = Some((prev, f_prev));
            (prev, f_prev) = (t, r - h);
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
        // A disc point has x = (rho cos a - r) c <= 0, |x| <= 2 r c, |y| <= r
        // and y^2 <= r^2 - (rho cos a)^2 <= 2 r |x| / c, so surf - disc <=
        // |x| (kf+ r c + |tw| r + kc+ r / c - s / c): where that bracket is
        // <= 0 the disc clears the quadric and every sample gives <= 0.
        let bound = k.feed.max(0.0) * r * c + k.twist.abs() * r + k.cross.max(0.0) * r / c - s / c;
        if bound <= 0.0 {
            return 0.0;
        }
        self.disc_gouge_sampled(k)
    }

    /// [`Self::disc_gouge`] from its samples alone: 4 radii x 32 angles.
    fn disc_gouge_sampled(&self, k: Curvatures) -> f64 {
        let (s, c) = self.lead.sin_cos();
        let r = self.radius;
        let mut depth = 0.0f64;
        for i in 1..=4 {
            let rho = r * i as f64 / 4.0;
            for &(sin_a, cos_a) in DISC_ANGLES.iter() {
                let x = (rho * cos_a - r) * c;
                let y = rho * sin_a;
                let disc = -x * s / c;
                let surf = 0.5 * (k.feed * x * x + 2.0 * k.twist * x * y + k.cross * y * y);
                depth = depth.max(surf - disc);
            }
        }
        depth
    }
}

/// phi, (sin phi, cos phi) and tan(phi / 2).
type EdgeSample = (f64, (f64, f64), f64);

/// Samples of the edge parameter in [`LeadCutter::half_width`]: phi_i =
/// pi/2 i / 24, i = 0..=24, with phi_i.sin_cos() and the half-angle
/// tan(phi_i / 2) (computed once: the width is asked for at every contact of
/// every pass, and the trigonometry was most of its cost).
static EDGE_SAMPLES: LazyLock<[EdgeSample; 25]> = LazyLock::new(|| {
    std::array::from_fn(|i| {
        let phi = std::f64::consts::FRAC_PI_2 * i as f64 / 24.0;
        let (s, c) = phi.sin_cos();
        (phi, (s, c), s / (1.0 + c))
    })
});

/// Where the parabola x(f) through three points (x_i, f_i) with distinct
/// f_i crosses f = 0 (Lagrange's form at f = 0); NaN or infinite for equal
/// values (the root finder then starts at the chord's crossing).
fn inverse_quadratic([(x0, f0), (x1, f1), (x2, f2)]: [(f64, f64); 3]) -> f64 {
    x0 * f1 * f2 / ((f0 - f1) * (f0 - f2))
        + x1 * f0 * f2 / ((f1 - f0) * (f1 - f2))
        + x2 * f0 * f1 / ((f2 - f0) * (f2 - f1))
}

/// Arc length on the osculating circle of curvature `kc` across the feed
/// from the contact to the foot of the edge point (|y|, z).
fn arc_to(ya: f64, z: f64, kc: f64) -> f64 {
    if kc.abs() < 1e-12 {
        ya
    } else {
        (kc * ya).atan2(1.0 - kc * z) / kc
    }
}

/// (sin a, cos a) of the 32 angles a_j = 2 pi j / 32 at which
/// [`LeadCutter::disc_gouge`] samples the disc.
static DISC_ANGLES: LazyLock<[(f64, f64); 32]> = LazyLock::new(|| {
    std::array::from_fn(|j| {
        let a = std::f64::consts::TAU * j as f64 / 32.0;
        (a.sin(), a.cos())
    })
});

/// Normal curvatures at `g` in the frame of the unit tangent `t` (3-D).
pub fn curvatures_along(g: &FundamentalForms, t: Vector3<f64>) -> Curvatures {
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

/// The widest single-pass strip width at a point (over the feed directions;
/// the principal directions are its stationary points, so both are tried) and
/// the feed that gives it.
pub fn max_strip_width(
    cutter: &LeadCutter,
    h: f64,
    g: &LocalGeometry,
) -> std::result::Result<(f64, Vector3<f64>), WidthError> {
    let mut best: Option<(f64, Vector3<f64>)> = None;
    let mut err = None;
    for t in [g.dir_min, g.dir_max] {
        match cutter.strip_width(h, curvatures_along(&g.forms, t)) {
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
pub fn gouge_error(cutter: &LeadCutter, uv: [f64; 2], kappa: f64, depth: f64) -> Error {
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

#[cfg(test)]
mod tests {
    use super::*;

    const R: f64 = 2.5;
    const H: f64 = 0.05;

    fn flat() -> LeadCutter {
        LeadCutter {
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

    /// The half-width against bisection on the residual in phi itself (with
    /// phi.sin_cos(), not the half-angle form the width's Newton steps use),
    /// for random curvatures, both sides, flat end and ball: the same root
    /// to 1e-12 mm. The plane's also against its closed form.
    #[test]
    fn half_width_is_the_root_of_the_residual_in_phi() {
        let mut rng = crate::geometry::test_rng::XorShift(0x5eed_0f1d_7e57_u64);
        let mut checked = 0;
        for case in 0..400 {
            let cutter = LeadCutter {
                ball: case % 4 == 3,
                ..flat()
            };
            let mut curv = |scale: f64| scale * (2.0 * rng.unit() - 1.0);
            let k = Curvatures {
                feed: curv(0.03),
                twist: curv(0.015),
                cross: curv(0.03),
            };
            let lead_sc = cutter.lead.sin_cos();
            for side in [1.0, -1.0] {
                let Ok(w) = cutter.half_width(H, k, side) else {
                    continue;
                };
                let g = |phi: f64| cutter.residual_sc(phi, phi.sin_cos(), side, k, lead_sc) - H;
                let (mut lo, mut hi) = (0.0, std::f64::consts::FRAC_PI_2);
                if g(hi) < 0.0 {
                    continue;
                }
                // The first crossing: step out from the contact.
                let mut a = 0.0;
                while g(a + 1e-3) < 0.0 {
                    a += 1e-3;
                }
                (lo, hi) = (a.max(lo), (a + 1e-3).min(hi));
                for _ in 0..200 {
                    let mid = 0.5 * (lo + hi);
                    if g(mid) < 0.0 {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                let exact = cutter.arc(0.5 * (lo + hi), side, k, lead_sc);
                assert!(
                    (w - exact).abs() < 1e-12,
                    "case {case} side {side}: {w} vs {exact}"
                );
                checked += 1;
            }
        }
        assert!(checked > 500, "{checked} widths checked");
        let plane = Curvatures {
            feed: 0.0,
            twist: 0.0,
            cross: 0.0,
        };
        let lam = 5f64.to_radians();
        let exact = R * (1.0 - (1.0 - H / (R * lam.sin())).powi(2)).sqrt();
        assert!((flat().half_width(H, plane, 1.0).unwrap() - exact).abs() < 1e-13);
    }

    /// The disc's clearance bound never hides a sampled dip: on random
    /// curvatures (many past the bound) disc_gouge equals its samples'
    /// maximum, and is 0 wherever the bound lets it skip them.
    #[test]
    fn disc_gouge_bound_agrees_with_the_samples() {
        let mut rng = crate::geometry::test_rng::XorShift(0x00d1_5c06_006e);
        let (mut skipped, mut dipping) = (0, 0);
        for case in 0..2000 {
            let scale = [0.005, 0.02, 0.08][case % 3];
            let mut curv = || scale * (2.0 * rng.unit() - 1.0);
            let k = Curvatures {
                feed: curv(),
                twist: curv(),
                cross: curv(),
            };
            let sampled = flat().disc_gouge_sampled(k);
            assert_eq!(flat().disc_gouge(k), sampled.max(0.0), "{k:?}");
            skipped += usize::from(sampled <= 0.0);
            dipping += usize::from(sampled > 1e-3 * H);
        }
        assert!(
            skipped > 500 && dipping > 100,
            "{skipped} clear, {dipping} dipping"
        );
    }
}
