//! `toolpath demo`: the node and a built-in client as a process pair on
//! loopback. The node runs as a child process (`toolpath node`) on a private
//! ROS domain; this process publishes every built-in sample shape and its job
//! over DDS, collects the statuses and toolpaths, and prints the results table.
//!
//! Into `--out DIR` go the node's config (`node.yaml`), the bag the node
//! records of the run (`DIR/demo_run/`, recording on unless `--no-record`),
//! one picture per sample (`DIR/<sample>.png`) and, next to it, one NC
//! program per milling sample for the built-in mill5 (`DIR/<sample>.ngc`,
//! LinuxCNC joint space, `toolpath post`). The pictures are drawn from a
//! local re-plan of the sample job: planning is deterministic, so it is the
//! node's toolpath (the point counts are checked), and the local result also
//! carries what the Toolpath message does not (separatrices, medial axis,
//! degenerate-point kinds) plus the simulator's residual map.

use futures::StreamExt;
use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::net::{IpAddr, Ipv4Addr};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use toolpath_formats::{Job, PlanResult, Shape};
use toolpath_kernel::error::{Error, Result};
use toolpath_messages::{self as msgs, convert, topics, JobStatus};
use toolpath_node::node::{qos, RosNode};
use toolpath_pipeline::{self as pipeline, RunOptions};
use toolpath_planners::NoProgress;
use toolpath_plot::{self as plot, PlotInput};
use toolpath_post::{self as post, Format, PostMachine};
use toolpath_samples as samples;

/// How long the demo waits for all jobs.
const JOBS_TIMEOUT: Duration = Duration::from_secs(900);

/// Name of the demo's bag inside `--out`.
pub const DEMO_BAG: &str = "demo_run";

/// The node child process; stopped by pid when dropped.
pub struct NodeChild(Child);

impl NodeChild {
    /// SIGTERM (the node finishes its bag), then SIGKILL after `grace`.
    pub fn stop(&mut self, grace: Duration) {
        if matches!(self.0.try_wait(), Ok(Some(_))) {
            return;
        }
        let pid = nix::unistd::Pid::from_raw(self.0.id() as i32);
        if nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGTERM).is_ok() {
            let deadline = Instant::now() + grace;
            while Instant::now() < deadline {
                if matches!(self.0.try_wait(), Ok(Some(_))) {
                    return;
                }
                std::thread::sleep(Duration::from_millis(20));
            }
        }
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

impl Drop for NodeChild {
    fn drop(&mut self) {
        self.stop(Duration::from_secs(10));
    }
}

/// A domain of its own (so the demo never talks to another node), unless
/// ROS_DOMAIN_ID asks for one.
pub fn demo_domain() -> u16 {
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

/// Starts `toolpath node [--config CONFIG]` on `domain` and waits for its ready line.
pub fn start_node(domain: u16, config: Option<&Path>) -> Result<NodeChild> {
    let log = std::env::var("RUST_LOG").unwrap_or_else(|_| "off".into());
    start_node_with(domain, config, &log, false).map(|(n, _)| n)
}

/// [`start_node`] with the node's RUST_LOG filter, and its stderr piped to
/// the caller when `capture_stderr` (else inherited).
pub fn start_node_with(
    domain: u16,
    config: Option<&Path>,
    rust_log: &str,
    capture_stderr: bool,
) -> Result<(NodeChild, Option<std::process::ChildStderr>)> {
    let exe = std::env::current_exe()
        .map_err(|e| Error::planning(format!("cannot find the toolpath binary: {e}")))?;
    let mut cmd = Command::new(exe);
    cmd.arg("node");
    if let Some(c) = config {
        cmd.arg("--config").arg(c);
    }
    let mut child = cmd
        .env("ROS_DOMAIN_ID", domain.to_string())
        .env("RUST_LOG", rust_log)
        .stdout(Stdio::piped())
        .stderr(if capture_stderr {
            Stdio::piped()
        } else {
            Stdio::inherit()
        })
        .spawn()
        .map_err(|e| Error::planning(format!("cannot start `toolpath node`: {e}")))?;
    let stdout = child.stdout.take();
    let stderr = child.stderr.take();
    let guard = NodeChild(child);
    let mut lines =
        BufReader::new(stdout.ok_or_else(|| Error::planning("node stdout missing"))?).lines();
    match lines.next() {
        Some(Ok(line)) if line.starts_with("ready") => Ok((guard, stderr)),
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

/// The node config of the demo: defaults, recording into `out` unless `record` is off.
fn demo_config(out: &Path, record: bool) -> Result<PathBuf> {
    let path = out.join("node.yaml");
    let dir = std::fs::canonicalize(out).map_err(|e| Error::io(out.display().to_string(), e))?;
    let text = format!(
        "# Written by `toolpath demo`: the node config of the demo run.\n\
         recording:\n  enabled: {record}\n  directory: \"{}\"\n  bag_name: {DEMO_BAG}\n",
        dir.display()
            .to_string()
            .replace('\\', "\\\\")
            .replace('"', "\\\"")
    );
    std::fs::write(&path, text).map_err(|e| Error::io(path.display().to_string(), e))?;
    Ok(path)
}

/// Removes the bag of an earlier demo run (only if it is one: a bag's files and nothing else).
fn remove_old_bag(bag: &Path) -> Result<()> {
    let Ok(entries) = std::fs::read_dir(bag) else {
        return Ok(());
    };
    let names: Vec<String> = entries
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    let ours = names
        .iter()
        .all(|n| n == "metadata.yaml" || n == &format!("{DEMO_BAG}_0.mcap"));
    if !ours {
        return Err(Error::invalid(
            "out",
            format!(
                "{} exists and is not a demo bag: choose another --out directory",
                bag.display()
            ),
        ));
    }
    std::fs::remove_dir_all(bag).map_err(|e| Error::io(bag.display().to_string(), e))
}

/// Re-plans `job` locally and draws it to `path` (with the residual map for
/// milling); returns the local result.
fn plot_sample(job: &Job, node_points: Option<u32>, path: &Path) -> Result<PlanResult> {
    let options = RunOptions::PLAN_ONLY;
    let result = pipeline::run(job, &NoProgress, options)?;
    let local_points = result.passes.iter().map(|p| p.points.len()).sum::<usize>()
        + result
            .tools
            .iter()
            .flatten()
            .flat_map(|t| &t.passes)
            .map(Vec::len)
            .sum::<usize>();
    if let Some(n) = node_points {
        if n as usize != local_points {
            eprintln!(
                "warning: {}: the node planned {n} points, the local re-plan for the picture {local_points}",
                job.job_id
            );
        }
    }
    let residual = plot::residual_for(job, &result)?;
    let (surface, pocket) = match &job.shape {
        Shape::Surface(s) => (Some(s), None),
        Shape::Pocket(p) => (None, Some(p)),
    };
    plot::draw(
        &PlotInput {
            result: &result,
            surface,
            pocket,
            residual: residual.as_ref(),
        },
        path,
    )?;
    Ok(result)
}

/// The program of a milling sample's result for the built-in mill5.
fn write_program(job: &Job, result: &PlanResult, path: &Path) -> Result<()> {
    let program = post::post(job, result, &PostMachine::builtin_mill5(), DEMO_FORMAT)?;
    std::fs::write(path, program.text).map_err(|e| Error::io(path.display().to_string(), e))
}

/// Format of the demo's programs: joint space runs on any XYZAC LinuxCNC setup.
const DEMO_FORMAT: Format = Format::LinuxcncJoint;

/// Plans every sample job through the node and prints one row each; writes
/// the bag of the run and a picture per sample into `out`.
pub fn run(out: &Path, record: bool) -> Result<()> {
    super::node::init_logging_with("off");
    std::fs::create_dir_all(out).map_err(|e| Error::io(out.display().to_string(), e))?;
    let bag = out.join(DEMO_BAG);
    if record {
        remove_old_bag(&bag)?;
    }
    let config = demo_config(out, record)?;
    let domain = demo_domain();
    let mut node = start_node(domain, Some(&config))?;
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| Error::planning(format!("cannot start the async runtime: {e}")))?;
    let rows = runtime.block_on(client(domain))?;
    drop(runtime);
    // SIGTERM: the node writes the bag's summary and metadata.yaml.
    node.stop(Duration::from_secs(30));
    print_table(&rows, domain);
    if record {
        println!("bag of the run: {}", bag.display());
    }
    write_outputs(&rows, out)
}

/// The results table of the demo's jobs.
fn print_table(rows: &[Row], domain: u16) {
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
}

/// A picture per sample and a program per milling or pocket sample, in `out`.
fn write_outputs(rows: &[Row], out: &Path) -> Result<()> {
    let mut pictures = 0;
    let mut programs = 0;
    for r in rows {
        let path = out.join(format!("{}.png", r.sample));
        let job = samples::job(r.sample)?;
        let points = r.toolpath.as_ref().map(|t| t.stats.points);
        match plot_sample(&job, points, &path) {
            Ok(result) => {
                pictures += 1;
                if pipeline::is_milling(job.strategy) || job.strategy.needs_pocket() {
                    let program = out.join(format!("{}.{}", r.sample, DEMO_FORMAT.extension()));
                    match write_program(&job, &result, &program) {
                        Ok(()) => programs += 1,
                        Err(e) => eprintln!("warning: no program of {}: {e}", r.sample),
                    }
                }
            }
            Err(e) => eprintln!("warning: no picture of {}: {e}", r.sample),
        }
    }
    println!("pictures: {pictures} in {}", out.display());
    println!(
        "NC programs ({} for mill5): {programs} in {}",
        DEMO_FORMAT.name(),
        out.display()
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
