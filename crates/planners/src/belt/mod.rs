//! 6-axis belt grinding (docs/methods.md, "Belt contact and removal").
//!
//! - [`contact`]: the contact wheel's line contact, its pose, the scallop
//!   between neighbouring contact paths and the gouge of a rigid belt on a
//!   concave section.
//! - [`iso_parametric`]: contact paths along one parameter, stepped so the
//!   scallop between paths stays within h.
//! - [`iso_planar`]: contact paths in parallel section planes whose normal is
//!   the dominant minimum-curvature direction (orientation tensor), stepped the
//!   same way.

pub mod contact;
pub(crate) mod iso_parametric;
pub mod iso_planar;

use crate::refine::Refinement;
use crate::strategy::PathLevels;
use crate::Progress;
use toolpath_formats::{Job, PlanResult};
use toolpath_kernel::error::Result;

/// A belt strategy: contact paths on levels, each planned by the strategy's
/// `plan_with` with what the removal simulation's refinement rounds changed
/// (nothing at first).
pub(crate) struct BeltStrategy {
    id: toolpath_formats::Strategy,
    levels: PathLevels,
    plan_with: fn(&Job, &dyn Progress, &Refinement) -> Result<PlanResult>,
}

impl crate::Strategy for BeltStrategy {
    fn id(&self) -> toolpath_formats::Strategy {
        self.id
    }
    fn plan(&self, job: &Job, progress: &dyn Progress) -> Result<PlanResult> {
        (self.plan_with)(job, progress, &Refinement::default())
    }
    fn path_levels(&self) -> Option<PathLevels> {
        Some(self.levels)
    }
    fn plan_refined(
        &self,
        job: &Job,
        progress: &dyn Progress,
        refinement: &Refinement,
    ) -> Result<PlanResult> {
        (self.plan_with)(job, progress, refinement)
    }
}
