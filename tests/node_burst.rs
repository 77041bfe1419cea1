//! Job bursts through the pure-Rust stack (ros2-client over RustDDS) reach
//! the node without loss: a burst of 200 jobs, none lost.
//!
//! RustDDS 0.15 caps a KEEP_ALL reader's cache at 64 samples and evicts the
//! oldest over the cap even when not yet taken, after acknowledging them; with
//! KEEP_ALL a burst of more than ~128 jobs loses jobs (docs/architecture.md,
//! "Job bursts: the RustDDS reader cache"). The first test checks the node's job reader QoS directly on two
//! participants, the second a 200-job burst through `toolpath node` with the
//! benchmark's client. Everything stays on loopback, on domains of their own;
//! the node is killed by pid.

#[path = "common/node_process.rs"]
mod node_process;

use futures::StreamExt;
use node_process::NodeProcess;
use ros2_client::qos::{History, WhenFull};
use std::collections::BTreeMap;
use std::net::{IpAddr, Ipv4Addr};
use std::time::{Duration, Instant};
use toolpath_planner::cli::bench_node;
use toolpath_planner::messages::{self as msgs, topics};
use toolpath_planner::ros::node::{qos, RosNode};

/// More jobs than one 64 KB loopback datagram of coalesced DATA carries
/// (~350), so several arrive while the reader has not taken the first.
const DDS_BURST: usize = 1000;

#[test]
fn job_reader_keeps_every_job_of_a_burst_from_a_rustdds_writer() {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    let d = node_process::fresh_domain(0);
    let received: BTreeMap<String, usize> = rt.block_on(async move {
        let lo = Some(vec![IpAddr::V4(Ipv4Addr::LOCALHOST)]);
        let mut client = RosNode::new("burst_client", "/", d, lo.clone()).unwrap();
        let mut node = RosNode::new("burst_node", "/", d, lo).unwrap();
        let sub = node
            .subscription::<msgs::Job>(topics::JOB, qos::job_reader())
            .unwrap();
        let job_qos = qos::job()
            .reliability_reliable(WhenFull::Wait(Duration::from_secs(30)))
            .history(History::KeepLast { depth: DDS_BURST });
        let publisher = client.publisher::<msgs::Job>(topics::JOB, job_qos).unwrap();
        tokio::time::timeout(
            Duration::from_secs(30),
            publisher.wait_for_subscription(&client.node),
        )
        .await
        .expect("the reader was not matched within 30 s");
        let mut stream = Box::pin(sub.async_stream());
        for k in 0..DDS_BURST {
            let job = msgs::Job {
                job_id: format!("job_{k:04}"),
                surface_id: "s".into(),
                strategy: "iso_parametric".into(),
                ..Default::default()
            };
            publisher.publish(job).unwrap();
        }
        let mut received = BTreeMap::new();
        let deadline = Instant::now() + Duration::from_secs(30);
        while received.len() < DDS_BURST {
            let left = deadline.saturating_duration_since(Instant::now());
            match tokio::time::timeout(left, stream.next()).await {
                Ok(Some(Ok((m, _)))) => *received.entry(m.job_id).or_insert(0) += 1,
                Ok(other) => panic!("job stream: {other:?}"),
                Err(_) => break,
            }
        }
        // A little longer, to see duplicates.
        while let Ok(Some(Ok((m, _)))) =
            tokio::time::timeout(Duration::from_millis(300), stream.next()).await
        {
            *received.entry(m.job_id).or_insert(0) += 1;
        }
        received
    });
    let missing: Vec<String> = (0..DDS_BURST)
        .map(|k| format!("job_{k:04}"))
        .filter(|id| !received.contains_key(id))
        .collect();
    assert!(
        missing.is_empty(),
        "{} of {DDS_BURST} jobs lost, first {:?}",
        missing.len(),
        missing.first()
    );
    assert_eq!(received.len(), DDS_BURST);
    assert!(
        received.values().all(|&n| n == 1),
        "a job was delivered twice"
    );
}

#[test]
fn node_answers_every_job_of_a_200_burst_from_the_rust_client() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("node.yaml");
    std::fs::write(&config, bench_node::NODE_CONFIG).unwrap();
    let d = node_process::fresh_domain(1);
    // The benchmark's launch config; killed by pid on drop.
    let (_node, ready) = NodeProcess::spawn(&config, d);
    assert!(ready.starts_with("ready"), "node said {ready:?}");

    // 200 tiny jobs take about 13 s in the dev profile on one worker.
    let outcomes = bench_node::burst(d, 200, 1, Duration::from_secs(120)).unwrap();
    let b = &outcomes[0];
    assert_eq!(b.sent, 200);
    assert_eq!(b.lost(), 0, "{} of 200 jobs got no final status", b.lost());
    assert_eq!(b.duplicates, 0, "jobs with more than one final status");
    assert!(b.all_succeeded_once(), "final states {:?}", b.states);
}
