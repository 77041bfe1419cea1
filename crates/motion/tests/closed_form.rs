//! Cases with an exact optimum worked out by hand.

use toolpath_motion::{
    parameterise, plan, Follow, Limits, Options, Parameter, Path, Segment, SegmentKind, Tips,
    Tolerance, ToolPose,
};

fn seg(kind: SegmentKind, cap: Option<f64>, n: usize) -> Vec<Segment> {
    vec![
        Segment {
            kind,
            tip_speed_cap: cap
        };
        n
    ]
}

fn path<'a>(
    q: &'a [Vec<f64>],
    segs: &'a [Segment],
    tips: Tips<'a>,
    param: &'a Parameter,
) -> Path<'a> {
    Path {
        positions: q,
        segments: segs,
        stops: &[],
        tips,
        parameter: param,
    }
}

/// The shortest time to move `l` from rest to rest at speed `v` and
/// acceleration `a`: a trapezoid, or a triangle when `l` is too short to
/// reach `v`.
fn bang_bang(l: f64, v: f64, a: f64) -> f64 {
    if l >= v * v / a {
        l / v + v / a
    } else {
        2.0 * (l / a).sqrt()
    }
}

#[test]
fn a_single_joint_moves_in_the_bang_bang_time() {
    let param = Parameter::ScaledJointChord;
    for (l, v, a) in [
        (100.0, 50.0, 200.0),   // trapezoid
        (10.0, 50.0, 200.0),    // triangle (v^2 / a = 12.5 > 10)
        (2.0, 3.0, 1.5),        // rotary-like, triangle
        (300.0, 500.0, 2000.0), // a mill rapid, trapezoid
    ] {
        let q = vec![vec![0.0], vec![l]];
        let segs = seg(SegmentKind::Link, None, 1);
        let p = path(&q, &segs, Tips::None, &param);
        let limits = Limits::new(vec![v], vec![a]);
        let exact = bang_bang(l, v, a);
        let timing = parameterise(&p, &limits, &Options::default()).unwrap();
        let t = timing.duration();
        // Never faster than the optimum, and within the grid's and the
        // margin's cost of it.
        assert!(t >= exact * (1.0 - 1e-9), "{l} {v} {a}: {t} < {exact}");
        assert!(t <= exact * 1.005, "{l} {v} {a}: {t} vs {exact}");
        let plan = plan(&p, &limits, &Options::default(), None).unwrap();
        let r = &plan.report.kinds[&SegmentKind::Link];
        assert!(
            r.max_velocity_ratio <= 1.0 && r.max_acceleration_ratio <= 1.0,
            "{r:?}"
        );
        // The trajectory sent is that long too.
        let sent = plan.trajectory.duration();
        assert!(
            sent >= exact * (1.0 - 1e-9) && sent <= exact * 1.01,
            "{sent} vs {exact}"
        );
        // A trapezoid reaches its top speed, held between the ramps.
        if l >= v * v / a {
            assert!(r.max_velocity_ratio > 0.995, "{r:?}");
        }
    }
}

/// Tip = the first three joints (a gantry's linear axes).
fn gantry(q: &[f64]) -> ToolPose {
    ToolPose {
        tip: [q[0], q[1], q[2]],
        axis: [0.0, 0.0, 1.0],
    }
}

#[test]
fn a_feed_capped_line_takes_length_over_feed_plus_its_ramps() {
    // 120 mm along (3, 4, 12) / 13 through 41 unevenly spaced waypoints;
    // feed 40 mm/s well below the joints' speeds.
    let d = [3.0 / 13.0, 4.0 / 13.0, 12.0 / 13.0];
    let len = 120.0;
    let q: Vec<Vec<f64>> = (0..=40)
        .map(|k| {
            let w = k as f64 / 40.0;
            let s = len * (w + 0.3 * w * (1.0 - w) * (7.0 * w).sin());
            vec![d[0] * s + 10.0, d[1] * s - 5.0, d[2] * s, 0.1]
        })
        .collect();
    let feed = 40.0;
    let acc = [500.0, 800.0, 300.0, 10.0];
    let limits = Limits::new(vec![500.0, 500.0, 300.0, 3.0], acc.to_vec());
    // Along the line the tip's acceleration is capped by the axis that
    // reaches its limit first: a_tip = min_j a_j / d_j.
    let a_tip = (0..3).map(|j| acc[j] / d[j]).fold(f64::INFINITY, f64::min);
    let exact = len / feed + feed / a_tip;
    let segs = seg(SegmentKind::Cut, Some(feed), 40);
    let param = Parameter::ScaledJointChord;
    let tips: Vec<[f64; 3]> = q.iter().map(|r| gantry(r).tip).collect();
    for source in [Tips::Kinematics(&gantry), Tips::Points(&tips)] {
        let p = path(&q, &segs, source, &param);
        let t = parameterise(&p, &limits, &Options::default())
            .unwrap()
            .duration();
        assert!(
            t >= exact * (1.0 - 1e-9) && t <= exact * 1.004,
            "{t} vs {exact}"
        );
    }
    let p = path(&q, &segs, Tips::Kinematics(&gantry), &param);
    let follow = Follow {
        kinematics: &gantry,
        poses: None,
        tolerance: Tolerance {
            chord: 0.005,
            axis: 1e-3,
        },
    };
    let pl = plan(&p, &limits, &Options::default(), Some(follow)).unwrap();
    let r = &pl.report.kinds[&SegmentKind::Cut];
    assert!(
        r.max_tip_speed_ratio <= 1.0 && r.max_tip_speed_ratio > 0.995,
        "{r:?}"
    );
    assert!(r.max_tip_deviation < 1e-6, "{r:?}");
    assert!(r.max_acceleration_ratio <= 1.0, "{r:?}");
    assert!((pl.trajectory.duration() - exact).abs() < 0.005 * exact);
}

#[test]
fn a_circle_is_taken_at_the_speed_its_centripetal_limit_allows() {
    // Three turns of radius r in x, y with acceleration limit a on both
    // axes. Where the circle crosses the x axis, x'' = -v^2 / r whatever
    // the tangential acceleration, so the fastest speed there is sqrt(a r).
    let (r, a) = (20.0, 500.0);
    let turns = 3.0;
    let n = 3 * 180;
    let q: Vec<Vec<f64>> = (0..=n)
        .map(|k| {
            let th = turns * std::f64::consts::TAU * k as f64 / n as f64;
            vec![r * th.cos(), r * th.sin()]
        })
        .collect();
    let segs = seg(SegmentKind::Cut, None, n);
    let param = Parameter::ScaledJointChord;
    let p = path(&q, &segs, Tips::None, &param);
    let limits = Limits::new(vec![1e4, 1e4], vec![a, a]);
    let timing = parameterise(&p, &limits, &Options::default()).unwrap();
    let want = (a * r).sqrt();
    // The middle turn crosses the x axis (theta = 2 pi) at waypoint 180
    // and (theta = 3 pi) at 270; tangential speed = |q'| s_dot.
    let grid = timing.grid();
    let speed_at = |k: usize| {
        let s = timing.s[k];
        let g = grid
            .iter()
            .min_by(|x, y| (x.s - s).abs().total_cmp(&(y.s - s).abs()))
            .unwrap();
        let ds = timing.s[k + 1] - timing.s[k - 1];
        let dq = ((q[k + 1][0] - q[k - 1][0]).powi(2) + (q[k + 1][1] - q[k - 1][1]).powi(2)).sqrt();
        g.s_dot * dq / ds
    };
    for k in [180, 270, 360] {
        let v = speed_at(k);
        assert!(
            v <= want * 1.001 && v >= want * 0.995,
            "waypoint {k}: {v} vs {want}"
        );
    }
    let pl = plan(&p, &limits, &Options::default(), None).unwrap();
    let rep = &pl.report.kinds[&SegmentKind::Cut];
    assert!(
        rep.max_acceleration_ratio <= 1.0 && rep.max_acceleration_ratio > 0.99,
        "{rep:?}"
    );
}
