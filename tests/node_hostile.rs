//! Hostile jobs through the node (a child process with one worker, so any
//! job that wedged it would block the next): a job over its budget, a
//! pocket of 1e7 mm, a bad message, a job over `node.job_time_limit_s` and
//! a job canceled while planning each end with a FAILED or REJECTED status
//! naming the reason, and a normal job is served right after each.
//! Loopback only, a random domain, the node killed by pid.

#[path = "common/node_client.rs"]
mod node_client;
#[path = "common/node_process.rs"]
mod node_process;

use futures::StreamExt;
use node_process::NodeProcess;
use std::time::{Duration, Instant};
use toolpath_planner::formats::{Job, Shape};
use toolpath_planner::geometry::Pocket;
use toolpath_planner::messages::follow_joint_trajectory::StringMsg;
use toolpath_planner::messages::{self as msgs, convert};
use toolpath_planner::samples;

const TIME_LIMIT_S: f64 = 3.0;

/// The plane and wing_mould sample jobs, their surfaces published as
/// `plane_shape` and `wing_shape`.
fn publish_sample_surfaces(surfaces: &ros2_client::Publisher<msgs::Surface>) -> (Job, Job) {
    let plane = samples::job("plane").unwrap();
    let wing = samples::job("wing_mould").unwrap();
    for (id, job) in [("plane_shape", &plane), ("wing_shape", &wing)] {
        let Shape::Surface(s) = &job.shape else {
            panic!("surface jobs")
        };
        surfaces
            .publish(convert::surface_to_msg(id, s, msgs::Header::default()))
            .unwrap();
    }
    (plane, wing)
}

/// Resident memory of a process, MB.
fn rss_mb(pid: u32) -> f64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap();
    let kb: f64 = status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .unwrap();
    kb / 1024.0
}

#[test]
fn hostile_jobs_fail_with_a_reason_and_the_node_keeps_serving() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("node.yaml");
    std::fs::write(
        &config,
        format!("node:\n  verify: false\n  workers: 1\n  job_time_limit_s: {TIME_LIMIT_S}\n"),
    )
    .unwrap();
    let d = node_process::fresh_domain(0);
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    let (node, ready) = NodeProcess::spawn(&config, d);
    assert!(ready.starts_with("ready"), "node said {ready:?}");
    let pid = node.child.id();
    rt.block_on(async {
        let client = node_client::NodeClient::connect("hostile_client", d).await;
        let node_client::NodeClient {
            surfaces,
            pockets,
            jobs,
            cancel,
            status,
            ..
        } = client;
        let (plane, wing) = publish_sample_surfaces(&surfaces);
        let rect = samples::job("rect_pocket").unwrap();
        let Shape::Pocket(p) = &rect.shape else {
            panic!("a pocket job")
        };
        let scale = |l: &[[f64; 2]]| l.iter().map(|q| [q[0] * 1e5, q[1] * 1e5]).collect::<Vec<_>>();
        let huge = Pocket::new(
            &scale(&p.outer),
            &p.holes.iter().map(|h| scale(h)).collect::<Vec<_>>(),
        )
        .unwrap();
        pockets
            .publish(convert::pocket_to_msg(
                "huge_pocket",
                &huge,
                msgs::Header::default(),
            ))
            .unwrap();
        let baseline_mb = rss_mb(pid);

        let mut statuses = Box::pin(status.async_stream());
        // Sends a job message; returns its final status, the seconds from
        // its first RUNNING status (or from sending) to the final one, and
        // the estimated seconds left its RUNNING statuses gave. With
        // `cancel_running`, cancels it at its first RUNNING status.
        let mut run = async |msg: msgs::Job, cancel_running: bool| {
            let id = msg.job_id.clone();
            jobs.publish(msg).unwrap();
            let mut from = Instant::now();
            let deadline = from + Duration::from_secs(120);
            let mut canceled = false;
            let mut etas = Vec::new();
            loop {
                let st = node_client::next_status_of(&mut statuses, &id, deadline).await;
                // Planning progress of 1 % or more carries an estimate of
                // the time left; other statuses say it is not known.
                if st.state == msgs::JobStatus::RUNNING && st.progress >= 0.01 {
                    assert!(st.eta_s.is_finite() && st.eta_s >= 0.0, "{id}: {st:?}");
                    etas.push(st.eta_s);
                } else if st.state != msgs::JobStatus::RUNNING {
                    assert!(st.eta_s < 0.0, "{id}: {st:?}");
                }
                if st.state == msgs::JobStatus::RUNNING && !canceled {
                    from = Instant::now();
                    if cancel_running {
                        cancel.publish(StringMsg { data: id.clone() }).unwrap();
                    }
                    canceled = true;
                }
                if st.is_final() {
                    return (st, from.elapsed().as_secs_f64(), etas);
                }
            }
        };
        let cases = hostile_cases(&plane, &wing, &rect);
        for (k, (what, msg, cancel_running, state, expect)) in cases.into_iter().enumerate() {
            let (st, secs, etas) = run(msg, cancel_running).await;
            assert_eq!(st.state, state, "{what}: {}", st.message);
            if what.starts_with("over the") {
                assert!(!etas.is_empty(), "{what}: no RUNNING status gave the time left");
            }
            for e in &expect {
                assert!(st.message.contains(e.as_str()), "{what}: {}", st.message);
            }
            let bound = match what {
                "over the time limit" => TIME_LIMIT_S + 1.5,
                "over the job's own time limit" => 1.0 + 1.5,
                _ => 1.0,
            };
            assert!(secs < bound, "{what}: final status after {secs:.2} s");
            // A normal job right after, on the same single worker.
            let started = Instant::now();
            let (st, _, _) = run(message(&plane, "plane_shape", &format!("normal_{k}")), false).await;
            assert_eq!(st.state, msgs::JobStatus::SUCCEEDED, "after {what}: {}", st.message);
            let normal_s = started.elapsed().as_secs_f64();
            assert!(normal_s < 10.0, "after {what}: {normal_s:.1} s");
            eprintln!(
                "{what}: final after {secs:.2} s, next job {normal_s:.2} s, node {:.0} MB (baseline {baseline_mb:.0} MB)",
                rss_mb(pid)
            );
        }
        // What the stopped jobs held is freed (within the allocator's slack).
        let after_mb = rss_mb(pid);
        assert!(
            after_mb < baseline_mb + 100.0,
            "node {after_mb:.0} MB, baseline {baseline_mb:.0} MB"
        );
    });
    drop(node);
}

/// With two workers (the default on a 2-core machine), a small job sent
/// after a heavy one is served while the heavy one still plans.
#[test]
fn a_small_job_overtakes_a_heavy_one_with_two_workers() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("node.yaml");
    std::fs::write(
        &config,
        "node:\n  verify: false\n  workers: 2\n  job_time_limit_s: 60\n",
    )
    .unwrap();
    let d = node_process::fresh_domain(97);
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    let (node, ready) = NodeProcess::spawn(&config, d);
    assert!(ready.starts_with("ready"), "node said {ready:?}");
    rt.block_on(async {
        let client = node_client::NodeClient::connect("overtake_client", d).await;
        let node_client::NodeClient {
            surfaces,
            jobs,
            cancel,
            status,
            ..
        } = client;
        let (plane, wing) = publish_sample_surfaces(&surfaces);
        let mut statuses = Box::pin(status.async_stream());
        let mut heavy = convert::job_to_msg(&wing, "wing_shape", msgs::Header::default());
        heavy.job_id = "heavy".into();
        let mut small = convert::job_to_msg(&plane, "plane_shape", msgs::Header::default());
        small.job_id = "small".into();
        jobs.publish(heavy).unwrap();
        // The small job goes once the heavy one is planning.
        let deadline = Instant::now() + Duration::from_secs(120);
        let mut sent_small = false;
        let mut finals = Vec::new();
        while finals.len() < 2 {
            let left = deadline.saturating_duration_since(Instant::now());
            let (st, _) = tokio::time::timeout(left, statuses.next())
                .await
                .expect("no final statuses")
                .unwrap()
                .unwrap();
            if st.job_id == "heavy" && st.state == msgs::JobStatus::RUNNING && !sent_small {
                jobs.publish(small.clone()).unwrap();
                sent_small = true;
            }
            if st.job_id == "small" && st.is_final() {
                assert_eq!(st.state, msgs::JobStatus::SUCCEEDED, "{}", st.message);
                // Done with the heavy one still planning: stop it.
                cancel
                    .publish(StringMsg {
                        data: "heavy".into(),
                    })
                    .unwrap();
            }
            if st.is_final() {
                finals.push(st.job_id.clone());
            }
        }
        assert_eq!(finals, ["small", "heavy"], "the small job waited");
    });
    drop(node);
}

/// A job message for `job` on the shape `shape`, under the id `id`.
fn message(job: &Job, shape: &str, id: &str) -> msgs::Job {
    let mut m = convert::job_to_msg(job, shape, msgs::Header::default());
    m.job_id = id.into();
    m
}

/// A hostile case: what it is, its message, whether to cancel it once it
/// runs, the final state it must reach and what its reason must say.
type HostileCase = (&'static str, msgs::Job, bool, u8, Vec<String>);

/// Jobs over the memory budget, over the time limits, malformed, or
/// canceled while planning.
fn hostile_cases(plane: &Job, wing: &Job, rect: &Job) -> Vec<HostileCase> {
    let mut over_budget = message(wing, "wing_shape", "over_budget");
    over_budget.scallop = 1e-6;
    let mut bad = message(plane, "plane_shape", "bad_message");
    bad.scallop = f64::NAN;
    // Several times the limit's work within the budget: a scallop finer
    // than wing_mould's h = 0.015, which plans well inside the limit.
    let mut over_time = message(wing, "wing_shape", "over_time");
    over_time.scallop = 0.002;
    // The job's own limit, shorter than the node's: the job's wins.
    let mut over_own_time = message(wing, "wing_shape", "over_own_time");
    over_own_time.scallop = 0.002;
    over_own_time.time_limit_s = 1.0;
    vec![
        (
            "over budget",
            over_budget,
            false,
            msgs::JobStatus::FAILED,
            vec!["refused before planning".into(), "raise scallop".into()],
        ),
        (
            "huge pocket",
            message(rect, "huge_pocket", "huge_pocket_job"),
            false,
            msgs::JobStatus::FAILED,
            vec!["refused before planning".into(), "split the pocket".into()],
        ),
        (
            "bad message",
            bad,
            false,
            msgs::JobStatus::REJECTED,
            vec!["scallop".into()],
        ),
        (
            "over the time limit",
            over_time,
            false,
            msgs::JobStatus::FAILED,
            vec![
                format!("over its time limit of {TIME_LIMIT_S} s"),
                "node.job_time_limit_s".into(),
            ],
        ),
        (
            "over the job's own time limit",
            over_own_time,
            false,
            msgs::JobStatus::FAILED,
            vec![
                "over its time limit of 1 s".into(),
                "the job's time_limit_s".into(),
            ],
        ),
        (
            "canceled while planning",
            message(wing, "wing_shape", "canceled"),
            true,
            msgs::JobStatus::CANCELED,
            vec!["canceled on topic cancel while planning".into()],
        ),
    ]
}
