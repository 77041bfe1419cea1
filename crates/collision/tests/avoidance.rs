//! The axis search against a closed-form answer: a ball cutter at a cc point
//! on a floor next to a wall, whose holder hits the wall with the axis
//! vertical, tilts away from the wall by the least angle that clears it,
//! keeping the contact point, lead before tilt, within the admissible set.

use nalgebra::Vector3;
use std::f64::consts::{FRAC_PI_2, PI};
use std::sync::Arc;
use toolpath_collision::shapes::Plane;
use toolpath_collision::{
    find_clear_axis, AxisSearch, ClearAxis, Cutter, Face, HolderSegment, QueryOptions,
    SamplingOptions, ToolAssembly, Workpiece,
};

const R: f64 = 3.0;
const WALL: f64 = 20.0;
const CLEARANCE: f64 = 1.0;

fn tool() -> ToolAssembly {
    ToolAssembly::new(
        Cutter::ball(R, 15.0),
        vec![
            HolderSegment::cylinder(20.0, 3.0),
            HolderSegment::cylinder(40.0, 10.0),
        ],
    )
    .unwrap()
}

/// Floor z = 0 (machined) and a wall across `normal` (x or y) at WALL.
fn part(normal: Vector3<f64>) -> Workpiece {
    let side = Vector3::z().cross(&normal);
    let floor: Arc<dyn Face> = Arc::new(Plane {
        origin: Vector3::zeros(),
        e_u: Vector3::x(),
        e_v: Vector3::y(),
        u: [-60.0, WALL],
        v: [-60.0, WALL],
    });
    let wall: Arc<dyn Face> = Arc::new(Plane {
        origin: normal * WALL,
        e_u: side,
        e_v: Vector3::z(),
        u: [-60.0, 60.0],
        v: [0.0, 100.0],
    });
    let mut w = Workpiece::new(vec![floor, wall], SamplingOptions::for_cutter_radius(R)).unwrap();
    w.set_machined(&[0]).unwrap();
    w
}

fn search() -> AxisSearch {
    AxisSearch {
        base_axis: Vector3::z(),
        lead_direction: Vector3::y(),
        max_angle: 30f64.to_radians(),
        step: 1f64.to_radians(),
        directions: 16,
        tolerance: 1e-5,
    }
}

/// The least tilt away from the wall: the holder's bottom rim (radius 10,
/// 35 above the tip) at CLEARANCE from it. With the axis tilted by b away
/// from the wall, the tip at C - R a, C the ball's centre 4 mm from the wall,
/// the rim's furthest point towards the wall is WALL - 4 + R sin b - 35 sin b
/// + 10 cos b (the shank's rims and the cutter stay further).
fn least_tilt() -> f64 {
    let gap =
        |b: f64| WALL - 4.0 + R * b.sin() - 35.0 * b.sin() + 10.0 * b.cos() - (WALL - CLEARANCE);
    let (mut lo, mut hi) = (0.0, FRAC_PI_2);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if gap(mid) > 0.0 {
            lo = mid
        } else {
            hi = mid
        }
    }
    hi
}

fn run(normal: Vector3<f64>, admissible: impl Fn(&Vector3<f64>) -> bool) -> Option<ClearAxis> {
    let w = part(normal);
    let cc = normal * (WALL - 4.0);
    let centre = cc + Vector3::z() * R;
    let opts = QueryOptions::new(0.01, CLEARANCE);
    find_clear_axis(
        &w,
        &tool(),
        &opts,
        &search(),
        |a| Some(centre - a * R),
        admissible,
    )
    .unwrap()
}

#[test]
fn tilts_away_from_a_wall_by_the_least_angle() {
    let want = least_tilt();
    assert!(want > 0.1 && want < 0.3, "the scene needs a tilt: {want}");
    // Wall on +x: away from it is -x = a0 x l, pure tilt (+t).
    let found = run(Vector3::x(), |_| true).expect("a clear axis");
    assert!(
        (found.azimuth - FRAC_PI_2).abs() < 1e-12,
        "azimuth {}",
        found.azimuth
    );
    assert!(
        found.angle >= want - 1e-9 && found.angle <= want + 1e-5 + 1e-9,
        "{} vs {want}",
        found.angle
    );
    assert!((found.tilt - found.angle).abs() < 1e-12 && found.lead.abs() < 1e-12);
    // The contact point is kept: the ball's centre is where it was.
    let centre = Vector3::new(WALL - 4.0, 0.0, R);
    assert!((found.pose.tip + found.pose.axis * R - centre).norm() < 1e-12);
    // Wall on +y (ahead along the lead direction): lean back, pure lead (-l).
    let back = run(Vector3::y(), |_| true).expect("a clear axis");
    assert!(
        (back.azimuth - PI).abs() < 1e-12,
        "azimuth {}",
        back.azimuth
    );
    assert!((back.angle - found.angle).abs() < 1e-9);
    assert!((back.lead + back.angle).abs() < 1e-12);
}

#[test]
fn the_admissible_set_is_respected_and_the_search_is_deterministic() {
    // A rotary limit of 10 deg on leaning towards -x: no clear axis left.
    let limit = 10f64.to_radians().sin();
    assert!(run(Vector3::x(), |a| a.x >= -limit).is_none());
    // Within 20 deg, the same answer twice.
    let limit = 20f64.to_radians().sin();
    let a = run(Vector3::x(), |a| a.x >= -limit);
    let b = run(Vector3::x(), |a| a.x >= -limit);
    assert_eq!(a, b);
    assert!(a.unwrap().pose.axis.x >= -limit);
}

#[test]
fn bad_searches_name_their_field() {
    let w = part(Vector3::x());
    let opts = QueryOptions::new(0.01, 1.0);
    let mut s = search();
    s.directions = 6;
    let e = find_clear_axis(&w, &tool(), &opts, &s, |a| Some(*a), |_| true).unwrap_err();
    assert_eq!(e.field, "search.directions");
    let mut s = search();
    s.lead_direction = Vector3::z();
    let e = find_clear_axis(&w, &tool(), &opts, &s, |a| Some(*a), |_| true).unwrap_err();
    assert_eq!(e.field, "search.lead_direction");
}
