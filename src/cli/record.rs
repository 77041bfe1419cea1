use crate::error::Result;
use crate::formats;
use crate::machines::Machines;
use crate::recording::runs;
use std::path::Path;

/// `toolpath record JOB -o BAG`: plans the job as the node would and records
/// its inputs and outputs as a rosbag2 bag.
pub fn run(job: &Path, output: &Path) -> Result<()> {
    let job = formats::read_job(job)?;
    let summary = runs::record_job(&job, output, &Machines::default())?;
    println!(
        "{}: {} messages, {} chunks, {} bytes ({} uncompressed)",
        summary.directory.display(),
        summary.messages,
        summary.chunks,
        summary.file_bytes,
        summary.uncompressed_bytes
    );
    Ok(())
}
