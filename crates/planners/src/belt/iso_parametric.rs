//! Strategy `belt_iso_parametric` (the belt-grinding paper's algorithm 1;
//! docs/methods.md, "Belt paths"): contact paths along iso-parameter curves,
//! feed along `u` or `v` (`job.feed_direction`, default `u`). Starting at the
//! low edge of the other parameter, each next curve is the smallest parameter
//! reached by the next-contact search of the belt contact model from every
//! point of the current curve (the most conservative candidate), within one
//! belt width; a last curve runs along the far edge.

use super::contact::{self, BeltSpec};
use crate::refine::Refinement;
use crate::Progress;
use nalgebra::{Vector2, Vector3};
use toolpath_formats::{FeedDirection, Job, PlanResult};
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::{LocalGeometry, NurbsSurface};

/// Passes beyond this mean the step collapsed (bad geometry), not a real plan.
const MAX_PASSES: usize = 20_000;

/// The strategy `belt_iso_parametric`.
pub(crate) static BELT_ISO_PARAMETRIC: super::BeltStrategy = super::BeltStrategy {
    id: toolpath_formats::Strategy::BeltIsoParametric,
    levels: crate::strategy::PathLevels::CrossParameter,
    plan_with,
};

/// The plan as refined by the removal simulation (`crate::refine`): steps
/// aiming below h where it found material left, more paths on the
/// iso-curves at its added cross parameters.
pub(crate) fn plan_with(
    job: &Job,
    progress: &dyn Progress,
    refinement: &Refinement,
) -> Result<PlanResult> {
    let surface = job.surface()?;
    let spec = BeltSpec::from_job(job)?;
    let feed_dir = job.feed_direction.unwrap_or(FeedDirection::U);
    let mut result = PlanResult::new(&job.job_id, job.strategy.name());
    let (mut paths, mut diag) = plan_paths(surface, &spec, feed_dir, refinement, progress)?;
    let feed_u = feed_dir == FeedDirection::U;
    let ((u0, u1), (v0, v1)) = surface.domain();
    let (c0, c1) = if feed_u { (v0, v1) } else { (u0, u1) };
    let (feed, hint) = frames(feed_u);
    for &c in &refinement.added {
        if !(c0..=c1).contains(&c) {
            continue;
        }
        let uvs = iso_curve(surface, feed_u, c, contact::point_spacing(&spec));
        let path = contact::analyse_path(surface, &uvs, &feed, &hint, &spec, false, &mut diag);
        paths.push((c, path));
    }
    contact::assemble_levelled(paths, &spec, &mut result, &diag)?;
    Ok(result)
}

/// Feed direction and next-path side at a point: along and across the feed parameter.
#[allow(clippy::type_complexity)]
fn frames(
    feed_u: bool,
) -> (
    impl Fn(&LocalGeometry) -> Vector3<f64>,
    impl Fn(&LocalGeometry) -> Vector3<f64>,
) {
    let feed = move |g: &LocalGeometry| -> Vector3<f64> {
        if feed_u {
            g.forms.derivs.su
        } else {
            g.forms.derivs.sv
        }
    };
    let hint = move |g: &LocalGeometry| -> Vector3<f64> {
        if feed_u {
            g.forms.derivs.sv
        } else {
            g.forms.derivs.su
        }
    };
    (feed, hint)
}

/// uv points of the iso-curve `c` (the cross parameter) along the feed parameter.
fn iso_curve(surface: &NurbsSurface, feed_u: bool, c: f64, spacing: f64) -> Vec<Vector2<f64>> {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let (f0, f1) = if feed_u { (u0, u1) } else { (v0, v1) };
    let at = |f: f64| {
        if feed_u {
            Vector2::new(f, c)
        } else {
            Vector2::new(c, f)
        }
    };
    // Length from a coarse polyline; points then uniform in the parameter.
    let coarse = 64;
    let mut len = 0.0;
    let mut prev = surface.point(at(f0).x, at(f0).y);
    for i in 1..=coarse {
        let uv = at(f0 + (f1 - f0) * i as f64 / coarse as f64);
        let p = surface.point(uv.x, uv.y);
        len += (p - prev).norm();
        prev = p;
    }
    let count = ((len / spacing).ceil() as usize).clamp(1, 100_000) + 1;
    (0..count)
        .map(|i| at(f0 + (f1 - f0) * i as f64 / (count - 1) as f64))
        .collect()
}

/// The contact paths in machining order with their cross parameters, and
/// what was noticed on the way.
#[allow(clippy::type_complexity)]
pub(crate) fn plan_paths(
    surface: &NurbsSurface,
    spec: &BeltSpec,
    feed_dir: FeedDirection,
    refinement: &Refinement,
    progress: &dyn Progress,
) -> Result<(Vec<(f64, Vec<contact::ContactPoint>)>, contact::Diagnostics)> {
    let feed_u = feed_dir == FeedDirection::U;
    let ((u0, u1), (v0, v1)) = surface.domain();
    let (c0, c1) = if feed_u { (v0, v1) } else { (u0, u1) };
    let cross_index = if feed_u { 1 } else { 0 };
    let range = c1 - c0;
    let eps = 1e-9 * range;
    let spacing = contact::point_spacing(spec);
    let (feed, hint) = frames(feed_u);
    let mut paths = Vec::new();
    let mut diag = contact::Diagnostics::default();
    let mut c = c0;
    loop {
        let last = c >= c1 - eps;
        let uvs = iso_curve(surface, feed_u, c, spacing);
        let aim = BeltSpec {
            scallop: spec.scallop * refinement.factor(c, true),
            ..*spec
        };
        let path = contact::analyse_path(surface, &uvs, &feed, &hint, &aim, !last, &mut diag);
        let mut c_next = c1;
        for cp in &path {
            let Some(nc) = cp.next else { continue };
            let reached = nc.uv[cross_index];
            if nc.at_boundary && nc.sigma <= 0.5 * spec.width {
                // The edge is within this belt's half width: covered already.
                continue;
            }
            c_next = c_next.min(reached);
        }
        paths.push((c, path));
        progress.set(((c - c0) / range).clamp(0.0, 1.0) as f32 * 0.95);
        progress.check()?;
        if last {
            break;
        }
        if c_next <= c + eps {
            let p = surface.point(if feed_u { u0 } else { c }, if feed_u { c } else { v0 });
            return Err(Error::planning(format!(
                "belt step collapsed at the iso-curve {}={c:.6} near ({:.3}, {:.3}, {:.3}): the next-path search made no progress",
                if feed_u { "v" } else { "u" },
                p.x,
                p.y,
                p.z
            )));
        }
        if paths.len() >= MAX_PASSES {
            return Err(Error::planning(format!(
                "more than {MAX_PASSES} belt passes needed: scallop {} mm is too small for this surface",
                spec.scallop
            )));
        }
        c = if c_next >= c1 - eps { c1 } else { c_next };
    }
    Ok((paths, diag))
}
