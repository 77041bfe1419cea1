use std::net::{IpAddr, Ipv4Addr};
use std::path::Path;
use std::time::Duration;
use toolpath_kernel::error::{Error, Result};
use toolpath_machines::Machines;
use toolpath_node::republish::{self, PublishOptions};
use toolpath_node::NodeConfig;
use toolpath_recording::runs;

/// How `--publish` reaches the node.
pub struct PublishArgs<'a> {
    pub namespace: &'a str,
    pub timeout_s: f64,
}

/// `toolpath replay BAG [--check] [--publish]`: re-plans every job of the bag
/// (or, with `--publish`, republishes its inputs to a running node on
/// ROS_DOMAIN_ID over loopback); with `--check`, prints what differs from the
/// recording and fails on a difference.
pub fn run(bag: &Path, check: bool, publish: Option<PublishArgs<'_>>) -> Result<()> {
    let report = match publish {
        None => runs::replay(bag, &Machines::default())?,
        Some(args) => {
            if !args.timeout_s.is_finite() || args.timeout_s <= 0.0 {
                return Err(Error::invalid(
                    "--timeout-s",
                    "must be a positive number of seconds",
                ));
            }
            let options = PublishOptions {
                // ROS_DOMAIN_ID, else 0 (a bad value is an error naming it).
                domain_id: NodeConfig::default().domain_id()?,
                namespace: args.namespace.to_string(),
                interfaces: Some(vec![IpAddr::V4(Ipv4Addr::LOCALHOST)]),
                discovery_timeout: Duration::from_secs(30),
                timeout: Duration::from_secs_f64(args.timeout_s),
            };
            super::node::init_logging_with("error,rustdds=off");
            let runtime = tokio::runtime::Builder::new_multi_thread()
                .worker_threads(2)
                .enable_all()
                .build()
                .map_err(|e| Error::planning(format!("cannot start the async runtime: {e}")))?;
            runtime.block_on(republish::republish(bag, &options))?
        }
    };
    if let Some(t) = &report.truncated {
        eprintln!("warning: {t}");
    }
    for j in &report.jobs {
        let verdict = if j.differences.is_empty() {
            "same"
        } else {
            "DIFFERENT"
        };
        println!(
            "{:<28} {:<20} {:<6} {:>8} points  {verdict}",
            j.job_id, j.strategy, j.machine, j.points
        );
        if check {
            for d in &j.differences {
                println!("    {d}");
            }
        }
    }
    let n = report.differences();
    if check && n > 0 {
        return Err(Error::planning(format!(
            "{n} difference(s) from the recording in {}",
            bag.display()
        )));
    }
    Ok(())
}
