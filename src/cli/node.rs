use crate::error::{Error, Result};
use crate::ros::{node, NodeConfig};
use std::path::Path;

/// `toolpath node [--config FILE]`: runs the node until SIGINT/SIGTERM.
pub fn run(config: Option<&Path>) -> Result<()> {
    let config = match config {
        Some(p) => NodeConfig::read(p)?,
        None => NodeConfig::default(),
    };
    init_logging();
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| Error::planning(format!("cannot start the async runtime: {e}")))?;
    runtime.block_on(node::run(config))
}

/// Logs to stderr; RUST_LOG overrides (ros2-client warns through `log`).
pub fn init_logging() {
    init_logging_with("warn,rustdds=off,ros2_client::distributions=error,toolpath_planner=info");
}

/// Logs to stderr with `default` as the filter unless RUST_LOG is set.
pub fn init_logging_with(default: &str) {
    let env = env_logger::Env::default().default_filter_or(default);
    let _ = env_logger::Builder::from_env(env)
        .format_timestamp_millis()
        .try_init();
}
