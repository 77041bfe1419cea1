//! `toolpath bench-node`: the node's overhead and burst figures, measured
//! against a `toolpath node` child process on loopback, printed as a table. A
//! benchmark, not a test: run it on an idle machine, release build.
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
//! Burst: `--bursts` rounds of `--burst` jobs on a small surface, each round
//! published back to back; every job must get exactly one final status
//! (target: none lost); the figure is the median time from the first job sent
//! to the last final status. [`burst`] is the same client for a running node
//! (tests/node_burst.rs).

use super::demo::{demo_domain, start_node_with};
use futures::StreamExt;
use ros2_client::qos::{History, WhenFull};
use ros2_client::{MessageInfo, Publisher, Subscription};
use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::net::{IpAddr, Ipv4Addr};
use std::sync::mpsc;
use std::time::{Duration, Instant};
use toolpath_formats::{FeedDirection, Job, JobFile, Machine, Shape, Strategy};
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::NurbsSurface;
use toolpath_kernel::tools::Tool;
use toolpath_messages::{self as msgs, convert, topics, JobStatus};
use toolpath_node::node::{qos, RosNode, TIMING_TAG};
use toolpath_pipeline::{self as pipeline, RunOptions};
use toolpath_planners::NoProgress;

/// Target for the node overhead at the 99th percentile, ms.
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
    iso_parametric_job(job_id, surface, 0.5)
}

/// iso_parametric with a flat end R 2.5 on mill5 at scallop `scallop_mm`,
/// lead 5 deg, feed along u at 2000 mm/min: the benchmark's and the soak
/// test's job.
pub fn iso_parametric_job(job_id: &str, surface: NurbsSurface, scallop_mm: f64) -> Result<Job> {
    let tool = Tool::FlatEnd {
        radius: 2.5,
        length: None,
    };
    let file = JobFile {
        machine: Some(Machine::Mill5),
        scallop: Some(scallop_mm),
        lead_angle_deg: Some(5.0),
        feed_direction: Some(FeedDirection::U),
        feed_rate: Some(2000.0),
        ..JobFile::new(job_id, Strategy::IsoParametric, Some(tool))
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
    bursts: Vec<BurstOutcome>,
    /// Planning time of each burst job, from the node's timing lines.
    burst_planning_ms: Vec<f64>,
}

/// What one burst got back.
#[derive(Clone, Debug)]
pub struct BurstOutcome {
    /// Jobs published back to back.
    pub sent: usize,
    /// Jobs with at least one final status.
    pub answered: usize,
    /// Jobs with more than one final status.
    pub duplicates: usize,
    /// First final state of each answered job, by state name.
    pub states: BTreeMap<&'static str, usize>,
    /// First job published to last final status received (to the timeout
    /// when some are missing), s.
    pub seconds: f64,
}

impl BurstOutcome {
    pub fn lost(&self) -> usize {
        self.sent - self.answered
    }
    /// Every job answered exactly once, and SUCCEEDED.
    pub fn all_succeeded_once(&self) -> bool {
        self.lost() == 0
            && self.duplicates == 0
            && self.states.get("SUCCEEDED").copied() == Some(self.sent)
    }
}

/// Runs the benchmark and prints the table: `jobs` timed jobs (0: none),
/// then `bursts` bursts of `burst` jobs (0: none); the node runs with the
/// config file `config`, else [`NODE_CONFIG`].
pub fn run(
    jobs: usize,
    points: usize,
    burst: usize,
    bursts: usize,
    config: Option<&std::path::Path>,
) -> Result<()> {
    if points == 0 || (jobs == 0 && (burst == 0 || bursts == 0)) {
        return Err(Error::invalid(
            "--jobs/--points/--burst/--bursts",
            "nothing to measure: give --points >= 1 and --jobs >= 1 or --burst and --bursts >= 1",
        ));
    }
    super::node::init_logging_with("off");
    let (surface, actual_points) = if jobs > 0 {
        sized_surface(points)?
    } else {
        (rectangle(10.0)?, 0)
    };
    let dir = std::env::temp_dir().join(format!("toolpath_bench_node_{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(dir.display().to_string(), e))?;
    let given = config;
    let config = dir.join("node.yaml");
    let text = match given {
        Some(path) => toolpath_formats::read_text(path),
        None => Ok(NODE_CONFIG.to_string()),
    };
    let written = text.and_then(|text| {
        std::fs::write(&config, text).map_err(|e| Error::io(config.display().to_string(), e))
    });
    let domain = demo_domain();
    let started = written
        .and_then(|_| start_node_with(domain, Some(&config), "off,toolpath_node=debug", true));
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
    let figures = runtime().and_then(|rt| {
        rt.block_on(client(
            domain,
            surface,
            actual_points,
            jobs,
            (burst, bursts),
            timing_rx,
        ))
    });
    node.stop(Duration::from_secs(10));
    let f = figures?;
    print_table(&f, domain);
    Ok(())
}

/// The launch config the benchmark runs the node with: planning only, the
/// default workers (one per available core).
pub const NODE_CONFIG: &str = "node:\n  verify: false\n";

fn runtime() -> Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| Error::planning(format!("cannot start the async runtime: {e}")))
}

/// The burst half of the benchmark against a node already running on
/// `domain` (loopback), as a ROS 2 client built on ros2-client: `rounds`
/// bursts of `n` small jobs each, every burst published back to back and
/// waited for until every job has a final status or `timeout` passes.
pub fn burst(domain: u16, n: usize, rounds: usize, timeout: Duration) -> Result<Vec<BurstOutcome>> {
    burst_of(domain, &BurstLoad::small()?, n, rounds, timeout, |_, _| {})
}

/// Makes the job with a given id on the burst's surface.
pub type JobMaker = Box<dyn Fn(&str, &NurbsSurface) -> Result<Job>>;

/// What a burst sends: one surface, published once, and a job per id.
pub struct BurstLoad {
    pub surface: NurbsSurface,
    pub job: JobMaker,
}

impl BurstLoad {
    /// The benchmark's small job: iso_parametric on the plane sample.
    pub fn small() -> Result<Self> {
        Ok(BurstLoad {
            surface: toolpath_samples::surfaces::plane(),
            job: Box::new(|id, s| bench_job(id, s.clone())),
        })
    }
}

/// [`burst`] with the jobs of `load`, calling `after_round(round, outcome)`
/// after each round (the soak test samples the node's memory there).
pub fn burst_of(
    domain: u16,
    load: &BurstLoad,
    n: usize,
    rounds: usize,
    timeout: Duration,
    mut after_round: impl FnMut(usize, &BurstOutcome),
) -> Result<Vec<BurstOutcome>> {
    runtime()?.block_on(async {
        let c = Client::connect(domain, &load.surface).await?;
        let mut statuses = Box::pin(c.status_sub.async_stream());
        let mut out = Vec::with_capacity(rounds);
        for round in 0..rounds {
            let outcome = burst_round(&c.job_pub, &mut statuses, load, round, n, timeout).await?;
            after_round(round, &outcome);
            out.push(outcome);
        }
        Ok(out)
    })
}

fn print_table(f: &Figures, domain: u16) {
    if !f.node_overhead_ms.is_empty() {
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
    }
    if let Some(first) = f.bursts.first() {
        println!(
            "burst: {} x {} jobs published back to back (domain {domain}); per burst: final statuses, lost, duplicate finals, s",
            f.bursts.len(),
            first.sent
        );
        for (k, b) in f.bursts.iter().enumerate() {
            let states: Vec<String> = b.states.iter().map(|(k, v)| format!("{v} {k}")).collect();
            println!(
                "  burst {k}: {} ({}), {} lost, {} duplicates, {:.2} s ({:.1} jobs/s)",
                b.answered,
                states.join(", "),
                b.lost(),
                b.duplicates,
                b.seconds,
                b.answered as f64 / b.seconds.max(1e-9)
            );
        }
        let seconds: Vec<f64> = f.bursts.iter().map(|b| b.seconds).collect();
        let [p50, _, _, max] = percentiles(&seconds);
        let lost: usize = f.bursts.iter().map(BurstOutcome::lost).sum();
        let duplicates: usize = f.bursts.iter().map(|b| b.duplicates).sum();
        println!(
            "burst of {}: median {p50:.2} s, max {max:.2} s ({:.1} jobs/s at the median), {lost} lost, {duplicates} duplicate finals; target every job exactly one final status (0 lost): {}",
            first.sent,
            first.sent as f64 / p50.max(1e-9),
            if lost == 0 && duplicates == 0 {
                "met"
            } else {
                "MISSED"
            }
        );
        if !f.burst_planning_ms.is_empty() {
            let [p50, _, _, max] = percentiles(&f.burst_planning_ms);
            println!(
                "burst jobs: planning p50 {p50:.1} ms, max {max:.1} ms each ({:.2} s of planning per burst at p50, over {} workers)",
                p50 * first.sent as f64 / 1e3,
                toolpath_node::config::NodeSettings::default().worker_count()
            );
        }
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

/// Surface id of the small surface the burst jobs use.
const BURST_SURFACE: &str = "bench_small";

/// The benchmark's ROS 2 client: a participant on loopback with the job and
/// surface publishers and the status and toolpath readers.
struct Client {
    ros: RosNode,
    surface_pub: Publisher<msgs::Surface>,
    job_pub: Publisher<msgs::Job>,
    status_sub: Subscription<msgs::JobStatus>,
    toolpath_sub: Subscription<msgs::Toolpath>,
}

impl Client {
    /// Connects to the node on `domain` and publishes `burst_surface`.
    async fn connect(domain: u16, burst_surface: &NurbsSurface) -> Result<Self> {
        let mut ros = RosNode::new(
            "toolpath_bench_node",
            "/",
            domain,
            Some(vec![IpAddr::V4(Ipv4Addr::LOCALHOST)]),
        )?;
        let surface_pub = ros.publisher::<msgs::Surface>(topics::SURFACE, qos::shapes())?;
        // Reliable with a history as deep as the node's job reader, as a real
        // client sending bursts would; RustDDS keeps unacknowledged samples
        // for repair regardless, the depth only matters before matching.
        let job_qos = qos::job()
            .reliability_reliable(WhenFull::Wait(Duration::from_secs(30)))
            .history(History::KeepLast {
                depth: qos::JOB_READER_DEPTH,
            });
        let job_pub = ros.publisher::<msgs::Job>(topics::JOB, job_qos)?;
        let status_sub =
            ros.subscription::<msgs::JobStatus>(topics::JOB_STATUS, qos::status_reader())?;
        let toolpath_sub = ros.subscription::<msgs::Toolpath>(topics::TOOLPATH, qos::results())?;
        tokio::time::timeout(
            Duration::from_secs(30),
            job_pub.wait_for_subscription(&ros.node),
        )
        .await
        .map_err(|_| {
            Error::planning("the node's job subscription was not discovered within 30 s")
        })?;
        surface_pub
            .publish(convert::surface_to_msg(
                BURST_SURFACE,
                burst_surface,
                header(),
            ))
            .map_err(send_error)?;
        Ok(Self {
            ros,
            surface_pub,
            job_pub,
            status_sub,
            toolpath_sub,
        })
    }
}

/// Publishes `n` small jobs (ids `burst{round}_NNNN`) back to back and
/// collects their final statuses from `statuses` until every job has one and
/// 500 ms more have passed quietly (to catch duplicates), or `timeout` passes.
async fn burst_round<S, E>(
    job_pub: &Publisher<msgs::Job>,
    statuses: &mut S,
    load: &BurstLoad,
    round: usize,
    n: usize,
    timeout: Duration,
) -> Result<BurstOutcome>
where
    S: futures::Stream<Item = std::result::Result<(JobStatus, MessageInfo), E>> + Unpin,
{
    let prefix = format!("burst{round}_");
    let ids: Vec<String> = (0..n).map(|k| format!("{prefix}{k:04}")).collect();
    let mut finals: BTreeMap<String, Vec<u8>> = BTreeMap::new();
    let t0 = Instant::now();
    for id in &ids {
        let job = (load.job)(id, &load.surface)?;
        job_pub
            .publish(convert::job_to_msg(&job, BURST_SURFACE, header()))
            .map_err(send_error)?;
    }
    let deadline = t0 + timeout;
    let mut seconds = None;
    let mut quiet_until: Option<Instant> = None;
    loop {
        // Once all are answered, listen a little longer for duplicates.
        if quiet_until.is_none() && ids.iter().all(|id| finals.contains_key(id)) {
            seconds = Some(t0.elapsed().as_secs_f64());
            quiet_until = Some(Instant::now() + Duration::from_millis(500));
        }
        let until = quiet_until.unwrap_or(deadline).min(deadline);
        let left = until.saturating_duration_since(Instant::now());
        if left.is_zero() {
            break;
        }
        tokio::select! {
            Some(Ok((m, _))) = statuses.next() => {
                if m.is_final() && m.job_id.starts_with(&prefix) {
                    finals.entry(m.job_id.clone()).or_default().push(m.state);
                }
            }
            _ = tokio::time::sleep(left) => {}
        }
    }
    let mut states = BTreeMap::new();
    for v in finals.values() {
        if let Some(&s) = v.first() {
            *states.entry(JobStatus::state_name(s)).or_default() += 1;
        }
    }
    Ok(BurstOutcome {
        sent: n,
        answered: ids.iter().filter(|id| finals.contains_key(*id)).count(),
        duplicates: finals.values().filter(|v| v.len() > 1).count(),
        states,
        seconds: seconds.unwrap_or_else(|| t0.elapsed().as_secs_f64()),
    })
}

/// Waits for job `id`'s toolpath and its final status (which must be
/// SUCCEEDED), at most `timeout`; returns when the toolpath arrived, from `t0`.
async fn answer<S, T, E1, E2>(
    id: &str,
    statuses: &mut S,
    toolpaths: &mut T,
    timeout: Duration,
    t0: Instant,
) -> Result<Duration>
where
    S: futures::Stream<Item = std::result::Result<(JobStatus, MessageInfo), E1>> + Unpin,
    T: futures::Stream<Item = std::result::Result<(msgs::Toolpath, MessageInfo), E2>> + Unpin,
{
    let deadline = Instant::now() + timeout;
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
                return Err(Error::planning(format!("bench job {id}: no answer within {} s", timeout.as_secs())));
            }
        }
    }
    Ok(received.unwrap_or_default())
}

/// The node's timing line for job `id` (earlier jobs' lines are skipped).
fn timing_line(timings: &mpsc::Receiver<(String, Timing)>, id: &str) -> Result<Timing> {
    loop {
        match timings.recv_timeout(Duration::from_secs(10)) {
            Ok((jid, t)) if jid == id => return Ok(t),
            Ok(_) => continue,
            Err(_) => {
                return Err(Error::planning(format!(
                    "the node logged no timing line for {id}"
                )))
            }
        }
    }
}

async fn client(
    domain: u16,
    surface: NurbsSurface,
    points: usize,
    jobs: usize,
    (burst, bursts): (usize, usize),
    timings: mpsc::Receiver<(String, Timing)>,
) -> Result<Figures> {
    let load = BurstLoad::small()?;
    let c = Client::connect(domain, &load.surface).await?;
    let mut statuses = Box::pin(c.status_sub.async_stream());
    let mut toolpaths = Box::pin(c.toolpath_sub.async_stream());
    let job_timeout = Duration::from_secs(300);

    let mut figures = Figures {
        points,
        node_overhead_ms: Vec::new(),
        client_overhead_ms: Vec::new(),
        planning_ms: Vec::new(),
        bursts: Vec::new(),
        burst_planning_ms: Vec::new(),
    };
    if jobs > 0 {
        c.surface_pub
            .publish(convert::surface_to_msg("bench_rect", &surface, header()))
            .map_err(send_error)?;
    }
    let warmup = if jobs > 0 { 3 } else { 0 };
    for k in 0..warmup + jobs {
        let id = format!("overhead_{k:04}");
        let job = bench_job(&id, surface.clone())?;
        let t0 = Instant::now();
        c.job_pub
            .publish(convert::job_to_msg(&job, "bench_rect", header()))
            .map_err(send_error)?;
        let received = answer(&id, &mut statuses, &mut toolpaths, job_timeout, t0).await?;
        let timing = timing_line(&timings, &id)?;
        if k < warmup {
            continue;
        }
        let e2e_ms = received.as_secs_f64() * 1e3;
        figures.planning_ms.push(timing.planning_ms);
        figures
            .node_overhead_ms
            .push(timing.received_to_published_ms - timing.planning_ms);
        figures.client_overhead_ms.push(e2e_ms - timing.planning_ms);
    }
    // The burst's toolpaths are not needed; their reader just drops them.
    drop(toolpaths);
    let burst_timeout = Duration::from_secs(600);
    for round in 0..if burst > 0 { bursts } else { 0 } {
        let b = burst_round(
            &c.job_pub,
            &mut statuses,
            &load,
            round,
            burst,
            burst_timeout,
        )
        .await?;
        let complete = b.lost() == 0;
        figures.bursts.push(b);
        if !complete {
            // Later bursts would only queue behind the missing jobs.
            break;
        }
    }
    // The node logs each job's timing line before its SUCCEEDED, so every
    // answered burst job's line is in the channel by now.
    figures.burst_planning_ms = timings
        .try_iter()
        .filter(|(id, _)| id.starts_with("burst"))
        .map(|(_, t)| t.planning_ms)
        .collect();
    drop(c.ros);
    Ok(figures)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timing_lines_parse() {
        let line = "[2026-11-22T10:00:00.000Z DEBUG toolpath_node::node] timing: job=a_1 received_to_toolpath_published_ms=12.500 planning_ms=10.250";
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
