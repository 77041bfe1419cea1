use super::progress::Bar;
use crate::error::Result;
use crate::formats;
use crate::pipeline::{self, Conformance, RunOptions};
use std::path::Path;

/// Plans the job and writes the result, unless the simulator finds a gouge
/// beyond the job's gouge tolerance (exit code 3, nothing written: a toolpath
/// that cuts into the part is never handed out). A residual above h writes
/// the result and exits with code 4.
pub fn run(job_path: &Path, output: &Path, no_verify: bool, no_timing: bool) -> Result<()> {
    let job = formats::read_job(job_path)?;
    let bar = Bar::new(&format!("planning {}", job.job_id));
    let result = pipeline::run(
        &job,
        &bar,
        RunOptions {
            skip_verify: no_verify,
            no_timing,
        },
    );
    bar.finish();
    let result = result?;
    let conformance = Conformance::of(&job, &result);
    if conformance.gouge.is_none() {
        formats::write_json(output, &result)?;
    }
    match conformance.error() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}
