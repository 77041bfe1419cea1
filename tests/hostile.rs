//! Hostile inputs through the `toolpath` binary: special and oversized
//! files, runaway parameters and time limits. Each must end quickly with a
//! one-line error naming what is wrong and where (the file, the field or
//! the parameter to change), never a panic or a hang; runaway jobs are
//! refused before planning, from their estimate (docs/limits.md).

use serde_json::{json, Value};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use toolpath_planner::samples;

/// Runs `toolpath ARGS` in `dir`, killing it after `limit`: (exit code,
/// stderr, seconds). A run still going at `limit` fails the test (a hang).
fn run(args: &[&str], dir: &Path, limit: Duration) -> (Option<i32>, String, f64) {
    let start = Instant::now();
    let mut child = Command::new(env!("CARGO_BIN_EXE_toolpath"))
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("toolpath {args:?} still running after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let secs = start.elapsed().as_secs_f64();
    let out = child.wait_with_output().unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
        secs,
    )
}

/// Asserts exit `code`, one line, no panic, and every string of `expect`.
fn assert_error(got: &(Option<i32>, String, f64), code: i32, expect: &[&str]) {
    let (c, stderr, _) = got;
    assert_eq!(*c, Some(code), "stderr: {stderr}");
    assert!(
        !stderr.contains("panicked") && !stderr.contains("backtrace"),
        "{stderr}"
    );
    assert_eq!(stderr.trim_end().lines().count(), 1, "one line: {stderr}");
    for e in expect {
        assert!(stderr.contains(e), "expected {e:?} in: {stderr}");
    }
}

fn sample_job(name: &str) -> Value {
    serde_json::to_value(samples::job(name).unwrap().to_file()).unwrap()
}

fn write(dir: &Path, name: &str, job: &Value) {
    std::fs::write(dir.join(name), job.to_string()).unwrap();
}

const QUICK: Duration = Duration::from_secs(10);

#[test]
fn special_oversized_and_binary_files_are_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("folder.json")).unwrap();
    let fifo = d.join("fifo.json");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    // Sparse: 300 MB long, nothing written, above the 256 MB limit.
    std::fs::File::create(d.join("huge.json"))
        .unwrap()
        .set_len(300 << 20)
        .unwrap();
    std::fs::write(d.join("binary.json"), [0xff, 0xfe, 0x00, 0x80]).unwrap();
    let special = "is a special file (device, FIFO or socket), not a regular file";
    let cases: [(&str, &[&str]); 6] = [
        ("/dev/zero", &["/dev/zero", special]),
        ("/dev/null", &["/dev/null", special]),
        ("fifo.json", &["fifo.json", special]),
        ("folder.json", &["folder.json", "is a directory"]),
        (
            "huge.json",
            &["huge.json", "314572800 bytes, above the limit of 268435456"],
        ),
        ("binary.json", &["binary.json", "not UTF-8"]),
    ];
    for (path, expect) in cases {
        let got = run(&["plan", path, "-o", "out.json"], d, QUICK);
        assert_error(&got, 2, expect);
        assert!(got.2 < 5.0, "{path}: {} s", got.2);
        // The surface reader of `inspect` goes through the same check.
        let got = run(&["inspect", path, "--uv", "0.5", "0.5"], d, QUICK);
        assert_error(&got, 2, expect);
    }
    // A job whose surface is a file reference to one of them.
    for (path, expect) in [("/dev/zero", special), ("fifo.json", special)] {
        let mut job = sample_job("plane");
        job["surface"] = json!({ "file": path });
        write(d, "ref.json", &job);
        let got = run(&["plan", "ref.json", "-o", "out.json"], d, QUICK);
        assert_error(&got, 2, &[path, expect]);
    }
    assert!(!d.join("out.json").exists());
}

/// Jobs whose work would not fit the machine are refused before planning,
/// in well under a second, naming what they would need and the parameter
/// to change; none of them may start allocating.
#[test]
fn runaway_parameters_are_refused_before_planning() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut huge_pocket = sample_job("rect_pocket");
    let outer: Vec<Value> = huge_pocket["surface"]["outer"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| json!([p[0].as_f64().unwrap() * 1e5, p[1].as_f64().unwrap() * 1e5]))
        .collect();
    huge_pocket["surface"]["outer"] = Value::Array(outer);
    let mut tiny_scallop = sample_job("wing_mould");
    tiny_scallop["scallop"] = json!(1e-6);
    let mut tiny_tool = sample_job("wing_mould");
    tiny_tool["tool"]["radius"] = json!(1e-4);
    let mut tiny_belt = sample_job("egg_crate");
    tiny_belt["tool"]["width"] = json!(1e-3);
    let mut tiny_tolerance = sample_job("die_saddle");
    tiny_tolerance["tolerance"] = json!(1e-7);
    let cases: [(&str, Value, &[&str]); 5] = [
        (
            "huge_pocket",
            huge_pocket,
            &["10000000 x 6000000 mm pocket", "split the pocket"],
        ),
        (
            "tiny_scallop",
            tiny_scallop,
            &["scallop 0.000001 mm", "raise scallop"],
        ),
        (
            "tiny_tool",
            tiny_tool,
            &["radius 0.0001 mm", "larger tool radius"],
        ),
        ("tiny_belt", tiny_belt, &["0.001 mm wide", "wider belt"]),
        ("tiny_tolerance", tiny_tolerance, &["raise tolerance"]),
    ];
    for (name, job, expect) in cases {
        let file = format!("{name}.json");
        write(d, &file, &job);
        let got = run(&["plan", &file, "-o", "out.json"], d, QUICK);
        assert_error(&got, 1, &["refused before planning", "limit"]);
        assert_error(&got, 1, expect);
        assert!(got.2 < 2.0, "{name}: {} s", got.2);
        assert!(!d.join("out.json").exists(), "{name}");
    }
    // A simulator grid beyond its limit is refused before the planning it
    // would follow, naming the field.
    let mut fine_grid = sample_job("wing_mould");
    fine_grid["simulation_resolution"] = json!(1e-4);
    write(d, "fine_grid.json", &fine_grid);
    let got = run(&["plan", "fine_grid.json", "-o", "out.json"], d, QUICK);
    assert_error(&got, 2, &["simulation_resolution", "more than the limit"]);
    assert!(got.2 < 2.0, "{} s", got.2);
    // The limits are the caller's: a tight --max-passes refuses the sample.
    write(d, "plane.json", &sample_job("plane"));
    let got = run(
        &["plan", "plane.json", "-o", "out.json", "--max-passes", "5"],
        d,
        QUICK,
    );
    assert_error(&got, 1, &["refused before planning", "passes (limit 5)"]);
}

#[test]
fn absurd_limits_on_the_command_line_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(d, "plane.json", &sample_job("plane"));
    for (flag, value) in [
        ("--time-limit", "-1"),
        ("--time-limit", "0"),
        ("--time-limit", "NaN"),
        ("--time-limit", "1e12"),
        ("--max-passes", "0"),
        ("--max-points", "inf"),
        ("--max-memory-mb", "NaN"),
    ] {
        let arg = format!("{flag}={value}");
        let got = run(&["plan", "plane.json", "-o", "o.json", &arg], d, QUICK);
        assert_error(&got, 2, &[flag]);
    }
    let mut job = sample_job("plane");
    for bad in [json!(-1.0), json!(0.0), json!(1e12)] {
        job["time_limit_s"] = bad.clone();
        write(d, "limited.json", &job);
        let got = run(&["plan", "limited.json", "-o", "o.json"], d, QUICK);
        assert_error(&got, 2, &["time_limit_s"]);
    }
}

/// wing_mould takes over ten seconds to plan and verify: a time limit of
/// 0.3 s (the job's own, or --time-limit) stops it soon after, with exit
/// code 5 and the parameter to raise, and writes nothing.
#[test]
fn a_job_over_its_time_limit_stops_with_its_parameter() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut job = sample_job("wing_mould");
    write(d, "wing.json", &job);
    let got = run(
        &["plan", "wing.json", "-o", "out.json", "--time-limit", "0.3"],
        d,
        QUICK,
    );
    assert_error(
        &got,
        5,
        &[
            "stopped: over its time limit of 0.3 s",
            "raise --time-limit",
        ],
    );
    assert!(got.2 < 1.5, "stopped after {} s", got.2);
    job["time_limit_s"] = json!(0.3);
    write(d, "wing.json", &job);
    let got = run(&["plan", "wing.json", "-o", "out.json"], d, QUICK);
    assert_error(
        &got,
        5,
        &["over its time limit of 0.3 s", "the job's time_limit_s"],
    );
    assert!(got.2 < 1.5, "stopped after {} s", got.2);
    assert!(!d.join("out.json").exists());
}
