//! What the controller really does with a trajectory, sampled as it runs
//! it (every 1 ms): joint velocity, acceleration and jerk against the limits,
//! the tool tip against the planned cut (distance to the tip polyline, angle
//! of the tool axis) and the tip speed against the segment's cap.

use crate::jtc::{JointState, Trajectory};
use crate::path::{Kinematics, Limits, Segment, SegmentKind, ToolPose};
use std::collections::BTreeMap;

/// How close the tool must follow the planned cut (Cut segments).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerance {
    /// Largest distance of the tip from the planned tip polyline, mm.
    pub chord: f64,
    /// Largest angle of the tool axis from the planned one, rad.
    pub axis: f64,
}

/// The planned path a trajectory must follow.
#[derive(Clone, Copy)]
pub struct Planned<'a> {
    /// Path parameter of each waypoint (locates a sample on the path).
    pub s: &'a [f64],
    pub segments: &'a [Segment],
    /// Planned tool pose at each waypoint: the cut as a polyline of tips,
    /// the axis interpolated along it.
    pub poses: &'a [ToolPose],
    pub kinematics: Kinematics<'a>,
}

/// The worst of one kind of segment over the samples.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct KindReport {
    pub samples: usize,
    /// Time spent in these segments, s.
    pub duration: f64,
    pub max_velocity_ratio: f64,
    pub max_acceleration_ratio: f64,
    /// Ratio to the jerk limit (0 without one).
    pub max_jerk_ratio: f64,
    /// Largest joint jerk relative to nothing: |jerk| / acceleration limit, 1/s.
    pub max_jerk_per_acceleration: f64,
    pub max_tip_deviation: f64,
    pub max_axis_deviation: f64,
    /// Tip speed over the cap (0 where no cap).
    pub max_tip_speed_ratio: f64,
}

/// The sampled check of a trajectory.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Report {
    pub kinds: BTreeMap<SegmentKind, KindReport>,
    /// Per path segment: the time stretch that would bring it within every
    /// limit (max of velocity ratio, sqrt of acceleration ratio, cube root of
    /// jerk ratio, tip speed ratio), 0 where it was not sampled.
    pub segment_stretch: Vec<f64>,
}

impl Report {
    /// The worst value of `f` over all kinds.
    pub fn worst(&self, f: impl Fn(&KindReport) -> f64) -> f64 {
        self.kinds.values().map(f).fold(0.0, f64::max)
    }
}

/// One sample's measures.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Measure {
    pub velocity: f64,
    pub acceleration: f64,
    pub jerk: f64,
    pub jerk_per_acceleration: f64,
    pub deviation: f64,
    pub axis: f64,
    pub tip_speed: f64,
}

impl Measure {
    pub fn stretch(&self) -> f64 {
        self.velocity
            .max(self.acceleration.sqrt())
            .max(self.jerk.cbrt())
            .max(self.tip_speed)
    }

    /// Whether this sample breaks a limit or, on a cut, the tolerance.
    pub fn breaks(&self, kind: SegmentKind, tol: Option<&Tolerance>) -> bool {
        self.stretch() > 1.0
            || (kind == SegmentKind::Cut
                && tol.is_some_and(|t| self.deviation > t.chord || self.axis > t.axis))
    }
}

/// The segment of the path holding parameter `s`, within waypoints
/// `first..=last`.
pub(crate) fn segment_of(s_wp: &[f64], s: f64, first: usize, last: usize) -> usize {
    let k = s_wp[first..=last].partition_point(|&x| x <= s);
    first + k.clamp(1, last - first) - 1
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn point_segment_distance(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let ab = sub(b, a);
    let l2 = dot(ab, ab);
    let t = if l2 > 0.0 {
        (dot(sub(p, a), ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let d = sub(p, [a[0] + t * ab[0], a[1] + t * ab[1], a[2] + t * ab[2]]);
    dot(d, d).sqrt()
}

fn angle(a: [f64; 3], b: [f64; 3]) -> f64 {
    let (na, nb) = (dot(a, a).sqrt(), dot(b, b).sqrt());
    if na == 0.0 || nb == 0.0 {
        return 0.0;
    }
    (dot(a, b) / (na * nb)).clamp(-1.0, 1.0).acos()
}

/// Measures one sample: joint states `js` at path parameter `s` in
/// segment `seg` (within waypoints first..=last).
pub(crate) fn measure(
    js: &[JointState],
    limits: &Limits,
    planned: Option<&Planned>,
    s: f64,
    seg: usize,
    (first, last): (usize, usize),
) -> Measure {
    let mut m = Measure::default();
    for (j, st) in js.iter().enumerate() {
        m.velocity = m.velocity.max(st.v.abs() / limits.velocity[j]);
        m.acceleration = m.acceleration.max(st.a.abs() / limits.acceleration[j]);
        m.jerk_per_acceleration = m
            .jerk_per_acceleration
            .max(st.j.abs() / limits.acceleration[j]);
        if let Some(jl) = &limits.jerk {
            m.jerk = m.jerk.max(st.j.abs() / jl[j]);
        }
    }
    let Some(pl) = planned else { return m };
    let q: Vec<f64> = js.iter().map(|x| x.q).collect();
    let pose = (pl.kinematics)(&q);
    let lo = seg.saturating_sub(1).max(first);
    let hi = (seg + 1).min(last - 1);
    m.deviation = (lo..=hi)
        .map(|k| point_segment_distance(pose.tip, pl.poses[k].tip, pl.poses[k + 1].tip))
        .fold(f64::INFINITY, f64::min);
    let (s0, s1) = (pl.s[seg], pl.s[seg + 1]);
    let w = ((s - s0) / (s1 - s0)).clamp(0.0, 1.0);
    let (a0, a1) = (pl.poses[seg].axis, pl.poses[seg + 1].axis);
    let axis = [
        a0[0] + w * (a1[0] - a0[0]),
        a0[1] + w * (a1[1] - a0[1]),
        a0[2] + w * (a1[2] - a0[2]),
    ];
    m.axis = angle(pose.axis, axis);
    if let Some(cap) = pl.segments[seg].tip_speed_cap {
        // Tip velocity J(q) q' by a central difference along q'.
        let h = 1e-5;
        let qa: Vec<f64> = js.iter().map(|x| x.q - h * x.v).collect();
        let qb: Vec<f64> = js.iter().map(|x| x.q + h * x.v).collect();
        let d = sub((pl.kinematics)(&qb).tip, (pl.kinematics)(&qa).tip);
        m.tip_speed = dot(d, d).sqrt() / (2.0 * h) / cap;
    }
    m
}

fn record(r: &mut KindReport, m: &Measure) {
    r.samples += 1;
    r.max_velocity_ratio = r.max_velocity_ratio.max(m.velocity);
    r.max_acceleration_ratio = r.max_acceleration_ratio.max(m.acceleration);
    r.max_jerk_ratio = r.max_jerk_ratio.max(m.jerk);
    r.max_jerk_per_acceleration = r.max_jerk_per_acceleration.max(m.jerk_per_acceleration);
    r.max_tip_deviation = r.max_tip_deviation.max(m.deviation);
    r.max_axis_deviation = r.max_axis_deviation.max(m.axis);
    r.max_tip_speed_ratio = r.max_tip_speed_ratio.max(m.tip_speed);
}

/// Samples `traj` every `period` s as the controller interpolates it and
/// reports the worst per kind of segment. Without `planned`, `segments`
/// alone gives the kinds (no tip measures). A sample is located on the path
/// by the trajectory's `s`, interpolated linearly in time.
pub fn check(
    traj: &Trajectory,
    limits: &Limits,
    segments: &[Segment],
    s_wp: &[f64],
    planned: Option<&Planned>,
    period: f64,
) -> Report {
    let mut report = Report {
        segment_stretch: vec![0.0; segments.len()],
        ..Default::default()
    };
    let n = traj.len();
    if n < 2 || s_wp.len() != segments.len() + 1 {
        return report;
    }
    let last = s_wp.len() - 1;
    for (t, js) in traj.samples(period) {
        let k = traj.interval(t);
        let (t0, t1) = (traj.times[k], traj.times[k + 1]);
        let w = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
        let s = traj.s[k] + w * (traj.s[k + 1] - traj.s[k]);
        let seg = traj.segment[k].min(last - 1);
        let m = measure(&js, limits, planned, s, seg, (0, last));
        let r = report.kinds.entry(segments[seg].kind).or_default();
        record(r, &m);
        report.segment_stretch[seg] = report.segment_stretch[seg].max(m.stretch());
    }
    for k in 0..n - 1 {
        let seg = traj.segment[k].min(last - 1);
        let r = report.kinds.entry(segments[seg].kind).or_default();
        r.duration += traj.times[k + 1] - traj.times[k];
    }
    report
}
