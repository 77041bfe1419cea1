//! The planning strategies behind one interface: every strategy is a unit
//! struct in its own module implementing [`Strategy`] (the two belt
//! strategies one [`crate::belt::BeltStrategy`] each), and [`strategy`] maps
//! a job's strategy name to it, so callers dispatch on the trait instead of
//! matching on the job's strategy.

use crate::refine::Refinement;
use crate::Progress;
use toolpath_formats::{Family, Job, PlanResult};
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::tools::Tool;

/// How a strategy lays its paths on levels, so that a simulation's residual
/// can be placed between two paths (`crate::refine`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PathLevels {
    /// Each path lies on one value of the cross-feed parameter
    /// (iso-parametric belt paths, MPEC passes).
    CrossParameter,
    /// Each path lies in one section plane: its level is the offset along
    /// the result's section normal (iso-planar belt paths).
    SectionPlane,
}

/// One planning strategy: its identity and family, the tools it plans with,
/// and how it plans (and, where a simulation asks for it, plans again).
pub trait Strategy: Sync {
    /// The strategy as job files name it.
    fn id(&self) -> toolpath_formats::Strategy;

    /// Its name in job and result files.
    fn name(&self) -> &'static str {
        self.id().name()
    }

    /// Its method family: tool model, machine, how plans are verified.
    fn family(&self) -> Family {
        self.id().family()
    }

    /// Whether it plans with `tool` (job validation refuses the others).
    fn accepts(&self, tool: &Tool) -> bool {
        self.family().accepts(tool)
    }

    /// Plans `job` on the untrimmed surface; [`crate::plan`] clips the
    /// passes to a trimmed face.
    fn plan(&self, job: &Job, progress: &dyn Progress) -> Result<PlanResult>;

    /// The candidate plans, shortest first, unclipped: one plan, unless the
    /// strategy keeps the shortest of several that verifies.
    fn candidates(&self, job: &Job, progress: &dyn Progress) -> Result<Vec<PlanResult>> {
        Ok(vec![self.plan(job, progress)?])
    }

    /// How many plans planning holds in memory at once, at most (the work
    /// estimate counts their points).
    fn plans_held(&self) -> usize {
        1
    }

    /// How its paths lie on levels; `None` for a strategy a simulation
    /// cannot refine by levels.
    fn path_levels(&self) -> Option<PathLevels> {
        None
    }

    /// Plans `job` again with what the refinement rounds changed (re-stepped
    /// gaps, added paths): for the strategies with [`Strategy::path_levels`].
    fn plan_refined(
        &self,
        job: &Job,
        progress: &dyn Progress,
        refinement: &Refinement,
    ) -> Result<PlanResult> {
        let _ = (job, progress, refinement);
        Err(Error::planning(format!(
            "internal: strategy {} cannot be refined",
            self.name()
        )))
    }
}

/// The strategy a job names.
pub fn strategy(id: toolpath_formats::Strategy) -> &'static dyn Strategy {
    use crate::{belt, mpec, pocket, strip_width};
    use toolpath_formats::Strategy as Id;
    match id {
        Id::TensorRegions => &strip_width::tensor_regions::TensorRegions,
        Id::IsoScallop => &strip_width::iso_scallop::IsoScallop,
        Id::IsoParametric => &strip_width::iso_parametric::IsoParametric,
        Id::Mpec => &mpec::positioning::Mpec,
        Id::PocketMat => &pocket::pocket_mat::PocketMat,
        Id::BeltIsoParametric => &belt::iso_parametric::BELT_ISO_PARAMETRIC,
        Id::BeltIsoPlanar => &belt::iso_planar::BELT_ISO_PLANAR,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use toolpath_formats::Strategy as Id;

    #[test]
    fn every_strategy_is_registered_under_its_own_id() {
        for id in Id::ALL {
            let s = strategy(id);
            assert_eq!(s.id(), id);
            assert_eq!(s.name(), id.name());
            assert_eq!(s.family(), id.family());
        }
    }

    #[test]
    fn families_take_their_tools_and_refinable_strategies_have_levels() {
        let flat = Tool::FlatEnd {
            radius: 2.5,
            length: None,
        };
        let ball = Tool::Ball {
            radius: 2.5,
            length: None,
        };
        let torus = Tool::Torus {
            radius: 5.0,
            corner_radius: 1.0,
            length: None,
        };
        let belt = Tool::Belt {
            width: 20.0,
            wheel_radius: 50.0,
        };
        let takes = |id: Id| -> Vec<bool> {
            [&flat, &ball, &torus, &belt]
                .iter()
                .map(|t| strategy(id).accepts(t))
                .collect()
        };
        for id in [Id::TensorRegions, Id::IsoScallop, Id::IsoParametric] {
            assert_eq!(takes(id), [true, true, false, false], "{id:?}");
        }
        assert_eq!(takes(Id::Mpec), [false, false, true, false]);
        assert_eq!(takes(Id::PocketMat), [true, false, false, false]);
        for id in [Id::BeltIsoParametric, Id::BeltIsoPlanar] {
            assert_eq!(takes(id), [false, false, false, true], "{id:?}");
        }
        let levels: Vec<Option<PathLevels>> = Id::ALL
            .iter()
            .map(|&id| strategy(id).path_levels())
            .collect();
        assert_eq!(
            levels,
            [
                None,
                None,
                None,
                Some(PathLevels::CrossParameter),
                None,
                Some(PathLevels::CrossParameter),
                Some(PathLevels::SectionPlane),
            ]
        );
    }
}
