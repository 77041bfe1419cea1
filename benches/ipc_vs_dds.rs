//! Delivery of a 1 000 000-point toolpath to a consumer on the same host:
//! iceoryx2 (zero-copy, `ipc::ToolpathPublisher`) against DDS on loopback
//! (ros2-client / RustDDS, CDR). Each iteration is timed from the planner's
//! `PlanResult` in the publisher to the consumer having read every point
//! (sum of the cl coordinates), so conversion and serialisation count.
//!
//!     cargo bench --bench ipc_vs_dds
//!
//! Set TOOLPATH_BENCH_POINTS to change the size.
//!
//! DDS carries the path as one message per pass (10 000 points, about 1 MB
//! each, the last one flagged): a single 1 000 000-point sample (about
//! 104 MB) is not delivered by RustDDS on loopback within 120 s. Set
//! TOOLPATH_BENCH_DDS_SINGLE=1 to try the single sample anyway.

use criterion::{criterion_group, criterion_main, Criterion};
use futures::StreamExt;
use ros2_client::{
    qos::{Durability, History, WhenFull},
    ros2::QosProfile,
    Context, MessageTypeName, Name, NodeName, NodeOptions,
};
use serde::{Deserialize, Serialize};
use std::sync::mpsc;
use std::time::{Duration, Instant};
use toolpath_planner::formats::{Pass, PathPoint, PlanResult};
use toolpath_planner::ipc::{self, ToolpathPublisher, ToolpathSubscriber};

fn points() -> usize {
    std::env::var("TOOLPATH_BENCH_POINTS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000)
}

fn big_result(n: usize) -> PlanResult {
    let per_pass = 10_000;
    let mut r = PlanResult::new("bench", "iso_scallop");
    for k in 0..n.div_ceil(per_pass) {
        let m = per_pass.min(n - k * per_pass);
        r.passes.push(Pass {
            region: 0,
            points: (0..m)
                .map(|i| {
                    let x = i as f64 * 0.01;
                    PathPoint {
                        cc: [x, k as f64, 0.0],
                        cl: [x, k as f64, 1.0],
                        axis: [0.0, 0.0, 1.0],
                        uv: [x, k as f64],
                        strip_width: Some(1.0),
                        ..Default::default()
                    }
                })
                .collect(),
            min_strip_width: None,
        });
    }
    r
}

/// The same content as the iceoryx2 payload, as a CDR message.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct DdsPoint {
    cc: [f64; 3],
    cl: [f64; 3],
    axis: [f64; 3],
    uv: [f64; 2],
    strip_width: f64,
    pass: u32,
    region: u32,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
struct DdsToolpath {
    job_id: String,
    /// Index of this message of the path, and how many there are.
    part: u32,
    parts: u32,
    points: Vec<DdsPoint>,
}

/// The path as DDS messages: one per pass, or one for all (`single`).
fn to_dds(r: &PlanResult, single: bool) -> Vec<DdsToolpath> {
    let point = |k: usize, p: &toolpath_planner::formats::Pass, q: &PathPoint| DdsPoint {
        cc: q.cc,
        cl: q.cl,
        axis: q.axis,
        uv: q.uv,
        strip_width: q.strip_width.unwrap_or(f64::NAN),
        pass: k as u32,
        region: p.region as u32,
    };
    let groups: Vec<Vec<DdsPoint>> = if single {
        vec![r
            .passes
            .iter()
            .enumerate()
            .flat_map(|(k, p)| p.points.iter().map(move |q| point(k, p, q)))
            .collect()]
    } else {
        r.passes
            .iter()
            .enumerate()
            .map(|(k, p)| p.points.iter().map(|q| point(k, p, q)).collect())
            .collect()
    };
    let parts = groups.len() as u32;
    groups
        .into_iter()
        .enumerate()
        .map(|(i, points)| DdsToolpath {
            job_id: r.job_id.clone(),
            part: i as u32,
            parts,
            points,
        })
        .collect()
}

fn bench_iceoryx2(c: &mut Criterion, r: &PlanResult) {
    let prefix = format!("tpb{}_", std::process::id());
    let service = "toolpath_planner/bench/toolpath";
    let (ready_tx, ready_rx) = mpsc::channel();
    let (done_tx, done_rx) = mpsc::channel::<(Instant, f64)>();
    let (stop_tx, stop_rx) = mpsc::channel::<()>();
    let p2 = prefix.clone();
    let consumer = std::thread::spawn(move || {
        let sub = ToolpathSubscriber::with_prefix(service, Some(&p2)).unwrap();
        ready_tx.send(()).unwrap();
        while stop_rx.try_recv().is_err() {
            let got = sub
                .receive_with(Duration::from_millis(100), |b| {
                    // Read every point in place.
                    let n = (b.len() - ipc::HEADER_SIZE) / ipc::POINT_SIZE;
                    let mut sum = 0.0;
                    for k in 0..n {
                        let at = ipc::HEADER_SIZE + k * ipc::POINT_SIZE + 24;
                        for c in 0..3 {
                            sum += f64::from_le_bytes(
                                b[at + 8 * c..at + 8 * c + 8].try_into().unwrap(),
                            );
                        }
                    }
                    sum
                })
                .unwrap();
            if let Some(sum) = got {
                done_tx.send((Instant::now(), sum)).unwrap();
            }
        }
    });
    ready_rx.recv().unwrap();
    let mut publisher = ToolpathPublisher::with_prefix(service, Some(&prefix)).unwrap();
    let mut g = c.benchmark_group("toolpath_delivery");
    g.sample_size(10);
    g.bench_function(format!("iceoryx2_{}_points", r.point_count()), |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let t0 = Instant::now();
                publisher.publish(r).unwrap();
                let (t1, sum) = done_rx
                    .recv_timeout(Duration::from_secs(60))
                    .expect("delivered");
                assert!(sum.is_finite());
                total += t1 - t0;
            }
            total
        })
    });
    g.finish();
    stop_tx.send(()).unwrap();
    consumer.join().unwrap();
    drop(publisher);
    // iceoryx2 keeps one management segment per prefix: remove ours.
    if let Ok(entries) = std::fs::read_dir("/dev/shm") {
        for e in entries.flatten() {
            if e.file_name().to_string_lossy().starts_with(&prefix) {
                let _ = std::fs::remove_file(e.path());
            }
        }
    }
}

fn bench_dds(c: &mut Criterion, r: &PlanResult) {
    let rt = tokio::runtime::Runtime::new().unwrap();
    // A domain of its own, loopback only: a benchmark never talks to the
    // cell network.
    let domain = 150 + (std::process::id() % 50) as u16;
    let qos = QosProfile::subscription_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_secs(60)))
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 1000 });
    let make = |name: &str| {
        let dp = rustdds::DomainParticipantBuilder::new(domain)
            .with_only_networks([std::net::IpAddr::V4(std::net::Ipv4Addr::LOCALHOST)])
            .build()
            .unwrap();
        let ctx = Context::from_domain_participant(dp).unwrap();
        let mut node = ctx
            .new_node(
                NodeName::new("/", name).unwrap(),
                NodeOptions::new().enable_rosout(false),
            )
            .unwrap();
        let spinner = node.spinner().unwrap();
        rt.spawn(async move {
            let _ = spinner.spin().await;
        });
        (ctx, node)
    };
    let _guard = rt.enter();
    let (_c1, mut pub_node) = make("bench_pub");
    let (_c2, mut sub_node) = make("bench_sub");
    let topic_name = Name::new("/", "bench_toolpath").unwrap();
    let ty = MessageTypeName::new("toolpath_bench", "Toolpath");
    let t1 = pub_node
        .create_topic(&topic_name, ty.clone(), &qos)
        .unwrap();
    let t2 = sub_node.create_topic(&topic_name, ty, &qos).unwrap();
    let publisher = pub_node
        .create_publisher::<DdsToolpath>(&t1, Some(qos.clone()))
        .unwrap();
    let subscription = sub_node
        .create_subscription::<DdsToolpath>(&t2, Some(qos.clone()))
        .unwrap();
    rt.block_on(async {
        tokio::time::timeout(
            Duration::from_secs(30),
            publisher.wait_for_subscription(&pub_node),
        )
        .await
        .expect("DDS subscription matched");
    });
    let mut stream = Box::pin(subscription.async_stream());
    let mut g = c.benchmark_group("toolpath_delivery");
    g.sample_size(10);
    let single = std::env::var("TOOLPATH_BENCH_DDS_SINGLE").is_ok_and(|v| v == "1");
    g.bench_function(format!("dds_loopback_{}_points", r.point_count()), |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let t0 = Instant::now();
                let msgs = to_dds(r, single);
                let parts = msgs.len();
                rt.block_on(async {
                    for msg in msgs {
                        if publisher.async_publish(msg).await.is_err() {
                            panic!("DDS publish failed");
                        }
                    }
                    let mut sum = 0.0;
                    let mut got = 0;
                    while got < parts {
                        let (m, _) = tokio::time::timeout(Duration::from_secs(120), stream.next())
                            .await
                            .expect("delivered within 120 s")
                            .expect("stream open")
                            .unwrap();
                        assert_eq!(m.parts as usize, parts);
                        sum += m
                            .points
                            .iter()
                            .map(|p| p.cl[0] + p.cl[1] + p.cl[2])
                            .sum::<f64>();
                        got += 1;
                    }
                    assert!(sum.is_finite());
                });
                total += t0.elapsed();
            }
            total
        })
    });
    g.finish();
}

fn benches(c: &mut Criterion) {
    let r = big_result(points());
    bench_iceoryx2(c, &r);
    bench_dds(c, &r);
}

criterion_group!(group, benches);
criterion_main!(group);
