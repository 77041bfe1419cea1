//! File formats (docs/formats.md): surfaces, pockets, jobs and results, with
//! errors that name the offending field.

pub mod job;
pub mod result;
pub mod shape;
pub mod step;

pub use job::{Family, FeedDirection, GrindingParams, Job, JobFile, Machine, Strategy};
pub use result::{Pass, PathPoint, PlanResult, Stats};
pub use shape::{Shape, SurfaceFile, TrimFile};

use serde::de::DeserializeOwned;
use std::path::Path;
use toolpath_kernel::error::{Error, Result};

/// Deserialises with the path of the failing field in the error.
pub fn from_value<T: DeserializeOwned>(value: serde_json::Value) -> Result<T> {
    serde_path_to_error::deserialize(value).map_err(|e| {
        let path = e.path().to_string();
        let path = if path == "." { String::new() } else { path };
        Error::invalid(path, e.into_inner().to_string())
    })
}

/// Parses JSON text; syntax errors give line and column, and the path of the
/// value being read when the error struck (e.g. a number out of range such as
/// 1e999, which JSON cannot hold as a finite f64).
pub(crate) fn parse_json(text: &str, what: &str) -> Result<serde_json::Value> {
    let mut de = serde_json::Deserializer::from_str(text);
    let value: serde_json::Value = serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let path = e.path().to_string();
        let path = if path == "." { String::new() } else { path };
        let inner = e.into_inner();
        let hint = if inner.to_string().starts_with("number out of range") {
            " (numbers must be finite)"
        } else {
            ""
        };
        Error::invalid(path, format!("{what} is not valid JSON: {inner}{hint}"))
    })?;
    de.end()
        .map_err(|e| Error::invalid("", format!("{what} is not valid JSON: {e}")))?;
    Ok(value)
}

/// Largest text input file (job, surface, pocket, result, config), bytes:
/// far above any real surface (a 1000 x 1000 control net is about 80 MB).
pub(crate) const MAX_TEXT_FILE_BYTES: u64 = 256 << 20;

/// The bytes of a regular file of at most `max_bytes`. Anything else is
/// refused before it is opened: a directory, a device such as /dev/zero
/// (endless) or a FIFO (opening one waits for a writer) would wedge the
/// reader.
pub fn read_file_limited(path: &Path, max_bytes: u64) -> Result<Vec<u8>> {
    use std::io::Read;
    let shown = path.display().to_string();
    let meta = std::fs::metadata(path).map_err(|e| Error::io(&shown, e))?;
    if !meta.is_file() {
        let kind = if meta.is_dir() {
            "a directory"
        } else {
            "a special file (device, FIFO or socket)"
        };
        return Err(Error::io(
            &shown,
            format!("is {kind}, not a regular file: give the path of a file"),
        ));
    }
    let too_big = |size: u64| {
        Error::io(
            &shown,
            format!("is {size} bytes, above the limit of {max_bytes} bytes for this kind of file"),
        )
    };
    if meta.len() > max_bytes {
        return Err(too_big(meta.len()));
    }
    let file = std::fs::File::open(path).map_err(|e| Error::io(&shown, e))?;
    // The file may have grown since: never read more than the limit.
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.take(max_bytes + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(&shown, e))?;
    if bytes.len() as u64 > max_bytes {
        return Err(too_big(bytes.len() as u64));
    }
    Ok(bytes)
}

/// A text input file ([`read_file_limited`] to [`MAX_TEXT_FILE_BYTES`]) as UTF-8.
pub fn read_text(path: &Path) -> Result<String> {
    let bytes = read_file_limited(path, MAX_TEXT_FILE_BYTES)?;
    String::from_utf8(bytes).map_err(|e| {
        Error::io(
            path.display().to_string(),
            format!("is not UTF-8 text: {e}"),
        )
    })
}

/// Reads a surface or pocket file.
pub fn read_shape(path: &Path) -> Result<Shape> {
    let text = read_text(path)?;
    parse_json(&text, "the surface file")
        .and_then(shape::shape_from_value)
        .map_err(|e| e.in_file(path))
}

/// Parses a job from JSON text (`base_dir` resolves `{"file": ...}` surfaces).
pub fn parse_job(text: &str, base_dir: Option<&Path>) -> Result<Job> {
    let value = parse_json(text, "the job")?;
    let file: JobFile = from_value(value)?;
    Job::from_file(file, base_dir)
}

/// Reads and validates a job file.
pub fn read_job(path: &Path) -> Result<Job> {
    let text = read_text(path)?;
    parse_job(&text, path.parent()).map_err(|e| e.in_file(path))
}

/// Reads and validates a job file into one job per face (see
/// [`job::jobs_from_file`]): several when its surface names several STEP faces.
pub fn read_jobs(path: &Path) -> Result<Vec<Job>> {
    let text = read_text(path)?;
    parse_json(&text, "the job")
        .and_then(from_value)
        .and_then(|file: JobFile| job::jobs_from_file(file, path.parent()))
        .map_err(|e| e.in_file(path))
}

/// Reads a result file.
pub fn read_result(path: &Path) -> Result<PlanResult> {
    let text = read_text(path)?;
    parse_json(&text, "the result file")
        .and_then(from_value)
        .map_err(|e| e.in_file(path))
}

/// Pretty JSON with a trailing newline; deterministic for equal values.
pub fn to_json_pretty<T: serde::Serialize>(value: &T) -> String {
    let mut s = serde_json::to_string_pretty(value).expect("plain data serialises");
    s.push('\n');
    s
}

/// Writes JSON to a file, or to stdout for "-".
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    let text = to_json_pretty(value);
    if path == Path::new("-") {
        print!("{text}");
        return Ok(());
    }
    std::fs::write(path, text).map_err(|e| Error::io(path.display().to_string(), e))
}
