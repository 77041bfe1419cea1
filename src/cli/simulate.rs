//! `toolpath simulate JOB RESULT [--map FILE]`: grinds a belt result on the
//! part's height field (Hamann model), prints the removal statistics as JSON
//! and optionally writes the removal-depth map. Exits 4 when the residual is
//! above the job's h; refuses (exit 2) a result of another job.

use std::path::Path;
use toolpath_formats::{read_job, read_result, write_json};
use toolpath_kernel::error::Result;
use toolpath_pipeline::{check_belongs, is_belt, Conformance};
use toolpath_simulation::removal::simulate_job;

pub fn run(job: &Path, result: &Path, map: Option<&Path>) -> Result<()> {
    let job = read_job(job)?;
    let result = read_result(result)?;
    // A milling job is refused by the simulation itself, naming its tool.
    if is_belt(job.strategy) {
        check_belongs(&job, &result)?;
    }
    let sim = simulate_job(&job, &result)?;
    if let Some(path) = map {
        write_json(path, &sim.map())?;
    }
    write_json(Path::new("-"), &sim.stats)?;
    // Held to h only: the removal model's depth below the part is not a
    // cutter's gouge (see `Conformance`).
    let conformance = Conformance::of_figures(&job, None, Some(sim.stats.max_scallop_mm));
    match conformance.error() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}
