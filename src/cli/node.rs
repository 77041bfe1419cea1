use std::path::Path;
use toolpath_kernel::error::{Error, Result};
use toolpath_node::ros_args::{self, RosArgs};
use toolpath_node::{logging, node, parameters, security, NodeConfig};

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
    let enclave_dir = enclave_dir(&security::Request::from_env(args.enclave.as_deref()))?;
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| Error::planning(format!("cannot start the async runtime: {e}")))?;
    runtime.block_on(node::run(resolved, enclave_dir))
}

/// The enclave directory the node secures its participant with, checked
/// before anything starts; `None` runs unsecured (the default), with a
/// warning when an enclave was asked for but security is not enabled.
fn enclave_dir(request: &security::Request) -> Result<Option<std::path::PathBuf>> {
    if !request.enabled {
        if request.enclave != "/" {
            log::warn!(
                "--enclave {}: DDS Security is off (it is on only with ROS_SECURITY_ENABLE=true)",
                request.enclave
            );
        }
        return Ok(None);
    }
    let Some(dir) = request.enclave_dir()? else {
        return Ok(None);
    };
    if !security::BUILT_WITH_SECURITY && request.strategy == security::Strategy::Permissive {
        log::warn!(
            "DDS Security is off: this build of toolpath has no DDS Security (cargo build --features security); ROS_SECURITY_STRATEGY=Enforce refuses to start instead"
        );
        return Ok(None);
    }
    log::info!(
        "DDS Security on: enclave {} ({})",
        request.enclave,
        dir.display()
    );
    Ok(Some(dir))
}

/// Logs to stderr with `default` as the filter unless RUST_LOG is set.
pub fn init_logging_with(default: &str) {
    let env = env_logger::Env::default().default_filter_or(default);
    let _ = env_logger::Builder::from_env(env)
        .format_timestamp_millis()
        .try_init();
}
