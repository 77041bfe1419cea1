//! The node records its runs (launch-config `recording:`) and
//! `toolpath replay BAG --publish` republishes a bag's inputs to a running
//! node: golden bags republished to a recording node come back identical
//! (checked by the replay itself), the node's own bag replays identically,
//! and a node killed with SIGKILL leaves its finished jobs readable.
//!
//! Every node runs on loopback on a domain of its own and is stopped by pid.

#[path = "common/node_process.rs"]
mod node_process;

use node_process::NodeProcess;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};
use toolpath_planner::machines::Machines;
use toolpath_planner::messages::{self as msgs, topics};
use toolpath_planner::recording::runs::{self, replay};
use toolpath_planner::recording::{read_bag, BagMetadata};

const BIN: &str = env!("CARGO_BIN_EXE_toolpath");

fn golden(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("bags")
        .join(name)
}

/// A domain no other test of this file (or a parallel run) is likely to use.
fn domain(offset: u32) -> u16 {
    (201 + (std::process::id() * 3 + offset) % 30) as u16
}

/// `toolpath node` with recording into `dir/bag_name`; killed by pid on drop.
struct Node {
    process: NodeProcess,
    domain: u16,
}

impl Node {
    /// `toolpath node --config CONFIG` on `domain`, and its first stdout line.
    fn spawn(config: &Path, domain: u16) -> (Node, String) {
        let (process, line) = NodeProcess::spawn(config, domain);
        (Node { process, domain }, line)
    }

    fn start(dir: &Path, bag_name: &str, domain: u16) -> Node {
        let config = dir.join(format!("{bag_name}.yaml"));
        std::fs::write(
            &config,
            format!(
                "recording:\n  enabled: true\n  directory: \"{}\"\n  bag_name: {bag_name}\n",
                dir.display()
            ),
        )
        .unwrap();
        let (node, line) = Node::spawn(&config, domain);
        assert!(line.starts_with("ready"), "node did not start: {line:?}");
        assert!(
            line.contains(&format!("recording to {}", dir.join(bag_name).display())),
            "{line}"
        );
        node
    }

    fn replay_publish(&self, bag: &Path) -> std::process::Output {
        Command::new(BIN)
            .args(["replay", bag.to_str().unwrap(), "--publish", "--check"])
            .args(["--timeout-s", "300"])
            .env("ROS_DOMAIN_ID", self.domain.to_string())
            .output()
            .unwrap()
    }

    /// SIGTERM, then wait (the node writes the bag's summary and metadata.yaml).
    fn terminate(mut self) {
        let pid = nix::unistd::Pid::from_raw(self.process.child.id() as i32);
        nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGTERM).unwrap();
        let t0 = Instant::now();
        while t0.elapsed() < Duration::from_secs(30) {
            if let Ok(Some(status)) = self.process.child.try_wait() {
                assert!(status.success(), "node exit: {status}");
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        panic!("the node did not stop within 30 s of SIGTERM");
    }
}

fn assert_same(out: &std::process::Output) {
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && stdout.contains("same") && !stdout.contains("DIFFERENT"),
        "replay --publish --check: {}\n{stdout}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn republished_golden_bags_match_and_the_node_records_them() {
    let tmp = tempfile::tempdir().unwrap();
    let node = Node::start(tmp.path(), "run", domain(0));
    // Both machines; the second replay of the same bag must ignore the
    // answers of the first (the node's outputs are transient-local).
    for bag in [
        "iso_parametric_plane",
        "belt_iso_planar_sine_wave",
        "iso_parametric_plane",
    ] {
        assert_same(&node.replay_publish(&golden(bag)));
    }
    node.terminate();

    let bag_dir = tmp.path().join("run");
    assert!(bag_dir.join("metadata.yaml").is_file());
    let bag = read_bag(&bag_dir).unwrap();
    assert!(bag.truncated.is_none());
    let count = |relative: &str| bag.messages_on(&topics::absolute("/", relative)).count();
    assert!(count(topics::SURFACE) >= 2 && count(topics::JOB) == 3);
    assert_eq!(count(topics::TOOLPATH), 3);
    assert_eq!(count(topics::MILL5_TRAJECTORY), 2);
    assert_eq!(count(topics::BELT6_TRAJECTORY), 1);
    assert_eq!(count(topics::TOOL_POSES), 3);
    assert_eq!(count(topics::MARKERS), 3);
    let spec = runs::topic_specs()
        .into_iter()
        .find(|s| s.topic == topics::absolute("/", topics::JOB_STATUS))
        .unwrap();
    let finals: Vec<msgs::JobStatus> = bag
        .messages
        .iter()
        .enumerate()
        .filter(|(_, m)| m.topic == spec.topic)
        .map(|(i, _)| bag.decode::<msgs::JobStatus>(i, &spec).unwrap())
        .filter(|s| s.is_final())
        .collect();
    assert_eq!(finals.len(), 3);
    assert!(finals.iter().all(|s| s.state == msgs::JobStatus::SUCCEEDED));
    // The node's bag replays like a golden one; the duplicate job id is
    // matched to its last run.
    let report = replay(&bag_dir, &Machines::default()).unwrap();
    assert_eq!(report.jobs.len(), 3);
    assert_eq!(report.differences(), 0, "{:?}", report.jobs);
}

#[test]
fn a_killed_node_leaves_its_finished_jobs_readable() {
    let tmp = tempfile::tempdir().unwrap();
    let node = Node::start(tmp.path(), "killed", domain(1));
    assert_same(&node.replay_publish(&golden("iso_parametric_plane")));
    // The chunk of a finished job is written once the recorder's queue is
    // empty, which can fall between the toolpath and the final status: the
    // job is finished in the bag once both are there.
    let file = tmp.path().join("killed/killed_0.mcap");
    let t0 = Instant::now();
    loop {
        let bag = runs::Recorded::read(&file);
        if bag
            .as_ref()
            .is_ok_and(|b| b.toolpaths.len() == 1 && b.statuses.iter().any(|s| s.is_final()))
        {
            break;
        }
        assert!(t0.elapsed() < Duration::from_secs(10), "{bag:?}");
        std::thread::sleep(Duration::from_millis(50));
    }
    drop(node); // SIGKILL
    let dir = tmp.path().join("killed");
    // metadata.yaml was written at the start and names the storage file.
    let meta = BagMetadata::read(&dir.join("metadata.yaml")).unwrap();
    assert_eq!(meta.relative_file_paths, vec!["killed_0.mcap".to_string()]);
    let report = replay(&dir, &Machines::default()).unwrap();
    assert!(report.truncated.is_some());
    assert_eq!(report.jobs.len(), 1);
    assert_eq!(report.differences(), 0, "{:?}", report.jobs);
    // `toolpath bag reindex` makes it a finished bag for the standard readers.
    let recovered = read_bag(&dir).unwrap().messages.len();
    let out = Command::new(BIN)
        .args(["bag", "reindex", dir.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let bag = read_bag(&dir).unwrap();
    assert!(bag.truncated.is_none());
    assert_eq!(bag.messages.len(), recovered);
    assert_eq!(bag.metadata.unwrap().message_count, recovered as u64);
    let counts = python_counts(&dir);
    assert_eq!(
        counts,
        format!("{recovered} {recovered} 1"),
        "mcap, rosbags, final statuses"
    );
    let report = replay(&dir, &Machines::default()).unwrap();
    assert_eq!(report.differences(), 0, "{:?}", report.jobs);
}

/// Messages read by Python `mcap` + `mcap-ros2-support` (decoded) and by
/// `rosbags`, and the final statuses among the decoded ones: "N M F".
fn python_counts(dir: &Path) -> String {
    let script = r#"
import sys, pathlib
from mcap_ros2.reader import read_ros2_messages
from rosbags.rosbag2 import Reader
d = pathlib.Path(sys.argv[1])
mcap = next(d.glob("*.mcap"))
n, final = 0, 0
for m in read_ros2_messages(str(mcap)):
    n += 1
    if m.channel.topic.endswith("/job_status") and m.ros_msg.state >= 2:
        final += 1
with Reader(d) as r:
    k = sum(1 for _ in r.messages())
print(n, k, final)
"#;
    let out = Command::new("python3")
        .args(["-c", script, dir.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).trim().to_string()
}

#[test]
fn republishing_a_bad_bag_or_timeout_is_a_clear_error() {
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("x.mcap");
    std::fs::write(&p, b"not a bag").unwrap();
    let out = Command::new(BIN)
        .args(["replay", p.to_str().unwrap(), "--publish"])
        .env("ROS_DOMAIN_ID", domain(2).to_string())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("not an MCAP file"));
    let out = Command::new(BIN)
        .args(["replay", golden("iso_parametric_plane").to_str().unwrap()])
        .args(["--publish", "--timeout-s=0"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--timeout-s"));
}

#[test]
fn bench_node_prints_its_table() {
    // A tiny run: the figures themselves come from an idle machine
    // (docs/results.md, "Node").
    let out = Command::new(BIN)
        .args([
            "bench-node",
            "--jobs",
            "2",
            "--points",
            "600",
            "--burst",
            "5",
            "--bursts",
            "2",
        ])
        .env("ROS_DOMAIN_ID", domain(3).to_string())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("node: job received -> toolpath published - planning"),
        "{stdout}"
    );
    for k in 0..2 {
        assert!(
            stdout.contains(&format!("burst {k}: 5 (5 SUCCEEDED), 0 lost, 0 duplicates")),
            "{stdout}"
        );
    }
    assert!(
        stdout.contains(
            "0 lost, 0 duplicate finals; target every job exactly one final status (0 lost): met"
        ),
        "{stdout}"
    );
}

/// Files under /dev/shm and /tmp/iceoryx2 whose names contain `prefix`.
fn iceoryx2_files(prefix: &str) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for dir in ["/dev/shm", "/tmp/iceoryx2"] {
        let mut stack = vec![PathBuf::from(dir)];
        while let Some(d) = stack.pop() {
            for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
                let p = e.path();
                if p.is_dir() {
                    stack.push(p);
                } else if e.file_name().to_string_lossy().contains(prefix) {
                    out.push(p);
                }
            }
        }
    }
    out
}

#[test]
fn the_node_publishes_every_toolpath_over_iceoryx2() {
    use toolpath_planner::ipc::ToolpathSubscriber;
    let tmp = tempfile::tempdir().unwrap();
    let prefix = format!("tpn{}_", std::process::id());
    let service = format!("toolpath_planner/test_{}", std::process::id());
    let config = tmp.path().join("ipc.yaml");
    std::fs::write(
        &config,
        format!("ipc:\n  enabled: true\n  service: {service}\n  prefix: {prefix}\n"),
    )
    .unwrap();
    let d = domain(4);
    let sub = ToolpathSubscriber::with_prefix(&service, Some(&prefix)).unwrap();
    let (node, line) = Node::spawn(&config, d);
    assert!(
        line.contains(&format!("iceoryx2 service {service}")),
        "{line}"
    );
    let bag = golden("iso_parametric_plane");
    assert_same(&node.replay_publish(&bag));
    let got = sub
        .receive(Duration::from_secs(30))
        .unwrap()
        .expect("a toolpath on iceoryx2");
    let rec = runs::Recorded::read(&bag).unwrap();
    let tp = &rec.toolpaths[0];
    assert_eq!(got.job_id, tp.job_id);
    assert_eq!(got.points.len(), runs::point_count(tp));
    assert_eq!(got.pass_count as usize, tp.passes.len());
    let first = &tp.passes[0].points[0];
    assert!((got.points[0].cl[0] - first.cl.x).abs() < 1e-9);
    node.terminate();
    drop(sub);
    // The node removed its publisher's files on SIGTERM; iceoryx2 keeps one
    // management segment per prefix by design: remove ours.
    let left = iceoryx2_files(&prefix);
    let (mgmt, other): (Vec<PathBuf>, Vec<PathBuf>) = left
        .into_iter()
        .partition(|f| f.to_string_lossy().ends_with(".global_mgmt"));
    for f in &mgmt {
        let _ = std::fs::remove_file(f);
    }
    assert!(other.is_empty(), "iceoryx2 files left behind: {other:?}");
}

/// A tmpfs of `size` mounted at `dir`; unmounted on drop.
struct SmallDisk(PathBuf);

impl SmallDisk {
    fn mount(dir: &Path, size: &str) -> SmallDisk {
        std::fs::create_dir_all(dir).unwrap();
        let out = Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs"])
            .arg(dir)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "mount (needs root): {}",
            String::from_utf8_lossy(&out.stderr)
        );
        SmallDisk(dir.to_path_buf())
    }
}

impl Drop for SmallDisk {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).output();
    }
}

/// The final-status log lines of the node (`job ID: SUCCEEDED 1.00 MESSAGE`).
fn final_status_lines(log: &str) -> Vec<&str> {
    log.lines()
        .filter(|l| l.contains(": SUCCEEDED ") || l.contains(": FAILED: "))
        .collect()
}

#[test]
fn a_full_disk_is_reported_in_the_job_status_and_recording_resumes() {
    let tmp = tempfile::tempdir().unwrap();
    // Room for the bag's header, schemas and metadata.yaml, not for a job.
    let disk = SmallDisk::mount(&tmp.path().join("small"), "32k");
    let config = tmp.path().join("full.yaml");
    std::fs::write(
        &config,
        format!(
            "recording:\n  enabled: true\n  directory: \"{}\"\n  bag_name: full\n",
            disk.0.display()
        ),
    )
    .unwrap();
    let d = domain(5);
    let log_path = tmp.path().join("node.log");
    let log = std::fs::File::create(&log_path).unwrap();
    let mut child = Command::new(BIN)
        .args(["node", "--config", config.to_str().unwrap()])
        .env("ROS_DOMAIN_ID", d.to_string())
        .stdout(std::process::Stdio::piped())
        .stderr(log)
        .spawn()
        .unwrap();
    let mut line = String::new();
    std::io::BufRead::read_line(
        &mut std::io::BufReader::new(child.stdout.take().unwrap()),
        &mut line,
    )
    .unwrap();
    let process = NodeProcess { child };
    assert!(line.starts_with("ready"), "{line:?}");
    // The job itself is planned and published as usual; its status says
    // that its messages could not be recorded.
    let node = Node { process, domain: d };
    assert_same(&node.replay_publish(&golden("iso_parametric_plane")));
    let stderr = std::fs::read_to_string(&log_path).unwrap();
    let finals = final_status_lines(&stderr);
    assert_eq!(finals.len(), 1, "{stderr}");
    assert!(
        finals[0].contains("SUCCEEDED") && finals[0].contains("recording failed"),
        "{}",
        finals[0]
    );
    // Space is freed: the next job is recorded in a new storage file.
    let out = Command::new("mount")
        .args(["-o", "remount,size=16m"])
        .arg(&disk.0)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let second = node.replay_publish(&golden("mpec_die_saddle"));
    if !second.status.success() {
        let mut process = node.process;
        let alive = process.child.try_wait().map(|s| format!("{s:?}"));
        panic!(
            "second job: {}\n{}\nnode (exit: {alive:?}) log:\n{}",
            String::from_utf8_lossy(&second.stdout),
            String::from_utf8_lossy(&second.stderr),
            std::fs::read_to_string(&log_path).unwrap_or_default()
        );
    }
    assert_same(&second);
    let mut process = node.process;
    let pid = nix::unistd::Pid::from_raw(process.child.id() as i32);
    nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGTERM).unwrap();
    let t0 = Instant::now();
    let status = loop {
        if let Ok(Some(status)) = process.child.try_wait() {
            break status;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "no exit after SIGTERM"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    let stderr = std::fs::read_to_string(&log_path).unwrap();
    let finals = final_status_lines(&stderr);
    assert_eq!(finals.len(), 2, "{stderr}");
    assert!(!finals[1].contains("recording failed"), "{}", finals[1]);
    // The exit code still says that recording failed.
    assert_eq!(status.code(), Some(2), "{stderr}");
    let last = stderr.lines().last().unwrap_or_default();
    assert!(
        last.contains("recording failed") && last.contains("write error") && last.contains("full"),
        "{last}"
    );
    // The bag lists both storage files; the second holds the second job.
    let dir = disk.0.join("full");
    let meta = BagMetadata::read(&dir.join("metadata.yaml")).unwrap();
    assert_eq!(
        meta.relative_file_paths,
        ["full_0.mcap", "full_1.mcap"],
        "{meta:?}"
    );
    let recorded = runs::Recorded::read(&dir).unwrap();
    let second = runs::Recorded::read(&golden("mpec_die_saddle")).unwrap();
    for job in &second.jobs {
        let id = &job.job_id;
        assert!(
            recorded.outputs(id).toolpath.is_some(),
            "job {id} not recorded"
        );
    }
}
