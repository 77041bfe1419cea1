//! The jerk limit and the chord tolerance, on cases with known answers.

use toolpath_motion::{
    parameterise, plan, Follow, Limits, Options, Parameter, Path, Segment, SegmentKind, Tips,
    Tolerance, ToolPose,
};

fn line(l: f64) -> Vec<Vec<f64>> {
    vec![vec![0.0], vec![l]]
}

#[test]
fn a_jerk_limited_move_takes_the_s_curve_time_and_keeps_every_limit() {
    // Rest to rest over l with v, a, j limits reaching both v and a: the
    // time-optimal S-curve lasts l / v + v / a + a / j.
    let (l, v, a, j) = (200.0, 100.0, 500.0, 5000.0);
    let q = line(l);
    let segs = [Segment {
        kind: SegmentKind::Link,
        tip_speed_cap: None,
    }];
    let param = Parameter::ScaledJointChord;
    let p = Path {
        positions: &q,
        segments: &segs,
        stops: &[],
        tips: Tips::None,
        parameter: &param,
    };
    let limits = Limits::new(vec![v], vec![a]).with_jerk(vec![j]);
    let exact = l / v + v / a + a / j;
    let timing = parameterise(&p, &limits, &Options::default()).unwrap();
    let t = timing.duration();
    assert!(
        t >= exact * (1.0 - 1e-9) && t <= exact * 1.005,
        "{t} vs {exact}"
    );
    let pl = plan(&p, &limits, &Options::default(), None).unwrap();
    let r = &pl.report.kinds[&SegmentKind::Link];
    assert!(r.max_jerk_ratio <= 1.0 && r.max_jerk_ratio > 0.9, "{r:?}");
    assert!(
        r.max_velocity_ratio <= 1.0 && r.max_acceleration_ratio <= 1.0,
        "{r:?}"
    );
    assert!(
        !pl.trajectory.accelerations.is_empty(),
        "jerk limits send accelerations"
    );
    let sent = pl.trajectory.duration();
    assert!(sent <= exact * 1.01, "{sent} vs {exact}");
}

/// A two-link planar arm (links 300 and 200 mm): the tip moves on arcs
/// when the joints move on straight lines.
fn arm(q: &[f64]) -> ToolPose {
    let (a, b) = (q[0], q[0] + q[1]);
    ToolPose {
        tip: [
            300.0 * a.cos() + 200.0 * b.cos(),
            300.0 * a.sin() + 200.0 * b.sin(),
            0.0,
        ],
        axis: [b.cos(), b.sin(), 0.0],
    }
}

#[test]
fn points_are_added_until_the_interpolated_tip_keeps_the_chord_tolerance() {
    // Joint waypoints of a tip line sampled every 20 mm: between them the
    // joint spline (and the controller's cubic) bows off the straight cut.
    let ik = |x: f64, y: f64| {
        let (l1, l2) = (300.0f64, 200.0f64);
        let c2 = ((x * x + y * y - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)).clamp(-1.0, 1.0);
        let q2 = c2.acos();
        let q1 = y.atan2(x) - (l2 * q2.sin()).atan2(l1 + l2 * q2.cos());
        vec![q1, q2]
    };
    let q: Vec<Vec<f64>> = (0..=10)
        .map(|k| ik(350.0, -100.0 + 20.0 * k as f64))
        .collect();
    let segs = vec![
        Segment {
            kind: SegmentKind::Cut,
            tip_speed_cap: Some(50.0),
        };
        10
    ];
    let param = Parameter::ScaledJointChord;
    let p = Path {
        positions: &q,
        segments: &segs,
        stops: &[],
        tips: Tips::Kinematics(&arm),
        parameter: &param,
    };
    let limits = Limits::new(vec![2.0, 2.0], vec![20.0, 20.0]);
    let loose = Tolerance {
        chord: 10.0,
        axis: 1.0,
    };
    let tight = Tolerance {
        chord: 0.01,
        axis: 1.0,
    };
    let run = |tol: Tolerance| {
        let f = Follow {
            kinematics: &arm,
            poses: None,
            tolerance: tol,
        };
        plan(&p, &limits, &Options::default(), Some(f)).unwrap()
    };
    let (a, b) = (run(loose), run(tight));
    let (ra, rb) = (
        &a.report.kinds[&SegmentKind::Cut],
        &b.report.kinds[&SegmentKind::Cut],
    );
    // The spline itself bows by more than the tight tolerance between the
    // sparse waypoints, so the loose plan sends (nearly) only them.
    assert!(ra.max_tip_deviation > 0.01, "{ra:?}");
    assert!(
        b.trajectory.len() > a.trajectory.len(),
        "{} vs {}",
        b.trajectory.len(),
        a.trajectory.len()
    );
    assert!(rb.max_tip_speed_ratio <= 1.0 && ra.max_tip_speed_ratio <= 1.0);
    // Points come from the same plan: the tight one deviates no more than
    // the spline does at its own samples.
    assert!(
        rb.max_tip_deviation <= ra.max_tip_deviation * 1.0001,
        "{rb:?} vs {ra:?}"
    );
}
