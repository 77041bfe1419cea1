//! Verification of belt plans: the removal simulation, then re-stepped gaps
//! and added paths where it leaves nodes above h (`planners::refine`),
//! round by round.

use crate::budget::{self, Estimate};
use crate::milling::record_repair;
use crate::verification::{first_candidate, Verification};
use crate::ABOVE_LIMIT;
use std::time::Instant;
use toolpath_formats::{Job, PlanResult};
use toolpath_kernel::error::Result;
use toolpath_kernel::geometry::NurbsSurface;
use toolpath_planners::refine::{self, Mode, Refinement, Residual};
use toolpath_planners::{self as planners, Progress};
use toolpath_simulation::removal::{simulate_job, Simulation};

/// Rounds of belt refinement after the first removal simulation.
pub(crate) const BELT_REFINE_ROUNDS: usize = 4;
/// The first rounds re-step the gaps left above h; the later ones split them.
pub(crate) const BELT_TIGHTEN_ROUNDS: usize = 2;

/// The belt family's verification.
pub(crate) struct Belt;

impl Verification for Belt {
    fn estimate(&self, job: &Job) -> Result<Estimate> {
        budget::belt(job)
    }

    /// The first candidate, refined ([`verify_and_refine_belt`]).
    fn verify(
        &self,
        job: &Job,
        candidates: Vec<PlanResult>,
        progress: &dyn Progress,
    ) -> Result<(PlanResult, f64)> {
        verify_and_refine_belt(job, first_candidate(candidates)?, progress)
    }
}

/// Belt results: simulates the removal; where nodes are left above h,
/// re-steps the gaps holding them, later adds paths at their middle
/// (`planners::refine`), and simulates again, at most
/// [`BELT_REFINE_ROUNDS`] times. The result carries the simulation's
/// figures (`max_scallop_mm`; in `extra` the removal figures,
/// `simulated_gouge_mm` and, when paths were added, `repair_passes` and
/// `repair_length_mm`; the planner's rigid-belt `max_gouge_mm` stays as
/// planned), `within_scallop` and, where h is not held, a warning saying
/// where. Returns the result and the seconds spent planning the added paths.
pub(crate) fn verify_and_refine_belt(
    job: &Job,
    result: PlanResult,
    progress: &dyn Progress,
) -> Result<(PlanResult, f64)> {
    let h = job.scallop()?;
    let (raw_passes, raw_length) = (result.passes.len(), result.cl_path_length());
    progress.check()?;
    let (mut result, sim, planning_s) = refine_rounds(job, result, h, progress)?;
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
    record_repair(&mut result, raw_passes, raw_length);
    let within = s.max_scallop_mm <= h;
    result.within_scallop = Some(within);
    if !within {
        result
            .warnings
            .push(above_h_warning(job.surface()?, &sim, h));
    }
    Ok((result, planning_s))
}

/// Simulates `result` and refines it while nodes are left above `h`;
/// returns the last plan, its simulation and the seconds spent planning.
fn refine_rounds(
    job: &Job,
    mut result: PlanResult,
    h: f64,
    progress: &dyn Progress,
) -> Result<(PlanResult, Simulation, f64)> {
    let surface = job.surface()?;
    let strategy = planners::strategy(job.strategy);
    let mut refinement = Refinement::default();
    let mut planning_s = 0.0;
    let mut sim = simulate_job(job, &result)?;
    for round in 0..BELT_REFINE_ROUNDS {
        if sim.stats.max_scallop_mm <= h {
            break;
        }
        let residuals: Vec<Residual> = sim
            .nodes_above(h)
            .into_iter()
            .map(|(uv, height)| {
                let p = surface.point(uv[0], uv[1]);
                Residual {
                    uv,
                    point: [p.x, p.y, p.z],
                    height,
                }
            })
            .collect();
        // Re-step first; what that leaves above h is split.
        let mode = if round < BELT_TIGHTEN_ROUNDS {
            Mode::Tighten
        } else {
            Mode::Split
        };
        if !refine::refine(job, &result, &residuals, h, mode, &mut refinement)? {
            break;
        }
        progress.check()?;
        let started = Instant::now();
        result = strategy.plan_refined(job, progress, &refinement)?;
        planning_s += started.elapsed().as_secs_f64();
        progress.check()?;
        sim = simulate_job(job, &result)?;
    }
    Ok((result, sim, planning_s))
}

/// The warning for a belt plan the removal simulation leaves above `h`:
/// the maximum, the area above h and the highest place.
fn above_h_warning(surface: &NurbsSurface, sim: &Simulation, h: f64) -> String {
    let s = &sim.stats;
    let above = sim.nodes_above(h);
    let cell = s.resolution_mm * s.resolution_mm;
    let worst = above
        .iter()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(uv, _)| surface.point(uv[0], uv[1]));
    format!(
        "{ABOVE_LIMIT} {h} mm: the removal simulation finds {:.4} mm at most, {:.2} mm^2 above h{}",
        s.max_scallop_mm,
        above.len() as f64 * cell,
        worst.map_or(String::new(), |p| format!(
            ", the highest at ({:.1}, {:.1}, {:.1}) mm",
            p.x, p.y, p.z
        ))
    )
}
