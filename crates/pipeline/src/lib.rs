//! The application layer: plan a job, verify it with the simulator, fill the
//! common statistics. The CLI and the ROS node both call this.

use limits::Limited;
use std::time::Instant;
use toolpath_formats::result::polyline_length;
use toolpath_formats::{Family, Job, PlanResult, Strategy};
use toolpath_kernel::error::{Error, Result};
use toolpath_planners::{self as planners, Progress};
use verification::verification;

mod belt;
pub mod budget;
mod islands;
pub(crate) mod limits;
mod milling;
mod mpec;
mod strip_width;
mod verification;

pub use budget::{Budget, Estimate};
pub use limits::TimeLimit;
pub use milling::{verify_and_repair, verify_milling};
pub use toolpath_formats::result::check_belongs;

/// Options that do not change the toolpath.
#[derive(Clone, Copy, Debug, Default)]
pub struct RunOptions {
    /// Skip the simulator (max_scallop_mm stays `None`).
    pub skip_verify: bool,
    /// Report compute_ms as 0 so that repeated runs give identical bytes.
    pub no_timing: bool,
    /// Stop the job once it has run this long (besides the job's own
    /// `time_limit_s`: the shorter one stops it).
    pub time_limit: Option<TimeLimit>,
    /// Refuse a job whose estimate exceeds these before planning.
    pub budget: Budget,
}

impl RunOptions {
    /// Plan only: no simulator, compute_ms 0 (benches, tests, edges that verify elsewhere).
    pub const PLAN_ONLY: RunOptions = RunOptions {
        skip_verify: true,
        no_timing: true,
        time_limit: None,
        budget: Budget::DEFAULT,
    };
}

/// Plans the jobs of several faces ([`toolpath_formats::read_jobs`]) one after
/// another, each within its own face's trim, into one result: the passes
/// grouped by face in the order given (`pass_faces` gives each pass's
/// face), the statistics summed (lengths, passes, points, times, lower
/// bounds, areas in `extra`) or the worst taken (scallop, gouge), the
/// shape fingerprint left out (no single shape verifies it). Passes are not
/// stitched across faces (docs/formats.md, "Several faces").
pub fn run_faces(jobs: &[Job], progress: &dyn Progress, options: RunOptions) -> Result<PlanResult> {
    let [first, ..] = jobs else {
        return Err(toolpath_kernel::error::Error::invalid(
            "surface.faces",
            "is empty",
        ));
    };
    if jobs.len() == 1 {
        return run(first, progress, options);
    }
    let mut out = PlanResult::new(&first.job_id, first.strategy.name());
    let mut faces = Vec::new();
    let mut within = Some(true);
    let add = |x: Option<f64>, y: Option<f64>| match (x, y) {
        (Some(x), Some(y)) => Some(x + y),
        (x, y) => x.or(y),
    };
    let max = |x: Option<f64>, y: Option<f64>| match (x, y) {
        (Some(x), Some(y)) => Some(x.max(y)),
        (x, y) => x.or(y),
    };
    for (k, job) in jobs.iter().enumerate() {
        let r = run(job, progress, options)?;
        faces.extend(std::iter::repeat_n(k, r.passes.len()));
        out.machine = r.machine.clone();
        let (a, b) = (&mut out.stats, &r.stats);
        a.path_length_mm += b.path_length_mm;
        a.passes += b.passes;
        a.compute_ms += b.compute_ms;
        a.max_scallop_mm = max(a.max_scallop_mm, b.max_scallop_mm);
        a.max_gouge_mm = max(a.max_gouge_mm, b.max_gouge_mm);
        a.path_length_lower_bound_mm =
            add(a.path_length_lower_bound_mm, b.path_length_lower_bound_mm);
        a.machining_time_min = add(a.machining_time_min, b.machining_time_min);
        a.uncut_area_mm2 = add(a.uncut_area_mm2, b.uncut_area_mm2);
        a.points = Some(a.points.unwrap_or(0) + b.points.unwrap_or(0));
        for (key, v) in &b.extra {
            if key.ends_with("_mm2") || key.ends_with("_mm") || key.ends_with("_s") {
                *a.extra.entry(key.clone()).or_insert(0.0) += v;
            } else {
                a.extra.insert(format!("face{k}_{key}"), *v);
            }
        }
        within = match (within, r.within_scallop) {
            (Some(x), Some(y)) => Some(x && y),
            _ => None,
        };
        out.warnings
            .extend(r.warnings.iter().map(|w| format!("face {k}: {w}")));
        out.passes.extend(r.passes);
    }
    out.within_scallop = within;
    out.pass_faces = Some(faces);
    Ok(out)
}

/// Plans `job` and fills the statistics every result carries. Unless
/// `options.skip_verify`, the plans are verified and repaired by their
/// family's `Verification` (milling plans by the scallop simulator, see
/// [`verify_and_repair`]; belt plans by the removal simulation); of several
/// candidate plans (tensor_regions) the shortest after repair is kept,
/// preferring one within the scallop height.
///
/// Before any of that the job's estimate is checked against
/// `options.budget`; the job's `time_limit_s` and `options.time_limit` stop
/// it through `progress` checks (`Error::Stopped`), as a cancel does.
pub fn run(job: &Job, progress: &dyn Progress, options: RunOptions) -> Result<PlanResult> {
    let own = job.time_limit_s.map(|seconds| TimeLimit {
        seconds,
        parameter: "the job's time_limit_s",
    });
    let own = Limited::new(progress, own);
    let limited = Limited::new(&own, options.time_limit);
    let progress: &dyn Progress = &limited;
    progress.check()?;
    options.budget.check(job)?;
    let family = verification(job.strategy.family());
    let verify = !options.skip_verify;
    if verify {
        family.check_job(job)?;
    }
    let start = Instant::now();
    let candidates = planners::plan_candidates(job, progress)?;
    progress.check()?;
    let mut planning_s = start.elapsed().as_secs_f64();
    let mut result = if verify {
        let (result, repair_s) = family.verify(job, candidates, progress)?;
        planning_s += repair_s;
        result
    } else {
        verification::first_candidate(candidates)?
    };
    result.job_id = job.job_id.clone();
    result.shape_fingerprint = Some(job.shape.fingerprint());
    result.strategy = job.strategy.name().to_string();
    result.machine = Some(job.machine.name().to_string());
    fill_path_stats(&mut result, job.feed_rate);
    result.stats.compute_ms = if options.no_timing {
        0.0
    } else {
        (planning_s * 1e6).round() / 1000.0
    };
    progress.set(1.0);
    Ok(result)
}

/// Path length, pass and point counts and machining time at `feed_rate` (mm/min).
pub(crate) fn fill_path_stats(result: &mut PlanResult, feed_rate: f64) {
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

/// Strategies whose results the scallop simulator checks (pocket and belt
/// results have their own): [`Family::scallop_simulated`].
pub fn is_milling(strategy: Strategy) -> bool {
    strategy.family().scallop_simulated()
}

/// Belt strategies, checked by the material-removal simulation.
pub fn is_belt(strategy: Strategy) -> bool {
    strategy.family() == Family::Belt
}

/// How the warning of a plan above its scallop height (or tolerance) begins.
pub const ABOVE_LIMIT: &str = "not within the scallop height";
/// How the warning of an MPEC plan that cuts below its band begins.
pub const BELOW_BAND: &str = "not within the tolerance band: it cuts below";

/// Simulated figures within this much of a tolerance count as within it, mm
/// (0.1 micrometre, far below what a machine holds): the simulator's refined
/// extrema carry numerical error of that order, and a plan built to touch its
/// band (MPEC's -delta, docs/methods.md, "The error curve") lands on the band
/// to within that error, on either side of it
/// (`die_saddle_touches_its_band_within_the_slack`).
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
        if !job.strategy.family().scallop_simulated() {
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
#[cfg(test)]
mod tests {
    use super::*;

    /// die_saddle's MPEC plan is built to touch the gouge side of its band
    /// (every drive point's dips at -delta): the simulator's refined gouge
    /// lands just beyond delta, 0.0100136 mm against 0.01 mm, within
    /// [`CONFORMANCE_SLACK_MM`], so the plan is in spec. Without the slack
    /// it would be out of spec; a slack below 1.4e-5 mm would refuse it.
    #[test]
    fn die_saddle_touches_its_band_within_the_slack() {
        let job = toolpath_samples::job("die_saddle").unwrap();
        let r = run(&job, &toolpath_planners::NoProgress, RunOptions::default()).unwrap();
        let delta = job.gouge_tolerance();
        assert_eq!(delta, 0.01);
        let gouge = r.stats.max_gouge_mm.unwrap();
        assert!(
            gouge > delta && gouge <= delta + CONFORMANCE_SLACK_MM,
            "gouge {gouge} mm against the band {delta} mm"
        );
        assert!((gouge - 0.0100136).abs() < 5e-6, "gouge {gouge} mm");
        assert_eq!(Conformance::of(&job, &r), Conformance::default());
        assert_eq!(r.within_scallop, Some(true), "{:?}", r.warnings);
    }
}
