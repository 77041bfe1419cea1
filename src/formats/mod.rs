//! File formats (docs/formats.md): surfaces, pockets, jobs and results, with
//! errors that name the offending field.

pub mod job;
pub mod result;
pub mod shape;

pub use job::{FeedDirection, GrindingParams, Job, JobFile, Machine, Strategy};
pub use result::{Pass, PathPoint, PlanResult, Stats};
pub use shape::{PocketFile, Shape, SurfaceFile, TrimFile};

use crate::error::{Error, Result};
use serde::de::DeserializeOwned;
use std::path::Path;

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
pub fn parse_json(text: &str, what: &str) -> Result<serde_json::Value> {
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

fn read_text(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).map_err(|e| Error::io(path.display().to_string(), e))
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
