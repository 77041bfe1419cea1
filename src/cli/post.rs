//! `toolpath post RESULT --job JOB [--machine FILE] --format F [-o FILE]`:
//! writes a milling result as an NC program (formats in docs/formats.md) and
//! prints what it did: blocks, inverse-time blocks, the largest rotary step.

use std::path::Path;
use toolpath_formats as formats;
use toolpath_kernel::error::{Error, Result};
use toolpath_post::{self as post, Format, PostMachine};

pub fn run(
    result_path: &Path,
    job_path: &Path,
    machine: Option<&Path>,
    format: &str,
    output: &Path,
) -> Result<()> {
    let format = Format::parse(format)?;
    let machine = match machine {
        Some(p) => PostMachine::read(p)?,
        None => PostMachine::builtin_mill5(),
    };
    let job = formats::read_job(job_path)?;
    let result = formats::read_result(result_path)?;
    let program = post::post(&job, &result, &machine, format).map_err(|e| match &e {
        Error::Invalid { field, .. } if field == "feed_rate" => e.in_file(job_path),
        _ => e.in_file(result_path),
    })?;
    let r = &program.report;
    let summary = format!(
        "{}: {} passes, {} tool positions, {} blocks ({} with G93 inverse-time feed) for machine {}; {}",
        format.name(),
        r.passes,
        r.cut_points,
        r.blocks,
        r.inverse_time_blocks,
        r.machine,
        r.rotary_line()
    );
    if output == Path::new("-") {
        use std::io::Write;
        std::io::stdout()
            .write_all(program.text.as_bytes())
            .map_err(|e| Error::io("stdout", e))?;
        eprintln!("{summary}");
    } else {
        std::fs::write(output, &program.text)
            .map_err(|e| Error::io(output.display().to_string(), e))?;
        println!("{summary}");
        println!("program: {}", output.display());
    }
    Ok(())
}
