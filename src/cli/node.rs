use crate::error::{Error, Result};
use crate::ros::ros_args::{self, RosArgs};
use crate::ros::{logging, node, parameters, NodeConfig};
use std::path::Path;

/// `toolpath node [--config FILE] [--ros-args ...]`: runs the node until
/// SIGINT/SIGTERM. The ROS arguments override the config (see
/// [`parameters::resolve`]); bad ones stop the node before it starts.
pub fn run(config: Option<&Path>, ros: Option<&[String]>) -> Result<()> {
    let config = match config {
        Some(p) => NodeConfig::read(p)?,
        None => NodeConfig::default(),
    };
    let args = match ros {
        Some(tokens) => ros_args::parse(tokens)?,
        None => RosArgs::default(),
    };
    let resolved = parameters::resolve(&config, &args)?;
    let settings = &resolved.config.node;
    let logger = logging::logger_name(&settings.namespace, &settings.name);
    logging::init(
        &logging::directives(&args.log_levels, &logger),
        args.stdout_logs.unwrap_or(true),
    );
    if let Some(enclave) = &args.enclave {
        log::warn!(
            "--enclave {enclave}: DDS security (SROS2 enclaves) is not supported by this node yet; it runs without security"
        );
    }
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| Error::planning(format!("cannot start the async runtime: {e}")))?;
    runtime.block_on(node::run(resolved))
}

/// Logs to stderr with `default` as the filter unless RUST_LOG is set.
pub fn init_logging_with(default: &str) {
    let env = env_logger::Env::default().default_filter_or(default);
    let _ = env_logger::Builder::from_env(env)
        .format_timestamp_millis()
        .try_init();
}
