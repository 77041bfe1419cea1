//! Measures how long timing a long 5-axis pass takes (release build):
//! 15 000 waypoints 0.1 mm apart on a wavy surface, feed 2000 mm/min,
//! mill-like limits. Prints the TOPP-RA time and the whole plan's
//! (placement and the 1 ms check included).

use std::time::Instant;
use toolpath_motion::{
    parameterise, plan, Follow, Limits, Options, Parameter, Path, Segment, SegmentKind, Tips,
    Tolerance, ToolPose,
};

/// Tip = linear axes; tool axis from A (about x) and C (about z).
fn fk(q: &[f64]) -> ToolPose {
    let (a, c) = (q[3], q[4]);
    ToolPose {
        tip: [q[0], q[1], q[2]],
        axis: [a.sin() * c.sin(), -a.sin() * c.cos(), a.cos()],
    }
}

fn main() {
    let n = 15_000;
    let q: Vec<Vec<f64>> = (0..n)
        .map(|k| {
            let x = 0.1 * k as f64;
            vec![
                x,
                20.0 * (x / 40.0).sin(),
                5.0 * (x / 15.0).cos(),
                0.3 * (x / 60.0).sin(),
                0.5 * (x / 90.0).cos(),
            ]
        })
        .collect();
    let segs = vec![
        Segment {
            kind: SegmentKind::Cut,
            tip_speed_cap: Some(2000.0 / 60.0),
        };
        n - 1
    ];
    let param = Parameter::ScaledJointChord;
    let path = Path {
        positions: &q,
        segments: &segs,
        stops: &[],
        tips: Tips::Kinematics(&fk),
        parameter: &param,
    };
    let limits = Limits::new(
        vec![500.0, 500.0, 300.0, 1.5, 3.0],
        vec![2000.0, 2000.0, 2000.0, 5.0, 10.0],
    );
    let options = Options::default();
    let runs = 5;
    let mut best = f64::INFINITY;
    let mut duration = 0.0;
    for _ in 0..runs {
        let t = Instant::now();
        let timing = parameterise(&path, &limits, &options).unwrap();
        best = best.min(t.elapsed().as_secs_f64());
        duration = timing.duration();
    }
    let follow = Follow {
        kinematics: &fk,
        poses: None,
        tolerance: Tolerance {
            chord: 0.005,
            axis: 1e-3,
        },
    };
    let t = Instant::now();
    let pl = plan(&path, &limits, &options, Some(follow)).unwrap();
    let whole = t.elapsed().as_secs_f64();
    let r = &pl.report.kinds[&SegmentKind::Cut];
    println!(
        "{n} waypoints, 5 joints: TOPP-RA {:.1} ms (best of {runs}), whole plan {:.1} ms; \
         duration {duration:.3} s (feed bound {:.3} s), {} points sent, \
         max ratios v {:.4} a {:.4} tip speed {:.4}, tip deviation {:.2e} mm",
        best * 1e3,
        whole * 1e3,
        0.1 * (n - 1) as f64 / (2000.0 / 60.0),
        pl.trajectory.len(),
        r.max_velocity_ratio,
        r.max_acceleration_ratio,
        r.max_tip_speed_ratio,
        r.max_tip_deviation,
    );
}
