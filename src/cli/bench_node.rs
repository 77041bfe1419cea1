//! `toolpath bench-node`: the node's overhead and burst figures (issue 7),
//! measured against a `toolpath node` child process on loopback, printed as
//! a table. A benchmark, not a test: run it on an idle machine, release build.
//!
//! Overhead: jobs of about `--points` points (iso_parametric on a flat
//! rectangle, width chosen by a local plan) are sent one at a time, each after
//! the previous one's final status. The node logs, per job, the time from
//! receiving the job to having published its toolpath and the time spent in
//! planning (`pipeline::run`; the node runs with `verify: false`, so this is
//! the planner); overhead = the difference (conversion, IK and timing of the
//! joint trajectory, serialisation, publishing). The client's view adds the
//! DDS delivery of the job and of the toolpath: job sent to toolpath received,
//! minus planning. Target: node overhead p99 < 20 ms at 10 000 points.
//!
//! Burst: `--burst` jobs on a small surface published back to back; every job
//! must get exactly one final status (target: none lost).

use super::demo::{demo_domain, start_node_with};
use crate::error::{Error, Result};
use crate::formats::{FeedDirection, Job, JobFile, Machine, Shape, Strategy};
use crate::geometry::NurbsSurface;
use crate::pipeline::{self, RunOptions};
use crate::planners::NoProgress;
use crate::ros::convert;
use crate::ros::msgs::{self, JobStatus};
use crate::ros::node::{qos, topics, RosNode, TIMING_TAG};
use crate::tools::Tool;
use futures::StreamExt;
use ros2_client::qos::{History, WhenFull};
use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::net::{IpAddr, Ipv4Addr};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// The target of issue 7 for the node overhead at the 99th percentile, ms.
const OVERHEAD_P99_TARGET_MS: f64 = 20.0;
/// Rectangle length along the feed, mm (about 130 points per pass).
const LENGTH_MM: f64 = 600.0;

fn rectangle(width_mm: f64) -> Result<NurbsSurface> {
    NurbsSurface::new(
        1,
        1,
        vec![0.0, 0.0, 1.0, 1.0],
        vec![0.0, 0.0, 1.0, 1.0],
        &[
            vec![[0.0, 0.0, 0.0], [0.0, width_mm, 0.0]],
            vec![[LENGTH_MM, 0.0, 0.0], [LENGTH_MM, width_mm, 0.0]],
        ],
        None,
    )
}

fn bench_job(job_id: &str, surface: NurbsSurface) -> Result<Job> {
    let file = JobFile {
        job_id: job_id.into(),
        surface: serde_json::Value::Null,
        strategy: Strategy::IsoParametric,
        tool: Tool::FlatEnd {
            radius: 2.5,
            length: None,
        },
        machine: Some(Machine::Mill5),
        scallop: Some(0.5),
        tolerance: None,
        lead_angle_deg: Some(5.0),
        side_tilt_deg: None,
        feed_direction: Some(FeedDirection::U),
        feed_rate: Some(2000.0),
        tool_catalogue: None,
        section_normal: None,
        simulation_resolution: None,
        grinding: None,
    };
    Job::new(file, Shape::Surface(surface))
}

fn points_of(job: &Job) -> Result<usize> {
    let options = RunOptions::PLAN_ONLY;
    Ok(pipeline::run(job, &NoProgress, options)?.point_count())
}

/// A rectangle whose job has about `target` points (passes grow with the width).
fn sized_surface(target: usize) -> Result<(NurbsSurface, usize)> {
    let w0 = 300.0;
    let n0 = points_of(&bench_job("size", rectangle(w0)?)?)?;
    let width = (w0 * target as f64 / n0.max(1) as f64).clamp(10.0, 20_000.0);
    let s = rectangle(width)?;
    let n = points_of(&bench_job("size", s.clone())?)?;
    Ok((s, n))
}

/// (p50, p90, p99, max) by nearest rank.
fn percentiles(v: &[f64]) -> [f64; 4] {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let at = |q: f64| {
        let k = ((q * s.len() as f64).ceil() as usize).clamp(1, s.len().max(1)) - 1;
        s.get(k).copied().unwrap_or(f64::NAN)
    };
    [
        at(0.5),
        at(0.9),
        at(0.99),
        s.last().copied().unwrap_or(f64::NAN),
    ]
}

struct Timing {
    received_to_published_ms: f64,
    planning_ms: f64,
}

/// Parses a node timing line: `... timing: job=ID received_to_toolpath_published_ms=A planning_ms=B`.
fn parse_timing(line: &str) -> Option<(String, Timing)> {
    let rest = &line[line.find(TIMING_TAG)? + TIMING_TAG.len()..];
    let mut id = None;
    let mut total = None;
    let mut planning = None;
    for field in rest.split_whitespace() {
        let (k, v) = field.split_once('=')?;
        match k {
            "job" => id = Some(v.to_string()),
            "received_to_toolpath_published_ms" => total = v.parse().ok(),
            "planning_ms" => planning = v.parse().ok(),
            _ => {}
        }
    }
    Some((
        id?,
        Timing {
            received_to_published_ms: total?,
            planning_ms: planning?,
        },
    ))
}

struct Figures {
    points: usize,
    node_overhead_ms: Vec<f64>,
    client_overhead_ms: Vec<f64>,
    planning_ms: Vec<f64>,
    burst_sent: usize,
    burst_answered: usize,
    burst_duplicates: usize,
    burst_states: BTreeMap<&'static str, usize>,
    burst_s: f64,
}

/// Runs the benchmark and prints the table.
pub fn run(jobs: usize, points: usize, burst: usize) -> Result<()> {
    if jobs == 0 || points == 0 {
        return Err(Error::invalid("--jobs/--points", "must be at least 1"));
    }
    super::node::init_logging_with("off");
    let (surface, actual_points) = sized_surface(points)?;
    let dir = std::env::temp_dir().join(format!("toolpath_bench_node_{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(dir.display().to_string(), e))?;
    let config = dir.join("node.yaml");
    let written = std::fs::write(&config, "node:\n  verify: false\n  workers: 1\n")
        .map_err(|e| Error::io(config.display().to_string(), e));
    let domain = demo_domain();
    let started = written.and_then(|_| {
        start_node_with(
            domain,
            Some(&config),
            "off,toolpath_planner::ros::node=debug",
            true,
        )
    });
    let _ = std::fs::remove_dir_all(&dir);
    let (mut node, stderr) = started?;
    let (timing_tx, timing_rx) = mpsc::channel();
    if let Some(stderr) = stderr {
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(|l| l.ok()) {
                if let Some(t) = parse_timing(&line) {
                    if timing_tx.send(t).is_err() {
                        break;
                    }
                }
            }
        });
    }
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| Error::planning(format!("cannot start the async runtime: {e}")))?;
    let figures = runtime.block_on(client(
        domain,
        surface,
        actual_points,
        jobs,
        burst,
        timing_rx,
    ));
    drop(runtime);
    node.stop(Duration::from_secs(10));
    let f = figures?;
    print_table(&f, domain);
    Ok(())
}

fn print_table(f: &Figures, domain: u16) {
    println!(
        "node overhead: {} jobs of {} points (iso_parametric, mill5), one at a time, node and client on loopback (domain {domain})",
        f.node_overhead_ms.len(),
        f.points
    );
    println!(
        "{:<52} {:>9} {:>9} {:>9} {:>9}",
        "ms", "p50", "p90", "p99", "max"
    );
    for (name, v) in [
        (
            "node: job received -> toolpath published - planning",
            &f.node_overhead_ms,
        ),
        (
            "client: job sent -> toolpath received - planning",
            &f.client_overhead_ms,
        ),
        ("planning (pipeline::run, no simulator)", &f.planning_ms),
    ] {
        let [a, b, c, d] = percentiles(v);
        println!("{name:<52} {a:>9.2} {b:>9.2} {c:>9.2} {d:>9.2}");
    }
    let p99 = percentiles(&f.node_overhead_ms)[2];
    println!(
        "target: node overhead p99 < {OVERHEAD_P99_TARGET_MS} ms at 10 000 points: {}",
        if p99 < OVERHEAD_P99_TARGET_MS {
            "met"
        } else {
            "MISSED"
        }
    );
    if f.burst_sent > 0 {
        let states: Vec<String> = f
            .burst_states
            .iter()
            .map(|(k, v)| format!("{v} {k}"))
            .collect();
        let lost = f.burst_sent - f.burst_answered;
        println!(
            "burst: {} jobs sent back to back, {} final statuses ({}), {lost} lost, {} duplicate finals, {:.1} s ({:.1} jobs/s); target 0 lost: {}",
            f.burst_sent,
            f.burst_answered,
            states.join(", "),
            f.burst_duplicates,
            f.burst_s,
            f.burst_answered as f64 / f.burst_s.max(1e-9),
            if lost == 0 && f.burst_duplicates == 0 {
                "met"
            } else {
                "MISSED"
            }
        );
    }
}

fn send_error<E: std::fmt::Debug>(e: E) -> Error {
    Error::planning(format!("cannot publish: {e:?}"))
}

fn header() -> msgs::Header {
    msgs::Header {
        stamp: msgs::Time::now(),
        frame_id: "workpiece".into(),
    }
}

async fn client(
    domain: u16,
    surface: NurbsSurface,
    points: usize,
    jobs: usize,
    burst: usize,
    timings: mpsc::Receiver<(String, Timing)>,
) -> Result<Figures> {
    let mut ros = RosNode::new(
        "toolpath_bench_node",
        "/",
        domain,
        Some(vec![IpAddr::V4(Ipv4Addr::LOCALHOST)]),
    )?;
    let surface_pub = ros.publisher::<msgs::Surface>(topics::SURFACE, qos::shapes())?;
    // Keep every job of a burst until the node has it.
    let job_qos = qos::job()
        .reliability_reliable(WhenFull::Wait(Duration::from_secs(30)))
        .history(History::KeepLast { depth: burst + 10 });
    let job_pub = ros.publisher::<msgs::Job>(topics::JOB, job_qos)?;
    let status_sub = ros.subscription::<msgs::JobStatus>(topics::JOB_STATUS, qos::status())?;
    let toolpath_sub = ros.subscription::<msgs::Toolpath>(topics::TOOLPATH, qos::results())?;
    tokio::time::timeout(
        Duration::from_secs(30),
        job_pub.wait_for_subscription(&ros.node),
    )
    .await
    .map_err(|_| Error::planning("the node's job subscription was not discovered within 30 s"))?;
    surface_pub
        .publish(convert::surface_to_msg("bench_rect", &surface, header()))
        .map_err(send_error)?;
    let small = crate::samples::surfaces::plane();
    surface_pub
        .publish(convert::surface_to_msg("bench_small", &small, header()))
        .map_err(send_error)?;
    let mut statuses = Box::pin(status_sub.async_stream());
    let mut toolpaths = Box::pin(toolpath_sub.async_stream());
    let job_timeout = Duration::from_secs(300);

    let mut figures = Figures {
        points,
        node_overhead_ms: Vec::new(),
        client_overhead_ms: Vec::new(),
        planning_ms: Vec::new(),
        burst_sent: 0,
        burst_answered: 0,
        burst_duplicates: 0,
        burst_states: BTreeMap::new(),
        burst_s: 0.0,
    };
    let warmup = 3;
    for k in 0..warmup + jobs {
        let id = format!("overhead_{k:04}");
        let job = bench_job(&id, surface.clone())?;
        let t0 = Instant::now();
        job_pub
            .publish(convert::job_to_msg(&job, "bench_rect", header()))
            .map_err(send_error)?;
        let deadline = Instant::now() + job_timeout;
        let mut received = None;
        let mut final_status = None;
        while final_status.is_none() || received.is_none() {
            let left = deadline.saturating_duration_since(Instant::now());
            tokio::select! {
                Some(Ok((m, _))) = toolpaths.next() => {
                    if m.job_id == id {
                        received = Some(t0.elapsed());
                    }
                }
                Some(Ok((m, _))) = statuses.next() => {
                    if m.job_id == id && m.is_final() {
                        if m.state != JobStatus::SUCCEEDED {
                            return Err(Error::planning(format!(
                                "bench job {id} ended {}: {}",
                                JobStatus::state_name(m.state),
                                m.message
                            )));
                        }
                        final_status = Some(m);
                    }
                }
                _ = tokio::time::sleep(left) => {
                    return Err(Error::planning(format!("bench job {id}: no answer within {} s", job_timeout.as_secs())));
                }
            }
        }
        let timing = loop {
            match timings.recv_timeout(Duration::from_secs(10)) {
                Ok((jid, t)) if jid == id => break t,
                Ok(_) => continue,
                Err(_) => {
                    return Err(Error::planning(format!(
                        "the node logged no timing line for {id}"
                    )))
                }
            }
        };
        if k < warmup {
            continue;
        }
        let e2e_ms = received.unwrap_or_default().as_secs_f64() * 1e3;
        figures.planning_ms.push(timing.planning_ms);
        figures
            .node_overhead_ms
            .push(timing.received_to_published_ms - timing.planning_ms);
        figures.client_overhead_ms.push(e2e_ms - timing.planning_ms);
    }

    if burst > 0 {
        let ids: Vec<String> = (0..burst).map(|k| format!("burst_{k:04}")).collect();
        let mut finals: BTreeMap<String, Vec<u8>> = BTreeMap::new();
        let t0 = Instant::now();
        for id in &ids {
            let job = bench_job(id, small.clone())?;
            job_pub
                .publish(convert::job_to_msg(&job, "bench_small", header()))
                .map_err(send_error)?;
        }
        let deadline = Instant::now() + Duration::from_secs(1800);
        let mut quiet_until: Option<Instant> = None;
        loop {
            let all = ids.iter().all(|id| finals.contains_key(id));
            // Once all are answered, listen a little longer for duplicates.
            if all && quiet_until.is_none() {
                figures.burst_s = t0.elapsed().as_secs_f64();
                quiet_until = Some(Instant::now() + Duration::from_millis(500));
            }
            let until = quiet_until.unwrap_or(deadline).min(deadline);
            let left = until.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break;
            }
            tokio::select! {
                Some(Ok((m, _))) = statuses.next() => {
                    if m.is_final() && m.job_id.starts_with("burst_") {
                        finals.entry(m.job_id.clone()).or_default().push(m.state);
                    }
                }
                _ = tokio::time::sleep(left) => {}
            }
        }
        if figures.burst_s == 0.0 {
            figures.burst_s = t0.elapsed().as_secs_f64();
        }
        figures.burst_sent = burst;
        figures.burst_answered = ids.iter().filter(|id| finals.contains_key(*id)).count();
        figures.burst_duplicates = finals.values().filter(|v| v.len() > 1).count();
        for v in finals.values() {
            if let Some(&s) = v.first() {
                *figures
                    .burst_states
                    .entry(JobStatus::state_name(s))
                    .or_default() += 1;
            }
        }
    }
    Ok(figures)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timing_lines_parse() {
        let line = "[2026-11-22T10:00:00.000Z DEBUG toolpath_planner::ros::node] timing: job=a_1 received_to_toolpath_published_ms=12.500 planning_ms=10.250";
        let (id, t) = parse_timing(line).unwrap();
        assert_eq!(id, "a_1");
        assert_eq!(t.received_to_published_ms, 12.5);
        assert_eq!(t.planning_ms, 10.25);
        assert!(parse_timing("timing: job=x").is_none());
        assert!(parse_timing("no tag here").is_none());
    }

    #[test]
    fn nearest_rank_percentiles() {
        let v: Vec<f64> = (1..=100).rev().map(f64::from).collect();
        assert_eq!(percentiles(&v), [50.0, 90.0, 99.0, 100.0]);
        assert_eq!(percentiles(&[3.0]), [3.0; 4]);
    }
}
