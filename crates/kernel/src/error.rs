//! One error type for the whole crate. Every bad input names the field (a
//! JSON-path-like location) and says what is wrong; the CLI maps
//! [`Error::exit_code`] to its exit status.

use std::fmt;

#[derive(Debug, Clone, PartialEq)]
pub enum Error {
    /// Malformed input: a file, a message or a parameter. Exit code 2.
    Invalid { field: String, message: String },
    /// Valid input the method cannot plan (tool too large for the curvature, ...).
    Planning { message: String },
    /// A file could not be read or written.
    Io { path: String, message: String },
    /// A plan the simulator finds outside the job's tolerances: a gouge
    /// beyond the gouge tolerance (exit code 3) or a residual above the
    /// scallop height h (exit code 4).
    OutOfSpec { message: String, gouge: bool },
    /// Work stopped on request (a cancel) or by a limit (the job's time
    /// budget): `canceled` tells the two apart. Exit code 5.
    Stopped { message: String, canceled: bool },
}

pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    pub fn invalid(field: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Invalid {
            field: field.into(),
            message: message.into(),
        }
    }
    pub fn planning(message: impl Into<String>) -> Self {
        Error::Planning {
            message: message.into(),
        }
    }
    /// A cancel from the job's owner: the job ends CANCELED.
    pub fn canceled(message: impl Into<String>) -> Self {
        Error::Stopped {
            message: message.into(),
            canceled: true,
        }
    }
    pub fn io(path: impl Into<String>, err: impl fmt::Display) -> Self {
        Error::Io {
            path: path.into(),
            message: err.to_string(),
        }
    }
    /// Names the file a bad field came from: `job.json: tool.radius`.
    pub fn in_file(self, path: &std::path::Path) -> Self {
        match self {
            Error::Invalid { field, message } => Error::Invalid {
                field: if field.is_empty() {
                    path.display().to_string()
                } else {
                    format!("{}: {field}", path.display())
                },
                message,
            },
            other => other,
        }
    }
    /// Prefixes the field path, e.g. `tool` + `radius` -> `tool.radius`.
    pub fn within(self, parent: &str) -> Self {
        match self {
            Error::Invalid { field, message } => Error::Invalid {
                field: if field.is_empty() {
                    parent.to_string()
                } else if field.starts_with('[') {
                    format!("{parent}{field}")
                } else {
                    format!("{parent}.{field}")
                },
                message,
            },
            other => other,
        }
    }
    /// Process exit code for the CLI: 2 for bad input, 3 for a gouge beyond
    /// the tolerance, 4 for a residual above h, 5 for stopped work, 1
    /// otherwise.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Invalid { .. } | Error::Io { .. } => 2,
            Error::Planning { .. } => 1,
            Error::OutOfSpec { gouge: true, .. } => 3,
            Error::OutOfSpec { gouge: false, .. } => 4,
            Error::Stopped { .. } => 5,
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Invalid { field, message } if field.is_empty() => {
                write!(f, "invalid input: {message}")
            }
            Error::Invalid { field, message } => write!(f, "invalid input: {field}: {message}"),
            Error::Planning { message } => write!(f, "cannot plan: {message}"),
            Error::Io { path, message } => write!(f, "{path}: {message}"),
            Error::OutOfSpec { message, .. } => write!(f, "out of spec: {message}"),
            Error::Stopped {
                message,
                canceled: true,
            } => write!(f, "canceled: {message}"),
            Error::Stopped { message, .. } => write!(f, "stopped: {message}"),
        }
    }
}

impl std::error::Error for Error {}
