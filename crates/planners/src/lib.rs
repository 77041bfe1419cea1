//! Planners: one folder per method family, each strategy one module named
//! after it. Planners know nothing of ROS, recording or transport; they take a
//! validated [`Job`] and return a [`PlanResult`].
//!
//! - [`strip_width`]: flat-end 5-axis finishing (`iso_parametric`,
//!   `iso_scallop`, `tensor_regions`) on the strip-width model.
//! - [`mpec`]: torus-cutter positioning by mid-point error control.
//! - [`pocket`]: 2.5-axis pockets with tools chosen from the medial axis.
//! - [`belt`]: 6-axis belt grinding (`belt_iso_parametric`, `belt_iso_planar`).
//! - [`strategy`]: the [`Strategy`] trait every strategy implements, and
//!   the registry from a job's strategy to it.
//! - [`refine`]: more paths where a simulation finds material above the
//!   limit (belts, MPEC), from plain residual places.

pub mod belt;
pub mod mpec;
pub mod pocket;
pub mod refine;
pub mod strategy;
pub mod strip_width;
#[cfg(test)]
pub mod test_surfaces;
pub(crate) mod trim_clip;

pub use strategy::{strategy, PathLevels, Strategy};
use toolpath_formats::{Job, PlanResult};
use toolpath_kernel::error::Result;
pub use toolpath_kernel::progress::{CheckOnly, NoProgress, Progress};

/// Cells per parameter direction for the path-length lower bound quadrature
/// (3 x 3 Gauss points each).
pub(crate) const LOWER_BOUND_CELLS: usize = 40;

/// The candidate plans of a job, shortest first ([`Strategy::candidates`]),
/// each clipped to a trimmed face ([`trim_clip`]).
pub fn plan_candidates(job: &Job, progress: &dyn Progress) -> Result<Vec<PlanResult>> {
    let mut candidates = strategy(job.strategy).candidates(job, progress)?;
    for c in &mut candidates {
        trim_clip::clip_result(job, c)?;
    }
    Ok(candidates)
}

/// Plans a job with its strategy ([`Strategy::plan`]). Fills passes and the
/// strategy's own fields; the common statistics are filled by
/// `toolpath_pipeline`. On a trimmed face the passes are clipped to it
/// ([`trim_clip`]).
pub fn plan(job: &Job, progress: &dyn Progress) -> Result<PlanResult> {
    let mut result = strategy(job.strategy).plan(job, progress)?;
    trim_clip::clip_result(job, &mut result)?;
    Ok(result)
}
