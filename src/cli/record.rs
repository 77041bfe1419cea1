use std::path::Path;
use toolpath_formats as formats;
use toolpath_kernel::error::{Error, Result};
use toolpath_machines::Machines;
use toolpath_messages as msgs;
use toolpath_recording::runs;

/// `toolpath record JOB -o BAG [--require-success]`: plans the job as the
/// node would and records its inputs and outputs as a rosbag2 bag (a job that
/// fails is recorded with its status; `--require-success` then exits non-zero).
///
/// With `fake_execute` the bag is the recording of a node that executed the
/// job on a fake controller ([`super::record_executed`]).
pub fn run(job: &Path, output: &Path, require_success: bool, fake_execute: bool) -> Result<()> {
    let job = formats::read_job(job)?;
    if fake_execute {
        let (last, goals) = super::record_executed::record(&job, output)?;
        println!(
            "{}: recorded by the node; job {} {}; {goals} goals to the fake controller",
            output.display(),
            last.job_id,
            msgs::JobStatus::state_name(last.state)
        );
        return check_success(&last, require_success);
    }
    let (summary, last) = runs::record_job(&job, output, &Machines::default())?;
    println!(
        "{}: {} messages, {} chunks, {} bytes ({} uncompressed); job {} {}",
        summary.directory.display(),
        summary.messages,
        summary.chunks,
        summary.file_bytes,
        summary.uncompressed_bytes,
        last.job_id,
        msgs::JobStatus::state_name(last.state)
    );
    check_success(&last, require_success)
}

fn check_success(last: &msgs::JobStatus, require_success: bool) -> Result<()> {
    if require_success && last.state != msgs::JobStatus::SUCCEEDED {
        return Err(Error::planning(format!(
            "job {} recorded as {}: {}",
            last.job_id,
            msgs::JobStatus::state_name(last.state),
            last.message
        )));
    }
    Ok(())
}
