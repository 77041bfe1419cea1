use super::progress::Bar;
use crate::error::Result;
use crate::formats;
use crate::pipeline::{self, RunOptions};
use std::path::Path;

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
    formats::write_json(output, &result?)
}
