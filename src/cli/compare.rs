//! `toolpath compare JOB`: dispatches on what the job machines.

use std::path::Path;
use toolpath_formats::{self as formats, Shape, Strategy};
use toolpath_kernel::error::Result;

pub fn run(job_path: &Path) -> Result<()> {
    let job = formats::read_job(job_path)?;
    match (&job.shape, job.strategy) {
        (Shape::Pocket(_), _) => super::compare_pocket::run(&job),
        (_, Strategy::Mpec) => super::compare_mpec::run(&job),
        _ => super::compare_milling::run(&job),
    }
}
