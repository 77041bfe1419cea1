//! Strategy `iso_scallop`: the whole surface as one region, Lee-style
//! iso-scallop offsetting from the boundary curve at the start of the
//! cross-feed parameter (feed along `feed_direction`, u by default). Same
//! cutter model and tool axis as `tensor_regions` (docs/methods.md,
//! "Iso-scallop offsetting").

use super::offset::cover;
use super::passes::{sample_curve, PassSettings};
use super::regions::whole_domain;
use crate::error::Result;
use crate::formats::{FeedDirection, Job, PlanResult};
use crate::planners::Progress;
use nalgebra::Vector2;

pub fn plan(job: &Job, progress: &dyn Progress) -> Result<PlanResult> {
    let surface = job.surface()?;
    let settings = PassSettings::from_job(job)?;
    let feed = job.feed_direction.unwrap_or(FeedDirection::U);
    let region = whole_domain(surface);
    let ((u0, u1), (v0, v1)) = surface.domain();
    let curve_uv = |t: f64| match feed {
        FeedDirection::U => Vector2::new(u0 + (u1 - u0) * t, v0),
        FeedDirection::V => Vector2::new(u0, v0 + (v1 - v0) * t),
    };
    let curve = |t: f64| {
        let p = curve_uv(t);
        surface.point(p.x, p.y)
    };
    let ts = sample_curve(&curve, settings.chord_tolerance, settings.point_step, 9);
    let initial: Vec<Vector2<f64>> = ts.into_iter().map(curve_uv).collect();
    progress.set(0.1);
    let passes = cover(surface, &settings, &region, &initial)?;
    let mut result = PlanResult::new(&job.job_id, job.strategy.name());
    result.passes = passes;
    result.stats.path_length_lower_bound_mm = Some(
        super::lower_bound::job_path_length_lower_bound(job, surface, &settings.cutter)?,
    );
    Ok(result)
}
