//! The application layer: plan a job, verify it with the simulator, fill the
//! common statistics. The CLI and the ROS node both call this.

use crate::error::Result;
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
