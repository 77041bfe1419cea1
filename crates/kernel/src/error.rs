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
    /// A transport the node talks through failed: DDS / ROS 2 (participant,
    /// topic, publisher, service, action) or iceoryx2 shared memory. Exit
    /// code 6.
    Transport { via: Transport, message: String },
    /// A controller did not execute a trajectory: it refused or aborted a
    /// pass, or did not answer. Exit code 7.
    Execution { message: String },
    /// A part of the node needed for the work has stopped or is stopping
    /// (the node shutting down, a worker thread gone). Exit code 8.
    Shutdown { message: String },
    /// The operating system refused a resource: a thread, a signal handler,
    /// the list of network interfaces. Exit code 9.
    System { message: String },
}

/// What a [`Error::Transport`] went through.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Transport {
    /// DDS, through ros2-client and RustDDS.
    Dds,
    /// iceoryx2 shared memory.
    Ipc,
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
    /// A DDS / ROS 2 failure.
    pub fn dds(message: impl Into<String>) -> Self {
        Error::Transport {
            via: Transport::Dds,
            message: message.into(),
        }
    }
    /// An iceoryx2 (shared memory) failure.
    pub fn ipc(message: impl Into<String>) -> Self {
        Error::Transport {
            via: Transport::Ipc,
            message: message.into(),
        }
    }
    /// A controller did not execute a trajectory.
    pub fn execution(message: impl Into<String>) -> Self {
        Error::Execution {
            message: message.into(),
        }
    }
    /// A part of the node has stopped or is stopping.
    pub fn shutdown(message: impl Into<String>) -> Self {
        Error::Shutdown {
            message: message.into(),
        }
    }
    /// The operating system refused a resource.
    pub fn system(message: impl Into<String>) -> Self {
        Error::System {
            message: message.into(),
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
    /// Process exit code for the CLI: 1 when the job cannot be planned, 2
    /// for bad input (or a file that cannot be read or written), 3 for a
    /// gouge beyond the tolerance, 4 for a residual above h, 5 for stopped
    /// work, 6 for a failed transport (DDS, iceoryx2), 7 for a controller
    /// that did not execute, 8 for a part of the node that stopped, 9 for a
    /// resource the operating system refused.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Planning { .. } => 1,
            Error::Invalid { .. } | Error::Io { .. } => 2,
            Error::OutOfSpec { gouge: true, .. } => 3,
            Error::OutOfSpec { gouge: false, .. } => 4,
            Error::Stopped { .. } => 5,
            Error::Transport { .. } => 6,
            Error::Execution { .. } => 7,
            Error::Shutdown { .. } => 8,
            Error::System { .. } => 9,
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
            Error::Transport {
                via: Transport::Dds,
                message,
            } => write!(f, "DDS: {message}"),
            Error::Transport {
                via: Transport::Ipc,
                message,
            } => write!(f, "iceoryx2: {message}"),
            Error::Execution { message } => write!(f, "not executed: {message}"),
            Error::Shutdown { message } => write!(f, "stopped: {message}"),
            Error::System { message } => write!(f, "system: {message}"),
        }
    }
}

impl std::error::Error for Error {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_of_failure_has_its_own_exit_code_and_prefix() {
        let cases = [
            (Error::planning("p"), 1, "cannot plan: p"),
            (Error::invalid("f", "m"), 2, "invalid input: f: m"),
            (Error::io("a.json", "gone"), 2, "a.json: gone"),
            (
                Error::OutOfSpec {
                    message: "g".into(),
                    gouge: true,
                },
                3,
                "out of spec: g",
            ),
            (
                Error::OutOfSpec {
                    message: "h".into(),
                    gouge: false,
                },
                4,
                "out of spec: h",
            ),
            (Error::canceled("c"), 5, "canceled: c"),
            (
                Error::dds("cannot create topic job"),
                6,
                "DDS: cannot create topic job",
            ),
            (Error::ipc("no service"), 6, "iceoryx2: no service"),
            (
                Error::execution("pass 1/2 aborted"),
                7,
                "not executed: pass 1/2 aborted",
            ),
            (
                Error::shutdown("the node is shutting down"),
                8,
                "stopped: the node is shutting down",
            ),
            (
                Error::system("cannot start a thread"),
                9,
                "system: cannot start a thread",
            ),
        ];
        for (e, code, text) in cases {
            assert_eq!((e.exit_code(), e.to_string()), (code, text.to_string()));
        }
    }
}
