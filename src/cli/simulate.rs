//! `toolpath simulate JOB RESULT [--map FILE]`: grinds a belt result on the
//! part's height field (Hamann model), prints the removal statistics as JSON
//! and optionally writes the removal-depth map.

use crate::error::Result;
use crate::formats::{read_job, read_result, write_json};
use crate::simulation::removal::simulate_job;
use std::path::Path;

pub fn run(job: &Path, result: &Path, map: Option<&Path>) -> Result<()> {
    let job = read_job(job)?;
    let result = read_result(result)?;
    let sim = simulate_job(&job, &result)?;
    if let Some(path) = map {
        write_json(path, &sim.map())?;
    }
    write_json(Path::new("-"), &sim.stats)
}
