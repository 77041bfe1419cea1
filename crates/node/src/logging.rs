//! The node's log: the `log` crate's records go to stderr (env_logger) and,
//! once the ROS node exists, the node's own records (target
//! `toolpath_...`) also to `/rosout` as rcl_interfaces/Log with their
//! level, under the node's logger name (`cell_b.tp` for `/cell_b/tp`, as
//! rclcpp names it). Levels come from the default filter, then RUST_LOG,
//! then `--log-level` rules.

use super::ros_args::LogLevelRule;
use ros2_client::log::LogLevel;
use ros2_client::{NodeLoggingHandle, RosoutRaw};
use std::cell::Cell;
use std::sync::OnceLock;

/// Filter of the node's log unless RUST_LOG is set. RustDDS is quiet but
/// for its one-line reports of a peer whose QoS does not match one of the
/// node's endpoints (target `rustdds::incompatible_qos`, a vendored patch):
/// such a peer's data never arrives, and nothing else would say why.
pub const DEFAULT_FILTER: &str = "warn,rustdds=off,rustdds::incompatible_qos=warn,\
     ros2_client::distributions=error,toolpath_=info";

/// The workspace's log targets: `--log-level LEVEL` sets them. Every crate
/// of the workspace is named `toolpath_*`, and a filter directive matches
/// the targets its name is a prefix of, so this one covers the node, the
/// pipeline and the planners alike.
const OWN_TARGET: &str = "toolpath_";

struct Bridge {
    stderr: env_logger::Logger,
    to_stderr: bool,
    rosout: OnceLock<(NodeLoggingHandle, String)>,
}

thread_local! {
    /// Set while a record is being published on /rosout (a publish that logs
    /// must not publish again).
    static IN_ROSOUT: Cell<bool> = const { Cell::new(false) };
}

/// RustDDS's log target of an incompatible-QoS report (vendored patch).
const INCOMPATIBLE_QOS: &str = "rustdds::incompatible_qos";

/// DDS topics the node reads with a volatile and a transient-local reader.
static PAIRED_READERS: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());

/// Marks the DDS topic `dds_topic` (`rt/cell_b/surface`) as read by a
/// volatile and a transient-local reader: a volatile writer matches the
/// first and, by design, not the second, so that mismatch is not reported.
pub fn paired_durability_readers(dds_topic: &str) {
    let mut v = match PAIRED_READERS.lock() {
        Ok(g) => g,
        Err(p) => p.into_inner(),
    };
    v.push(dds_topic.to_string());
}

/// Whether `record` reports the expected durability mismatch of a volatile
/// writer with the transient-local twin of a volatile reader.
fn expected_mismatch(record: &log::Record) -> bool {
    if record.target() != INCOMPATIBLE_QOS {
        return false;
    }
    let text = record.args().to_string();
    if !text.contains("does not match this reader (durability: requested TransientLocal") {
        return false;
    }
    let topic = text
        .split_once("on DDS topic ")
        .and_then(|(_, rest)| rest.split_once(':'))
        .map(|(t, _)| t);
    let paired = match PAIRED_READERS.lock() {
        Ok(g) => g,
        Err(p) => p.into_inner(),
    };
    topic.is_some_and(|t| paired.iter().any(|p| p == t))
}

impl log::Log for Bridge {
    fn enabled(&self, metadata: &log::Metadata) -> bool {
        self.stderr.enabled(metadata)
    }

    fn log(&self, record: &log::Record) {
        if !self.stderr.matches(record) || expected_mismatch(record) {
            return;
        }
        if self.to_stderr {
            self.stderr.log(record);
        }
        if !record.target().starts_with(OWN_TARGET) || IN_ROSOUT.with(Cell::get) {
            return;
        }
        let Some((handle, name)) = self.rosout.get() else {
            return;
        };
        IN_ROSOUT.with(|c| c.set(true));
        let level = match record.level() {
            log::Level::Error => LogLevel::Error,
            log::Level::Warn => LogLevel::Warn,
            log::Level::Info => LogLevel::Info,
            log::Level::Debug | log::Level::Trace => LogLevel::Debug,
        };
        handle.rosout_raw(
            ros2_client::builtin_interfaces::Time::now(),
            level,
            name,
            &record.args().to_string(),
            record.file().unwrap_or(""),
            record.module_path().unwrap_or(""),
            record.line().unwrap_or(0),
        );
        IN_ROSOUT.with(|c| c.set(false));
    }

    fn flush(&self) {
        self.stderr.flush();
    }
}

static BRIDGE: OnceLock<&'static Bridge> = OnceLock::new();

/// The filter directives of `--log-level` rules: a rule without a name, or
/// naming the node's logger (`node_logger`, or its last part), sets the
/// crate's level; another name is a `log` target (`rustdds`,
/// `ros2_client`; `.` reads as `::`).
pub fn directives(rules: &[LogLevelRule], node_logger: &str) -> String {
    let base = node_logger.rsplit('.').next().unwrap_or(node_logger);
    rules
        .iter()
        .map(|r| {
            let target = match r.logger.as_deref() {
                None => OWN_TARGET.to_string(),
                Some(n) if n == node_logger || n == base => OWN_TARGET.to_string(),
                Some(n) => n.replace('.', "::"),
            };
            format!("{target}={}", r.severity.level_filter())
        })
        .collect::<Vec<_>>()
        .join(",")
}

/// rclcpp's logger name of a node: namespace and name joined by `.`.
pub fn logger_name(namespace: &str, name: &str) -> String {
    namespace
        .split('/')
        .filter(|p| !p.is_empty())
        .chain(std::iter::once(name))
        .collect::<Vec<_>>()
        .join(".")
}

/// Installs the node's logger (once per process): the default filter or
/// RUST_LOG, then `extra` directives (later ones win).
pub fn init(extra: &str, to_stderr: bool) {
    let base = std::env::var("RUST_LOG")
        .ok()
        .filter(|s| !s.trim().is_empty())
        .unwrap_or_else(|| DEFAULT_FILTER.to_string());
    let filter = if extra.is_empty() {
        base
    } else {
        format!("{base},{extra}")
    };
    let stderr = env_logger::Builder::new()
        .parse_filters(&filter)
        .format_timestamp_millis()
        .build();
    let max = stderr.filter();
    let bridge: &'static Bridge = Box::leak(Box::new(Bridge {
        stderr,
        to_stderr,
        rosout: OnceLock::new(),
    }));
    if log::set_logger(bridge).is_ok() {
        log::set_max_level(max);
        let _ = BRIDGE.set(bridge);
    }
}

/// From now on the node's records also go to `/rosout` through `handle`.
pub fn attach_rosout(handle: NodeLoggingHandle, logger_name: String) {
    if let Some(b) = BRIDGE.get() {
        let _ = b.rosout.set((handle, logger_name));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ros_args::Severity;

    #[test]
    fn log_level_rules_become_filter_directives() {
        let rules = [
            LogLevelRule {
                logger: None,
                severity: Severity::Debug,
            },
            LogLevelRule {
                logger: Some("cell_b.tp".into()),
                severity: Severity::Warn,
            },
            LogLevelRule {
                logger: Some("tp".into()),
                severity: Severity::Fatal,
            },
            LogLevelRule {
                logger: Some("rustdds.rtps".into()),
                severity: Severity::Info,
            },
        ];
        assert_eq!(
            directives(&rules, "cell_b.tp"),
            "toolpath_=DEBUG,toolpath_=WARN,toolpath_=ERROR,rustdds::rtps=INFO"
        );
        assert_eq!(logger_name("/cell_b", "tp"), "cell_b.tp");
        assert_eq!(logger_name("/", "toolpath_planner"), "toolpath_planner");
    }
}
