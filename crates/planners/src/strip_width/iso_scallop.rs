//! Strategy `iso_scallop`: the whole surface as one region, Lee-style
//! iso-scallop offsetting from the boundary curve at the start of the
//! cross-feed parameter (feed along `feed_direction`, u by default), its
//! first pass inset so that its strip edge meets that curve. Same
//! cutter model and tool axis as `tensor_regions` (docs/methods.md,
//! "Iso-scallop offsetting").

use super::offset::{boundary_start, cover_from_edge};
use super::passes::PassSettings;
use super::regions::whole_domain;
use crate::Progress;
use toolpath_formats::{FeedDirection, Job, PlanResult};
use toolpath_kernel::error::Result;

/// The strategy `iso_scallop`.
pub struct IsoScallop;

impl crate::Strategy for IsoScallop {
    fn id(&self) -> toolpath_formats::Strategy {
        toolpath_formats::Strategy::IsoScallop
    }
    fn plan(&self, job: &Job, progress: &dyn Progress) -> Result<PlanResult> {
        let surface = job.surface()?;
        let settings = PassSettings::from_job(job)?;
        let feed = job.feed_direction.unwrap_or(FeedDirection::U);
        let region = whole_domain(surface);
        let initial = boundary_start(surface, &settings, feed, false);
        progress.set(0.1);
        progress.check()?;
        let passes = cover_from_edge(surface, &settings, &region, &initial, progress)?;
        let mut result = PlanResult::new(&job.job_id, job.strategy.name());
        result.passes = passes;
        result.stats.path_length_lower_bound_mm = Some(
            super::lower_bound::job_path_length_lower_bound(job, surface, &settings.cutter)?,
        );
        Ok(result)
    }
}
