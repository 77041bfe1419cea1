//! Verification of MPEC plans: the scallop simulator against the band
//! +-delta, then passes added at the middle of the gaps it finds above the
//! band (`planners::refine`; MPEC has no scallop to aim its steps at),
//! round by round.

use crate::budget::{self, Estimate};
use crate::strip_width::REPAIR_ROUNDS;
use crate::verification::{Simulate, Verification};
use nalgebra::Point3;
use toolpath_formats::{Job, PlanResult};
use toolpath_kernel::error::Result;
use toolpath_planners::refine::{self, Mode, Refinement, Residual};
use toolpath_planners::{self as planners, Progress};
use toolpath_simulation::scallop::{self, ScallopReport};

/// The MPEC family's verification.
pub(crate) struct Mpec;

impl Verification for Mpec {
    fn estimate(&self, job: &Job) -> Result<Estimate> {
        budget::mpec(job)
    }

    /// Adds passes in the gaps holding grid samples above the band and plans
    /// again, at most [`REPAIR_ROUNDS`] times.
    fn repair(
        &self,
        job: &Job,
        mut result: PlanResult,
        mut report: ScallopReport,
        simulate: &mut Simulate,
        progress: &dyn Progress,
    ) -> Result<(PlanResult, ScallopReport)> {
        let Some(delta) = job.tolerance else {
            return Ok((result, report));
        };
        let mut refinement = Refinement::default();
        for _ in 0..REPAIR_ROUNDS {
            if report.max_scallop_mm <= delta {
                break;
            }
            // The grid peak may sit well below a refined maximum between
            // samples (a part edge): the band below the grid maximum as wide
            // as the refinement's gain counts, down to delta / 2.
            let threshold = residual_threshold(&report, delta, 0.5);
            let residuals = residuals_above(job, &result, &report, threshold)?;
            let changed = refine::refine(
                job,
                &result,
                &residuals,
                threshold,
                Mode::Split,
                &mut refinement,
            )?;
            if !changed {
                break;
            }
            progress.check()?;
            result = planners::strategy(job.strategy).plan_refined(job, progress, &refinement)?;
            report = simulate(&result, scallop::PEAK_STARTS)?;
        }
        Ok((result, report))
    }

    fn band_has_gouge_side(&self) -> bool {
        true
    }
}

/// The grid samples of `report` on the face above `threshold`, except
/// where the tool is lifted (no lead holds the band): more passes do not
/// help there, so those places are reported, not refined.
fn residuals_above(
    job: &Job,
    result: &PlanResult,
    report: &ScallopReport,
    threshold: f64,
) -> Result<Vec<Residual>> {
    let map = &report.map;
    let reach = job.tool()?.radius();
    let lifted: Vec<Point3<f64>> = result
        .passes
        .iter()
        .flat_map(|p| &p.points)
        .filter(|q| q.mpec.as_deref() == Some("lifted"))
        .map(|q| Point3::from(q.cc))
        .collect();
    let by_lifted = |xyz: [f64; 3]| {
        let p = Point3::from(xyz);
        lifted.iter().any(|q| (p - q).norm() <= reach)
    };
    Ok((0..map.uv.len())
        .filter(|&k| map.on_face(k))
        .filter_map(|k| {
            map.residual[k]
                .filter(|r| *r > threshold && !by_lifted(map.xyz[k]))
                .map(|height| Residual {
                    uv: map.uv[k],
                    point: map.xyz[k],
                    height,
                })
        })
        .collect())
}

/// The residual above which MPEC's grid samples count as above the band
/// `h`: `h`, or, where the simulator's refined maximum exceeds h but no
/// grid sample does, h lowered by the refinement's gain (at least `floor`
/// h), so the peak's samples are found.
fn residual_threshold(report: &ScallopReport, h: f64, floor: f64) -> f64 {
    let grid_max = report
        .map
        .residual
        .iter()
        .flatten()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    if report.max_scallop_mm > h && grid_max <= h {
        (h - (report.max_scallop_mm - grid_max)).max(floor * h)
    } else {
        h
    }
}
