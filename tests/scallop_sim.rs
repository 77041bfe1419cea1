//! Scallop simulator against exact answers: ball and flat-end scallops on a
//! plane, a ball in a concave cylinder, a torus flat on a plane, a known
//! gouge, a missing pass, and bad input.

use toolpath_planner::formats::{Pass, PathPoint, PlanResult};
use toolpath_planner::geometry::NurbsSurface;
use toolpath_planner::simulation::scallop::{simulate, ScallopSettings, Simulator};
use toolpath_planner::tools::Tool;
use toolpath_planner::Error;

/// Plane z = 0 over [0, a] x [0, b], u along x, v along y (normal +z).
fn plane(a: f64, b: f64) -> NurbsSurface {
    let k = vec![0.0, 0.0, 1.0, 1.0];
    let cps = vec![
        vec![[0.0, 0.0, 0.0], [0.0, b, 0.0]],
        vec![[a, 0.0, 0.0], [a, b, 0.0]],
    ];
    NurbsSurface::new(1, 1, k.clone(), k, &cps, None).unwrap()
}

fn result(passes: Vec<Vec<([f64; 3], [f64; 3])>>) -> PlanResult {
    let mut r = PlanResult::new("test", "iso_parametric");
    r.passes = passes
        .into_iter()
        .map(|pts| Pass {
            region: 0,
            points: pts
                .into_iter()
                .map(|(cl, axis)| PathPoint {
                    cl,
                    cc: cl,
                    axis,
                    ..Default::default()
                })
                .collect(),
            min_strip_width: None,
        })
        .collect();
    r
}

/// A straight pass from `a` to `b` with points every `step` mm, fixed axis.
fn line(a: [f64; 3], b: [f64; 3], step: f64, axis: [f64; 3]) -> Vec<([f64; 3], [f64; 3])> {
    let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt();
    let n = (len / step).ceil().max(1.0) as usize;
    (0..=n)
        .map(|i| {
            let f = i as f64 / n as f64;
            (
                [
                    a[0] + f * (b[0] - a[0]),
                    a[1] + f * (b[1] - a[1]),
                    a[2] + f * (b[2] - a[2]),
                ],
                axis,
            )
        })
        .collect()
}

const UP: [f64; 3] = [0.0, 0.0, 1.0];

#[test]
fn ball_parallel_passes_on_a_plane_give_the_exact_scallop() {
    let r = 2.5;
    let s = 2.0;
    let surface = plane(30.0, 20.0);
    let ys: Vec<f64> = (0..13).map(|k| -2.0 + s * k as f64).collect();
    let passes = ys
        .iter()
        .map(|&y| line([-3.0, y, 0.0], [33.0, y, 0.0], 1.0, UP))
        .collect();
    let tool = Tool::Ball {
        radius: r,
        length: None,
    };
    let rep = simulate(
        &surface,
        &tool,
        &result(passes),
        &ScallopSettings::default(),
    )
    .unwrap();
    let exact = r - (r * r - s * s / 4.0).sqrt();
    assert!(
        (rep.max_scallop_mm - exact).abs() < 1e-6,
        "{} vs {exact}",
        rep.max_scallop_mm
    );
    assert!(rep.max_gouge_mm < 1e-9);
    assert_eq!(rep.uncovered_area_mm2, 0.0);
    assert!((rep.machined_area_mm2 - 600.0).abs() < 1e-6);
    // The refined peaks sit on the cusps, midway between two passes (odd y),
    // with the exact scallop, and the highest is the reported maximum.
    assert!(!rep.peaks.is_empty());
    assert_eq!(rep.peaks[0].residual, rep.max_scallop_mm);
    for peak in &rep.peaks {
        let y = peak.xyz[1];
        assert!(
            ((y + 1.0).rem_euclid(s) - 0.0).abs() < 1e-3
                || ((y + 1.0).rem_euclid(s) - s).abs() < 1e-3,
            "peak off the cusp: {peak:?}"
        );
        assert!((peak.residual - exact).abs() < 1e-6, "{peak:?} vs {exact}");
        assert!((peak.xyz[0] - 30.0 * peak.uv[0]).abs() < 1e-9, "{peak:?}");
    }
    // Every sample: the ball's lower hemisphere of the nearest pass.
    for (xyz, res) in rep.map.xyz.iter().zip(&rep.map.residual) {
        let d = ys
            .iter()
            .map(|y| (xyz[1] - y).abs())
            .fold(f64::INFINITY, f64::min);
        let want = r - (r * r - d * d).sqrt();
        let got = res.expect("covered");
        assert!((got - want).abs() < 1e-7, "at {xyz:?}: {got} vs {want}");
    }
}

#[test]
fn sparse_diagonal_ball_passes_are_swept_between_points() {
    // Points 6 mm apart (more than the tool diameter): only the sweep covers between them.
    let r = 2.5;
    let surface = plane(20.0, 20.0);
    let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    let step = 3.0;
    let offsets: Vec<f64> = (-12..=12).map(|k| k as f64 * step).collect();
    let passes = offsets
        .iter()
        .map(|&o| {
            // Direction (c, s), offset o along (-s, c), through the plane's centre.
            let base = [10.0 - s * o, 10.0 + c * o];
            line(
                [base[0] - 30.0 * c, base[1] - 30.0 * s, 0.0],
                [base[0] + 30.0 * c, base[1] + 30.0 * s, 0.0],
                6.0,
                UP,
            )
        })
        .collect();
    let tool = Tool::Ball {
        radius: r,
        length: None,
    };
    let rep = simulate(
        &surface,
        &tool,
        &result(passes),
        &ScallopSettings::with_resolution(Some(0.4)),
    )
    .unwrap();
    for (xyz, res) in rep.map.xyz.iter().zip(&rep.map.residual) {
        let along = -s * (xyz[0] - 10.0) + c * (xyz[1] - 10.0);
        let d = offsets
            .iter()
            .map(|o| (along - o).abs())
            .fold(f64::INFINITY, f64::min);
        let want = r - (r * r - d * d).sqrt();
        let got = res.expect("covered");
        assert!((got - want).abs() < 1e-6, "at {xyz:?}: {got} vs {want}");
    }
    let exact = r - (r * r - step * step / 4.0).sqrt();
    assert!(
        (rep.max_scallop_mm - exact).abs() < 1e-5,
        "{} vs {exact}",
        rep.max_scallop_mm
    );
}

#[test]
fn flat_end_with_lead_angle_covers_the_exact_width() {
    // docs/methods.md, "Reference widths": R = 2.5, lambda = 5 deg, h = 0.05
    // -> W = 3.18704.
    let (r, lambda, h) = (2.5f64, 5f64.to_radians(), 0.05);
    let surface = plane(10.0, 10.0);
    let axis = [lambda.sin(), 0.0, lambda.cos()];
    let tip_z = r * lambda.sin();
    // Single pass along x through y = 5, points 2 mm apart.
    let pass = line([-4.0, 5.0, tip_z], [14.0, 5.0, tip_z], 2.0, axis);
    let tool = Tool::FlatEnd {
        radius: r,
        length: None,
    };
    let res = result(vec![pass]);
    let sim = Simulator::new(&surface, &tool, &res).unwrap();
    let at = |y: f64| sim.residual_at(0.37, y / 10.0);
    // Height profile across the pass: the swept rim of the tilted bottom.
    for k in 0..=24 {
        let dy = -2.4 + 0.2 * k as f64;
        let want = r * lambda.sin() * (1.0 - (1.0 - dy * dy / (r * r)).sqrt());
        let got = at(5.0 + dy).expect("covered");
        assert!((got - want).abs() < 2e-5, "dy {dy}: {got} vs {want}");
    }
    assert!(at(5.0 + r + 0.05).is_none());
    // Width at height h by bisection on the simulated residual.
    let (mut lo, mut hi) = (0.0, r);
    for _ in 0..50 {
        let mid = 0.5 * (lo + hi);
        if at(5.0 + mid).is_some_and(|x| x <= h) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let w = 2.0 * lo;
    assert!((w - 3.18704).abs() < 2e-4, "W = {w}");
    let rep = sim
        .run(&ScallopSettings::with_resolution(Some(0.25)))
        .unwrap();
    // Covered strip: width 2R over the 10 mm length.
    assert!(
        (rep.machined_area_mm2 - 2.0 * r * 10.0).abs() < 0.25 * 10.0 * 2.0 + 1e-9,
        "{}",
        rep.machined_area_mm2
    );
    assert!(rep.max_gouge_mm < 1e-9);
}

/// Trough: cylinder of radius rho, axis along x at height rho, angles -60..60 deg
/// (exact rational quadratic arc), normal towards the axis.
fn trough(rho: f64, len: f64) -> NurbsSurface {
    let s60 = 60f64.to_radians().sin();
    let row = |x: f64| {
        vec![
            [x, -rho * s60, rho * 0.5],
            [x, 0.0, -rho],
            [x, rho * s60, rho * 0.5],
        ]
    };
    let cps = vec![row(0.0), row(len)];
    let w = vec![vec![1.0, 0.5, 1.0]; 2];
    NurbsSurface::new(
        1,
        2,
        vec![0.0, 0.0, 1.0, 1.0],
        vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
        &cps,
        Some(&w),
    )
    .unwrap()
}

#[test]
fn ball_in_a_concave_cylinder_matches_the_circle_geometry() {
    let (rho, r, dphi) = (20.0f64, 2.5f64, 0.15f64);
    let surface = trough(rho, 10.0);
    let n0 = surface.normal(0.5, 0.5).unwrap();
    assert!(n0.z > 0.99, "normal must point to the axis: {n0:?}");
    let phis: Vec<f64> = (-8..=8).map(|k| k as f64 * dphi).collect();
    let passes = phis
        .iter()
        .map(|&phi| {
            // Ball centre at distance rho - R from the axis; tool axis along the surface normal.
            let axis = [0.0, -phi.sin(), phi.cos()];
            let centre = [(rho - r) * phi.sin(), rho - (rho - r) * phi.cos()];
            let tip = [centre[0] - r * axis[1], centre[1] - r * axis[2]];
            line([-3.0, tip[0], tip[1]], [13.0, tip[0], tip[1]], 2.0, axis)
        })
        .collect();
    let tool = Tool::Ball {
        radius: r,
        length: None,
    };
    let rep = simulate(
        &surface,
        &tool,
        &result(passes),
        &ScallopSettings::with_resolution(Some(0.3)),
    )
    .unwrap();
    // Along the radial line at angle psi, the ball at angle phi is first met at distance q from the axis.
    let exact = |psi: f64| {
        phis.iter()
            .map(|phi| {
                let a = psi - phi;
                let d = rho - r;
                let disc = r * r - d * d * a.sin().powi(2);
                if disc < 0.0 {
                    f64::INFINITY
                } else {
                    rho - (d * a.cos() + disc.sqrt())
                }
            })
            .fold(f64::INFINITY, f64::min)
    };
    for (xyz, res) in rep.map.xyz.iter().zip(&rep.map.residual) {
        let psi = xyz[1].atan2(rho - xyz[2]);
        let got = res.expect("covered");
        assert!(
            (got - exact(psi)).abs() < 1e-6,
            "psi {psi}: {got} vs {}",
            exact(psi)
        );
    }
    let cusp = exact(dphi / 2.0);
    assert!(
        (rep.max_scallop_mm - cusp).abs() < 1e-5,
        "{} vs {cusp}",
        rep.max_scallop_mm
    );
    assert!(rep.max_gouge_mm < 1e-9);
    // Surface area: 120 deg of a radius-20 cylinder, 10 long.
    let area = rho * 120f64.to_radians() * 10.0;
    assert!(
        (rep.machined_area_mm2 - area).abs() < 1e-3 * area,
        "{} vs {area}",
        rep.machined_area_mm2
    );
}

#[test]
fn torus_flat_on_a_plane_leaves_nothing_under_the_bottom_and_the_corner_profile_outside() {
    let (r, rc) = (3.0f64, 1.0f64);
    let surface = plane(10.0, 10.0);
    let tool = Tool::Torus {
        radius: r,
        corner_radius: rc,
        length: None,
    };
    let pass = line([-4.0, 5.0, 0.0], [14.0, 5.0, 0.0], 1.5, UP);
    let rep = simulate(
        &surface,
        &tool,
        &result(vec![pass]),
        &ScallopSettings::with_resolution(Some(0.1)),
    )
    .unwrap();
    let mut uncovered = 0.0;
    for (xyz, res) in rep.map.xyz.iter().zip(&rep.map.residual) {
        let d = (xyz[1] - 5.0).abs();
        match res {
            Some(got) => {
                let want = if d <= r - rc {
                    0.0
                } else {
                    rc - (rc * rc - (d - r + rc).powi(2)).sqrt()
                };
                assert!((got - want).abs() < 1e-7, "d {d}: {got} vs {want}");
            }
            None => {
                assert!(d > r - 1e-9, "uncovered at d = {d}");
                uncovered += 0.01;
            }
        }
    }
    assert!((rep.uncovered_area_mm2 - uncovered).abs() < 1e-6);
    assert!(
        (rep.uncovered_area_mm2 - (100.0 - 60.0)).abs() < 1e-6,
        "{}",
        rep.uncovered_area_mm2
    );
    assert!(rep.max_gouge_mm < 1e-9);
    assert!(
        (rep.max_scallop_mm - rc).abs() < 1e-3,
        "{}",
        rep.max_scallop_mm
    );
}

#[test]
fn a_tool_below_the_surface_is_reported_as_that_gouge() {
    let surface = plane(20.0, 20.0);
    let depth = 0.3;
    let ys: Vec<f64> = (0..9).map(|k| -2.0 + 3.0 * k as f64).collect();
    let passes: Vec<_> = ys
        .iter()
        .map(|&y| line([-3.0, y, -depth], [23.0, y, -depth], 1.0, UP))
        .collect();
    let ball = Tool::Ball {
        radius: 2.5,
        length: None,
    };
    let rep = simulate(
        &surface,
        &ball,
        &result(passes.clone()),
        &ScallopSettings::default(),
    )
    .unwrap();
    assert!(
        (rep.max_gouge_mm - depth).abs() < 1e-6,
        "{}",
        rep.max_gouge_mm
    );
    // A single flat-end pass 0.12 deep in the middle, the rest on the surface.
    let mut passes: Vec<_> = ys
        .iter()
        .map(|&y| line([-3.0, y, 0.0], [23.0, y, 0.0], 1.0, UP))
        .collect();
    passes[4] = line([-3.0, ys[4], -0.12], [23.0, ys[4], -0.12], 1.0, UP);
    let flat = Tool::FlatEnd {
        radius: 2.5,
        length: None,
    };
    let rep = simulate(
        &surface,
        &flat,
        &result(passes),
        &ScallopSettings::default(),
    )
    .unwrap();
    assert!(
        (rep.max_gouge_mm - 0.12).abs() < 1e-9,
        "{}",
        rep.max_gouge_mm
    );
    let gouged = rep
        .map
        .residual
        .iter()
        .filter(|r| r.is_some_and(|r| r < -0.1))
        .count();
    assert!(gouged > 0);
}

#[test]
fn a_missing_pass_leaves_the_uncovered_band() {
    // Passes 4 mm apart (R = 2.5) with the one at y = 10 left out: y in (8.5, 11.5)
    // is out of reach over the whole 30 mm length: 90 mm^2.
    let surface = plane(30.0, 20.0);
    let passes = [-2.0, 2.0, 6.0, 14.0, 18.0, 22.0]
        .iter()
        .map(|&y| line([-3.0, y, 0.0], [33.0, y, 0.0], 1.0, UP))
        .collect();
    let tool = Tool::Ball {
        radius: 2.5,
        length: None,
    };
    let rep = simulate(
        &surface,
        &tool,
        &result(passes),
        &ScallopSettings::with_resolution(Some(0.25)),
    )
    .unwrap();
    assert!(
        (rep.uncovered_area_mm2 - 90.0).abs() < 1e-6,
        "{}",
        rep.uncovered_area_mm2
    );
    assert!(
        (rep.machined_area_mm2 - 510.0).abs() < 1e-6,
        "{}",
        rep.machined_area_mm2
    );
    // The covered samples next to the gap reach almost the cap.
    assert!(
        rep.max_scallop_mm > 2.0 && rep.max_scallop_mm <= 2.5,
        "{}",
        rep.max_scallop_mm
    );
    // No passes at all: everything uncovered, no panic.
    let rep = simulate(
        &surface,
        &tool,
        &result(vec![]),
        &ScallopSettings::default(),
    )
    .unwrap();
    assert!((rep.uncovered_area_mm2 - 600.0).abs() < 1e-6);
    assert_eq!(rep.max_scallop_mm, 0.0);
}

#[test]
fn bad_input_names_the_field() {
    let surface = plane(10.0, 10.0);
    let mut pass = line([0.0, 5.0, 0.0], [10.0, 5.0, 0.0], 1.0, UP);
    pass[3].1 = [0.0, 0.0, 0.0];
    let tool = Tool::Ball {
        radius: 2.5,
        length: None,
    };
    match simulate(
        &surface,
        &tool,
        &result(vec![vec![], pass]),
        &ScallopSettings::default(),
    ) {
        Err(Error::Invalid { field, .. }) => assert_eq!(field, "passes[1].points[3].axis"),
        other => panic!("{other:?}"),
    }
    let mut pass = line([0.0, 5.0, 0.0], [10.0, 5.0, 0.0], 1.0, UP);
    pass[0].0[2] = f64::NAN;
    assert!(matches!(
        simulate(&surface, &tool, &result(vec![pass]), &ScallopSettings::default()),
        Err(Error::Invalid { field, .. }) if field == "passes[0].points[0].cl"
    ));
    let belt = Tool::Belt {
        width: 10.0,
        wheel_radius: 40.0,
    };
    assert!(simulate(
        &surface,
        &belt,
        &result(vec![]),
        &ScallopSettings::default()
    )
    .is_err());
    let fine = ScallopSettings::with_resolution(Some(1e-4));
    assert!(matches!(
        simulate(&surface, &tool, &result(vec![]), &fine),
        Err(Error::Invalid { field, .. }) if field == "simulation_resolution"
    ));
}
