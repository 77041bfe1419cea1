//! The golden bags in bags/ (made by `bags/record_all.sh`) replay with no
//! difference; a bag whose recorded toolpath was moved gives a readable diff
//! and a non-zero exit from `toolpath replay --check`. The `executed_*` bags
//! (recorded by a node executing on a fake controller) show every pass
//! executed, and their trajectory meets the controller rules from home.

use std::path::{Path, PathBuf};
use toolpath_planner::formats::Strategy;
use toolpath_planner::machines::{jtc, Machines};
use toolpath_planner::messages::{self as msgs, convert, topics};
use toolpath_planner::recording::runs::{self, replay, topic_specs, Recorded};
use toolpath_planner::recording::{read_bag, BagWriter, WriterOptions};

fn golden_bags() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("bags");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&root)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.join("metadata.yaml").is_file())
        .collect();
    v.sort();
    v
}

#[test]
fn every_golden_bag_replays_without_difference() {
    let bags = golden_bags();
    assert!(bags.len() >= 5, "golden bags missing: {bags:?}");
    let mut strategies = std::collections::BTreeSet::new();
    let mut machines = std::collections::BTreeSet::new();
    for bag in &bags {
        let report = replay(bag, &Machines::default()).unwrap();
        assert!(report.truncated.is_none());
        assert!(!report.jobs.is_empty());
        for j in &report.jobs {
            assert!(
                j.differences.is_empty(),
                "{}: job {} differs from its recording:\n  {}\n(re-record on purpose with bags/record_all.sh)",
                bag.display(),
                j.job_id,
                j.differences.join("\n  ")
            );
            strategies.insert(j.strategy.clone());
            machines.insert(j.machine.clone());
        }
    }
    assert!(
        machines.contains("mill5") && machines.contains("belt6"),
        "{machines:?}"
    );
    for s in Strategy::ALL {
        assert!(
            strategies.contains(s.name()),
            "no golden bag for strategy {} (add a job to bags/jobs/ and run bags/record_all.sh): {strategies:?}",
            s.name()
        );
    }
}

#[test]
fn every_golden_job_was_recorded_as_succeeded() {
    for bag in golden_bags() {
        let rec = Recorded::read(&bag).unwrap();
        for j in &rec.jobs {
            let out = rec.outputs(&j.job_id);
            let (state, message) = out.state.clone().expect("a final status");
            assert_eq!(
                state,
                msgs::JobStatus::SUCCEEDED,
                "{}: job {} recorded as {} ({message}): a golden bag must hold a feasible job",
                bag.display(),
                j.job_id,
                msgs::JobStatus::state_name(state)
            );
            let tp = out.toolpath.expect("a toolpath");
            assert!(runs::point_count(tp) > 0);
            assert!(out.poses.is_some() && out.trajectory.is_some());
        }
    }
}

#[test]
fn executed_bags_show_every_pass_executed_on_both_machines() {
    let m = Machines::default();
    let mut machines = std::collections::BTreeSet::new();
    for bag in golden_bags() {
        let name = bag.file_name().unwrap().to_str().unwrap().to_string();
        if !name.starts_with("executed_") {
            continue;
        }
        let rec = Recorded::read(&bag).unwrap();
        assert_eq!(rec.jobs.len(), 1, "{name}");
        let job = &rec.jobs[0];
        assert_eq!(job.execute, msgs::Job::EXECUTE, "{name}");
        let out = rec.outputs(&job.job_id);
        let passes = out.toolpath.expect("a toolpath").passes.len();
        let (machine, trajectory) = out.trajectory.expect("a trajectory");
        let axes = m.axes(machine);
        let (names, limits, home, controller) =
            (axes.joint_names, axes.limits, axes.home, axes.controller);
        let action = controller.action(machine.name());
        // One accepted goal per pass, in order, then SUCCEEDED saying so.
        let accepted: Vec<String> = rec
            .statuses
            .iter()
            .filter(|s| s.state == msgs::JobStatus::RUNNING && s.message.ends_with(": accepted"))
            .map(|s| s.message.clone())
            .collect();
        let want: Vec<String> = (1..=passes)
            .map(|k| format!("executing pass {k}/{passes} on {action}: accepted"))
            .collect();
        assert_eq!(accepted, want, "{name}");
        let (state, message) = out.state.clone().unwrap();
        assert_eq!(state, msgs::JobStatus::SUCCEEDED, "{name}: {message}");
        assert!(
            message.contains(&format!("; executed {passes} passes on {action} in ")),
            "{name}: {message}"
        );
        // The published trajectory starts from the controller's pose (home:
        // the fake controller's start) and meets every rule.
        let points = convert::trajectory_points(trajectory, &names, &limits);
        jtc::check(&points, &names, &limits, Some(&home)).unwrap_or_else(|e| panic!("{name}: {e}"));
        machines.insert(machine.name());
    }
    assert_eq!(
        machines.into_iter().collect::<Vec<_>>(),
        ["belt6", "mill5"],
        "an executed golden bag of each machine"
    );
}

/// Copies `src` into a new bag at `dst`, passing each toolpath through `edit`.
fn copy_with(
    src: &Path,
    dst: &Path,
    edit: impl Fn(&mut msgs::Toolpath),
    edit_status: impl Fn(&mut msgs::JobStatus),
) {
    let bag = read_bag(src).unwrap();
    let mut w = BagWriter::create(dst, WriterOptions::default()).unwrap();
    let specs = topic_specs();
    for s in &specs {
        w.add_topic(s).unwrap();
    }
    for (i, m) in bag.messages.iter().enumerate() {
        let spec = specs.iter().find(|s| s.topic == m.topic).unwrap();
        if m.topic == topics::absolute("/", topics::TOOLPATH) {
            let mut t: msgs::Toolpath = bag.decode(i, spec).unwrap();
            edit(&mut t);
            w.write(&m.topic, m.log_time, &t).unwrap();
        } else if m.topic == topics::absolute("/", topics::JOB_STATUS) {
            let mut s: msgs::JobStatus = bag.decode(i, spec).unwrap();
            edit_status(&mut s);
            w.write(&m.topic, m.log_time, &s).unwrap();
        } else {
            w.write_raw(&m.topic, m.log_time, &m.data).unwrap();
        }
    }
    w.finish().unwrap();
}

#[test]
fn a_moved_toolpath_fails_the_check_with_a_readable_diff() {
    let src = golden_bags()
        .into_iter()
        .find(|b| b.ends_with("iso_parametric_plane"))
        .expect("iso_parametric_plane bag");
    let tmp = tempfile::tempdir().unwrap();
    // An untouched copy replays clean.
    let same = tmp.path().join("same");
    copy_with(&src, &same, |_| {}, |_| {});
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_toolpath"))
        .args(["replay", same.to_str().unwrap(), "--check"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );

    let moved = tmp.path().join("moved");
    copy_with(
        &src,
        &moved,
        |t| t.passes[1].points[3].cc.y += 0.001,
        |_| {},
    );
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_toolpath"))
        .args([
            "replay",
            moved.join("moved_0.mcap").to_str().unwrap(),
            "--check",
        ])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{stdout}");
    assert!(
        stdout.contains("DIFFERENT") && stdout.contains("pass 1 point 3 cc: recorded"),
        "{stdout}"
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("1 difference"));
    // Below the tolerance: no difference.
    let tiny = tmp.path().join("tiny");
    copy_with(&src, &tiny, |t| t.passes[1].points[3].cc.y += 1e-8, |_| {});
    let r = replay(&tiny, &Machines::default()).unwrap();
    assert_eq!(r.differences(), 0);
    // A dropped pass and a changed status.
    let fewer = tmp.path().join("fewer");
    copy_with(
        &src,
        &fewer,
        |t| {
            t.passes.pop();
        },
        |s| {
            if s.state == msgs::JobStatus::SUCCEEDED {
                s.state = msgs::JobStatus::FAILED;
            }
        },
    );
    let r = replay(&fewer, &Machines::default()).unwrap();
    let d = r.jobs[0].differences.join("\n");
    assert!(
        d.contains("passes: recorded 20, now 21") || d.contains("passes: recorded"),
        "{d}"
    );
    assert!(d.contains("status: recorded FAILED"), "{d}");
}

#[test]
fn replay_of_a_bad_bag_is_a_clear_error() {
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("x.mcap");
    std::fs::write(&p, b"not a bag").unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_toolpath"))
        .args(["replay", p.to_str().unwrap(), "--check"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("not an MCAP file"));
}
