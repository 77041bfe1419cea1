//! Verification of the strip-width (flat-end) plans: the scallop simulator,
//! then repair passes (`planners::strip_width::repair`) over the islands it
//! finds above the scallop height h, round by round.

use crate::budget::{self, Estimate};
use crate::islands::islands;
use crate::verification::{Simulate, Verification};
use toolpath_formats::{Job, PlanResult};
use toolpath_kernel::error::Result;
use toolpath_planners::{self as planners, Progress};
use toolpath_simulation::scallop::{self, ScallopReport};

/// Rounds of repair passes after the first verification (flat ends and
/// MPEC alike).
pub(crate) const REPAIR_ROUNDS: usize = 3;

/// The strip-width family's verification.
pub(crate) struct StripWidth;

impl Verification for StripWidth {
    fn estimate(&self, job: &Job) -> Result<Estimate> {
        budget::strip_width(job)
    }

    /// Turns the islands above h (and the samples the tool never reached)
    /// into repair passes and simulates again, at most [`REPAIR_ROUNDS`]
    /// times. The repair passes get a region of their own, after the plan's.
    fn repair(
        &self,
        job: &Job,
        mut result: PlanResult,
        mut report: ScallopReport,
        simulate: &mut Simulate,
        progress: &dyn Progress,
    ) -> Result<(PlanResult, ScallopReport)> {
        let Some(h) = job.scallop else {
            return Ok((result, report));
        };
        let region = result
            .passes
            .iter()
            .map(|p| p.region + 1)
            .max()
            .unwrap_or(0);
        for _ in 0..REPAIR_ROUNDS {
            progress.check()?;
            let islands = islands(&report, h, job.tool()?.radius());
            if islands.is_empty() {
                break;
            }
            let passes = planners::strip_width::repair::repair_passes(job, &islands, region)?;
            if passes.is_empty() {
                break;
            }
            result.passes.extend(passes);
            // A plan with peaks above h may hide more among the ridges just
            // below it: the repaired plan's check climbs from more of them.
            report = simulate(&result, scallop::DEEP_PEAK_STARTS)?;
        }
        Ok((result, report))
    }
}
