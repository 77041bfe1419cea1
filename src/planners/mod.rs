//! Planners: one module per method, named after it. Planners know nothing of
//! ROS, recording or transport; they take a validated [`Job`] and return a
//! [`PlanResult`]. Shared pieces (direction fields, offsetting passes) live
//! once, in their own modules here.

pub mod belt_contact;
pub mod belt_iso_parametric;
pub mod belt_iso_planar;
pub mod degenerate_points;
pub mod iso_parametric;
pub mod iso_scallop;
pub mod iso_scallop_offset;
pub mod mpec;
pub mod mpec_error_curve;
pub mod partition;
pub mod pass_points;
pub mod pocket;
pub mod pocket_mat;
pub mod strip_width;
pub mod tensor_regions;
#[cfg(test)]
pub mod test_surfaces;

use crate::error::Result;
use crate::formats::{Job, PlanResult};

/// Cells per parameter direction for the path-length lower bound quadrature
/// (3 x 3 Gauss points each).
pub const LOWER_BOUND_CELLS: usize = 40;

/// Progress reporting from a planner to its caller (CLI bar, node status).
pub trait Progress: Sync {
    /// `fraction` in 0..=1.
    fn set(&self, fraction: f32);
}

/// Discards progress.
pub struct NoProgress;

impl Progress for NoProgress {
    fn set(&self, _fraction: f32) {}
}

/// Plans a job with its strategy. Fills passes and the strategy's own fields;
/// the common statistics are filled by [`crate::pipeline`].
pub fn plan(job: &Job, progress: &dyn Progress) -> Result<PlanResult> {
    use crate::formats::Strategy::*;
    match job.strategy {
        TensorRegions => tensor_regions::plan(job, progress),
        IsoScallop => iso_scallop::plan(job, progress),
        IsoParametric => iso_parametric::plan(job, progress),
        Mpec => mpec::plan(job, progress),
        PocketMat => pocket_mat::plan(job, progress),
        BeltIsoParametric => belt_iso_parametric::plan(job, progress),
        BeltIsoPlanar => belt_iso_planar::plan(job, progress),
    }
}
