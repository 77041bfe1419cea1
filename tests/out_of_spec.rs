//! Tolerance is a contract: out-of-spec results are never reported as
//! success, results are checked only against their own job, and parameters
//! outside their physical range or creased surfaces are refused by name.

use serde_json::{json, Value};
use std::path::Path;
use std::process::{Command, Output};
use toolpath_planner::error::Error;
use toolpath_planner::formats::{self, JobFile, Pass, PathPoint, PlanResult, Shape, Strategy};
use toolpath_planner::geometry::NurbsSurface;
use toolpath_planner::pipeline::{self, Conformance, RunOptions};
use toolpath_planner::planners::NoProgress;
use toolpath_planner::samples;
use toolpath_planner::tools::Tool;

fn plane(a: f64, b: f64) -> NurbsSurface {
    let k = vec![0.0, 0.0, 1.0, 1.0];
    let cps = vec![
        vec![[0.0, 0.0, 0.0], [0.0, b, 0.0]],
        vec![[a, 0.0, 0.0], [a, b, 0.0]],
    ];
    NurbsSurface::new(1, 1, k.clone(), k, &cps, None).unwrap()
}

/// A ball-end iso-parametric job on a 20 x 10 plane, h = 0.2.
fn ball_job() -> JobFile {
    let tool = Tool::Ball {
        radius: 2.5,
        length: None,
    };
    JobFile {
        surface: Shape::Surface(plane(20.0, 10.0)).to_json(),
        scallop: Some(0.2),
        lead_angle_deg: Some(0.0),
        feed_direction: Some(formats::FeedDirection::U),
        simulation_resolution: Some(0.25),
        ..JobFile::new("spec_test", Strategy::IsoParametric, Some(tool))
    }
}

/// Ball passes along x at the given y, the tip `depth` below the plane.
fn ball_passes(ys: &[f64], depth: f64) -> PlanResult {
    let mut r = PlanResult::new("spec_test", "iso_parametric");
    for &y in ys {
        let points = (0..=26)
            .map(|i| PathPoint {
                cl: [i as f64 - 3.0, y, -depth],
                cc: [i as f64 - 3.0, y, -depth],
                axis: [0.0, 0.0, 1.0],
                ..Default::default()
            })
            .collect();
        r.passes.push(Pass {
            region: 0,
            points,
            min_strip_width: None,
        });
    }
    r
}

fn toolpath(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_toolpath"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Ball passes 1 mm apart cover the plane with 2.5 - sqrt(2.5^2 - 0.5^2) =
/// 0.0505 mm < h; the same passes 0.1 mm deep gouge 0.1 mm (> 0.005 mm);
/// passes 3 mm apart leave 2.5 - sqrt(2.5^2 - 1.5^2) = 0.5 mm > h.
#[test]
fn verify_exits_3_on_a_gouge_and_4_on_a_residual_above_h() {
    let dir = tempfile::tempdir().unwrap();
    formats::write_json(&dir.path().join("job.json"), &ball_job()).unwrap();
    let ys_fine: Vec<f64> = (-2..=12).map(f64::from).collect();
    let cases = [
        (ball_passes(&ys_fine, 0.0), Some(0)),
        (ball_passes(&ys_fine, 0.1), Some(3)),
        (ball_passes(&[-1.0, 2.0, 5.0, 8.0, 11.0], 0.0), Some(4)),
    ];
    for (k, (result, code)) in cases.iter().enumerate() {
        formats::write_json(&dir.path().join("r.json"), result).unwrap();
        let out = toolpath(&["verify", "job.json", "r.json"], dir.path());
        assert_eq!(out.status.code(), *code, "case {k}: {}", stderr(&out));
        let summary: Value = serde_json::from_slice(&out.stdout).unwrap();
        let (gouge, scallop) = (
            summary["max_gouge_mm"].as_f64().unwrap(),
            summary["max_scallop_mm"].as_f64().unwrap(),
        );
        match code {
            Some(0) => assert!(
                gouge <= 0.005 && (scallop - 0.0505).abs() < 1e-3,
                "{summary}"
            ),
            Some(3) => {
                assert!((gouge - 0.1).abs() < 1e-6, "{summary}");
                assert!(
                    stderr(&out).contains("out of spec")
                        && stderr(&out).contains("gouge tolerance of 0.005 mm")
                );
            }
            _ => {
                assert!((scallop - 0.5).abs() < 1e-6, "{summary}");
                assert!(stderr(&out).contains("above the job's scallop height h = 0.2 mm"));
            }
        }
    }
}

#[test]
fn verify_refuses_a_result_of_another_job_or_shape() {
    let dir = tempfile::tempdir().unwrap();
    let wing = samples::job("wing_mould").unwrap();
    formats::write_json(&dir.path().join("wing.json"), &wing.to_file()).unwrap();
    // A pocket result checked against wing_mould.
    let pocket = samples::job("rect_pocket").unwrap();
    let pocket_result = pipeline::run(&pocket, &NoProgress, RunOptions::PLAN_ONLY).unwrap();
    formats::write_json(&dir.path().join("pocket_result.json"), &pocket_result).unwrap();
    let out = toolpath(&["verify", "wing.json", "pocket_result.json"], dir.path());
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("result.job_id"), "{}", stderr(&out));
    // The right job_id and strategy, planned on another surface.
    let mut other = samples::job("plane").unwrap();
    other.job_id = wing.job_id.clone();
    other.strategy = wing.strategy;
    other.tool = wing.tool;
    let mut result = PlanResult::new(&wing.job_id, wing.strategy.name());
    result.shape_fingerprint = Some(other.shape.fingerprint());
    formats::write_json(&dir.path().join("other_result.json"), &result).unwrap();
    let out = toolpath(&["verify", "wing.json", "other_result.json"], dir.path());
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("result.shape_fingerprint") && stderr(&out).contains("another shape"),
        "{}",
        stderr(&out)
    );
    // The fingerprint is the geometry's: equal for the same shape, not for another.
    assert_eq!(
        wing.shape.fingerprint(),
        samples::job("wing_mould").unwrap().shape.fingerprint()
    );
    assert_ne!(wing.shape.fingerprint(), other.shape.fingerprint());
}

#[test]
fn conformance_reads_the_simulated_figures_against_the_job() {
    let job = formats::Job::from_file(ball_job(), None).unwrap();
    let mut r = ball_passes(&[0.0], 0.0);
    assert_eq!(
        Conformance::of(&job, &r),
        Conformance::default(),
        "not simulated"
    );
    // Within CONFORMANCE_SLACK_MM (1e-4 mm) of the limits: in spec.
    r.stats.max_gouge_mm = Some(0.00505);
    r.stats.max_scallop_mm = Some(0.20005);
    assert_eq!(
        Conformance::of(&job, &r),
        Conformance::default(),
        "on the limits"
    );
    assert!(pipeline::refuse_gouge(&job, &r).is_ok());
    r.stats.max_gouge_mm = Some(0.0052);
    let e = pipeline::refuse_gouge(&job, &r).unwrap_err();
    assert!(matches!(e, Error::OutOfSpec { gouge: true, .. }), "{e}");
    assert_eq!(e.exit_code(), 3);
    r.stats.max_gouge_mm = Some(0.0);
    r.stats.max_scallop_mm = Some(0.2002);
    let c = Conformance::of(&job, &r);
    assert!(c.gouge.is_none() && c.scallop.is_some());
    assert_eq!(c.error().unwrap().exit_code(), 4);
    assert!(
        pipeline::refuse_gouge(&job, &r).is_ok(),
        "a residual is not a gouge"
    );
}

fn plan_rejects(job: Value, expect: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("job.json"), job.to_string()).unwrap();
    let out = toolpath(
        &["plan", "job.json", "-o", "out.json", "--no-verify"],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    for e in expect {
        assert!(
            stderr(&out).contains(e),
            "expected {e:?} in {}",
            stderr(&out)
        );
    }
    assert!(!dir.path().join("out.json").exists());
}

fn sample_json(name: &str) -> Value {
    serde_json::to_value(samples::job(name).unwrap().to_file()).unwrap()
}

#[test]
fn parameters_outside_their_physical_range_are_refused_with_the_range() {
    let mut job = sample_json("plane");
    job["lead_angle_deg"] = json!(89.0);
    plan_rejects(
        job,
        &["lead_angle_deg", "89", "valid range -45..45 degrees"],
    );
    let mut job = sample_json("plane");
    job["side_tilt_deg"] = json!(-60.0);
    plan_rejects(
        job,
        &["side_tilt_deg", "-60", "valid range -45..45 degrees"],
    );
    let mut job = sample_json("rect_pocket");
    job["tool_catalogue"] = json!([6.0, 500.0]);
    plan_rejects(job, &["tool_catalogue[1]", "500 mm", "0.1..100 mm"]);
    let mut job = sample_json("rect_pocket");
    job["tool_catalogue"] = json!([0.01, 6.0]);
    plan_rejects(job, &["tool_catalogue[0]", "0.01 mm", "0.1..100 mm"]);
}

/// A bicubic surface of 6 x 4 control points whose u knot 0.5 has
/// multiplicity 3 = degree: a 20 mm step (C0 crease) across the middle.
#[test]
fn a_creased_surface_is_refused_naming_the_knot() {
    let ku = vec![0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.5, 1.0, 1.0, 1.0, 1.0];
    let kv = vec![0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0];
    let cps: Vec<Vec<[f64; 3]>> = (0..7)
        .map(|i| {
            (0..4)
                .map(|j| {
                    let z = if i >= 3 { 20.0 } else { 0.0 };
                    [i as f64 * 10.0, j as f64 * 10.0, z]
                })
                .collect()
        })
        .collect();
    let surface = NurbsSurface::new(3, 3, ku, kv, &cps, None).unwrap();
    let mut job = sample_json("plane");
    job["surface"] = Shape::Surface(surface).to_json();
    plan_rejects(
        job,
        &["surface.knots_u[4]", "multiplicity 3", "degree 3", "crease"],
    );
    // Every built-in surface is smooth and passes.
    for info in samples::list() {
        samples::job(info.name).unwrap_or_else(|e| panic!("{}: {e}", info.name));
    }
}
