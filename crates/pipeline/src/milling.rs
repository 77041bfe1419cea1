//! The verification the scallop-simulated families share (strip width and
//! MPEC): each candidate simulated, repaired by its family's
//! [`repair`](crate::verification::Verification::repair), judged against the job's limit,
//! and the best kept.

use crate::islands::above_limit_warning;
use crate::verification::verification;
use crate::{BELOW_BAND, CONFORMANCE_SLACK_MM};
use std::time::Instant;
use toolpath_formats::{Job, PlanResult};
use toolpath_kernel::error::{Error, Result};
use toolpath_planners::{self as planners, Progress};
use toolpath_simulation::scallop::{self, ScallopReport, ScallopSettings};

/// Refuses, before planning, a simulator grid the simulator would refuse.
pub(crate) fn check_resolution(job: &Job) -> Result<()> {
    scallop::check_resolution(job.surface()?, job.simulation_resolution)
}

/// At most this many candidate plans are verified (shortest first).
pub(crate) const MAX_VERIFIED_CANDIDATES: usize = 3;

/// Verifies (and repairs, [`repair`](crate::verification::Verification::repair)) the
/// candidates shortest first and keeps the best: within the scallop height
/// before not, then shorter. A candidate already longer before repair than
/// the best after repair is not verified (repair only adds passes). Returns the kept result with its
/// simulator figures and the seconds spent making repair passes.
pub(crate) fn verify_candidates(
    job: &Job,
    candidates: Vec<PlanResult>,
    progress: &dyn Progress,
) -> Result<(PlanResult, f64)> {
    let total = candidates.len();
    let mut best: Option<(PlanResult, ScallopReport)> = None;
    let mut repair_s = 0.0;
    let mut verified = 0;
    for (rank, candidate) in candidates.into_iter().enumerate() {
        let raw = candidate.cl_path_length();
        if let Some((b, rb)) = &best {
            let within = b.within_scallop != Some(false) && rb.uncovered_area_mm2 <= 0.0;
            if (within && raw >= b.cl_path_length()) || verified >= MAX_VERIFIED_CANDIDATES {
                break;
            }
        }
        verified += 1;
        progress.check()?;
        let started = Instant::now();
        let (mut result, report, sim_s) = verify_and_repair_checked(job, candidate, progress)?;
        repair_s += (started.elapsed().as_secs_f64() - sim_s).max(0.0);
        if rank > 0 {
            if let Some(choice) = &mut result.plan_choice {
                *choice = format!(
                    "{choice}; kept after verification and repair (shorter, or within h where the shorter ones are not)"
                );
            }
        }
        let better = match &best {
            None => true,
            Some((b, _)) => {
                let (wa, wb) = (
                    result.within_scallop != Some(false),
                    b.within_scallop != Some(false),
                );
                (wa && !wb) || (wa == wb && result.cl_path_length() < b.cl_path_length())
            }
        };
        if better {
            best = Some((result, report));
        }
    }
    let (mut result, report) =
        best.ok_or_else(|| Error::planning("the planner returned no plan"))?;
    if total > 1 {
        result
            .stats
            .extra
            .insert("candidates_verified".into(), verified as f64);
    }
    fill_scallop_stats(&mut result, &report);
    Ok((result, repair_s))
}

/// Simulates `result`, repairs it where the job's limit (the scallop height
/// h, else the tolerance) is not held (the
/// [`repair`](crate::verification::Verification::repair) of the job's family: repair
/// passes over the islands for flat ends, passes added in the gaps for
/// MPEC, each round simulated again) and judges it (`judge`).
/// Returns the final report and the seconds the simulations took.
pub fn verify_and_repair(
    job: &Job,
    result: PlanResult,
) -> Result<(PlanResult, ScallopReport, f64)> {
    verify_and_repair_checked(job, result, &planners::NoProgress)
}

/// [`verify_and_repair`], checking `progress` for a stop in the simulator
/// and between repair rounds.
pub(crate) fn verify_and_repair_checked(
    job: &Job,
    result: PlanResult,
    progress: &dyn Progress,
) -> Result<(PlanResult, ScallopReport, f64)> {
    let mut sim_s = 0.0;
    let mut simulate = |r: &PlanResult, peak_starts: usize| -> Result<ScallopReport> {
        let t = Instant::now();
        let report = verify_milling_with(job, r, progress, peak_starts)?;
        sim_s += t.elapsed().as_secs_f64();
        Ok(report)
    };
    let report = simulate(&result, scallop::PEAK_STARTS)?;
    let raw_length = result.cl_path_length();
    let raw_passes = result.passes.len();
    let family = verification(job.strategy.family());
    let (mut result, report) = family.repair(job, result, report, &mut simulate, progress)?;
    record_repair(&mut result, raw_passes, raw_length);
    judge(job, &mut result, &report, family.band_has_gouge_side())?;
    Ok((result, report, sim_s))
}

/// Sets `within_scallop` from the simulator's report against the job's
/// limit (h, else the tolerance; with `band` its gouge side -limit too) and,
/// where the limit is not held, a warning naming the area and where it is.
fn judge(job: &Job, result: &mut PlanResult, report: &ScallopReport, band: bool) -> Result<()> {
    let Some(h) = job.scallop.or(job.tolerance) else {
        return Ok(());
    };
    let above = report.max_scallop_mm > h || report.uncovered_area_mm2 > 0.0;
    let below = band && report.max_gouge_mm > h + CONFORMANCE_SLACK_MM;
    result.within_scallop = Some(!above && !below);
    if above {
        result
            .warnings
            .push(above_limit_warning(report, h, job.tool()?.radius()));
    }
    if below {
        result.warnings.push(format!(
            "{BELOW_BAND} -{h} mm: the simulator finds a gouge of {:.4} mm",
            report.max_gouge_mm
        ));
    }
    Ok(())
}

/// Puts into `extra` what repair passes (or refinement paths) added to a
/// plan that had `raw_passes` passes of `raw_length` mm: `repair_passes`
/// and `repair_length_mm`, nothing when none were added.
pub(crate) fn record_repair(result: &mut PlanResult, raw_passes: usize, raw_length: f64) {
    if result.passes.len() > raw_passes {
        result.stats.extra.insert(
            "repair_passes".into(),
            (result.passes.len() - raw_passes) as f64,
        );
        result.stats.extra.insert(
            "repair_length_mm".into(),
            result.cl_path_length() - raw_length,
        );
    }
}

/// Runs the scallop simulator on a milling result of `job` at the job's `simulation_resolution`.
pub fn verify_milling(job: &Job, result: &PlanResult) -> Result<ScallopReport> {
    verify_milling_checked(job, result, &planners::NoProgress)
}

/// [`verify_milling`], checking `progress` for a stop about every thousand samples.
pub(crate) fn verify_milling_checked(
    job: &Job,
    result: &PlanResult,
    progress: &dyn Progress,
) -> Result<ScallopReport> {
    verify_milling_with(job, result, progress, scallop::PEAK_STARTS)
}

/// [`verify_milling_checked`] with `peak_starts` grid extrema refined.
pub(crate) fn verify_milling_with(
    job: &Job,
    result: &PlanResult,
    progress: &dyn Progress,
    peak_starts: usize,
) -> Result<ScallopReport> {
    let surface = job.surface()?;
    let settings = ScallopSettings {
        peak_starts,
        ..ScallopSettings::with_resolution(job.simulation_resolution)
    };
    scallop::simulate_checked(surface, job.tool()?, result, &settings, progress)
}

/// Puts the simulator's figures into the result's stats: max_scallop_mm,
/// max_gouge_mm and, in `extra`, uncovered/machined area and the grid spacing.
pub(crate) fn fill_scallop_stats(result: &mut PlanResult, report: &ScallopReport) {
    result.stats.max_scallop_mm = Some(report.max_scallop_mm);
    result.stats.max_gouge_mm = Some(report.max_gouge_mm);
    let extra = &mut result.stats.extra;
    extra.insert("uncovered_area_mm2".into(), report.uncovered_area_mm2);
    extra.insert("machined_area_mm2".into(), report.machined_area_mm2);
    extra.insert("simulation_resolution_mm".into(), report.resolution_mm);
}
