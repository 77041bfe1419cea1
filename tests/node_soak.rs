//! The node's memory levels off over long job streams: 2000 small jobs and
//! 100 wing_mould jobs through one `toolpath node`, the settled resident set
//! size after each round of a burst; the second half of each stream may
//! raise the peak by a small margin only.
//!
//! Bounded in count and time (a few minutes in all); the node runs on
//! loopback, on a domain of its own, and is killed by pid.

#[path = "common/node_process.rs"]
mod node_process;

use node_process::NodeProcess;
use std::time::Duration;
use toolpath_planner::cli::bench_node::{self, BurstLoad};
use toolpath_planner::samples::surfaces;

/// Resident set size of `pid`, MiB (from /proc).
fn rss_mib(pid: u32) -> f64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap();
    let kib: f64 = status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .expect("VmRSS in /proc/PID/status");
    kib / 1024.0
}

/// iso_parametric on wing_mould at h 0.05 mm: a large toolpath and trajectory.
fn wing_mould_load() -> BurstLoad {
    BurstLoad {
        surface: surfaces::wing_mould(),
        job: Box::new(|id, s| bench_node::iso_parametric_job(id, s.clone(), 0.05)),
    }
}

/// The node's settled RSS after a round: the least over [`SETTLE`], sampled
/// every 50 ms. The last final status can arrive while a worker still
/// releases its job's memory and the queue-empty trim has not run, so one
/// sample taken at once varies by up to 100 MiB with two workers; and the
/// large outputs of a round of wing_mould jobs can stay resident for more
/// than 1.5 s after it (over 1.5 s, single rounds settled up to 50 MiB above
/// the rest, three runs of three on an idle machine; over 4 s, none did).
/// A leak raises the settled level.
fn settled_rss_mib(pid: u32) -> f64 {
    let mut least = rss_mib(pid);
    let start = std::time::Instant::now();
    while start.elapsed() < SETTLE {
        std::thread::sleep(Duration::from_millis(50));
        least = least.min(rss_mib(pid));
    }
    least
}

const SETTLE: Duration = Duration::from_millis(4000);

/// Runs `rounds` bursts of `n` jobs of `load` and returns the settled RSS
/// after each.
fn stream(node: &NodeProcess, d: u16, load: &BurstLoad, n: usize, rounds: usize) -> Vec<f64> {
    let pid = node.child.id();
    let mut rss = Vec::new();
    let outcomes = bench_node::burst_of(d, load, n, rounds, Duration::from_secs(600), |_, _| {
        rss.push(settled_rss_mib(pid))
    })
    .unwrap();
    for o in &outcomes {
        assert_eq!(o.lost(), 0, "jobs lost: {o:?}");
        assert_eq!(o.states.get("SUCCEEDED"), Some(&n), "{o:?}");
    }
    rss
}

/// The median of the second half of the stream is at most `margin_mib`
/// above the peak of the first half. A leak raises every round, and so the
/// second half's median; a round whose outputs stay resident past [`SETTLE`]
/// raises its own figure only (single wing_mould rounds settled 35 to 50 MiB
/// above the rest in CI runs, two of them in a row once: 136.2 and 129.4 MiB
/// against 94-106), which a median of five rounds passes over. The first
/// half is taken by its peak: its first rounds fill the outputs' QoS
/// histories, and single figures vary by tens of MiB with what the
/// allocator could hand back when the queue emptied (33 to 81 MiB over the
/// first eight small rounds of one run, 83 to 91 over the next eight).
/// Caught: 0.2 MiB a small job (the leak fixed on 2026-11-24, +200 MiB over
/// 1000 jobs) and more than about 1.2 MiB a wing_mould job.
fn assert_levels_off(what: &str, rss: &[f64], margin_mib: f64) {
    let (first, second) = rss.split_at(rss.len() / 2);
    let peak = first.iter().copied().fold(0.0, f64::max);
    let mut sorted = second.to_vec();
    sorted.sort_by(f64::total_cmp);
    let mid = sorted.len() / 2;
    let median = if sorted.len() % 2 == 1 {
        sorted[mid]
    } else {
        0.5 * (sorted[mid - 1] + sorted[mid])
    };
    eprintln!(
        "{what}: RSS after each round, MiB: {rss:.1?}; first half peak {peak:.1}, second half median {median:.1}"
    );
    assert!(
        median <= peak + margin_mib,
        "{what}: the RSS median of the second half, {median:.1} MiB, is more than \
         {margin_mib} MiB above the first half's peak, {peak:.1}: {rss:.1?}"
    );
}

#[test]
fn lingering_rounds_are_no_leak_but_a_rising_level_is() {
    // Recorded wing_mould streams that failed the earlier checks (CI runs
    // of 3722732, 74332b8 and 68a7f8b), and one small stream.
    for (what, rss) in [
        (
            "two lingering rounds",
            [
                81.9, 104.9, 93.2, 103.2, 94.6, 106.0, 94.4, 136.2, 129.4, 109.9,
            ],
        ),
        (
            "lingering last round",
            [34.7, 79.2, 95.2, 85.7, 92.0, 87.0, 93.6, 88.6, 92.8, 130.5],
        ),
        (
            "lingering round",
            [
                144.9, 140.6, 141.5, 141.5, 146.2, 145.0, 198.2, 115.9, 172.2, 151.8,
            ],
        ),
    ] {
        assert_levels_off(what, &rss, 30.0);
    }
    let small = [
        68.7, 80.9, 74.6, 63.2, 54.4, 46.8, 33.3, 79.8, 83.1, 86.4, 88.0, 88.7, 89.7, 90.2, 90.5,
        89.8,
    ];
    assert_levels_off("small, low first half", &small, 25.0);
    // Leaks: before the fix (after each of 8 bursts of 250 small jobs), and
    // 1.5 MiB a wing_mould job.
    let before_fix = [113.0, 163.0, 223.0, 291.0, 341.0, 389.0, 446.0, 489.0];
    let wing_leak: Vec<f64> = (0..10).map(|k| 90.0 + 15.0 * k as f64).collect();
    for (what, rss, margin) in [
        ("leak before the fix", before_fix.to_vec(), 25.0),
        ("wing leak", wing_leak, 30.0),
    ] {
        let caught = std::panic::catch_unwind(|| assert_levels_off(what, &rss, margin));
        assert!(caught.is_err(), "{what} passed");
    }
}

#[test]
fn memory_levels_off_over_small_and_large_job_streams() {
    let tmp = tempfile::tempdir().unwrap();
    let config = tmp.path().join("soak.yaml");
    std::fs::write(&config, bench_node::NODE_CONFIG).unwrap();
    let d = node_process::fresh_domain(0);
    let (node, line) = NodeProcess::spawn(&config, d);
    assert!(line.starts_with("ready"), "node did not start: {line:?}");

    // Before the leak was fixed: +200 MiB over the second 1000 small jobs.
    let small = stream(&node, d, &BurstLoad::small().unwrap(), 125, 16);
    assert_levels_off("2000 small jobs", &small, 25.0);

    let large = stream(&node, d, &wing_mould_load(), 10, 10);
    assert_levels_off("100 wing_mould jobs", &large, 30.0);
}
