//! Swept checks of straight motions against closed-form first contacts: a
//! translation into a wall, through a thin fin that both end poses clear,
//! and a turn of the axis about the tip into a wall.

mod common;

use common::tools;
use nalgebra::Vector3;
use std::f64::consts::FRAC_PI_2;
use std::sync::Arc;
use toolpath_collision::shapes::{box_faces, Plane};
use toolpath_collision::{
    check_motion, Face, Motion, Pose, QueryOptions, SamplingOptions, SweepOptions, SweepOutcome,
    ToolPart, Workpiece,
};

/// The plane x = x0 over y in [-50, 50], z in `z`.
fn wall(x0: f64, z: [f64; 2]) -> Arc<dyn Face> {
    Arc::new(Plane {
        origin: Vector3::new(x0, 0.0, 0.0),
        e_u: Vector3::y(),
        e_v: Vector3::z(),
        u: [-50.0, 50.0],
        v: z,
    })
}

fn part(faces: Vec<Arc<dyn Face>>) -> Workpiece {
    Workpiece::new(faces, SamplingOptions::for_cutter_radius(5.0)).unwrap()
}

fn opts(tolerance: f64) -> SweepOptions {
    SweepOptions {
        query: QueryOptions {
            cutter_limit: 0.0,
            holder_limit: 0.0,
            cutter_all_faces: true,
            search_margin: 0.0,
        },
        tolerance,
        max_poses: 100_000,
    }
}

fn pose(tip: [f64; 3], axis: [f64; 3]) -> Pose {
    Pose::new(Vector3::from(tip), Vector3::from(axis)).unwrap()
}

/// The motion's first collision: (s, part, poses checked).
fn first(w: &Workpiece, tool_index: usize, m: &Motion, tol: f64) -> (f64, ToolPart, usize) {
    let tool = &tools()[tool_index];
    match check_motion(w, tool, m, &opts(tol)).unwrap() {
        SweepOutcome::Collision {
            s, report, poses, ..
        } => {
            assert!(report.collides());
            (s, report.worst().unwrap().part, poses)
        }
        other => panic!("no collision found: {other:?}"),
    }
}

#[test]
fn translation_into_a_wall_stops_at_the_widest_part() {
    let w = part(vec![wall(50.0, [-10.0, 90.0])]);
    let m = Motion::new(
        pose([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
        pose([100.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
    )
    .unwrap();
    let tol = 0.01;
    // The holder cone's top rim, radius 12, meets the wall first.
    let want = (50.0 - 12.0) / 100.0;
    let (s, part, poses) = first(&w, 0, &m, tol);
    assert_eq!(part, ToolPart::Holder(1));
    assert!(
        s >= want - 1e-9 && s <= want + tol / 100.0 + 1e-9,
        "s {s} vs {want}"
    );
    assert!(poses < 80, "{poses} poses");
}

#[test]
fn a_thin_fin_both_ends_clear_is_found() {
    let w = part(vec![wall(0.0, [-5.0, 5.0])]);
    let m = Motion::new(
        pose([-30.0, 0.0, -2.0], [0.0, 0.0, 1.0]),
        pose([30.0, 0.0, -2.0], [0.0, 0.0, 1.0]),
    )
    .unwrap();
    let tol = 0.005;
    // Ball R 4: its cylinder reaches x = tip + 4 at the fin's heights.
    let want = (30.0 - 4.0) / 60.0;
    let (s, part, _) = first(&w, 1, &m, tol);
    assert_eq!(part, ToolPart::Cutter);
    assert!(
        s >= want - 1e-9 && s <= want + tol / 60.0 + 1e-9,
        "s {s} vs {want}"
    );
}

#[test]
fn turning_about_the_tip_into_a_wall() {
    let w = part(vec![wall(40.0, [-100.0, 100.0])]);
    let m = Motion::new(
        pose([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
        pose([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
    )
    .unwrap();
    let tool = &tools()[0];
    // Every part is convex, so its furthest point along x is a profile
    // corner (r, z): x = z sin b + r cos b. The corners from the sizes:
    let corners = [(5.0, 20.0), (3.0, 45.0), (8.0, 45.0), (12.0, 75.0)];
    let reach = |b: f64| {
        corners
            .iter()
            .map(|&(r, z)| z * b.sin() + r * b.cos())
            .fold(f64::MIN, f64::max)
    };
    let (mut lo, mut hi) = (0.0, FRAC_PI_2);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if reach(mid) < 40.0 {
            lo = mid
        } else {
            hi = mid
        }
    }
    let want = lo / FRAC_PI_2;
    let tol = 0.01;
    let d = m.rate_bound(tool, &opts(tol).query);
    let (s, part, _) = first(&w, 0, &m, tol);
    assert_eq!(part, ToolPart::Holder(1));
    assert!(
        s >= want - 1e-9 && s <= want + tol / d + 1e-9,
        "s {s} vs {want}"
    );
}

#[test]
fn a_rapid_above_the_part_is_clear_in_few_poses() {
    let w = part(box_faces(
        Vector3::new(-50.0, -50.0, -20.0),
        Vector3::new(50.0, 50.0, 0.0),
    ));
    let m = Motion::new(
        pose([-40.0, -40.0, 10.0], [0.0, 0.0, 1.0]),
        pose([40.0, 30.0, 12.0], [0.3, 0.0, 1.0]),
    )
    .unwrap();
    let tool = &tools()[2];
    match check_motion(&w, tool, &m, &opts(0.01)).unwrap() {
        SweepOutcome::Clear { poses } => assert!(poses < 200, "{poses} poses"),
        other => panic!("{other:?}"),
    }
    // From 1 mm above the top to 1 mm below it, axis vertical: the flat
    // bottom of the torus meets the top halfway.
    let low = Motion::new(
        pose([-40.0, -40.0, 1.0], [0.0, 0.0, 1.0]),
        pose([40.0, 30.0, -1.0], [0.0, 0.0, 1.0]),
    )
    .unwrap();
    match check_motion(&w, tool, &low, &opts(0.01)).unwrap() {
        SweepOutcome::Collision { s, .. } => assert!(
            (s - 0.5).abs() <= 0.01 / low.rate_bound(tool, &opts(0.01).query) + 1e-9,
            "s {s}"
        ),
        other => panic!("{other:?}"),
    }
    let e = check_motion(
        &w,
        tool,
        &low,
        &SweepOptions {
            max_poses: 3,
            ..opts(1e-6)
        },
    )
    .unwrap_err();
    assert_eq!(e.field, "options.max_poses");
}
