//! `toolpath verify` end to end, and the pipeline filling the stats from the simulator.

use std::process::Command;
use toolpath_planner::formats::{self, JobFile, Pass, PathPoint, PlanResult, Shape, Strategy};
use toolpath_planner::geometry::NurbsSurface;
use toolpath_planner::pipeline::{self, RunOptions};
use toolpath_planner::planners::NoProgress;
use toolpath_planner::simulation::scallop::ResidualMap;
use toolpath_planner::tools::Tool;

fn plane(a: f64, b: f64) -> NurbsSurface {
    let k = vec![0.0, 0.0, 1.0, 1.0];
    let cps = vec![
        vec![[0.0, 0.0, 0.0], [0.0, b, 0.0]],
        vec![[a, 0.0, 0.0], [a, b, 0.0]],
    ];
    NurbsSurface::new(1, 1, k.clone(), k, &cps, None).unwrap()
}

fn job_file(strategy: Strategy, tool: Tool, shape: &Shape) -> JobFile {
    JobFile {
        surface: shape.to_json(),
        scallop: Some(0.2),
        lead_angle_deg: Some(0.0),
        feed_direction: Some(formats::FeedDirection::U),
        simulation_resolution: Some(0.25),
        ..JobFile::new("verify_test", strategy, Some(tool))
    }
}

/// Ball passes along x, `step` apart across y, tip on the plane.
fn ball_passes(ys: &[f64], len: f64) -> PlanResult {
    let mut r = PlanResult::new("verify_test", "iso_parametric");
    for &y in ys {
        let points = (0..=((len + 6.0) as usize))
            .map(|i| PathPoint {
                cl: [i as f64 - 3.0, y, 0.0],
                cc: [i as f64 - 3.0, y, 0.0],
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

#[test]
fn verify_prints_the_summary_and_writes_the_map() {
    let dir = tempfile::tempdir().unwrap();
    let shape = Shape::Surface(plane(20.0, 10.0));
    let job = job_file(
        Strategy::IsoParametric,
        Tool::Ball {
            radius: 2.5,
            length: None,
        },
        &shape,
    );
    let job_path = dir.path().join("job.json");
    formats::write_json(&job_path, &job).unwrap();
    let ys = [-1.0, 2.0, 5.0, 8.0, 11.0];
    let result_path = dir.path().join("result.json");
    formats::write_json(&result_path, &ball_passes(&ys, 20.0)).unwrap();
    let map_path = dir.path().join("map.json");
    let out = Command::new(env!("CARGO_BIN_EXE_toolpath"))
        .arg("verify")
        .arg(&job_path)
        .arg(&result_path)
        .arg("--map")
        .arg(&map_path)
        .output()
        .unwrap();
    // Passes 3 mm apart leave 0.5 mm against h = 0.2: out of spec, exit 4,
    // with the summary printed all the same.
    assert_eq!(
        out.status.code(),
        Some(4),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let exact = 2.5 - (2.5f64 * 2.5 - 1.5 * 1.5).sqrt();
    let got = summary["max_scallop_mm"].as_f64().unwrap();
    assert!((got - exact).abs() < 1e-6, "{got} vs {exact}");
    assert_eq!(
        summary["within_scallop"],
        serde_json::Value::Bool(got <= 0.2)
    );
    assert_eq!(summary["uncovered_area_mm2"].as_f64(), Some(0.0));
    // The peaks above h lie on the cusp lines midway between the passes
    // (y = 0.5, 3.5, 6.5, 9.5), with the exact cusp height.
    let peaks = summary["peaks_above_scallop"].as_array().unwrap();
    assert!(!peaks.is_empty() && peaks.len() <= 10, "{peaks:?}");
    for peak in peaks {
        let y = peak["xyz"][1].as_f64().unwrap();
        assert!(
            ((y - 0.5) / 3.0 - ((y - 0.5) / 3.0).round()).abs() < 1e-3,
            "{peak}"
        );
        assert!(
            (peak["residual_mm"].as_f64().unwrap() - exact).abs() < 1e-6,
            "{peak}"
        );
    }
    let map: ResidualMap =
        serde_json::from_str(&std::fs::read_to_string(&map_path).unwrap()).unwrap();
    assert_eq!((map.nu, map.nv), (80, 40));
    assert_eq!(map.uv.len(), 3200);
    assert_eq!(map.xyz.len(), 3200);
    // Sample k = i * nv + j: i along u (x), j along v (y).
    let k = 7 * 40 + 3;
    assert!((map.xyz[k][0] - 7.5 * 0.25).abs() < 1e-9 && (map.xyz[k][1] - 3.5 * 0.25).abs() < 1e-9);
    let d = ys
        .iter()
        .map(|y| (map.xyz[k][1] - y).abs())
        .fold(f64::INFINITY, f64::min);
    assert!((map.residual[k].unwrap() - (2.5 - (6.25 - d * d).sqrt())).abs() < 1e-7);
}

#[test]
fn verify_rejects_bad_results_and_belt_jobs() {
    let dir = tempfile::tempdir().unwrap();
    let shape = Shape::Surface(plane(20.0, 10.0));
    let job_path = dir.path().join("job.json");
    formats::write_json(
        &job_path,
        &job_file(
            Strategy::IsoParametric,
            Tool::Ball {
                radius: 2.5,
                length: None,
            },
            &shape,
        ),
    )
    .unwrap();
    let mut bad = ball_passes(&[5.0], 20.0);
    bad.passes[0].points[2].axis = [0.0, 0.0, 0.0];
    let result_path = dir.path().join("result.json");
    formats::write_json(&result_path, &bad).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_toolpath"))
        .arg("verify")
        .arg(&job_path)
        .arg(&result_path)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("passes[0].points[2].axis"), "{err}");

    let belt_path = dir.path().join("belt.json");
    formats::write_json(
        &belt_path,
        &job_file(
            Strategy::BeltIsoPlanar,
            Tool::Belt {
                width: 10.0,
                wheel_radius: 40.0,
            },
            &shape,
        ),
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_toolpath"))
        .arg("verify")
        .arg(&belt_path)
        .arg(&result_path)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("strategy"));
}

#[test]
fn pipeline_fills_scallop_stats_from_the_simulator() {
    let shape = Shape::Surface(plane(30.0, 20.0));
    let tool = Tool::FlatEnd {
        radius: 2.5,
        length: None,
    };
    let mut file = job_file(Strategy::IsoParametric, tool, &shape);
    file.lead_angle_deg = Some(5.0);
    file.scallop = Some(0.05);
    file.simulation_resolution = None;
    let job = formats::Job::new(file, shape).unwrap();
    let Ok(result) = pipeline::run(&job, &NoProgress, RunOptions::default()) else {
        eprintln!("iso_parametric planner unavailable: nothing to fill");
        return;
    };
    let report = pipeline::verify_milling(&job, &result).unwrap();
    assert_eq!(result.stats.max_scallop_mm, Some(report.max_scallop_mm));
    assert_eq!(result.stats.max_gouge_mm, Some(report.max_gouge_mm));
    assert_eq!(
        result.stats.extra.get("uncovered_area_mm2"),
        Some(&report.uncovered_area_mm2)
    );
    let area = report.uncovered_area_mm2 + report.machined_area_mm2;
    assert!((area - 600.0).abs() < 1e-6, "{area}");
    let skipped = pipeline::run(&job, &NoProgress, RunOptions::PLAN_ONLY).unwrap();
    assert_eq!(skipped.stats.max_scallop_mm, None);
}
