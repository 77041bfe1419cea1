//! What the pipeline does around planning for each method family, behind one
//! trait: the work estimate before planning, the checks a simulator would
//! refuse later, and the verification by simulation with the repair or
//! refinement rounds where the simulation finds a plan above the job's
//! limit. The planners cannot call the simulators, which sit above them, so
//! this lives here; [`crate::run`] dispatches on [`verification`].

use crate::budget::{self, Estimate};
use crate::milling;
use toolpath_formats::{Family, Job, PlanResult};
use toolpath_kernel::error::{Error, Result};
use toolpath_planners::Progress;
use toolpath_simulation::scallop::ScallopReport;

/// Simulates a milling plan with the scallop simulator, refining this many
/// grid extrema (`scallop::PEAK_STARTS` or `DEEP_PEAK_STARTS`).
pub(crate) type Simulate<'a> = dyn FnMut(&PlanResult, usize) -> Result<ScallopReport> + 'a;

/// The pipeline's work on one family's jobs and plans.
pub(crate) trait Verification: Sync {
    /// The passes, points and memory a job will need, estimated before
    /// planning (`budget`).
    fn estimate(&self, job: &Job) -> Result<Estimate>;

    /// Refuses, before planning, a job whose verification would be refused:
    /// for the families the scallop simulator checks
    /// ([`Family::scallop_simulated`]), a grid finer than it allows.
    fn check_job(&self, job: &Job) -> Result<()> {
        if job.strategy.family().scallop_simulated() {
            milling::check_resolution(job)?;
        }
        Ok(())
    }

    /// Verifies the candidate plans (shortest first), repairs them and keeps
    /// one, with the verification's figures in its stats; returns it with the
    /// seconds spent planning repairs. For the families the scallop
    /// simulator checks, its verification ([`milling::verify_candidates`],
    /// repaired by [`Verification::repair`]); for the others the first
    /// candidate as planned (pocket plans report their uncut area
    /// themselves).
    fn verify(
        &self,
        job: &Job,
        candidates: Vec<PlanResult>,
        progress: &dyn Progress,
    ) -> Result<(PlanResult, f64)> {
        if job.strategy.family().scallop_simulated() {
            return milling::verify_candidates(job, candidates, progress);
        }
        Ok((first_candidate(candidates)?, 0.0))
    }

    /// Repairs `result` where the scallop simulator's `report` finds it above
    /// the job's limit, in rounds, each simulated with `simulate`; returns the
    /// repaired plan and its last report. Families the scallop simulator does
    /// not check, or that it cannot repair, keep the plan as it is.
    fn repair(
        &self,
        job: &Job,
        result: PlanResult,
        report: ScallopReport,
        simulate: &mut Simulate,
        progress: &dyn Progress,
    ) -> Result<(PlanResult, ScallopReport)> {
        let _ = (job, simulate, progress);
        Ok((result, report))
    }

    /// Whether the job's limit is a band with a gouge side too (MPEC's
    /// -delta): a simulated gouge beyond it puts the plan out of its limit.
    fn band_has_gouge_side(&self) -> bool {
        false
    }
}

/// The verification of a family's plans.
pub(crate) fn verification(family: Family) -> &'static dyn Verification {
    match family {
        Family::StripWidth => &crate::strip_width::StripWidth,
        Family::Mpec => &crate::mpec::Mpec,
        Family::Pocket => &Pocket,
        Family::Belt => &crate::belt::Belt,
    }
}

/// The first candidate plan; an error when the planner returned none.
pub(crate) fn first_candidate(candidates: Vec<PlanResult>) -> Result<PlanResult> {
    candidates
        .into_iter()
        .next()
        .ok_or_else(|| Error::planning("the planner returned no plan"))
}

/// Pockets: planned and checked by the planner itself (its uncut area).
struct Pocket;

impl Verification for Pocket {
    fn estimate(&self, job: &Job) -> Result<Estimate> {
        budget::pocket(job)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_mpec_verification_judges_a_gouge_side() {
        for family in [
            Family::StripWidth,
            Family::Mpec,
            Family::Pocket,
            Family::Belt,
        ] {
            // Only MPEC's limit is a band with a gouge side.
            let v = verification(family);
            assert_eq!(
                v.band_has_gouge_side(),
                family == Family::Mpec,
                "{family:?}"
            );
        }
    }
}
