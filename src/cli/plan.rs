use super::progress::Bar;
use std::path::Path;
use toolpath_formats as formats;
use toolpath_kernel::error::Result;
use toolpath_pipeline::{self as pipeline, Budget, Conformance, RunOptions, TimeLimit};

/// The options of `toolpath plan` that bound or skip work.
pub struct Limits {
    pub no_verify: bool,
    pub no_timing: bool,
    /// `--time-limit`, s.
    pub time_limit_s: Option<f64>,
    pub budget: Budget,
}

/// Plans the job and writes the result, unless the simulator finds a gouge
/// beyond the job's gouge tolerance (exit code 3, nothing written: a toolpath
/// that cuts into the part is never handed out). A residual above h writes
/// the result and exits with code 4; a job stopped by its time limit exits
/// with code 5.
pub fn run(job_path: &Path, output: &Path, limits: Limits) -> Result<()> {
    if let Some(s) = limits.time_limit_s {
        TimeLimit::validate(s, "--time-limit")?;
    }
    limits.budget.validate("--")?;
    let jobs = formats::read_jobs(job_path)?;
    let job = &jobs[0];
    let bar = Bar::new(&format!("planning {}", job.job_id));
    let result = pipeline::run_faces(
        &jobs,
        &bar,
        RunOptions {
            skip_verify: limits.no_verify,
            no_timing: limits.no_timing,
            time_limit: limits.time_limit_s.map(|seconds| TimeLimit {
                seconds,
                parameter: "--time-limit",
            }),
            budget: limits.budget,
        },
    );
    bar.finish();
    let result = result?;
    let conformance = Conformance::of(job, &result);
    if conformance.gouge.is_none() {
        formats::write_json(output, &result)?;
    }
    match conformance.error() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}
