//! Planners: one folder per method family, each strategy one module named
//! after it. Planners know nothing of ROS, recording or transport; they take a
//! validated [`Job`] and return a [`PlanResult`].
//!
//! - [`strip_width`]: flat-end 5-axis finishing (`iso_parametric`,
//!   `iso_scallop`, `tensor_regions`) on the strip-width model.
//! - [`mpec`]: torus-cutter positioning by mid-point error control.
//! - [`pocket`]: 2.5-axis pockets with tools chosen from the medial axis.
//! - [`belt`]: 6-axis belt grinding (`belt_iso_parametric`, `belt_iso_planar`).
//! - [`refine`]: more paths where a simulation finds material above the
//!   limit (belts, MPEC), from plain residual places.

pub mod belt;
pub mod mpec;
pub mod pocket;
pub mod refine;
pub mod strip_width;
#[cfg(test)]
pub mod test_surfaces;
pub mod trim_clip;

use toolpath_formats::{Job, PlanResult};
use toolpath_kernel::error::Result;
pub use toolpath_kernel::progress::{CheckOnly, NoProgress, Progress};

/// Cells per parameter direction for the path-length lower bound quadrature
/// (3 x 3 Gauss points each).
pub const LOWER_BOUND_CELLS: usize = 40;

/// The candidate plans of a job, shortest first: several for
/// `tensor_regions` (it keeps the shortest that verifies), one otherwise.
pub fn plan_candidates(job: &Job, progress: &dyn Progress) -> Result<Vec<PlanResult>> {
    match job.strategy {
        toolpath_formats::Strategy::TensorRegions => {
            let mut candidates = strip_width::tensor_regions::candidates(job, progress)?;
            for c in &mut candidates {
                trim_clip::clip_result(job, c)?;
            }
            Ok(candidates)
        }
        _ => Ok(vec![plan(job, progress)?]),
    }
}

/// Plans a job with its strategy. Fills passes and the strategy's own fields;
/// the common statistics are filled by [`toolpath_pipeline`].
/// On a trimmed face the passes are clipped to it ([`trim_clip`]).
pub fn plan(job: &Job, progress: &dyn Progress) -> Result<PlanResult> {
    let mut result = plan_untrimmed(job, progress)?;
    trim_clip::clip_result(job, &mut result)?;
    Ok(result)
}

fn plan_untrimmed(job: &Job, progress: &dyn Progress) -> Result<PlanResult> {
    use toolpath_formats::Strategy::*;
    match job.strategy {
        TensorRegions => strip_width::tensor_regions::plan(job, progress),
        IsoScallop => strip_width::iso_scallop::plan(job, progress),
        IsoParametric => strip_width::iso_parametric::plan(job, progress),
        Mpec => mpec::positioning::plan(job, progress),
        PocketMat => pocket::pocket_mat::plan(job, progress),
        BeltIsoParametric => belt::iso_parametric::plan(job, progress),
        BeltIsoPlanar => belt::iso_planar::plan(job, progress),
    }
}
