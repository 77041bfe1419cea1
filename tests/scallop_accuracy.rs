//! The fast scallop simulator against its exact reference (every candidate
//! motion scanned and refined in full, `Simulator::run_reference`): on real
//! plans of small samples and on hand-made passes with a gouge, the residual
//! map agrees within 1e-4 mm at every sample, with the same samples covered,
//! and the refined maximum scallop and gouge agree within 1e-4 mm; a result
//! moved by 3e-4 mm fails the same check.

use toolpath_planner::formats::{Pass, PathPoint, PlanResult, Strategy};
use toolpath_planner::geometry::NurbsSurface;
use toolpath_planner::planners::{self, NoProgress};
use toolpath_planner::samples;
use toolpath_planner::simulation::scallop::{ScallopSettings, Simulator};
use toolpath_planner::tools::Tool;

const TOL_MM: f64 = 1e-4;

/// How far a fast run is from the reference run of (possibly) another result.
struct Agreement {
    /// Largest residual difference over the samples both cover, mm.
    worst: f64,
    /// Samples covered by both.
    covered: usize,
    /// Samples covered by one run only.
    coverage_mismatches: usize,
    scallop: (f64, f64),
    gouge: (f64, f64),
    uncovered: (f64, f64),
}

impl Agreement {
    /// Every figure within [`TOL_MM`]; the first one that is not, named.
    fn check(&self) -> Result<(), String> {
        if self.covered == 0 {
            return Err("nothing covered, the comparison is empty".into());
        }
        if self.worst > TOL_MM {
            return Err(format!("residual maps differ by {:.2e} mm", self.worst));
        }
        if self.coverage_mismatches > 0 {
            return Err(format!(
                "{} samples covered by one run only",
                self.coverage_mismatches
            ));
        }
        for (what, (a, b)) in [("max scallop", self.scallop), ("max gouge", self.gouge)] {
            if (a - b).abs() > TOL_MM {
                return Err(format!("{what} {a} against {b}"));
            }
        }
        if self.uncovered.0 != self.uncovered.1 {
            return Err(format!("uncovered area {:?}", self.uncovered));
        }
        Ok(())
    }
}

/// The fast run on `fast_result` against the reference run on `result`, same grid.
fn agreement(
    surface: &NurbsSurface,
    tool: &Tool,
    fast_result: &PlanResult,
    result: &PlanResult,
    resolution: f64,
) -> Agreement {
    let settings = ScallopSettings::with_resolution(Some(resolution));
    let fast = Simulator::new(surface, tool, fast_result)
        .expect("simulator")
        .run(&settings)
        .expect("fast run");
    let exact = Simulator::new(surface, tool, result)
        .expect("simulator")
        .run_reference(&settings)
        .expect("reference run");
    assert_eq!(fast.map.uv, exact.map.uv, "grids differ");
    let mut a = Agreement {
        worst: 0.0,
        covered: 0,
        coverage_mismatches: 0,
        scallop: (fast.max_scallop_mm, exact.max_scallop_mm),
        gouge: (fast.max_gouge_mm, exact.max_gouge_mm),
        uncovered: (fast.uncovered_area_mm2, exact.uncovered_area_mm2),
    };
    for (x, y) in fast.map.residual.iter().zip(&exact.map.residual) {
        match (x, y) {
            (Some(x), Some(y)) => {
                a.worst = a.worst.max((x - y).abs());
                a.covered += 1;
            }
            (None, None) => {}
            _ => a.coverage_mismatches += 1,
        }
    }
    a
}

/// Asserts that the fast run agrees with the reference; returns the largest map difference.
fn compare(
    name: &str,
    surface: &NurbsSurface,
    tool: &Tool,
    result: &PlanResult,
    resolution: f64,
) -> f64 {
    let a = agreement(surface, tool, result, result, resolution);
    if let Err(e) = a.check() {
        panic!("{name}: {e}");
    }
    eprintln!(
        "{name}: {} samples, largest difference {:.2e} mm, scallop {:.7} / {:.7}, gouge {:.7} / {:.7}",
        a.covered, a.worst, a.scallop.0, a.scallop.1, a.gouge.0, a.gouge.1
    );
    a.worst
}

fn sample_plan(name: &str, strategy: Strategy) -> (toolpath_planner::formats::Job, PlanResult) {
    let mut job = samples::job(name).expect("sample job");
    job.strategy = strategy;
    let result = planners::plan(&job, &NoProgress).expect("plans");
    (job, result)
}

#[test]
fn flat_end_plans_of_the_small_samples_match_the_reference() {
    for (name, strategy, res) in [
        ("monkey_saddle", Strategy::TensorRegions, 0.5),
        ("concave_cylinder", Strategy::IsoScallop, 0.5),
        ("plane", Strategy::IsoParametric, 0.7),
    ] {
        let (job, result) = sample_plan(name, strategy);
        compare(
            &format!("{name} {}", strategy.name()),
            job.surface().unwrap(),
            job.tool().unwrap(),
            &result,
            res,
        );
    }
}

/// Straight ball / torus passes on the monkey saddle, tilted, sparse points
/// (the sweep between points matters), one pass sunk 0.03 mm into the part.
#[test]
fn ball_and_torus_passes_with_a_gouge_match_the_reference() {
    let job = samples::job("monkey_saddle").unwrap();
    let surface = job.surface().unwrap();
    for tool in [
        Tool::Ball {
            radius: 3.0,
            length: None,
        },
        Tool::Torus {
            radius: 4.0,
            corner_radius: 1.0,
            length: None,
        },
    ] {
        let r = tool.radius();
        let rc = tool.corner_radius();
        let mut result = PlanResult::new("test", "iso_parametric");
        let ((u0, u1), (v0, v1)) = surface.domain();
        for pass in 0..9 {
            let v = v0 + (v1 - v0) * (0.1 + 0.1 * pass as f64);
            let sink = if pass == 4 { 0.03 } else { 0.0 };
            let points = (0..=12)
                .map(|i| {
                    let u = u0 + (u1 - u0) * (0.05 + 0.075 * i as f64);
                    let d = surface.derivs(u, v);
                    let n = d.su.cross(&d.sv).normalize();
                    let f = d.su.normalize();
                    // Tool axis tilted 10 deg forward; tip placed so the corner
                    // torus touches the surface at the point (then sunk).
                    let axis =
                        (n * 10f64.to_radians().cos() + f * 10f64.to_radians().sin()).normalize();
                    let side = (n - axis * n.dot(&axis)).try_normalize(1e-12);
                    let centre = d.p.coords + n * rc;
                    let tube = side.map_or(centre, |s| centre + s * (r - rc));
                    let tip = tube - axis * rc - n * sink;
                    PathPoint {
                        cc: [d.p.x, d.p.y, d.p.z],
                        cl: [tip.x, tip.y, tip.z],
                        axis: [axis.x, axis.y, axis.z],
                        uv: [u, v],
                        ..Default::default()
                    }
                })
                .collect();
            result.passes.push(Pass {
                region: 0,
                points,
                min_strip_width: None,
            });
        }
        let worst = compare(tool.kind(), surface, &tool, &result, 0.6);
        assert!(worst.is_finite());
    }
}

/// wing_mould's tensor_regions plan (flat end with a lead, 108 passes, axes
/// turning between points) on a 1 mm grid: 30 000 samples.
#[test]
fn wing_mould_tensor_regions_matches_the_reference() {
    let (job, result) = sample_plan("wing_mould", Strategy::TensorRegions);
    compare(
        "wing_mould tensor_regions",
        job.surface().unwrap(),
        job.tool().unwrap(),
        &result,
        1.0,
    );
}

/// The comparison can fail: every tool position raised 3e-4 mm along its axis
/// moves the map by about that much, and the check says so.
#[test]
fn a_result_moved_by_three_tenths_of_a_micron_fails_the_comparison() {
    let (job, result) = sample_plan("monkey_saddle", Strategy::TensorRegions);
    let mut moved = result.clone();
    for q in moved.passes.iter_mut().flat_map(|p| p.points.iter_mut()) {
        for k in 0..3 {
            q.cl[k] += q.axis[k] * 3e-4;
        }
    }
    let surface = job.surface().unwrap();
    let tool = job.tool().unwrap();
    let a = agreement(surface, tool, &moved, &result, 0.5);
    assert!(
        a.worst > 2e-4 && a.worst < 4e-4,
        "moved map differs by {:.2e} mm",
        a.worst
    );
    let err = a.check().expect_err("a 3e-4 mm move must fail the check");
    assert!(err.contains("residual maps differ"), "{err}");
    // The same result against itself passes.
    assert_eq!(
        agreement(surface, tool, &result, &result, 0.5).check(),
        Ok(())
    );
}
