use std::path::Path;
use toolpath_formats::{self as formats, Shape};
use toolpath_kernel::error::{Error, Result};
use toolpath_plot::{self as plot, PlotInput};

/// `toolpath plot RESULT [--job JOB] -o FILE.png|svg`. The job supplies the
/// surface or pocket outline and, for milling results, the simulator's
/// residual-height map.
pub fn run(result_path: &Path, job_path: Option<&Path>, output: &Path) -> Result<()> {
    plot::ImageFormat::from_path(output)?;
    let result = formats::read_result(result_path)?;
    let job = job_path.map(formats::read_job).transpose()?;
    if let (Some(job), true) = (&job, !result.job_id.is_empty()) {
        if job.job_id != result.job_id {
            eprintln!(
                "warning: the result is for job \"{}\" but the job file is \"{}\"",
                result.job_id, job.job_id
            );
        }
    }
    let (surface, pocket) = match job.as_ref().map(|j| &j.shape) {
        Some(Shape::Surface(s)) => (Some(s), None),
        Some(Shape::Pocket(p)) => (None, Some(p)),
        None => (None, None),
    };
    let residual = match &job {
        Some(job) => plot::residual_for(job, &result)?,
        None => None,
    };
    let input = PlotInput {
        result: &result,
        surface,
        pocket,
        residual: residual.as_ref(),
    };
    plot::draw(&input, output).map_err(|e| match e {
        Error::Invalid { field, message } => Error::Invalid {
            field: format!("{}: {field}", result_path.display()),
            message,
        },
        other => other,
    })
}
