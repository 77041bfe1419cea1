//! The three flat-end strategies on `wing_mould` (R = 2.5, lambda = 5 deg,
//! h = 0.05) and on surfaces the planners were not tuned on, checked with the
//! scallop simulator (swept exact cutter), not with the planners' own width
//! model.
//!
//! On wing_mould: all three strategies within h, and tensor_regions' length
//! ratios against both baselines. Elsewhere each test asserts its own limit:
//! h for iso_parametric and iso_scallop on the second surface, and for
//! tensor_regions' partition as traced on the monkey saddle and the
//! 303 mm mould (the partition itself, whichever candidate the strategy
//! keeps); 1.1 h for
//! tensor_regions on the second surface and on the strongly anisotropic bowl;
//! 1.7 h for iso_scallop on that bowl (the figures are in docs/results.md,
//! "Flat-end planners on other surfaces (acceptance tests)").

use toolpath_planner::formats::shape::Shape;
use toolpath_planner::formats::{Job, PlanResult, Strategy};
use toolpath_planner::geometry::NurbsSurface;
use toolpath_planner::pipeline::{self, RunOptions};
use toolpath_planner::planners::{self, NoProgress};
use toolpath_planner::samples;
use toolpath_planner::simulation::scallop::{simulate, ScallopReport, ScallopSettings, Simulator};

const H: f64 = 0.05;
const GOUGE_LIMIT: f64 = 0.005;

fn with_strategy(mut job: Job, strategy: Strategy) -> Job {
    job.strategy = strategy;
    job
}

fn plan_and_simulate(job: &Job) -> (PlanResult, ScallopReport) {
    let result = planners::plan(job, &NoProgress).unwrap();
    let surface = job.surface().unwrap();
    let report = simulate(
        surface,
        job.tool().unwrap(),
        &result,
        &ScallopSettings::default(),
    )
    .unwrap();
    (result, report)
}

/// The partition of tensor_regions as traced (its regions unmerged, each
/// offset from its field line), simulated: the tests of the partition
/// itself, whichever candidate the strategy keeps.
fn partitioned_and_simulate(job: &Job) -> (PlanResult, ScallopReport) {
    let result =
        planners::strip_width::tensor_regions::candidate(job, "partitioned_as_traced", &NoProgress)
            .unwrap()
            .expect("a partition");
    let report = simulate(
        job.surface().unwrap(),
        job.tool().unwrap(),
        &result,
        &ScallopSettings::default(),
    )
    .unwrap();
    (result, report)
}

fn path_length(r: &PlanResult) -> f64 {
    r.cl_path_length()
}

/// What every plan here must meet by the simulator: nothing uncovered, no
/// gouge beyond [`GOUGE_LIMIT`], scallop within `scallop_limit`.
fn assert_machined(name: &str, report: &ScallopReport, scallop_limit: f64) {
    assert_eq!(report.uncovered_area_mm2, 0.0, "{name}: uncovered area");
    assert!(
        report.max_gouge_mm <= GOUGE_LIMIT,
        "{name}: gouge {}",
        report.max_gouge_mm
    );
    assert!(
        report.max_scallop_mm <= scallop_limit,
        "{name}: scallop {}",
        report.max_scallop_mm
    );
}

/// A bicubic freeform (5 x 5 control points over 120 x 100 mm): a tilted
/// dome running into a trough, concave and convex parts, no symmetry.
fn second_surface() -> NurbsSurface {
    let z = [
        [0.0, 3.0, 5.0, 4.0, 1.0],
        [2.0, 7.0, 9.0, 6.0, 2.0],
        [3.0, 6.0, 4.0, 2.0, 3.0],
        [1.0, 2.0, -1.0, 0.0, 4.0],
        [0.0, 1.0, 2.0, 5.0, 7.0],
    ];
    let cps: Vec<Vec<[f64; 3]>> = (0..5)
        .map(|i| {
            (0..5)
                .map(|j| [30.0 * i as f64, 25.0 * j as f64 + 3.0 * i as f64, z[i][j]])
                .collect()
        })
        .collect();
    let k = vec![0.0, 0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0, 1.0];
    NurbsSurface::new(3, 3, k.clone(), k, &cps, None).unwrap()
}

/// On the sample: all three strategies within h by the simulator (as
/// planned, without repair passes); tensor_regions no longer than either
/// baseline and at most 0.85 x iso_parametric (the paper's Table 1 has
/// 0.795 x); iso_scallop within 1.2 x the lower bound (gap passes only
/// where a strip's own side leaves material: the symmetric strip test added
/// 73 passes along the v = 0 edge, 1.354 x); and the partition itself three
/// regions round one trisector, within h. The paper's 0.901 x iso_scallop is
/// not asserted: against the iso_scallop built on the shared, sided gap
/// test the kept plan is 0.975 x (docs/results.md, "Flat-end strategy suite").
#[test]
fn wing_mould_three_strategies_against_the_simulator() {
    let job = samples::job("wing_mould").unwrap();
    assert_eq!(job.scallop.unwrap_or(H), H);
    let mut lengths = Vec::new();
    for strategy in [
        Strategy::IsoParametric,
        Strategy::IsoScallop,
        Strategy::TensorRegions,
    ] {
        let job = with_strategy(job.clone(), strategy);
        let (result, report) = plan_and_simulate(&job);
        let name = strategy.name();
        let lb = result.stats.path_length_lower_bound_mm.unwrap();
        let len = path_length(&result);
        eprintln!(
            "wing_mould {name}: length {len:.0} ({:.3} x bound {lb:.0}), {} passes, scallop {:.4}, gouge {:.4}",
            len / lb,
            result.passes.len(),
            report.max_scallop_mm,
            report.max_gouge_mm
        );
        // All three within h.
        assert_machined(name, &report, H);
        if strategy == Strategy::TensorRegions {
            let d = result.degenerate_points.as_ref().unwrap();
            assert!(d.iter().any(|p| p.kind == "trisector"));
        }
        if strategy == Strategy::IsoScallop {
            assert!(len < 1.2 * lb, "{name}: {len} vs bound {lb}");
        }
        // No set of passes beats the bound; a strip-width planner far
        // above it is broken (the constant parameter step is set by the
        // worst place of this anisotropic mould: 1.7 x).
        assert!(len > lb, "{name}: {len} vs bound {lb}");
        if strategy != Strategy::IsoParametric {
            assert!(len < 1.5 * lb, "{name}: {len} vs bound {lb}");
        }
        lengths.push(len);
    }
    let [iso_parametric, iso_scallop, tensor] = lengths[..] else {
        unreachable!()
    };
    eprintln!(
        "wing_mould tensor_regions: {:.3} x iso_parametric, {:.3} x iso_scallop",
        tensor / iso_parametric,
        tensor / iso_scallop
    );
    assert!(iso_scallop < iso_parametric, "{lengths:?}");
    assert!(tensor <= 0.85 * iso_parametric, "{lengths:?}");
    assert!(tensor <= iso_scallop, "{lengths:?}");
    let (partition, report) = partitioned_and_simulate(&job);
    assert_eq!(partition.regions.as_ref().map(Vec::len), Some(3));
    assert_machined("wing_mould partition", &report, H);
}

/// Two trisectors near the boundary and two wedges: the separatrix graph
/// does not tile this surface, so tensor_regions must fall back to one
/// region rather than leave faces uncut.
#[test]
fn second_freeform_surface_is_cut_without_gouge_or_gaps() {
    let mut job = samples::job("wing_mould").unwrap();
    job.shape = Shape::Surface(second_surface());
    for strategy in [
        Strategy::IsoParametric,
        Strategy::IsoScallop,
        Strategy::TensorRegions,
    ] {
        let job = with_strategy(job.clone(), strategy);
        let (result, report) = plan_and_simulate(&job);
        let name = strategy.name();
        eprintln!(
            "{name}: scallop {:.4} gouge {:.4} uncovered {:.2}",
            report.max_scallop_mm, report.max_gouge_mm, report.uncovered_area_mm2
        );
        // tensor_regions within 1.1 h: it leaves 0.0512 mm (by a finer
        // probe) at the v = 0 edge where two passes fan out
        // (docs/results.md, "Known limits of the flat-end planners
        // (measured, not asserted)").
        let scallop_limit = if strategy == Strategy::TensorRegions {
            1.1 * H
        } else {
            H
        };
        assert_machined(name, &report, scallop_limit);
        let lb = result.stats.path_length_lower_bound_mm.unwrap();
        let len = path_length(&result);
        eprintln!(
            "{name}: scallop {:.4} gouge {:.4} length {len:.0} bound {lb:.0}",
            report.max_scallop_mm, report.max_gouge_mm
        );
        assert!(len > lb, "{name}: {len} vs bound {lb}");
        // The constant parameter step is set by the worst place; the
        // strip-width planners adapt and must stay near the bound.
        if strategy != Strategy::IsoParametric {
            assert!(len < 1.5 * lb, "{name}: {len} vs bound {lb}");
        }
    }
}

/// Where offset passes end obliquely at region boundaries and surface edges
/// (the monkey saddle's regions meet its edges at 30 deg), the corners left
/// between pass ends must be cut: no uncovered area, no tool-radius deep
/// residue, and the scallop within h (passes that hook round into a surface
/// edge they meet at a corner leave more).
#[test]
fn monkey_saddle_regions_leave_no_uncut_corners() {
    let job = samples::job("monkey_saddle").unwrap();
    assert_eq!(job.strategy, Strategy::TensorRegions);
    let (result, report) = partitioned_and_simulate(&job);
    eprintln!(
        "monkey_saddle tensor_regions: scallop {:.4} gouge {:.4} uncovered {:.2} passes {}",
        report.max_scallop_mm,
        report.max_gouge_mm,
        report.uncovered_area_mm2,
        result.passes.len()
    );
    assert_eq!(result.regions.as_ref().map(Vec::len), Some(3));
    assert_machined("monkey_saddle tensor_regions", &report, H);
}

/// wing_mould's height function with another bowl radius and cubic
/// (monkey-saddle) term, on wing_mould's job otherwise.
fn mould_job(bowl_radius: f64, cubic: f64, strategy: Strategy) -> Job {
    use toolpath_planner::geometry::interpolation::interpolate_height_field;
    let height = move |x: f64, y: f64| {
        let (a, b, c1, c3) = (1.0 / bowl_radius, cubic, 1.5e-6, 2e-6);
        let (dx, dy) = (x - 82.0, y - 86.0);
        0.5 * a * (dx * dx + dy * dy)
            + b * (dx * dx * dx - 3.0 * dx * dy * dy)
            + c1 * dx * dx * dy
            + c3 * dy * dy * dy
    };
    let surface =
        interpolate_height_field(height, (0.0, 200.0), (0.0, 150.0), (3, 4), (3, 3)).unwrap();
    let mut job = with_strategy(samples::job("wing_mould").unwrap(), strategy);
    job.shape = Shape::Surface(surface);
    job
}

/// The strongly anisotropic bowl: bowl radius 160 mm, cubic term 4e-5.
fn anisotropic_bowl_job(strategy: Strategy) -> Job {
    mould_job(160.0, 4e-5, strategy)
}

/// A shallower mould than wing_mould (bowl radius 303 mm), whose offset
/// passes kink by about 20 deg along the umbilic's line: turning there
/// swings the disc rim's inner end back, so the strips' inner edges fall
/// short before each kink unless the tool runs on before turning
/// (docs/methods.md, "Run-ons before turns"). tensor_regions within h.
#[test]
fn tensor_regions_holds_h_between_kinked_passes() {
    let (result, report) =
        partitioned_and_simulate(&mould_job(303.0, 2e-5, Strategy::TensorRegions));
    eprintln!(
        "303 mm mould tensor_regions: {} passes, scallop {:.4}, gouge {:.4}",
        result.passes.len(),
        report.max_scallop_mm,
        report.max_gouge_mm
    );
    assert_eq!(result.regions.as_ref().map(Vec::len), Some(3));
    assert_machined("303 mm mould tensor_regions", &report, H);
}

/// Where the surface is anisotropic the strip-width field pays: on the bowl
/// tensor_regions must meet the paper's length ratios against both
/// baselines (at most 0.85 x iso_parametric and 0.95 x iso_scallop), each
/// plan as the pipeline delivers it (verified by the simulator, repair
/// passes included), cut everything without gouging and hold h. The plain
/// plan, before repair, may leave up to 1.2 h here: its fronts bend within
/// 0.4 R where the widths vary fastest, which the front's travel smooths
/// over (docs/methods.md, "Iso-scallop offsetting"; 0.0564 mm at h = 0.05).
#[test]
fn tensor_regions_beats_both_baselines_on_a_strongly_anisotropic_bowl() {
    let (plain, plain_report) = plan_and_simulate(&anisotropic_bowl_job(Strategy::TensorRegions));
    assert_machined(
        "anisotropic bowl tensor_regions, before repair",
        &plain_report,
        1.2 * H,
    );
    let delivered = |strategy| {
        pipeline::run(
            &anisotropic_bowl_job(strategy),
            &NoProgress,
            RunOptions::default(),
        )
        .unwrap()
    };
    let result = delivered(Strategy::TensorRegions);
    let len = result.stats.path_length_mm;
    let (iso_parametric, iso_scallop) = (
        delivered(Strategy::IsoParametric).stats.path_length_mm,
        delivered(Strategy::IsoScallop).stats.path_length_mm,
    );
    let scallop = result.stats.max_scallop_mm.unwrap();
    eprintln!(
        "anisotropic bowl tensor_regions: length {len:.0} ({:.3} x iso_parametric {iso_parametric:.0}, {:.3} x iso_scallop {iso_scallop:.0}), repair {:.0} mm, scallop {scallop:.4} ({:.4} before repair, plan {:.0} mm), gouge {:.4}",
        len / iso_parametric,
        len / iso_scallop,
        result.stats.extra.get("repair_length_mm").copied().unwrap_or(0.0),
        plain_report.max_scallop_mm,
        path_length(&plain),
        result.stats.max_gouge_mm.unwrap(),
    );
    assert_eq!(result.within_scallop, Some(true));
    assert!(
        scallop <= H,
        "anisotropic bowl tensor_regions: scallop {scallop}"
    );
    assert!(result.stats.max_gouge_mm.unwrap() <= GOUGE_LIMIT);
    assert_eq!(result.stats.extra["uncovered_area_mm2"], 0.0);
    assert!(len <= 0.85 * iso_parametric, "{len} vs {iso_parametric}");
    assert!(len <= 0.95 * iso_scallop, "{len} vs {iso_scallop}");
}

/// A strongly anisotropic bowl (principal curvatures about -0.012 .. 0.025
/// 1/mm against the cutter's 0.035): offset fronts fold where the widths
/// vary fast along them, and offsetting the fragments of folded fronts
/// again cascades into thousands of short crossing passes (more than 5 000:
/// an error). iso_scallop must finish, cut everything and not gouge.
#[test]
fn iso_scallop_finishes_on_a_strongly_anisotropic_bowl() {
    let job = anisotropic_bowl_job(Strategy::IsoScallop);
    let (result, report) = plan_and_simulate(&job);
    let lb = result.stats.path_length_lower_bound_mm.unwrap();
    let len = path_length(&result);
    eprintln!(
        "anisotropic bowl iso_scallop: {} passes, length {len:.0} (bound {lb:.0}), scallop {:.4}, gouge {:.4}, uncovered {:.2}",
        result.passes.len(),
        report.max_scallop_mm,
        report.max_gouge_mm,
        report.uncovered_area_mm2
    );
    assert!(len > lb && len < 2.5 * lb, "{len} vs bound {lb}");
    // Gouge: along the steep u = 1 wall the last pass leaves the edge at a
    // shallow angle with the tool tilted 70 deg; its run-out must be lifted
    // by the posed disc's depth below the surface itself (docs/methods.md,
    // "Pass ends: run-ins, run-outs and edge walks"), else it cuts into the
    // wall beside it. Scallop: 0.074 mm where the fronts fold, held to 1.7 h.
    assert_machined("anisotropic bowl iso_scallop", &report, 1.7 * H);
    let surface = job.surface().unwrap();
    let sim = Simulator::new(surface, job.tool().unwrap(), &result).unwrap();
    let n = 120;
    for i in 3..=n - 3 {
        for j in 3..=n - 3 {
            let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
            if let Some(r) = sim.residual_at(u, v) {
                assert!(r >= -GOUGE_LIMIT, "gouge {r} at uv ({u}, {v})");
            }
        }
    }
}
