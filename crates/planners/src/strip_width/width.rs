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

use nalgebra::{Vector2, Vector3};
use toolpath_formats::Job;
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::{FundamentalForms, LocalGeometry};
pub use toolpath_kernel::tools::{Curvatures, WidthError};
use toolpath_kernel::tools::{LeadCutter, LeadCutterError};

/// The posed cutter of a milling job (flat-end or ball). A negative lead angle
/// is refused: the heel would cut.
pub(crate) fn cutter_of_job(job: &Job) -> Result<LeadCutter> {
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

/// Normal curvatures at `g` in the frame of the unit tangent `t` (3-D).
pub(crate) fn curvatures_along(g: &FundamentalForms, t: Vector3<f64>) -> Curvatures {
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
pub(crate) fn max_strip_width(
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
pub(crate) fn gouge_error(cutter: &LeadCutter, uv: [f64; 2], kappa: f64, depth: f64) -> Error {
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
