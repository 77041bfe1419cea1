//! `toolpath demo`: the node and a built-in client as a process pair on
//! loopback. The node runs as a child process (`toolpath node`) on a private
//! ROS domain; this process publishes every built-in sample shape and its job
//! over DDS, collects the statuses and toolpaths, and prints the results table.

use crate::error::{Error, Result};
use crate::formats::Shape;
use crate::ros::convert;
use crate::ros::msgs::{self, JobStatus};
use crate::ros::node::{qos, topics, RosNode};
use crate::samples;
use futures::StreamExt;
use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::net::{IpAddr, Ipv4Addr};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// How long the demo waits for all jobs.
const JOBS_TIMEOUT: Duration = Duration::from_secs(900);

/// The node child process; killed by pid when dropped.
struct NodeChild(Child);

impl Drop for NodeChild {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A domain of its own (so the demo never talks to another node), unless
/// ROS_DOMAIN_ID asks for one.
fn demo_domain() -> u16 {
    if let Some(d) = std::env::var("ROS_DOMAIN_ID")
        .ok()
        .and_then(|s| s.trim().parse::<u16>().ok())
    {
        return d;
    }
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    (100 + (std::process::id() ^ nanos) % 100) as u16
}

fn start_node(domain: u16) -> Result<NodeChild> {
    let exe = std::env::current_exe()
        .map_err(|e| Error::planning(format!("cannot find the toolpath binary: {e}")))?;
    let mut child = Command::new(exe)
        .arg("node")
        .env("ROS_DOMAIN_ID", domain.to_string())
        .env(
            "RUST_LOG",
            std::env::var("RUST_LOG").unwrap_or_else(|_| "off".into()),
        )
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| Error::planning(format!("cannot start `toolpath node`: {e}")))?;
    let stdout = child.stdout.take();
    let guard = NodeChild(child);
    let mut lines =
        BufReader::new(stdout.ok_or_else(|| Error::planning("node stdout missing"))?).lines();
    match lines.next() {
        Some(Ok(line)) if line.starts_with("ready") => Ok(guard),
        other => Err(Error::planning(format!(
            "`toolpath node` did not start: {other:?}"
        ))),
    }
}

struct Row {
    sample: &'static str,
    strategy: String,
    machine: String,
    status: Option<msgs::JobStatus>,
    toolpath: Option<msgs::Toolpath>,
}

/// Plans every sample job through the node and prints one row each.
pub fn run(_out: &std::path::Path) -> Result<()> {
    super::node::init_logging_with("off");
    let domain = demo_domain();
    let _node = start_node(domain)?;
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| Error::planning(format!("cannot start the async runtime: {e}")))?;
    let rows = runtime.block_on(client(domain))?;
    println!(
        "{:<18} {:<20} {:<6} {:<10} {:>6} {:>7} {:>10} {:>9} {:>11} {:>9} {:>9}",
        "sample",
        "strategy",
        "mach",
        "status",
        "passes",
        "points",
        "length_mm",
        "time_min",
        "scallop_mm",
        "traj_s",
        "plan_ms"
    );
    let mut failed = 0;
    for r in rows {
        let state = r
            .status
            .as_ref()
            .map_or("NO ANSWER", |s| JobStatus::state_name(s.state));
        match (&r.toolpath, &r.status) {
            (Some(t), Some(s)) if s.state == JobStatus::SUCCEEDED => {
                let st = &t.stats;
                let scallop = if st.max_scallop_mm.is_finite() {
                    format!("{:.4}", st.max_scallop_mm)
                } else {
                    "-".into()
                };
                println!(
                    "{:<18} {:<20} {:<6} {:<10} {:>6} {:>7} {:>10.1} {:>9.2} {:>11} {:>9.1} {:>9.1}",
                    r.sample,
                    r.strategy,
                    r.machine,
                    state,
                    st.passes,
                    st.points,
                    st.path_length_mm,
                    st.machining_time_min,
                    scallop,
                    st.trajectory_duration_s,
                    st.compute_ms
                );
            }
            _ => {
                failed += 1;
                let why = r.status.as_ref().map_or("", |s| s.message.as_str());
                println!(
                    "{:<18} {:<20} {:<6} {:<10} {why}",
                    r.sample, r.strategy, r.machine, state
                );
            }
        }
    }
    println!(
        "(node and client on ROS domain {domain}, loopback; {failed} job(s) without a toolpath)"
    );
    Ok(())
}

async fn client(domain: u16) -> Result<Vec<Row>> {
    let mut ros = RosNode::new(
        "toolpath_demo",
        "/",
        domain,
        Some(vec![IpAddr::V4(Ipv4Addr::LOCALHOST)]),
    )?;
    let surface_pub = ros.publisher::<msgs::Surface>(topics::SURFACE, qos::shapes())?;
    let pocket_pub = ros.publisher::<msgs::Pocket>(topics::POCKET, qos::shapes())?;
    let job_pub = ros.publisher::<msgs::Job>(topics::JOB, qos::job())?;
    let status_sub = ros.subscription::<msgs::JobStatus>(topics::JOB_STATUS, qos::status())?;
    let toolpath_sub = ros.subscription::<msgs::Toolpath>(topics::TOOLPATH, qos::results())?;
    let header = || msgs::Header {
        stamp: msgs::Time::now(),
        frame_id: "workpiece".into(),
    };
    // The node's readers must be matched before volatile jobs are sent.
    tokio::time::timeout(
        Duration::from_secs(30),
        job_pub.wait_for_subscription(&ros.node),
    )
    .await
    .map_err(|_| Error::planning("the node's job subscription was not discovered within 30 s"))?;
    let mut rows = Vec::new();
    let mut index = BTreeMap::new();
    for s in samples::list() {
        let job = samples::job(s.name)?;
        let published = match &job.shape {
            Shape::Surface(surf) => surface_pub
                .publish(convert::surface_to_msg(s.name, surf, header()))
                .is_ok(),
            Shape::Pocket(p) => pocket_pub
                .publish(convert::pocket_to_msg(s.name, p, header()))
                .is_ok(),
        };
        if !published {
            return Err(Error::planning(format!("cannot publish sample {}", s.name)));
        }
        job_pub
            .publish(convert::job_to_msg(&job, s.name, header()))
            .map_err(|_| Error::planning(format!("cannot publish the job of {}", s.name)))?;
        index.insert(job.job_id.clone(), rows.len());
        rows.push(Row {
            sample: s.name,
            strategy: job.strategy.name().to_string(),
            machine: job.machine.name().to_string(),
            status: None,
            toolpath: None,
        });
    }
    let mut statuses = Box::pin(status_sub.async_stream());
    let mut toolpaths = Box::pin(toolpath_sub.async_stream());
    let deadline = Instant::now() + JOBS_TIMEOUT;
    let done = |rows: &Vec<Row>| {
        rows.iter().all(|r| match &r.status {
            Some(s) if s.state == JobStatus::SUCCEEDED => r.toolpath.is_some(),
            Some(s) => s.is_final(),
            None => false,
        })
    };
    while !done(&rows) {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            break;
        }
        tokio::select! {
            Some(Ok((m, _))) = statuses.next() => {
                if let Some(&k) = index.get(&m.job_id) {
                    if rows[k].status.as_ref().is_none_or(|s| !s.is_final()) {
                        rows[k].status = Some(m);
                    }
                }
            }
            Some(Ok((m, _))) = toolpaths.next() => {
                if let Some(&k) = index.get(&m.job_id) {
                    rows[k].toolpath = Some(m);
                }
            }
            _ = tokio::time::sleep(left) => break,
        }
    }
    Ok(rows)
}
