//! iceoryx2 toolpath output: the documented payload layout, and delivery to a
//! consumer in a second process; the test's shared-memory files are removed.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use toolpath_planner::formats::{Pass, PathPoint, PlanResult};
use toolpath_planner::ipc::{self, ToolpathPublisher, ToolpathSubscriber};

fn result(points_per_pass: usize) -> PlanResult {
    let mut r = PlanResult::new("ipc_job_é", "iso_scallop");
    r.machine = Some("mill5".into());
    for k in 0..3 {
        r.passes.push(Pass {
            region: k % 2 + 4,
            points: (0..points_per_pass)
                .map(|i| PathPoint {
                    cc: [i as f64, k as f64 * 10.0, 0.25 * i as f64],
                    cl: [i as f64, k as f64 * 10.0, 0.25 * i as f64 + 3.0],
                    axis: [0.0, 0.6, 0.8],
                    uv: [i as f64 / 100.0, k as f64 / 3.0],
                    strip_width: if k == 1 { None } else { Some(1.5 + i as f64) },
                    ..Default::default()
                })
                .collect(),
            min_strip_width: None,
        });
    }
    r.stats.path_length_mm = 123.5;
    r.stats.compute_ms = 7.25;
    r.stats.max_scallop_mm = Some(0.01);
    r
}

fn f64_le(b: &[u8], at: usize) -> f64 {
    f64::from_le_bytes(b[at..at + 8].try_into().unwrap())
}
fn u32_le(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

#[test]
fn payload_layout_is_as_documented() {
    let r = result(5);
    let b = ipc::encode(&r, 42).unwrap();
    assert_eq!(b.len(), 256 + 15 * 112);
    assert_eq!(&b[0..4], b"TPTH");
    assert_eq!(u32_le(&b, 4), 1);
    assert_eq!(u32_le(&b, 8), 256);
    assert_eq!(u32_le(&b, 12), 112);
    assert_eq!(u64::from_le_bytes(b[16..24].try_into().unwrap()), 15);
    assert_eq!(u64::from_le_bytes(b[24..32].try_into().unwrap()), 3);
    assert_eq!(u64::from_le_bytes(b[32..40].try_into().unwrap()), 42);
    assert_eq!(f64_le(&b, 40), 123.5);
    assert_eq!(f64_le(&b, 48), 7.25);
    assert_eq!(f64_le(&b, 56), 0.01);
    assert_eq!(&b[64..64 + "ipc_job_é".len()], "ipc_job_é".as_bytes());
    assert_eq!(b[64 + "ipc_job_é".len()], 0);
    assert_eq!(&b[128..140], b"iso_scallop\0");
    assert_eq!(&b[160..166], b"mill5\0");
    // Point 7 = pass 1, index 2: cc, cl, axis, uv, strip width (NaN: none), pass, region, flags.
    let p = 256 + 7 * 112;
    assert_eq!(
        [f64_le(&b, p), f64_le(&b, p + 8), f64_le(&b, p + 16)],
        [2.0, 10.0, 0.5]
    );
    assert_eq!(f64_le(&b, p + 40), 3.5);
    assert_eq!(f64_le(&b, p + 56), 0.6);
    assert_eq!(f64_le(&b, p + 80), 1.0 / 3.0);
    assert!(f64_le(&b, p + 88).is_nan());
    assert_eq!(
        (u32_le(&b, p + 96), u32_le(&b, p + 100), u32_le(&b, p + 104)),
        (1, 5, 0)
    );
    let first = 256 + 5 * 112;
    assert_eq!(u32_le(&b, first + 104), ipc::FIRST_OF_PASS);
    assert_eq!(f64_le(&b, 256 + 112 + 88), 2.5);

    let d = ipc::decode(&b).unwrap();
    assert_eq!(d.job_id, "ipc_job_é");
    assert_eq!(d.points.len(), 15);
    assert_eq!(d.points[7].cl, [2.0, 10.0, 3.5]);

    // Damaged payloads are refused with a reason.
    assert!(ipc::decode(&b[..100])
        .unwrap_err()
        .to_string()
        .contains("shorter"));
    assert!(ipc::decode(&b[..b.len() - 1])
        .unwrap_err()
        .to_string()
        .contains("point_count"));
    let mut bad = b.clone();
    bad[0] = b'X';
    assert!(ipc::decode(&bad).unwrap_err().to_string().contains("magic"));
    let mut bad = b.clone();
    bad[4] = 9;
    assert!(ipc::decode(&bad)
        .unwrap_err()
        .to_string()
        .contains("version"));
    // Long ids are cut on a character boundary.
    let mut long = r.clone();
    long.job_id = "é".repeat(40);
    let d = ipc::decode(&ipc::encode(&long, 1).unwrap()).unwrap();
    assert_eq!(d.job_id, "é".repeat(32));
}

/// Files under /dev/shm and /tmp/iceoryx2 whose names contain `prefix`.
fn files_with(prefix: &str) -> Vec<String> {
    fn walk(dir: &Path, prefix: &str, out: &mut Vec<String>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                walk(&p, prefix, out);
            } else if e.file_name().to_string_lossy().contains(prefix) {
                out.push(p.display().to_string());
            }
        }
    }
    let mut out = Vec::new();
    walk(Path::new("/dev/shm"), prefix, &mut out);
    walk(Path::new("/tmp/iceoryx2"), prefix, &mut out);
    out
}

/// Not a test by itself: the consumer process of `consumer_in_second_process`.
#[test]
fn child_consumer() {
    let (Ok(service), Ok(prefix)) = (
        std::env::var("TOOLPATH_TEST_IPC_SERVICE"),
        std::env::var("TOOLPATH_TEST_IPC_PREFIX"),
    ) else {
        return;
    };
    let sub = ToolpathSubscriber::with_prefix(&service, Some(&prefix)).unwrap();
    println!("ready");
    let got = sub
        .receive_with(Duration::from_secs(60), |bytes| {
            // Read in place: sum the cl coordinates straight from shared memory.
            let d = ipc::decode(bytes).unwrap();
            let sum: f64 = d.points.iter().map(|p| p.cl[0] + p.cl[1] + p.cl[2]).sum();
            format!(
                "{} {} {} {} {}",
                d.job_id,
                d.points.len(),
                d.pass_count,
                d.sequence,
                sum
            )
        })
        .unwrap()
        .expect("a toolpath within 60 s");
    println!("got {got}");
}

#[test]
fn consumer_in_second_process() {
    let prefix = format!("tpt{}_", std::process::id());
    let service = "toolpath_planner/test/toolpath";
    /// Kills the consumer if the test fails half-way.
    struct Guard(std::process::Child);
    impl Drop for Guard {
        fn drop(&mut self) {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
    let mut child = Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "child_consumer",
            "--nocapture",
            "--test-threads=1",
        ])
        .env("TOOLPATH_TEST_IPC_SERVICE", service)
        .env("TOOLPATH_TEST_IPC_PREFIX", &prefix)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let mut child = Guard(child);
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for l in lines.by_ref().map_while(Result::ok) {
            let _ = tx.send(l);
        }
    });
    let wait_for = |want: &str, pump: &mut dyn FnMut()| -> String {
        let start = Instant::now();
        loop {
            if let Ok(l) = rx.recv_timeout(Duration::from_millis(50)) {
                // libtest prints "test name ... " before the child's own output.
                if let Some(i) = l.find(want) {
                    return l[i..].to_string();
                }
            }
            pump();
            assert!(
                start.elapsed() < Duration::from_secs(60),
                "no \"{want}\" from the consumer"
            );
        }
    };
    wait_for("ready", &mut || {});
    let r = result(20_000);
    {
        let mut publisher = ToolpathPublisher::with_prefix(service, Some(&prefix)).unwrap();
        let mut sent = 0;
        let line = wait_for("got ", &mut || {
            // Repeat until the subscriber has connected and answered.
            publisher.publish(&r).unwrap();
            sent += 1;
        });
        let expected_sum: f64 = r
            .passes
            .iter()
            .flat_map(|p| &p.points)
            .map(|p| p.cl[0] + p.cl[1] + p.cl[2])
            .sum();
        let parts: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(parts[1], "ipc_job_é");
        assert_eq!(parts[2], "60000");
        assert_eq!(parts[3], "3");
        let seq: u64 = parts[4].parse().unwrap();
        assert!(seq >= 1 && seq <= sent);
        assert_eq!(parts[5].parse::<f64>().unwrap(), expected_sum);
    }
    assert!(child.0.wait().unwrap().success());
    // Everything of the service and nodes is gone; iceoryx2 keeps its one
    // global management segment per prefix by design: remove ours.
    let left = files_with(&prefix);
    let (mgmt, other): (Vec<String>, Vec<String>) =
        left.into_iter().partition(|f| f.ends_with(".global_mgmt"));
    assert!(other.is_empty(), "iceoryx2 files left behind: {other:?}");
    for f in mgmt {
        std::fs::remove_file(&f).unwrap();
    }
}
