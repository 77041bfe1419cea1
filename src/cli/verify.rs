//! `toolpath verify JOB RESULT [--map FILE]`: runs the scallop simulator on a
//! milling result and prints its figures as JSON; `--map` writes the residual map.
//! Exits 3 when the simulated gouge is beyond the job's gouge tolerance, 4
//! when the residual is above h; refuses (exit 2) a result of another job.

use serde::Serialize;
use std::path::Path;
use std::time::Instant;
use toolpath_formats as formats;
use toolpath_kernel::error::{Error, Result};
use toolpath_pipeline as pipeline;

#[derive(Serialize)]
struct Summary<'a> {
    job_id: &'a str,
    strategy: &'a str,
    max_scallop_mm: f64,
    max_gouge_mm: f64,
    uncovered_area_mm2: f64,
    machined_area_mm2: f64,
    resolution_mm: f64,
    samples: usize,
    /// The job's scallop height, and whether the simulated max stays within it.
    #[serde(skip_serializing_if = "Option::is_none")]
    scallop_mm: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    within_scallop: Option<bool>,
    /// Where the residual is above h: the highest refined peaks (at most
    /// [`LISTED_PEAKS`]), highest first.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    peaks_above_scallop: Vec<Peak>,
    verify_ms: f64,
}

/// A refined residual peak above h, as `toolpath verify` prints it.
#[derive(Serialize)]
struct Peak {
    xyz: [f64; 3],
    uv: [f64; 2],
    residual_mm: f64,
}

/// How many peaks above h the summary lists.
const LISTED_PEAKS: usize = 10;

pub fn run(job_path: &Path, result_path: &Path, map: Option<&Path>) -> Result<()> {
    let job = formats::read_job(job_path)?;
    if !pipeline::is_milling(job.strategy) {
        return Err(Error::invalid(
            "strategy",
            format!(
                "`toolpath verify` checks milling results (tensor_regions, iso_scallop, iso_parametric, mpec); {} results are checked by their own simulation",
                job.strategy.name()
            ),
        ));
    }
    let result = formats::read_result(result_path)?;
    pipeline::check_belongs(&job, &result)?;
    let start = Instant::now();
    let report = pipeline::verify_milling(&job, &result)?;
    let verify_ms = start.elapsed().as_secs_f64() * 1e3;
    if let Some(path) = map {
        formats::write_json(path, &report.map)?;
    }
    let summary = Summary {
        job_id: &job.job_id,
        strategy: &result.strategy,
        max_scallop_mm: report.max_scallop_mm,
        max_gouge_mm: report.max_gouge_mm,
        uncovered_area_mm2: report.uncovered_area_mm2,
        machined_area_mm2: report.machined_area_mm2,
        resolution_mm: report.resolution_mm,
        samples: report.map.residual.len(),
        scallop_mm: job.scallop,
        within_scallop: job.scallop.map(|h| report.max_scallop_mm <= h),
        peaks_above_scallop: job
            .scallop
            .map(|h| {
                report
                    .peaks
                    .iter()
                    .filter(|p| p.residual > h)
                    .take(LISTED_PEAKS)
                    .map(|p| Peak {
                        xyz: p.xyz,
                        uv: p.uv,
                        residual_mm: p.residual,
                    })
                    .collect()
            })
            .unwrap_or_default(),
        verify_ms: (verify_ms * 1000.0).round() / 1000.0,
    };
    formats::write_json(Path::new("-"), &summary)?;
    let conformance = pipeline::Conformance::of_figures(
        &job,
        Some(report.max_gouge_mm),
        Some(report.max_scallop_mm),
    );
    match conformance.error() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}
