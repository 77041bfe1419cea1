//! Bad input gets an error naming what is wrong and where, never a panic.

use toolpath_motion::{
    check::check, parameterise, plan, plan_timed, Error, Limits, Options, Parameter, Path, Segment,
    SegmentKind, Tips, Trajectory,
};

fn segs(n: usize, cap: Option<f64>) -> Vec<Segment> {
    vec![
        Segment {
            kind: SegmentKind::Cut,
            tip_speed_cap: cap
        };
        n
    ]
}

fn err(q: &[Vec<f64>], s: &[Segment], tips: Tips, param: &Parameter, limits: &Limits) -> String {
    let p = Path {
        positions: q,
        segments: s,
        stops: &[],
        tips,
        parameter: param,
    };
    match parameterise(&p, limits, &Options::default()) {
        Ok(_) => panic!("accepted"),
        Err(e @ Error::Invalid { .. }) => e.to_string(),
        Err(e) => panic!("not an input error: {e}"),
    }
}

/// Waypoints, segments, limits, parameter, and what the error must say.
type Case = (Vec<Vec<f64>>, Vec<Segment>, Limits, Parameter, &'static str);

#[test]
fn every_bad_input_is_named() {
    let ok = Limits::new(vec![1.0, 1.0], vec![1.0, 1.0]);
    let chord = Parameter::ScaledJointChord;
    let q2 = vec![vec![0.0, 0.0], vec![1.0, 1.0]];
    let cases: Vec<Case> = vec![
        (
            vec![vec![0.0, 0.0]],
            segs(0, None),
            ok.clone(),
            chord.clone(),
            "positions: has 1 waypoint(s)",
        ),
        (
            vec![vec![0.0, 0.0], vec![f64::NAN, 1.0]],
            segs(1, None),
            ok.clone(),
            chord.clone(),
            "positions[1][0]: is NaN",
        ),
        (
            vec![vec![0.0, 0.0], vec![1.0]],
            segs(1, None),
            ok.clone(),
            chord.clone(),
            "positions[1]: has 1 values, positions[0] has 2",
        ),
        (
            vec![vec![0.0, 0.0], vec![1.0, 1.0], vec![1.0, 1.0]],
            segs(2, None),
            ok.clone(),
            chord.clone(),
            "positions[2]: repeats the previous waypoint",
        ),
        (
            q2.clone(),
            segs(1, None),
            Limits::new(vec![1.0, 0.0], vec![1.0, 1.0]),
            chord.clone(),
            "limits.velocity[1]: is 0",
        ),
        (
            q2.clone(),
            segs(1, None),
            Limits::new(vec![1.0, 1.0], vec![1.0, f64::INFINITY]),
            chord.clone(),
            "limits.acceleration[1]: is inf",
        ),
        (
            q2.clone(),
            segs(1, None),
            ok.clone().with_jerk(vec![1.0]),
            chord.clone(),
            "limits.jerk: has 1 values for 2 joints",
        ),
        (
            q2.clone(),
            segs(2, None),
            ok.clone(),
            chord.clone(),
            "segments: has 2 entries for 2 waypoints",
        ),
        (
            q2.clone(),
            segs(1, Some(10.0)),
            ok.clone(),
            chord.clone(),
            "segments[0].tip_speed_cap: is set but the path has no tips",
        ),
        (
            q2.clone(),
            segs(1, Some(-1.0)),
            ok.clone(),
            chord.clone(),
            "segments[0].tip_speed_cap: is -1",
        ),
        (
            vec![vec![0.0, 0.0], vec![1.0, 1.0], vec![2.0, 0.0]],
            segs(2, None),
            ok.clone(),
            Parameter::Given(vec![0.0, 1.0, 1.0]),
            "parameter[2]: is 1 after 1: the path parameter must strictly increase",
        ),
        (
            q2.clone(),
            segs(1, None),
            ok.clone(),
            Parameter::TipChord,
            "parameter: TipChord needs tips",
        ),
    ];
    for (q, s, limits, param, want) in cases {
        let e = err(&q, &s, Tips::None, &param, &limits);
        assert!(e.contains(want), "{e:?} lacks {want:?}");
    }
}

#[test]
fn tips_and_stops_that_do_not_fit_the_path_are_named() {
    let ok = Limits::new(vec![1.0, 1.0], vec![1.0, 1.0]);
    let chord = Parameter::ScaledJointChord;
    let q2 = vec![vec![0.0, 0.0], vec![1.0, 1.0]];
    // A tip that stands still while the joints move: TipChord cannot run.
    let tips = [[0.0; 3], [0.0; 3]];
    let e = err(
        &q2,
        &segs(1, None),
        Tips::Points(&tips),
        &Parameter::TipChord,
        &ok,
    );
    assert!(e.contains("parameter[1]: is 0 after 0"), "{e}");
    let e = err(&q2, &segs(1, None), Tips::Points(&tips[..1]), &chord, &ok);
    assert!(e.contains("tips: has 1 points for 2 waypoints"), "{e}");
    let stops = [5usize];
    let p = Path {
        positions: &q2,
        segments: &segs(1, None),
        stops: &stops,
        tips: Tips::None,
        parameter: &chord,
    };
    let e = parameterise(&p, &ok, &Options::default())
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("stops[0]: is 5, past the last waypoint 1"),
        "{e}"
    );
}

#[test]
fn a_bad_trajectory_is_named_and_checking_an_empty_one_is_harmless() {
    let t = Trajectory {
        times: vec![0.0, 0.0],
        positions: vec![vec![0.0], vec![1.0]],
        ..Default::default()
    };
    assert!(t
        .check()
        .unwrap_err()
        .to_string()
        .contains("times[1]: 0 s does not come after 0 s"));
    let t = Trajectory {
        times: vec![0.0, 1.0],
        positions: vec![vec![0.0], vec![1.0]],
        accelerations: vec![vec![0.0], vec![0.0]],
        ..Default::default()
    };
    assert!(t
        .check()
        .unwrap_err()
        .to_string()
        .contains("without velocities"));
    let limits = Limits::new(vec![1.0], vec![1.0]);
    let r = check(&Trajectory::default(), &limits, &[], &[], None, 1e-3);
    assert!(r.kinds.is_empty());
}

#[test]
fn plan_timed_refuses_a_timing_of_another_path_and_repeats_plan_on_its_own() {
    let limits = Limits::new(vec![10.0, 5.0], vec![20.0, 8.0]);
    let q3 = [vec![0.0, 0.0], vec![3.0, 1.0], vec![4.0, -2.0]];
    let (s2, s1) = (segs(2, None), segs(1, None));
    let long = Path {
        positions: &q3,
        segments: &s2,
        stops: &[],
        tips: Tips::None,
        parameter: &Parameter::ScaledJointChord,
    };
    let short = Path {
        positions: &q3[..2],
        segments: &s1,
        ..long
    };
    let o = Options::default();
    let timing = parameterise(&short, &limits, &o).unwrap();
    let e = plan_timed(timing, &long, &limits, &o, None)
        .err()
        .expect("accepted a timing of 2 waypoints for 3")
        .to_string();
    assert!(
        e.contains("timing: times 2 waypoints, the path has 3"),
        "{e}"
    );
    let own = parameterise(&long, &limits, &o).unwrap();
    let a = plan_timed(own, &long, &limits, &o, None).unwrap();
    let b = plan(&long, &limits, &o, None).unwrap();
    assert_eq!(a.trajectory, b.trajectory);
    assert_eq!(a.timing.s, b.timing.s);
}
