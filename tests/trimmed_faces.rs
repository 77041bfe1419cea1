//! Trimmed faces against exact answers: a 100 x 100 mm plane with a
//! circular hole of radius 20 mm at its centre (docs/methods.md, "Trimmed
//! faces"). The face's area, the lower bound's share of the whole plane's,
//! the on-face length of every strategy's passes (exactly the untrimmed
//! plan's, clipped to the face by an independent segment/disc computation),
//! the hole skipped beyond the run-in and run-out, contacts inside the hole
//! only within a footprint's reach of its edge, and the simulator's scallop
//! and coverage judged on the face only.

use serde_json::json;
use toolpath_planner::formats::{Job, JobFile, Pass, PlanResult, Strategy};
use toolpath_planner::pipeline::{self, RunOptions};
use toolpath_planner::planners::NoProgress;
use toolpath_planner::simulation::scallop::{simulate, ScallopSettings};

const SIZE: f64 = 100.0;
const CENTRE: [f64; 2] = [50.0, 50.0];
const HOLE_R: f64 = 20.0;
const H: f64 = 0.05;

/// The plane z = 0 over [0, 100]² (u along x, v along y), trimmed to the
/// whole domain (a square loop on its edges) with a circular hole given as
/// an exact rational quadratic circle, clockwise.
fn surface_json(trimmed: bool) -> serde_json::Value {
    let w = std::f64::consts::FRAC_1_SQRT_2;
    let (c, r) = (0.5, HOLE_R / SIZE);
    let unit = [
        [1.0, 0.0],
        [1.0, -1.0],
        [0.0, -1.0],
        [-1.0, -1.0],
        [-1.0, 0.0],
        [-1.0, 1.0],
        [0.0, 1.0],
        [1.0, 1.0],
        [1.0, 0.0],
    ];
    let circle: Vec<[f64; 2]> = unit.iter().map(|p| [c + r * p[0], c + r * p[1]]).collect();
    let mut s = json!({
        "kind": "nurbs",
        "degree_u": 1, "degree_v": 1,
        "knots_u": [0.0, 0.0, 1.0, 1.0], "knots_v": [0.0, 0.0, 1.0, 1.0],
        "control_points": [[[0.0, 0.0, 0.0], [0.0, SIZE, 0.0]],
                           [[SIZE, 0.0, 0.0], [SIZE, SIZE, 0.0]]],
    });
    if trimmed {
        s["trim"] = json!({
            "outer": [{"polyline": [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.0, 0.0]]}],
            "holes": [[{"bspline": {
                "degree": 2,
                "knots": [0.0, 0.0, 0.0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1.0, 1.0, 1.0],
                "control_points": circle,
                "weights": [1.0, w, 1.0, w, 1.0, w, 1.0, w, 1.0],
            }}]],
        });
    }
    s
}

fn job(strategy: Strategy, trimmed: bool) -> Job {
    let mut j = json!({
        "job_id": "trimmed_plane",
        "surface": surface_json(trimmed),
        "strategy": strategy.name(),
    });
    match strategy {
        Strategy::Mpec => {
            j["tool"] = json!({"kind": "torus", "radius": 8.0, "corner_radius": 2.0});
            j["tolerance"] = json!(0.05);
            j["feed_direction"] = json!("u");
        }
        Strategy::BeltIsoParametric | Strategy::BeltIsoPlanar => {
            j["tool"] = json!({"kind": "belt", "width": 10.0, "wheel_radius": 50.0});
            j["scallop"] = json!(0.1);
        }
        _ => {
            j["tool"] = json!({"kind": "ball", "radius": 5.0});
            j["scallop"] = json!(H);
        }
    }
    let file: JobFile = serde_json::from_value(j).unwrap();
    Job::from_file(file, None).unwrap()
}

fn plan_only(job: &Job) -> PlanResult {
    pipeline::run(job, &NoProgress, RunOptions::PLAN_ONLY).unwrap()
}

/// How far from the face a contact may be in a run-in or run-out: the
/// footprint's reach (ball or torus radius, half the belt).
fn reach(job: &Job) -> f64 {
    match *job.tool().unwrap() {
        toolpath_planner::tools::Tool::Belt { width, .. } => 0.5 * width,
        ref t => t.radius(),
    }
}

/// Length of the segment a-b (x, y) inside the disc of radius `r` about the
/// hole's centre: exact line/circle clipping.
fn in_disc(a: [f64; 3], b: [f64; 3], r: f64) -> f64 {
    let (px, py) = (a[0] - CENTRE[0], a[1] - CENTRE[1]);
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len = dx.hypot(dy);
    if len == 0.0 {
        return 0.0;
    }
    // |p + t d|² = r², t in [0, 1].
    let (qa, qb, qc) = (
        dx * dx + dy * dy,
        2.0 * (px * dx + py * dy),
        px * px + py * py - r * r,
    );
    let disc = qb * qb - 4.0 * qa * qc;
    if disc <= 0.0 {
        return 0.0;
    }
    let s = disc.sqrt();
    let (t0, t1) = ((-qb - s) / (2.0 * qa), (-qb + s) / (2.0 * qa));
    (t1.min(1.0) - t0.max(0.0)).max(0.0) * len
}

fn seg_len(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// (total cc length, cc length inside the disc of radius r) of passes.
fn lengths(passes: &[Pass], r: f64) -> (f64, f64) {
    let mut total = 0.0;
    let mut inside = 0.0;
    for p in passes {
        for w in p.points.windows(2) {
            total += seg_len(w[0].cc, w[1].cc);
            inside += in_disc(w[0].cc, w[1].cc, r);
        }
    }
    (total, inside)
}

fn max_step(passes: &[Pass]) -> f64 {
    passes
        .iter()
        .flat_map(|p| p.points.windows(2))
        .map(|w| seg_len(w[0].cc, w[1].cc))
        .fold(0.0, f64::max)
}

#[test]
fn the_face_area_is_the_square_less_the_disc() {
    let job = job(Strategy::IsoParametric, true);
    let s = job.surface().unwrap();
    let exact = SIZE * SIZE - std::f64::consts::PI * HOLE_R * HOLE_R;
    let area = s.trim().unwrap().face_area(s, 64);
    eprintln!("face area {area:.4} mm², exact {exact:.4}");
    assert!((area - exact).abs() <= 1e-4 * exact, "{area} vs {exact}");
}

#[test]
fn the_lower_bound_is_the_face_share_of_the_planes() {
    // On a plane the strip width is the same everywhere, so the bound is
    // area / width and the trimmed one is the face's share of the whole.
    let full = plan_only(&job(Strategy::IsoParametric, false));
    let trimmed = plan_only(&job(Strategy::IsoParametric, true));
    let (lf, lt) = (
        full.stats.path_length_lower_bound_mm.unwrap(),
        trimmed.stats.path_length_lower_bound_mm.unwrap(),
    );
    let share = 1.0 - std::f64::consts::PI * HOLE_R * HOLE_R / (SIZE * SIZE);
    eprintln!(
        "lower bound {lt:.3} mm of {lf:.3} ({:.5}, exact {share:.5})",
        lt / lf
    );
    assert!((lt / lf - share).abs() <= 1e-4, "{} vs {share}", lt / lf);
}

/// Every surface strategy: the plan on the face is the untrimmed plan on
/// it, exactly; the hole is left beyond a run-in/run-out of about one
/// reach; no contact goes deeper into the hole than reach plus one step.
#[test]
fn every_surface_strategy_keeps_the_face_and_skips_the_hole() {
    for strategy in [
        Strategy::IsoParametric,
        Strategy::IsoScallop,
        Strategy::TensorRegions,
        Strategy::Mpec,
        Strategy::BeltIsoParametric,
        Strategy::BeltIsoPlanar,
    ] {
        let full_job = job(strategy, false);
        let trim_job = job(strategy, true);
        let full = plan_only(&full_job);
        let trimmed = plan_only(&trim_job);
        let reach = reach(&trim_job);
        let step = max_step(&full.passes).max(max_step(&trimmed.passes));
        let (lf, inside_f) = lengths(&full.passes, HOLE_R);
        let (lt, inside_t) = lengths(&trimmed.passes, HOLE_R);
        // The part of the hole no contact of the trimmed plan may cross,
        // bar one step at each end of each run-out: the disc of the points
        // at least reach + step from the face.
        let (_, clear_f) = lengths(&full.passes, HOLE_R - reach - step);
        let (_, clear_t) = lengths(&trimmed.passes, HOLE_R - reach - step);
        eprintln!(
            "{}: untrimmed {lf:.2} mm ({inside_f:.2} over the hole), trimmed {lt:.2} mm ({inside_t:.2} over the hole, {clear_t:.3} deeper than reach + step), {} -> {} passes, step {step:.3} mm, reach {reach} mm",
            strategy.name(),
            full.passes.len(),
            trimmed.passes.len()
        );
        let on_face_f = lf - inside_f;
        let on_face_t = lt - inside_t;
        assert!(
            (on_face_t - on_face_f).abs() <= 1e-9 * lf,
            "{}: on-face length {on_face_t} vs untrimmed {on_face_f}",
            strategy.name()
        );
        assert!(
            clear_f > 0.1 * inside_f,
            "{}: the plan crosses the hole",
            strategy.name()
        );
        assert!(
            clear_t <= 1e-9 * lf,
            "{}: {clear_t} mm of passes deeper in the hole than reach + step",
            strategy.name()
        );
        assert!(
            lt < lf - clear_f,
            "{}: {lt} vs {lf} - {clear_f}",
            strategy.name()
        );
        for p in &trimmed.passes {
            for q in &p.points {
                let d = (q.cc[0] - CENTRE[0]).hypot(q.cc[1] - CENTRE[1]);
                assert!(
                    d >= HOLE_R - reach - step,
                    "{}: contact {:?} {} mm into the hole",
                    strategy.name(),
                    q.cc,
                    HOLE_R - d
                );
            }
        }
    }
}

/// The simulator judges the face only: the trimmed plan holds h on it and
/// leaves none of it uncovered, while the same plan judged on the whole
/// plane leaves the hole's middle uncovered.
#[test]
fn the_simulator_judges_the_face_only() {
    let job = job(Strategy::IsoParametric, true);
    let r = pipeline::run(&job, &NoProgress, RunOptions::default()).unwrap();
    let s = &r.stats;
    let scallop = s.max_scallop_mm.unwrap();
    let uncovered = s.extra["uncovered_area_mm2"];
    let machined = s.extra["machined_area_mm2"];
    let res = s.extra["simulation_resolution_mm"];
    let exact = SIZE * SIZE - std::f64::consts::PI * HOLE_R * HOLE_R;
    eprintln!(
        "trimmed iso_parametric: {:.1} mm, scallop {scallop:.5} (h {H}), uncovered {uncovered}, machined {machined:.2} of {exact:.2} mm² (grid {res} mm), repair {:?}",
        s.path_length_mm,
        s.extra.get("repair_length_mm")
    );
    assert!(scallop <= H, "scallop {scallop}");
    assert_eq!(uncovered, 0.0);
    assert_eq!(r.within_scallop, Some(true));
    // Cell centres on the face: the hole's edge is off by at most one cell
    // across its perimeter.
    let perimeter = 2.0 * std::f64::consts::PI * HOLE_R;
    assert!(
        (machined - exact).abs() <= perimeter * res,
        "machined {machined} vs {exact}"
    );

    let whole = self::job(Strategy::IsoParametric, false);
    let rep = simulate(
        whole.surface().unwrap(),
        job.tool().unwrap(),
        &r,
        &ScallopSettings::with_resolution(None),
    )
    .unwrap();
    // Contacts stop within reach + step of the edge and the ball reaches
    // one radius further: the disc beyond stays uncovered.
    let clear = std::f64::consts::PI * (HOLE_R - 2.0 * reach(&job) - max_step(&r.passes)).powi(2);
    eprintln!(
        "the same plan on the whole plane: uncovered {:.1} mm²",
        rep.uncovered_area_mm2
    );
    assert!(
        rep.uncovered_area_mm2 >= clear,
        "{} vs {clear}",
        rep.uncovered_area_mm2
    );
}

#[test]
fn bad_trims_are_clear_errors() {
    let mut s = surface_json(true);
    s["trim"]["holes"][0][0]["bspline"]["control_points"][8] = json!([0.9, 0.5]);
    let file: JobFile = serde_json::from_value(json!({
        "job_id": "bad", "surface": s, "strategy": "iso_parametric",
        "tool": {"kind": "ball", "radius": 5.0}, "scallop": H,
    }))
    .unwrap();
    let e = Job::from_file(file, None).unwrap_err().to_string();
    assert!(
        e.contains("trim.holes[0]") && e.contains("not closed"),
        "{e}"
    );
}

/// The inside test against the exact disc: every point of a fine grid
/// farther than the sampling tolerance from the hole's circle is on the
/// face exactly when it is outside the disc.
#[test]
fn the_inside_test_agrees_with_the_exact_disc() {
    let job = job(Strategy::IsoParametric, true);
    let s = job.surface().unwrap();
    let tol = s.trim().unwrap().tolerance_mm;
    let n = 400;
    let mut checked = 0;
    for i in 0..=n {
        for j in 0..=n {
            let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
            let d = (SIZE * u - CENTRE[0]).hypot(SIZE * v - CENTRE[1]);
            if (d - HOLE_R).abs() <= tol {
                continue;
            }
            assert_eq!(s.in_face(u, v), d > HOLE_R, "({u}, {v}) at {d} mm");
            checked += 1;
        }
    }
    assert!(checked > 160_000);
}

/// tensor_regions reports its regions' areas on the face: they sum to the
/// face's area, not the plane's.
#[test]
fn regions_count_the_face_area() {
    let r = plan_only(&job(Strategy::TensorRegions, true));
    let sum: f64 = r.regions.as_ref().unwrap().iter().map(|g| g.area_mm2).sum();
    let exact = SIZE * SIZE - std::f64::consts::PI * HOLE_R * HOLE_R;
    eprintln!("regions' area {sum:.3} mm², face {exact:.3}");
    assert!((sum - exact).abs() <= 1e-3 * exact, "{sum} vs {exact}");
}

/// A curved face with a curved outer loop and a hole: the concave cylinder
/// sample trimmed to a disc of radius 0.45 with a hole of radius 0.15 (in
/// (u, v)). Every flat-end strategy holds h on the face by the simulator
/// and leaves none of it uncovered.
#[test]
fn a_trimmed_concave_cylinder_holds_h_on_the_face() {
    use toolpath_planner::formats::Shape;
    use toolpath_planner::geometry::trim::circle;
    use toolpath_planner::geometry::Trim;
    let base = toolpath_planner::samples::job("concave_cylinder").unwrap();
    let s = base.surface().unwrap().clone();
    let ((u0, u1), (v0, v1)) = s.domain();
    let at = |f: f64, g: f64| [u0 + f * (u1 - u0), v0 + g * (v1 - v0)];
    assert_eq!((u1 - u0, v1 - v0), (1.0, 1.0));
    let trim = Trim::new(
        &s,
        vec![circle(at(0.5, 0.5), 0.45, true)],
        vec![vec![circle(at(0.5, 0.5), 0.15, false)]],
        None,
    )
    .unwrap();
    let h = base.scallop.unwrap();
    for strategy in [
        Strategy::IsoParametric,
        Strategy::IsoScallop,
        Strategy::TensorRegions,
    ] {
        let mut job = base.clone();
        job.strategy = strategy;
        job.shape = Shape::Surface(s.clone().with_trim(trim.clone()));
        let r = pipeline::run(&job, &NoProgress, RunOptions::default()).unwrap();
        let st = &r.stats;
        let scallop = st.max_scallop_mm.unwrap();
        let uncovered = st.extra["uncovered_area_mm2"];
        eprintln!(
            "trimmed concave_cylinder {}: {:.1} mm, scallop {scallop:.5} (h {h}), gouge {:.5}, uncovered {uncovered}, machined {:.1} mm², repair {:?}",
            strategy.name(),
            st.path_length_mm,
            st.max_gouge_mm.unwrap(),
            st.extra["machined_area_mm2"],
            st.extra.get("repair_length_mm")
        );
        assert!(scallop <= h, "{}: scallop {scallop}", strategy.name());
        assert_eq!(uncovered, 0.0, "{}", strategy.name());
        assert_eq!(r.within_scallop, Some(true), "{}", strategy.name());
        for p in &r.passes {
            for q in &p.points {
                let far = trim.distance_mm(&s, q.uv);
                assert!(
                    s.in_face(q.uv[0], q.uv[1]) || far <= 4.0 * 2.5 + 2.0,
                    "{}: contact {:?} {far} mm off the face",
                    strategy.name(),
                    q.uv
                );
            }
        }
    }
}

/// The belt's removal simulation judges the face only: the trimmed plan
/// grinds every node on the face, within the job's h, while the same plan
/// on the whole plane leaves the hole's middle unground.
#[test]
fn the_removal_simulation_judges_the_face_only() {
    use toolpath_planner::simulation::removal::simulate_job;
    for strategy in [Strategy::BeltIsoParametric, Strategy::BeltIsoPlanar] {
        let job = job(strategy, true);
        let r = plan_only(&job);
        let on_face = simulate_job(&job, &r).unwrap().stats;
        let whole = simulate_job(&self::job(strategy, false), &r).unwrap().stats;
        let h = job.scallop.unwrap();
        eprintln!(
            "{}: face {} nodes, ground {:.5}, scallop {:.5} (h {h}); whole plane {} nodes, ground {:.5}",
            strategy.name(),
            on_face.nodes,
            on_face.ground_fraction,
            on_face.max_scallop_mm,
            whole.nodes,
            whole.ground_fraction
        );
        assert_eq!(on_face.ground_fraction, 1.0, "{}", strategy.name());
        assert!(on_face.max_scallop_mm <= h, "{}", strategy.name());
        let share = 1.0 - std::f64::consts::PI * HOLE_R * HOLE_R / (SIZE * SIZE);
        let face_share = on_face.nodes as f64 / whole.nodes as f64;
        assert!((face_share - share).abs() < 0.01, "{face_share} vs {share}");
        let step = max_step(&r.passes);
        let unground = std::f64::consts::PI * (HOLE_R - 2.0 * reach(&job) - step).powi(2);
        assert!(
            whole.ground_fraction <= 1.0 - unground / (SIZE * SIZE),
            "{}: {}",
            strategy.name(),
            whole.ground_fraction
        );
    }
}

/// The trimmed sample (`toolpath sample trimmed_saddle`): its job plans
/// within h on the face with nothing uncovered, its machined area is the
/// face's, and every contact is on the face or within a run-out of it.
#[test]
fn the_trimmed_saddle_sample_holds_h_on_its_face() {
    let job = toolpath_planner::samples::job("trimmed_saddle").unwrap();
    let s = job.surface().unwrap();
    let trim = s.trim().unwrap();
    let r = pipeline::run(&job, &NoProgress, RunOptions::default()).unwrap();
    let st = &r.stats;
    let h = job.scallop.unwrap();
    let scallop = st.max_scallop_mm.unwrap();
    let machined = st.extra["machined_area_mm2"];
    let area = trim.face_area(s, 64);
    eprintln!(
        "trimmed_saddle: {:.1} mm (lower bound {:.1}), scallop {scallop:.5} (h {h}), gouge {:.5}, machined {machined:.1} of {area:.1} mm², {} passes",
        st.path_length_mm,
        st.path_length_lower_bound_mm.unwrap(),
        st.max_gouge_mm.unwrap(),
        st.passes
    );
    assert!(scallop <= h, "scallop {scallop}");
    assert_eq!(st.extra["uncovered_area_mm2"], 0.0);
    assert_eq!(r.within_scallop, Some(true));
    assert!(
        (machined - area).abs() <= 0.01 * area,
        "{machined} vs {area}"
    );
    assert!(st.path_length_mm >= st.path_length_lower_bound_mm.unwrap());
    let reach = reach(&job);
    for p in &r.passes {
        for w in p.points.windows(2) {
            for q in [&w[0], &w[1]] {
                let off = trim.distance_mm(s, q.uv);
                assert!(
                    s.in_face(q.uv[0], q.uv[1])
                        || off <= reach + seg_len(w[0].cc, w[1].cc) + 1e-9
                        || off <= 4.0 * reach,
                    "contact {:?} {off} mm off the face",
                    q.uv
                );
            }
        }
    }
}
