//! Every class of bad input gets exit code 2 and a one-line message naming the
//! field, never a panic: run through the `toolpath` binary, and through the
//! Rust API for what JSON cannot carry (NaN).

use serde_json::{json, Value};
use std::path::Path;
use std::process::Command;
use toolpath_planner::error::Error;
use toolpath_planner::formats::{self, Job};
use toolpath_planner::geometry::{NurbsSurface, Pocket};
use toolpath_planner::samples;
use toolpath_planner::tools::Tool;

fn sample_job(name: &str) -> Value {
    serde_json::to_value(samples::job(name).unwrap().to_file()).unwrap()
}

/// Runs `toolpath ARGS` and returns (exit code, stderr).
fn run(args: &[&str], dir: &Path) -> (Option<i32>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_toolpath"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Plans `text` as a job file; asserts exit code 2, one line, no panic, and
/// that the message contains every string of `expect`.
fn rejects_text(text: &str, expect: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("job.json"), text).unwrap();
    let (code, stderr) = run(
        &["plan", "job.json", "-o", "out.json", "--no-verify"],
        dir.path(),
    );
    assert_eq!(code, Some(2), "stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "one line: {stderr}");
    for e in expect {
        assert!(stderr.contains(e), "expected {e:?} in: {stderr}");
    }
    assert!(!dir.path().join("out.json").exists(), "no result written");
}

fn rejects(job: &Value, expect: &[&str]) {
    rejects_text(&serde_json::to_string_pretty(job).unwrap(), expect);
}

/// Sets (or, in an object, inserts) the value at a JSON pointer.
fn with(mut job: Value, pointer: &str, value: Value) -> Value {
    if let Some(slot) = job.pointer_mut(pointer) {
        *slot = value;
        return job;
    }
    let (parent, key) = pointer.rsplit_once('/').unwrap();
    let obj = job.pointer_mut(parent).and_then(Value::as_object_mut);
    obj.unwrap_or_else(|| panic!("no {parent}"))
        .insert(key.to_string(), value);
    job
}

fn without(mut job: Value, parent: &str, key: &str) -> Value {
    job.pointer_mut(parent)
        .unwrap()
        .as_object_mut()
        .unwrap()
        .remove(key)
        .unwrap();
    job
}

#[test]
fn a_valid_sample_job_is_accepted() {
    // The harness itself: an unmodified job gets past validation.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("job.json"),
        serde_json::to_string(&sample_job("plane")).unwrap(),
    )
    .unwrap();
    let text = std::fs::read_to_string(dir.path().join("job.json")).unwrap();
    assert!(formats::parse_job(&text, None).is_ok());
}

#[test]
fn invalid_json() {
    rejects_text("{\"job_id\": \"x\",", &["not valid JSON", "line 1"]);
    rejects_text("", &["not valid JSON"]);
    rejects_text(
        "{\"job_id\": \"x\"} trailing",
        &["not valid JSON", "trailing"],
    );
    rejects_text("[1, 2]", &["invalid type"]);
}

#[test]
fn missing_fields() {
    let job = sample_job("plane");
    rejects(
        &without(job.clone(), "", "strategy"),
        &["missing field `strategy`"],
    );
    rejects(&without(job.clone(), "", "tool"), &["tool: is missing"]);
    rejects(
        &without(job.clone(), "", "surface"),
        &["missing field `surface`"],
    );
    rejects(
        &without(job.clone(), "/surface", "knots_u"),
        &["surface", "missing field `knots_u`"],
    );
    rejects(
        &without(job.clone(), "/surface", "kind"),
        &["surface.kind", "missing"],
    );
    rejects(
        &without(job.clone(), "/tool", "radius"),
        &["tool", "missing field `radius`"],
    );
    let pocket = sample_job("rect_pocket");
    rejects(
        &without(pocket, "/surface", "outer"),
        &["surface", "missing field `outer`"],
    );
    // A surface file that does not exist.
    rejects(
        &with(job, "/surface", json!({"file": "nowhere.json"})),
        &["nowhere.json"],
    );
}

#[test]
fn unknown_names() {
    let job = sample_job("plane");
    rejects(
        &with(job.clone(), "/strategy", json!("zigzag")),
        &["strategy", "zigzag"],
    );
    rejects(
        &with(job.clone(), "/tool/kind", json!("laser")),
        &["tool", "laser"],
    );
    rejects(
        &with(job.clone(), "/surface/kind", json!("mesh")),
        &["surface.kind", "mesh"],
    );
    rejects(
        &with(job.clone(), "/feed_direction", json!("w")),
        &["feed_direction"],
    );
    let mut extra = job;
    extra
        .as_object_mut()
        .unwrap()
        .insert("scalop".into(), json!(0.1));
    rejects(&extra, &["scalop"]);
}

#[test]
fn non_finite_numbers() {
    // JSON has no NaN or infinity; 1e999 overflows f64 and must be named.
    let job = sample_job("plane");
    let text = serde_json::to_string_pretty(&job).unwrap();
    let knots = text.replacen("\"scallop\": 0.05", "\"scallop\": 1e999", 1);
    assert_ne!(knots, text);
    rejects_text(&knots, &["scallop", "finite"]);
    let cp =
        serde_json::to_string(&job)
            .unwrap()
            .replacen("[[[0.0,0.0,0.0]", "[[[0.0,1e999,0.0]", 1);
    assert!(cp.contains("1e999"));
    rejects_text(&cp, &["surface.control_points[0][0][1]", "finite"]);
    rejects_text(
        &text.replacen("\"radius\": 2.5", "\"radius\": -1e999", 1),
        &["tool.radius"],
    );
}

#[test]
fn nan_through_the_rust_api() {
    let field = |e: Error| match e {
        Error::Invalid { field, .. } => field,
        other => panic!("not an input error: {other}"),
    };
    let knots = vec![0.0, 0.0, 1.0, 1.0];
    let cps = vec![
        vec![[0.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[1.0, 0.0, f64::NAN], [1.0, 1.0, 0.0]],
    ];
    let e = NurbsSurface::new(1, 1, knots.clone(), knots.clone(), &cps, None).unwrap_err();
    assert_eq!(field(e), "control_points[1][0]");
    let good = vec![
        vec![[0.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[1.0, 0.0, 0.0], [1.0, 1.0, 0.0]],
    ];
    let e = NurbsSurface::new(
        1,
        1,
        vec![0.0, 0.0, f64::NAN, 1.0],
        knots.clone(),
        &good,
        None,
    )
    .unwrap_err();
    assert!(field(e).starts_with("knots_u"));
    let w = vec![vec![1.0, f64::INFINITY], vec![1.0, 1.0]];
    let e = NurbsSurface::new(1, 1, knots.clone(), knots, &good, Some(&w)).unwrap_err();
    assert_eq!(field(e), "weights[0][1]");
    let e = Tool::Ball {
        radius: f64::NAN,
        length: None,
    }
    .validate()
    .unwrap_err();
    assert_eq!(field(e), "radius");
    let e = Pocket::new(&[[0.0, 0.0], [1.0, f64::NAN], [0.0, 1.0]], &[]).unwrap_err();
    assert_eq!(field(e), "outer[1]");
    let mut f = samples::job("plane").unwrap().to_file();
    f.scallop = Some(f64::NAN);
    let e = Job::new(f, samples::job("plane").unwrap().shape).unwrap_err();
    assert_eq!(field(e), "scallop");
    let mut f = samples::job("plane").unwrap().to_file();
    f.lead_angle_deg = Some(f64::NEG_INFINITY);
    let e = Job::new(f, samples::job("plane").unwrap().shape).unwrap_err();
    assert_eq!(field(e), "lead_angle_deg");
}

#[test]
fn bad_knot_vectors() {
    let job = sample_job("plane"); // bicubic, 4 x 4 control points, 8 knots each way
    rejects(
        &with(
            job.clone(),
            "/surface/knots_u",
            json!([0.0, 0.0, 0.0, 0.0, 1.0, 0.5, 1.0, 1.0]),
        ),
        &["surface.knots_u[5]", "non-decreasing"],
    );
    rejects(
        &with(
            job.clone(),
            "/surface/knots_v",
            json!([0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0]),
        ),
        &["surface.knots_v", "needs 8"],
    );
    rejects(
        &with(
            job.clone(),
            "/surface/knots_u",
            json!([1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]),
        ),
        &["surface.knots_u", "multiplicity"],
    );
    rejects(
        &with(job, "/surface/knots_u", json!("0 0 0 0 1 1 1 1")),
        &["surface.knots_u", "invalid type"],
    );
}

#[test]
fn bad_control_grids() {
    let job = sample_job("plane");
    let mut ragged = job.clone();
    ragged
        .pointer_mut("/surface/control_points/2")
        .unwrap()
        .as_array_mut()
        .unwrap()
        .pop();
    rejects(&ragged, &["surface.control_points[2]", "rectangular"]);
    rejects(
        &with(
            job.clone(),
            "/surface/control_points/1/1",
            json!([1.0, 2.0]),
        ),
        &["surface.control_points[1][1]"],
    );
    rejects(
        &with(job.clone(), "/surface/control_points", json!([])),
        &["surface.control_points", "empty"],
    );
    let mut short = job;
    short
        .pointer_mut("/surface/control_points")
        .unwrap()
        .as_array_mut()
        .unwrap()
        .truncate(3);
    rejects(&short, &["surface", "control points along u"]);
}

#[test]
fn bad_weights() {
    let job = sample_job("concave_cylinder"); // rational, 2 x 3 weights
    rejects(
        &with(job.clone(), "/surface/weights/1/2", json!(0.0)),
        &["surface.weights[1][2]", "positive"],
    );
    rejects(
        &with(job.clone(), "/surface/weights/0/1", json!(-0.5)),
        &["surface.weights[0][1]", "positive"],
    );
    rejects(
        &with(job.clone(), "/surface/weights/0", json!([1.0, 1.0])),
        &["surface.weights[0]"],
    );
    rejects(
        &with(job, "/surface/weights", json!([[1.0, 1.0, 1.0]])),
        &["surface.weights", "rows"],
    );
}

#[test]
fn bad_degrees() {
    let job = sample_job("plane");
    rejects(
        &with(job.clone(), "/surface/degree_u", json!(0)),
        &["surface.degree_u", "at least 1"],
    );
    rejects(
        &with(job.clone(), "/surface/degree_v", json!(26)),
        &["surface.degree_v", "maximum"],
    );
    rejects(
        &with(job.clone(), "/surface/degree_u", json!(-1)),
        &["surface.degree_u"],
    );
    rejects(
        &with(job, "/surface/degree_u", json!(2.5)),
        &["surface.degree_u"],
    );
}

#[test]
fn non_positive_tool_sizes_and_parameters() {
    let job = sample_job("plane");
    rejects(
        &with(job.clone(), "/tool/radius", json!(0.0)),
        &["tool.radius", "positive"],
    );
    rejects(
        &with(job.clone(), "/tool/radius", json!(-2.0)),
        &["tool.radius", "positive"],
    );
    rejects(
        &with(job.clone(), "/scallop", json!(0.0)),
        &["scallop", "positive"],
    );
    rejects(
        &with(job.clone(), "/scallop", json!(-0.01)),
        &["scallop", "positive"],
    );
    rejects(
        &with(job.clone(), "/feed_rate", json!(0)),
        &["feed_rate", "positive"],
    );
    rejects(
        &with(job.clone(), "/lead_angle_deg", json!(95.0)),
        &["lead_angle_deg"],
    );
    let die = sample_job("die_saddle");
    rejects(
        &with(die.clone(), "/tool/corner_radius", json!(0.0)),
        &["tool.corner_radius", "positive"],
    );
    rejects(
        &with(die.clone(), "/tool/corner_radius", json!(40.0)),
        &["tool.corner_radius", "smaller"],
    );
    rejects(
        &with(die, "/tolerance", json!(-1.0)),
        &["tolerance", "positive"],
    );
    let belt = sample_job("sine_wave");
    rejects(
        &with(belt.clone(), "/tool/width", json!(0.0)),
        &["tool.width", "positive"],
    );
    rejects(
        &with(belt, "/tool/wheel_radius", json!(-50.0)),
        &["tool.wheel_radius", "positive"],
    );
    let pocket = sample_job("rect_pocket");
    rejects(
        &with(pocket, "/tool_catalogue", json!([6.0, 0.0])),
        &["tool_catalogue[1]", "positive"],
    );
    // A tool kind the strategy cannot use.
    rejects(
        &with(
            job,
            "/tool",
            json!({"kind": "belt", "width": 10.0, "wheel_radius": 50.0}),
        ),
        &["tool.kind"],
    );
}

#[test]
fn bad_pockets() {
    let job = sample_job("rect_pocket");
    // Bow tie: the outline crosses itself.
    let bow = json!([[0.0, 0.0], [100.0, 60.0], [100.0, 0.0], [20.0, 50.0]]);
    rejects(
        &with(job.clone(), "/surface/outer", bow),
        &["surface.outer", "intersects itself"],
    );
    let outside = json!([[[150.0, 10.0], [160.0, 10.0], [160.0, 20.0]]]);
    rejects(
        &with(job.clone(), "/surface/holes", outside),
        &["surface.holes[0]", "outside"],
    );
    let crossing = json!([[[90.0, 10.0], [120.0, 10.0], [120.0, 20.0], [90.0, 20.0]]]);
    rejects(
        &with(job.clone(), "/surface/holes", crossing),
        &["surface.holes[0]", "crosses"],
    );
    let degenerate = json!([[0.0, 0.0], [10.0, 0.0]]);
    rejects(
        &with(job.clone(), "/surface/outer", degenerate),
        &["surface.outer", "at least 3"],
    );
    // A pocket for a surface strategy.
    rejects(
        &with(job, "/strategy", json!("tensor_regions")),
        &["surface", "needs a NURBS surface"],
    );
}

#[test]
fn bad_cli_arguments_and_surface_files() {
    let dir = tempfile::tempdir().unwrap();
    let (code, stderr) = run(&["sample", "no_such_sample"], dir.path());
    assert_eq!(code, Some(2));
    assert!(stderr.contains("sample") && stderr.contains("no_such_sample"));
    let (code, stderr) = run(&["plan", "missing.json"], dir.path());
    assert_eq!(code, Some(2));
    assert!(stderr.contains("missing.json"));
    let surface = serde_json::to_value(samples::shape("plane").unwrap().to_json()).unwrap();
    let bad = with(surface, "/weights", json!([[1.0, 1.0, 1.0, 1.0]]));
    std::fs::write(dir.path().join("s.json"), bad.to_string()).unwrap();
    let (code, stderr) = run(&["inspect", "s.json", "--uv", "0.5", "0.5"], dir.path());
    assert_eq!(code, Some(2), "{stderr}");
    assert!(
        stderr.contains("s.json") && stderr.contains("weights"),
        "{stderr}"
    );
    std::fs::write(
        dir.path().join("p.json"),
        samples::shape("plane").unwrap().to_json().to_string(),
    )
    .unwrap();
    let (code, stderr) = run(&["inspect", "p.json", "--uv", "1.5", "0.5"], dir.path());
    assert_eq!(code, Some(2));
    assert!(
        stderr.contains("--uv") && stderr.contains("outside"),
        "{stderr}"
    );
}

#[test]
fn bad_trims() {
    let job = sample_job("plane");
    let square = json!({"polyline": [[0.1, 0.1], [0.9, 0.1], [0.9, 0.9], [0.1, 0.9], [0.1, 0.1]]});
    let trimmed = |trim: Value| with(job.clone(), "/surface/trim", trim);
    // A valid trim is accepted by the binary (plans, exit 0).
    let dir = tempfile::tempdir().unwrap();
    let ok = trimmed(
        json!({"outer": [square], "holes": [[{"polyline": [[0.4, 0.4], [0.6, 0.4], [0.5, 0.6], [0.4, 0.4]]}]]}),
    );
    std::fs::write(dir.path().join("job.json"), ok.to_string()).unwrap();
    let (code, stderr) = run(
        &["plan", "job.json", "-o", "out.json", "--no-verify"],
        dir.path(),
    );
    assert_eq!(code, Some(0), "{stderr}");

    rejects(
        &trimmed(json!({"outer": [{"polyline": [[0.1, 0.1], [0.9, 0.1], [0.9, 0.9]]}]})),
        &["trim.outer", "not closed"],
    );
    rejects(
        &trimmed(
            json!({"outer": [{"polyline": [[0.1, 0.1], [0.9, 0.9], [0.9, 0.1], [0.1, 0.6], [0.1, 0.1]]}]}),
        ),
        &["trim.outer", "intersects itself"],
    );
    rejects(
        &trimmed(
            json!({"outer": [square], "holes": [[{"polyline": [[0.05, 0.4], [0.6, 0.4], [0.5, 0.6], [0.05, 0.4]]}]]}),
        ),
        &["trim"],
    );
    rejects(
        &trimmed(
            json!({"outer": [{"polyline": [[-0.5, 0.1], [0.9, 0.1], [0.9, 0.9], [-0.5, 0.1]]}]}),
        ),
        &["trim.outer", "domain"],
    );
    rejects(
        &trimmed(
            json!({"outer": [{"bspline": {"degree": 2, "knots": [0, 0, 1, 1], "control_points": [[0.1, 0.1], [0.5, 0.9], [0.9, 0.1]]}}]}),
        ),
        &["trim.outer[0].bspline.knots"],
    );
    rejects(
        &trimmed(json!({"outer": [square], "tolerance": -1.0})),
        &["trim.tolerance"],
    );
    rejects(
        &trimmed(json!({"outer": [square], "colour": 1})),
        &["colour"],
    );
}
