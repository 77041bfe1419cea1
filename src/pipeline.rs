//! The application layer: plan a job, verify it with the simulator, fill the
//! common statistics. The CLI and the ROS node both call this.

use crate::error::{Error, Result};
use crate::formats::result::polyline_length;
use crate::formats::{Job, PlanResult, Strategy};
use crate::planners::{self, Progress};
use crate::simulation::scallop::{self, ScallopReport, ScallopSettings};
use std::time::Instant;

/// Options that do not change the toolpath.
#[derive(Clone, Copy, Debug, Default)]
pub struct RunOptions {
    /// Skip the simulator (max_scallop_mm stays `None`).
    pub skip_verify: bool,
    /// Report compute_ms as 0 so that repeated runs give identical bytes.
    pub no_timing: bool,
}

impl RunOptions {
    /// Plan only: no simulator, compute_ms 0 (benches, tests, edges that verify elsewhere).
    pub const PLAN_ONLY: RunOptions = RunOptions {
        skip_verify: true,
        no_timing: true,
    };
}

/// Plans `job` and fills the statistics every result carries.
pub fn run(job: &Job, progress: &dyn Progress, options: RunOptions) -> Result<PlanResult> {
    let start = Instant::now();
    let mut result = planners::plan(job, progress)?;
    result.job_id = job.job_id.clone();
    result.shape_fingerprint = Some(job.shape.fingerprint());
    result.strategy = job.strategy.name().to_string();
    result.machine = Some(job.machine.name().to_string());
    let elapsed_ms = start.elapsed().as_secs_f64() * 1e3;
    fill_path_stats(&mut result, job.feed_rate);
    result.stats.compute_ms = if options.no_timing {
        0.0
    } else {
        (elapsed_ms * 1000.0).round() / 1000.0
    };
    if !options.skip_verify && is_milling(job.strategy) {
        let report = verify_milling(job, &result)?;
        fill_scallop_stats(&mut result, &report);
    }
    if !options.skip_verify && is_belt(job.strategy) {
        verify_belt(job, &mut result)?;
    }
    progress.set(1.0);
    Ok(result)
}

/// Belt strategies, checked by the material-removal simulation.
pub fn is_belt(strategy: Strategy) -> bool {
    matches!(
        strategy,
        Strategy::BeltIsoParametric | Strategy::BeltIsoPlanar
    )
}

/// Belt results: the material-removal simulation gives `max_scallop_mm` and,
/// in `extra`, the removal figures (the planner's rigid-belt `max_gouge_mm`
/// stays as planned).
pub fn verify_belt(job: &Job, result: &mut PlanResult) -> Result<()> {
    let sim = crate::simulation::removal::simulate_job(job, result)?;
    let s = &sim.stats;
    result.stats.max_scallop_mm = Some(s.max_scallop_mm);
    for (key, value) in [
        ("removal_mean_mm", s.mean_mm),
        ("removal_min_mm", s.min_mm),
        ("removal_max_mm", s.max_mm),
        ("removal_uniformity", s.uniformity),
        ("simulated_gouge_mm", s.max_gouge_mm),
    ] {
        result.stats.extra.insert(key.into(), value);
    }
    Ok(())
}

/// Path length, pass and point counts and machining time at `feed_rate` (mm/min).
pub fn fill_path_stats(result: &mut PlanResult, feed_rate: f64) {
    let length = match &result.tools {
        // Pockets: the tool-centre paths of every tool.
        Some(tools) => tools
            .iter()
            .flat_map(|t| t.passes.iter())
            .map(|p| polyline_length(p.iter().map(|q| [q[0], q[1], 0.0])))
            .sum(),
        None => result.cl_path_length(),
    };
    result.stats.path_length_mm = length;
    result.stats.passes = match &result.tools {
        Some(tools) => tools.iter().map(|t| t.passes.len()).sum(),
        None => result.passes.len(),
    };
    result.stats.points = Some(match &result.tools {
        // Pockets: the tool-centre points of every tool.
        Some(tools) => tools
            .iter()
            .flat_map(|t| t.passes.iter())
            .map(Vec::len)
            .sum(),
        None => result.point_count(),
    });
    result.stats.machining_time_min = Some(length / feed_rate);
}

/// Strategies whose results the scallop simulator checks (pocket and belt results have their own).
pub fn is_milling(strategy: Strategy) -> bool {
    matches!(
        strategy,
        Strategy::TensorRegions | Strategy::IsoScallop | Strategy::IsoParametric | Strategy::Mpec
    )
}

/// Runs the scallop simulator on a milling result of `job` at the job's `simulation_resolution`.
pub fn verify_milling(job: &Job, result: &PlanResult) -> Result<ScallopReport> {
    let surface = job.surface()?;
    let settings = ScallopSettings::with_resolution(job.simulation_resolution);
    scallop::simulate(surface, job.tool()?, result, &settings)
}

/// Puts the simulator's figures into the result's stats: max_scallop_mm,
/// max_gouge_mm and, in `extra`, uncovered/machined area and the grid spacing.
pub fn fill_scallop_stats(result: &mut PlanResult, report: &ScallopReport) {
    result.stats.max_scallop_mm = Some(report.max_scallop_mm);
    result.stats.max_gouge_mm = Some(report.max_gouge_mm);
    let extra = &mut result.stats.extra;
    extra.insert("uncovered_area_mm2".into(), report.uncovered_area_mm2);
    extra.insert("machined_area_mm2".into(), report.machined_area_mm2);
    extra.insert("simulation_resolution_mm".into(), report.resolution_mm);
}

/// Simulated figures within this much of a tolerance count as within it, mm
/// (0.1 micrometre, far below what a machine holds): the simulator's refined
/// extrema carry numerical error of that order, and a plan built to touch its
/// band (MPEC's -delta, docs/methods.md) lands on it: die_saddle's plan gives
/// a gouge of 0.0100136 mm against its 0.01 mm band.
pub const CONFORMANCE_SLACK_MM: f64 = 1e-4;

/// Where a simulated milling result breaks the job's tolerances, read from
/// the figures [`fill_scallop_stats`] put into its stats. Nothing is out of
/// spec in a result that was not simulated. Belt results are held to h only
/// (by `toolpath simulate`): their `max_gouge_mm` is the rigid-belt planning
/// figure, and the elastic removal model's depth below the part is not
/// comparable with a cutter's gouge tolerance.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Conformance {
    /// The simulated gouge beyond the job's gouge tolerance.
    pub gouge: Option<String>,
    /// The simulated residual above the job's scallop height h.
    pub scallop: Option<String>,
}

impl Conformance {
    /// Checks the simulator's `max_gouge_mm` against [`Job::gouge_tolerance`]
    /// and `max_scallop_mm` against h.
    pub fn of(job: &Job, result: &PlanResult) -> Self {
        if !is_milling(job.strategy) {
            return Self::default();
        }
        Self::of_figures(job, result.stats.max_gouge_mm, result.stats.max_scallop_mm)
    }

    /// The same check on given simulated figures (mm).
    pub fn of_figures(job: &Job, max_gouge_mm: Option<f64>, max_scallop_mm: Option<f64>) -> Self {
        let tolerance = job.gouge_tolerance();
        let gouge = max_gouge_mm.filter(|g| *g > tolerance + CONFORMANCE_SLACK_MM).map(|g| {
            format!("the simulator finds a gouge of {g:.4} mm, beyond the job's gouge tolerance of {tolerance} mm")
        });
        let scallop = match (max_scallop_mm, job.scallop) {
            (Some(s), Some(h)) if s > h + CONFORMANCE_SLACK_MM => Some(format!(
                "the simulator finds a residual of {s:.4} mm, above the job's scallop height h = {h} mm"
            )),
            _ => None,
        };
        Conformance { gouge, scallop }
    }

    /// The error for the worse breach (a gouge before a residual), if any.
    pub fn error(&self) -> Option<Error> {
        if let Some(m) = &self.gouge {
            return Some(Error::OutOfSpec {
                message: m.clone(),
                gouge: true,
            });
        }
        self.scallop.as_ref().map(|m| Error::OutOfSpec {
            message: m.clone(),
            gouge: false,
        })
    }
}

/// A plan whose simulated gouge is beyond the job's gouge tolerance is an
/// error (the node's job FAILED): no toolpath that cuts into the part is
/// handed out.
pub fn refuse_gouge(job: &Job, result: &PlanResult) -> Result<()> {
    match Conformance::of(job, result).gouge {
        Some(message) => Err(Error::OutOfSpec {
            message,
            gouge: true,
        }),
        None => Ok(()),
    }
}

/// Refuses to check `result` against `job` when it was planned for another
/// job: another job_id or strategy, or (when the result records it) another
/// shape.
pub fn check_belongs(job: &Job, result: &PlanResult) -> Result<()> {
    if result.job_id != job.job_id {
        return Err(Error::invalid(
            "result.job_id",
            format!(
                "\"{}\" is not the job's \"{}\": the result belongs to another job",
                result.job_id, job.job_id
            ),
        ));
    }
    if result.strategy != job.strategy.name() {
        return Err(Error::invalid(
            "result.strategy",
            format!(
                "{} is not the job's {}: the result belongs to another job",
                result.strategy,
                job.strategy.name()
            ),
        ));
    }
    if let Some(f) = &result.shape_fingerprint {
        let own = job.shape.fingerprint();
        if *f != own {
            return Err(Error::invalid(
                "result.shape_fingerprint",
                format!(
                    "{f} is not the job's shape ({own}): the result was planned on another shape"
                ),
            ));
        }
    }
    Ok(())
}
