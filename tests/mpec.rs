//! Strategy `mpec` against the reference of docs/methods.md, "The lead angle",
//! and an independent brute-force sweep of the solid torus along the planned
//! positions.

use toolpath_planner::error::Error;
use toolpath_planner::formats::{FeedDirection, Job, JobFile, PlanResult, Shape, Strategy};
use toolpath_planner::geometry::NurbsSurface;
use toolpath_planner::pipeline::{self, RunOptions};
use toolpath_planner::planners::mpec::error_curve::{
    self as ec, LeadSearch, LocalHeight, Position, Quadric, Solution, Status,
};
use toolpath_planner::planners::{self, mpec, NoProgress};
use toolpath_planner::tools::CutterShape;
use toolpath_planner::tools::Tool;

const R: f64 = 31.5;
const RC: f64 = 6.0;
const DELTA: f64 = 0.01;

/// z = 1/2 kf x^2 + 1/2 kc y^2 on [-a, a] x [-b, b], exactly, as a biquadratic Bezier patch.
fn quadric(kf: f64, kc: f64, a: f64, b: f64) -> NurbsSurface {
    let f = [0.5 * kf * a * a, -0.5 * kf * a * a, 0.5 * kf * a * a];
    let g = [0.5 * kc * b * b, -0.5 * kc * b * b, 0.5 * kc * b * b];
    let xs = [-a, 0.0, a];
    let ys = [-b, 0.0, b];
    let cps: Vec<Vec<[f64; 3]>> = (0..3)
        .map(|i| (0..3).map(|j| [xs[i], ys[j], f[i] + g[j]]).collect())
        .collect();
    let k = vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
    NurbsSurface::new(2, 2, k.clone(), k, &cps, None).unwrap()
}

/// Surface of revolution about an axis along y, so that the feed along the
/// circles (u) is exactly homogeneous: profile z = 1/2 kc y^2 at the drive
/// line x = 0, feed curvature kf (> 0 concave: axis above, < 0: axis below),
/// |x| up to about `a`, |y| <= b. Rational biquadratic, exact.
fn revolved(kf: f64, kc: f64, a: f64, b: f64) -> NurbsSurface {
    let rho = 1.0 / kf.abs();
    let s = kf.signum();
    let alpha = a / rho;
    let (sa, ca) = alpha.sin_cos();
    // Unit arc control points (x, z) seen from the axis, and weights.
    let arc = [(-sa, -s * ca), (0.0, -s / ca), (sa, -s * ca)];
    let w = [1.0, ca, 1.0];
    // Profile: distance from the axis d(y) = rho -+ 1/2 kc y^2 as a quadratic Bezier.
    let ys = [-b, 0.0, b];
    let e = 0.5 * kc * b * b;
    let d = [rho - s * e, rho + s * e, rho - s * e];
    let cps: Vec<Vec<[f64; 3]>> = (0..3)
        .map(|i| {
            (0..3)
                .map(|j| [d[j] * arc[i].0, ys[j], s * rho + d[j] * arc[i].1])
                .collect()
        })
        .collect();
    let ws: Vec<Vec<f64>> = (0..3).map(|i| vec![w[i]; 3]).collect();
    let k = vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
    NurbsSurface::new(2, 2, k.clone(), k, &cps, Some(&ws)).unwrap()
}

fn revolved_height(kf: f64, kc: f64, x: f64, y: f64) -> f64 {
    let rho = 1.0 / kf.abs();
    let s = kf.signum();
    let d = rho - s * 0.5 * kc * y * y;
    s * (rho - (d * d - x * x).sqrt())
}

fn job_file(feed: FeedDirection) -> JobFile {
    JobFile {
        job_id: "mpec_test".into(),
        surface: serde_json::Value::Null,
        strategy: Strategy::Mpec,
        tool: Some(Tool::Torus {
            radius: R,
            corner_radius: RC,
            length: None,
        }),
        machine: None,
        scallop: None,
        tolerance: Some(DELTA),
        lead_angle_deg: None,
        side_tilt_deg: None,
        feed_direction: Some(feed),
        feed_rate: None,
        tool_catalogue: None,
        section_normal: None,
        simulation_resolution: None,
        grinding: None,
        time_limit_s: None,
        execute: None,
    }
}

fn plan(surface: NurbsSurface, feed: FeedDirection) -> toolpath_planner::error::Result<PlanResult> {
    let job = Job::new(job_file(feed), Shape::Surface(surface))?;
    planners::plan(&job, &NoProgress)
}

fn inside_points(r: &PlanResult) -> impl Iterator<Item = &toolpath_planner::formats::PathPoint> {
    r.passes
        .iter()
        .flat_map(|p| p.points.iter())
        .filter(|q| (0.0..=1.0).contains(&q.uv[0]) && (0.0..=1.0).contains(&q.uv[1]))
}

#[test]
fn reference_quadric_on_a_nurbs_surface() {
    let r = plan(quadric(0.0, 1.0 / 1198.0, 100.0, 100.0), FeedDirection::U).unwrap();
    assert!(r.passes.len() >= 4, "{} passes", r.passes.len());
    let mut n = 0;
    for p in inside_points(&r) {
        n += 1;
        assert_eq!(p.mpec.as_deref(), Some("ok"));
        let lead = p.lead_deg.unwrap();
        assert!((lead - 0.8938).abs() < 0.01, "lead {lead} at {:?}", p.uv);
        let w = p.strip_width.unwrap();
        assert!((w - 45.62).abs() < 0.01 * 45.62, "width {w} at {:?}", p.uv);
    }
    assert!(n > 100);
    for pass in &r.passes {
        let w = pass.min_strip_width.unwrap();
        assert!((w - 45.62).abs() < 0.01 * 45.62, "{w}");
    }
}

#[test]
fn convex_across_the_feed_is_not_applicable() {
    let r = plan(quadric(0.0, -1.0 / 1198.0, 100.0, 100.0), FeedDirection::U).unwrap();
    for p in inside_points(&r) {
        assert_eq!(p.mpec.as_deref(), Some("not_applicable"));
        assert!(p.strip_width.unwrap() > 0.0);
    }
    assert!(r.warnings.iter().any(|w| w.contains("MPEC does not apply")));
}

#[test]
fn bad_input_gives_clear_errors() {
    let s = quadric(0.0, 1.0 / 1198.0, 100.0, 100.0);
    let mut f = job_file(FeedDirection::U);
    f.tool = Some(Tool::Torus {
        radius: 6.0,
        corner_radius: 6.0,
        length: None,
    });
    match Job::new(f, Shape::Surface(s.clone())) {
        Err(Error::Invalid { field, .. }) => assert_eq!(field, "tool.corner_radius"),
        other => panic!("{other:?}"),
    }
    for tol in [0.0, -0.01] {
        let mut f = job_file(FeedDirection::U);
        f.tolerance = Some(tol);
        match Job::new(f, Shape::Surface(s.clone())) {
            Err(Error::Invalid { field, .. }) => assert_eq!(field, "tolerance"),
            other => panic!("{other:?}"),
        }
    }
    let mut f = job_file(FeedDirection::U);
    f.tolerance = None;
    let job = Job::new(f, Shape::Surface(s.clone())).unwrap();
    match planners::plan(&job, &NoProgress) {
        Err(Error::Invalid { field, .. }) => assert_eq!(field, "tolerance"),
        other => panic!("{other:?}"),
    }
}

/// The twisted surface of the earlier refusal (the curvature across the feed
/// swings along it, so the "W" collapses on one side): planned, its lopsided
/// points in the conventional position, and within the band by the
/// simulator.
#[test]
fn twisted_surface_plans_within_the_band() {
    let f =
        |x: f64, y: f64| (1.0 + 0.4 * (y / 45.0).sin()) * x * x / 1800.0 + 2.0 * (y / 70.0).cos();
    let twisted = toolpath_planner::geometry::interpolation::interpolate_height_field(
        f,
        (-90.0, 90.0),
        (0.0, 200.0),
        (3, 12),
        (3, 16),
    )
    .unwrap();
    let job = Job::new(job_file(FeedDirection::V), Shape::Surface(twisted)).unwrap();
    let r = pipeline::run(&job, &NoProgress, RunOptions::default()).unwrap();
    let st = &r.stats;
    eprintln!(
        "twisted: {} passes, scallop {:.5}, gouge {:.5}, warnings {:?}",
        r.passes.len(),
        st.max_scallop_mm.unwrap(),
        st.max_gouge_mm.unwrap(),
        r.warnings
    );
    assert!(inside_points(&r).any(|p| p.mpec.as_deref() == Some("not_applicable")));
    assert!(inside_points(&r).any(|p| p.mpec.as_deref() == Some("ok")));
    assert_eq!(r.within_scallop, Some(true), "{:?}", r.warnings);
    assert!(st.max_scallop_mm.unwrap() <= DELTA);
    assert!(st.max_gouge_mm.unwrap() <= DELTA + pipeline::CONFORMANCE_SLACK_MM);
}

/// Concave radius 4 mm (below the corner radius) and 20 mm (no lead up to
/// 60 degrees holds the dips) across the feed: planned with the tool lifted
/// clear, never gouging beyond the band by the simulator, and flagged: not
/// within the band, the lifted points and the area above it in warnings.
#[test]
fn too_curved_spots_are_lifted_and_flagged() {
    for k in [1.0 / 4.0, 1.0 / 20.0] {
        let job = Job::new(
            job_file(FeedDirection::U),
            Shape::Surface(quadric(0.0, k, 2.0, 2.0)),
        )
        .unwrap();
        let r = pipeline::run(&job, &NoProgress, RunOptions::default()).unwrap();
        let st = &r.stats;
        eprintln!(
            "radius {}: scallop {:.4}, gouge {:.5}, {:?}",
            1.0 / k,
            st.max_scallop_mm.unwrap(),
            st.max_gouge_mm.unwrap(),
            r.warnings
        );
        assert!(inside_points(&r).all(|p| p.mpec.as_deref() == Some("lifted")));
        assert!(st.max_gouge_mm.unwrap() <= DELTA + pipeline::CONFORMANCE_SLACK_MM);
        // Above the band, or not reached at all.
        assert!(st.max_scallop_mm.unwrap() > DELTA || st.extra["uncovered_area_mm2"] > 0.0);
        assert_eq!(r.within_scallop, Some(false));
        assert!(r.warnings.iter().any(|w| w.contains("lifted clear")));
        assert!(r
            .warnings
            .iter()
            .any(|w| w.starts_with(pipeline::ABOVE_LIMIT)));
    }
}

// ---- the error curve where MPEC does not apply, by brute force ----

/// Brute force: the error at cross offset `y` from a dense psi grid and,
/// for each sphere, a dense run of feed offsets around its centre.
fn dense_error(t: CutterShape, pos: Position, h: &dyn LocalHeight, y: f64) -> f64 {
    let mut best = f64::INFINITY;
    for i in 0..3000 {
        let psi = -std::f64::consts::PI + std::f64::consts::TAU * i as f64 / 3000.0;
        let c = ec::sphere_centre(t, pos, psi);
        let q = t.corner_radius * t.corner_radius - (y - c[1]).powi(2);
        if q < 0.0 {
            continue;
        }
        for k in -50..=50 {
            let dx = 0.02 * k as f64;
            if dx * dx <= q {
                best = best.min(c[2] - (q - dx * dx).sqrt() - h.height(c[0] + dx, y).0);
            }
        }
    }
    best
}

/// Concave across tighter than the tool at any lead: the lifted
/// position dips exactly to -delta (no gouge beyond the band) and, its
/// middle far above +delta, claims no strip.
#[test]
fn too_curved_is_lifted_to_the_band() {
    let t = CutterShape::torus(R, RC);
    let h = Quadric {
        kxx: 0.0,
        kxy: 0.0,
        kyy: 1.0 / 20.0,
    };
    assert!(ec::solve(t, &h, h.kyy, 0.01, &LeadSearch::default()).is_err());
    let s = ec::solve_lifted(t, &h, 0.01, &LeadSearch::default());
    assert_eq!(s.status, Status::Lifted);
    // The whole tool (the part meets it anywhere across its width), then
    // finely around the lowest sample.
    let coarse = (0..=252)
        .map(|i| -31.5 + 0.25 * i as f64)
        .map(|y| (dense_error(t, s.pos, &h, y), y))
        .fold((f64::INFINITY, 0.0), |a, b| if b.0 < a.0 { b } else { a });
    let lowest = (0..=100)
        .map(|i| dense_error(t, s.pos, &h, coarse.1 - 0.25 + 0.005 * i as f64))
        .fold(f64::INFINITY, f64::min);
    assert!((lowest + 0.01).abs() < 1e-3, "{lowest} at {}", coarse.1);
    assert!(dense_error(t, s.pos, &h, 0.0) > 0.01);
    assert_eq!(s.strip_width(), 0.0);
}

/// A twisted part (kxy) tilts the error curve across the strip: the
/// MPEC strip is lopsided and the conventional one wider on its
/// narrower side; both within the band by brute force.
#[test]
fn twisted_part_conventional_strip_is_wider_on_the_narrow_side() {
    let h = Quadric {
        kxx: 0.0,
        kxy: 1.0 / 1000.0,
        kyy: 1.0 / 4000.0,
    };
    let delta = 0.01;
    let narrower = |s: &Solution| (-s.y_left).min(s.y_right);
    let m = ec::solve(
        CutterShape::torus(R, RC),
        &h,
        h.kyy,
        delta,
        &LeadSearch::default(),
    )
    .unwrap();
    let c = ec::solve_conventional(CutterShape::torus(R, RC), &h, delta, &LeadSearch::default())
        .unwrap();
    assert!(
        narrower(&m) < 0.5 * narrower(&c),
        "MPEC {} {}, conventional {} {}",
        m.y_left,
        m.y_right,
        c.y_left,
        c.y_right
    );
    for s in [m, c] {
        for i in 0..=40 {
            let y = s.y_left + (s.y_right - s.y_left) * i as f64 / 40.0;
            let e = dense_error(CutterShape::torus(R, RC), s.pos, &h, y);
            assert!(
                (-delta - 2e-4..=delta + 2e-4).contains(&e),
                "{:?} y {y}: {e}",
                s.status
            );
        }
    }
}

// ---- brute force: the solid torus swept along the planned positions ----

/// Signed-distance lower bound of the tool solid (flat bottom of radius R0 at
/// the tip, torus corner r around it, cylinder above) at `q`.
fn tool_sdf(cl: [f64; 3], axis: [f64; 3], q: [f64; 3]) -> f64 {
    let d = [q[0] - cl[0], q[1] - cl[1], q[2] - cl[2]];
    let h = d[0] * axis[0] + d[1] * axis[1] + d[2] * axis[2];
    let rad = [d[0] - h * axis[0], d[1] - h * axis[1], d[2] - h * axis[2]];
    let rho = (rad[0] * rad[0] + rad[1] * rad[1] + rad[2] * rad[2]).sqrt();
    let r0 = R - RC;
    let torus = ((rho - r0).powi(2) + (h - RC).powi(2)).sqrt() - RC;
    // Inner disk body: rho <= R0, h >= 0 (capped far above).
    let core = (rho - r0).max(-h).max(h - 200.0);
    // Outer cylinder above the corner: rho <= R, h >= r.
    let upper = (rho - R).max(RC - h).max(h - 200.0);
    torus.min(core).min(upper)
}

/// Lowest point of the tool on the vertical line through (x, y), searched upwards from z_from.
fn lowest_on_line(cl: [f64; 3], axis: [f64; 3], x: f64, y: f64, z_from: f64, z_to: f64) -> f64 {
    let mut z = z_from;
    for _ in 0..2000 {
        let d = tool_sdf(cl, axis, [x, y, z]);
        if d <= 1e-7 {
            return z;
        }
        z += d.max(1e-7);
        if z > z_to {
            return f64::INFINITY;
        }
    }
    f64::INFINITY
}

/// Machined height over (x, y) by the continuous motion through `points` (cl,
/// axis linearly interpolated): 0.1 mm steps, then the best step refined by
/// golden section so that no feed-direction cusp of the sampling remains.
fn envelope(points: &[([f64; 3], [f64; 3])], x: f64, y: f64, z_from: f64, z_to: f64) -> f64 {
    let at = |a: ([f64; 3], [f64; 3]), b: ([f64; 3], [f64; 3]), t: f64| {
        let cl = [0, 1, 2].map(|i| a.0[i] + t * (b.0[i] - a.0[i]));
        let ax = [0, 1, 2].map(|i| a.1[i] + t * (b.1[i] - a.1[i]));
        let n = (ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2]).sqrt();
        lowest_on_line(cl, ax.map(|c| c / n), x, y, z_from, z_to)
    };
    let mut best = (f64::INFINITY, 0usize, 0.0, 0.0);
    for (w_i, w) in points.windows(2).enumerate() {
        let (a, b) = (w[0], w[1]);
        let len =
            ((b.0[0] - a.0[0]).powi(2) + (b.0[1] - a.0[1]).powi(2) + (b.0[2] - a.0[2]).powi(2))
                .sqrt();
        let dx = (a.0[0] - x).abs().min((b.0[0] - x).abs());
        let dy = (a.0[1] - y).abs().min((b.0[1] - y).abs());
        if dx > R + 2.0 || dy > R + 2.0 {
            continue;
        }
        let steps = ((len / 0.1).ceil() as usize).max(1);
        for k in 0..=steps {
            let t = k as f64 / steps as f64;
            let z = at(a, b, t);
            if z < best.0 {
                best = (z, w_i, t, 1.0 / steps as f64);
            }
        }
    }
    if !best.0.is_finite() {
        return best.0;
    }
    let (a, b) = (points[best.1], points[best.1 + 1]);
    let (mut lo, mut hi) = ((best.2 - best.3).max(0.0), (best.2 + best.3).min(1.0));
    const G: f64 = 0.618_033_988_749_894_8;
    for _ in 0..30 {
        let (m1, m2) = (hi - G * (hi - lo), lo + G * (hi - lo));
        if at(a, b, m1) <= at(a, b, m2) {
            hi = m2;
        } else {
            lo = m1;
        }
    }
    best.0.min(at(a, b, 0.5 * (lo + hi)))
}

/// Checks one pass's strip at the section x = x0 against the swept solid tool.
fn check_strip_by_sweep(kf: f64, kc: f64, heel_free: bool) {
    let height = |x: f64, y: f64| revolved_height(kf, kc, x, y);
    let surface = revolved(kf, kc, 80.0, 80.0);
    // The test surface itself: on the drive line and across it.
    for (x, y) in [(0.0, 0.0), (0.0, 40.0), (30.0, -20.0)] {
        let p = surface.point(0.5 + x / 160.0, 0.5 + y / 160.0);
        assert!((p.z - height(p.x, p.y)).abs() < 1e-9, "{p:?}");
    }
    let job = Job::new(job_file(FeedDirection::U), Shape::Surface(surface)).unwrap();
    let r = planners::plan(&job, &NoProgress).unwrap();
    // The pass nearest the middle, and its drive point nearest x = 0.
    let pass = r
        .passes
        .iter()
        .min_by(|a, b| {
            let ya = a.points[0].cc[1].abs();
            let yb = b.points[0].cc[1].abs();
            ya.total_cmp(&yb)
        })
        .unwrap();
    let mid = pass
        .points
        .iter()
        .min_by(|a, b| a.cc[0].abs().total_cmp(&b.cc[0].abs()))
        .unwrap();
    assert_eq!(mid.mpec.as_deref(), Some("ok"));
    let x0 = mid.cc[0];
    let yc = mid.cc[1];
    // The same drive curve positioned every 0.15 mm from just behind the
    // section to past the tool's heel, so that moving linearly between
    // positions adds no chord error (at the planned 1.5 mm spacing the chord
    // of a 600 mm feed curvature lifts the tool by about 0.5 um mid-step).
    let planner = mpec::Planner::from_job(&job).unwrap();
    let du = 0.15 / 160.0;
    let dense: Vec<(f64, bool)> = (0..440)
        .map(|i| (mid.uv[0] - 20.0 * du + du * i as f64, true))
        .collect();
    let positions: Vec<([f64; 3], [f64; 3])> = planner
        .pass(mid.uv[1], &dense)
        .unwrap()
        .iter()
        .map(|q| {
            let p = q.to_path_point(planner.tool);
            (p.cl, p.axis)
        })
        .collect();
    let err = |y: f64| {
        let s = height(x0, y);
        envelope(&positions, x0, y, s - 0.5, s + 0.5) - s
    };
    // Middle at +delta, unless the heel (concave feed) cuts it lower, within the band.
    let middle = err(yc);
    if heel_free {
        assert!((middle - DELTA).abs() < 5e-4, "middle {middle}");
    } else {
        assert!(
            (-DELTA - 5e-4..=DELTA + 5e-4).contains(&middle),
            "middle {middle}"
        );
    }
    // Scan the strip: within the band, lowest point touching -delta.
    let mut lowest = f64::INFINITY;
    let mut inside = vec![];
    for i in -120..=120 {
        let y = yc + 0.25 * i as f64;
        let e = err(y);
        lowest = lowest.min(e);
        if e <= DELTA {
            inside.push(y);
        }
    }
    assert!(lowest >= -DELTA - 5e-4, "gouge {lowest}");
    assert!(
        lowest <= -DELTA + 1e-3,
        "dips do not reach -delta: {lowest}"
    );
    // Outermost +delta crossings by bisection from the scan.
    let crossing = |inner: f64, outer: f64| {
        let (mut a, mut b) = (inner, outer);
        for _ in 0..30 {
            let m = 0.5 * (a + b);
            if err(m) <= DELTA {
                a = m;
            } else {
                b = m;
            }
        }
        a
    };
    let lo = inside.first().copied().unwrap();
    let hi = inside.last().copied().unwrap();
    let width = crossing(hi, hi + 0.25) - crossing(lo, lo - 0.25);
    let claimed = mid.strip_width.unwrap();
    assert!(
        (width - claimed).abs() < 0.01 * claimed,
        "swept width {width}, planned {claimed}"
    );
}

#[test]
fn strip_with_convex_feed_curvature_matches_the_swept_tool() {
    check_strip_by_sweep(-1.0 / 500.0, 1.0 / 700.0, true);
}

#[test]
fn strip_with_concave_feed_curvature_matches_the_swept_tool() {
    check_strip_by_sweep(1.0 / 600.0, 1.0 / 900.0, false);
}

/// The paper's die: every drive point positioned with MPEC, passes spaced by
/// the strip widths, the whole surface covered.
#[test]
fn die_saddle_plan() {
    let job = toolpath_planner::samples::job("die_saddle").unwrap();
    let r = planners::plan(&job, &NoProgress).unwrap();
    let n = r.passes.len();
    assert!((8..=12).contains(&n), "{n} passes");
    for p in inside_points(&r) {
        assert_eq!(p.mpec.as_deref(), Some("ok"));
        let w = p.strip_width.unwrap();
        // kc = 1/1198 across the feed everywhere on the drive lines' middle;
        // the strip stays close to the reference width.
        assert!(w > 40.0 && w < 50.0, "{w} at {:?}", p.uv);
    }
    // Adjacent drive lines are no further apart than the facing narrowest half-widths.
    for w in r.passes.windows(2) {
        let gap = w[0]
            .points
            .iter()
            .zip(&w[1].points)
            .filter(|(a, _)| (0.0..=1.0).contains(&a.uv[0]))
            .map(|(a, b)| {
                ((a.cc[0] - b.cc[0]).powi(2)
                    + (a.cc[1] - b.cc[1]).powi(2)
                    + (a.cc[2] - b.cc[2]).powi(2))
                .sqrt()
            })
            .fold(0.0, f64::max);
        let budget = 0.5 * (w[0].min_strip_width.unwrap() + w[1].min_strip_width.unwrap());
        assert!(gap <= budget + 0.05, "gap {gap} > {budget}");
    }
}

fn assert_simulated_within_band(job: &Job, r: &PlanResult) {
    let report = toolpath_planner::simulation::scallop::simulate(
        job.surface().unwrap(),
        job.tool().unwrap(),
        r,
        &toolpath_planner::simulation::scallop::ScallopSettings::default(),
    )
    .unwrap();
    assert!(
        report.max_scallop_mm <= DELTA + 0.002,
        "scallop {}",
        report.max_scallop_mm
    );
    assert!(
        report.max_gouge_mm <= DELTA + 0.002,
        "gouge {}",
        report.max_gouge_mm
    );
    assert_eq!(report.uncovered_area_mm2, 0.0);
}

#[test]
fn die_saddle_simulated_within_the_band() {
    let job = toolpath_planner::samples::job("die_saddle").unwrap();
    let r = planners::plan(&job, &NoProgress).unwrap();
    assert_simulated_within_band(&job, &r);
}

/// The band has a gouge side: the die_saddle plan with every tool lowered
/// by 3 delta along its axis is refused `within_scallop` by the simulator,
/// with a warning saying it cuts below the band; as planned it is within.
#[test]
fn a_plan_cutting_below_the_band_is_not_within_it() {
    let job = toolpath_planner::samples::job("die_saddle").unwrap();
    let planned = planners::plan(&job, &NoProgress).unwrap();
    let (ok, _, _) = pipeline::verify_and_repair(&job, planned.clone()).unwrap();
    assert_eq!(ok.within_scallop, Some(true), "{:?}", ok.warnings);
    let delta = job.tolerance.unwrap();
    let mut lowered = planned;
    for p in lowered.passes.iter_mut().flat_map(|p| p.points.iter_mut()) {
        for k in 0..3 {
            p.cl[k] -= 3.0 * delta * p.axis[k];
        }
    }
    let (low, report, _) = pipeline::verify_and_repair(&job, lowered).unwrap();
    assert!(
        report.max_gouge_mm > 2.0 * delta,
        "gouge {}",
        report.max_gouge_mm
    );
    assert!(report.max_scallop_mm <= delta);
    assert_eq!(low.within_scallop, Some(false));
    assert!(low
        .warnings
        .iter()
        .any(|w| w.starts_with(pipeline::BELOW_BAND)));
}

/// A bicubic surface whose curvatures vary along and across the feed (v):
/// heights from the real surface, strips of varying width.
#[test]
fn varying_curvature_feed_along_v_simulated_within_the_band() {
    let f = |x: f64, y: f64| x * x / (1800.0 + 6.0 * x) + 2.0 * (y / 70.0).cos();
    let s = toolpath_planner::geometry::interpolation::interpolate_height_field(
        f,
        (-90.0, 90.0),
        (0.0, 200.0),
        (3, 12),
        (3, 16),
    )
    .unwrap();
    let job = Job::new(job_file(FeedDirection::V), Shape::Surface(s)).unwrap();
    let r = planners::plan(&job, &NoProgress).unwrap();
    assert!(r.passes.len() >= 4, "{}", r.passes.len());
    let widths: Vec<f64> = r
        .passes
        .iter()
        .map(|p| p.min_strip_width.unwrap())
        .collect();
    assert!(widths.iter().all(|w| *w > 20.0), "{widths:?}");
    assert_simulated_within_band(&job, &r);
}
