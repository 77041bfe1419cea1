//! The geometric joint path to be timed: waypoints, what each segment is,
//! where the machine stops, where the tool tip is; checked and split into
//! pieces (one C2 spline each) at the stops.

use crate::error::{check_finite, check_positive, Error, Result};
use crate::spline::Spline;

/// Per-joint limits (mm or rad per s, per s^2, per s^3).
#[derive(Clone, Debug, PartialEq)]
pub struct Limits {
    pub velocity: Vec<f64>,
    pub acceleration: Vec<f64>,
    /// Optional jerk limit per joint.
    pub jerk: Option<Vec<f64>>,
}

impl Limits {
    pub fn new(velocity: Vec<f64>, acceleration: Vec<f64>) -> Self {
        Limits {
            velocity,
            acceleration,
            jerk: None,
        }
    }

    pub fn with_jerk(mut self, jerk: Vec<f64>) -> Self {
        self.jerk = Some(jerk);
        self
    }

    pub fn joints(&self) -> usize {
        self.velocity.len()
    }

    /// Every limit finite and above zero, one per joint.
    pub fn check(&self, joints: usize) -> Result<()> {
        let lists = [
            ("limits.velocity", Some(&self.velocity)),
            ("limits.acceleration", Some(&self.acceleration)),
            ("limits.jerk", self.jerk.as_ref()),
        ];
        for (what, list) in lists {
            let Some(list) = list else { continue };
            if list.len() != joints {
                return Err(Error::invalid(
                    what,
                    format!("has {} values for {joints} joints", list.len()),
                ));
            }
            for (j, &x) in list.iter().enumerate() {
                check_positive(&format!("{what}[{j}]"), x)?;
            }
        }
        Ok(())
    }
}

/// What a segment of the path is, for the statistics and the checks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SegmentKind {
    /// Cutting (plunge, pass, leave): the tool tip follows the planned cut.
    Cut,
    /// A link between passes (rapid or feed move).
    Link,
    /// The move from the machine's start pose to the first waypoint.
    StartMove,
}

/// The segment from waypoint k to k + 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    pub kind: SegmentKind,
    /// Cap on the tool tip's speed along the path, mm/s (the feed); `None`:
    /// joint limits only.
    pub tip_speed_cap: Option<f64>,
}

/// A tool pose from forward kinematics: tip (mm) and unit tool axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToolPose {
    pub tip: [f64; 3],
    pub axis: [f64; 3],
}

/// Forward kinematics: joint positions to tool pose.
pub type Kinematics<'a> = &'a dyn Fn(&[f64]) -> ToolPose;

/// Where the tool tip is, for the tip speed cap.
#[derive(Clone, Copy)]
pub enum Tips<'a> {
    /// No cap can apply (every `tip_speed_cap` must be `None`).
    None,
    /// Tip at each waypoint, splined in the path parameter like the joints.
    Points(&'a [[f64; 3]]),
    /// Tip of the joint path by forward kinematics.
    Kinematics(Kinematics<'a>),
}

/// How the path parameter s runs through the waypoints.
#[derive(Clone, Debug, PartialEq)]
pub enum Parameter {
    /// Cumulative chord of the joint polyline with every joint divided by its
    /// velocity limit (s in seconds at full speed): never stalls where the
    /// tip stands still while rotary axes turn, mixes mm and rad on the
    /// machine's own scale, and a chord-length parameter keeps the spline
    /// from ringing between unevenly spaced waypoints.
    ScaledJointChord,
    /// Cumulative chord of the tool tips (needs tips): fails where the tip
    /// stands still.
    TipChord,
    /// Strictly increasing values given by the caller.
    Given(Vec<f64>),
}

/// A joint path to time.
#[derive(Clone, Copy)]
pub struct Path<'a> {
    /// Joint positions per waypoint (mm, rad).
    pub positions: &'a [Vec<f64>],
    /// One per consecutive pair of waypoints.
    pub segments: &'a [Segment],
    /// Inner waypoints where the machine comes to rest (corners); the ends
    /// always are.
    pub stops: &'a [usize],
    pub tips: Tips<'a>,
    pub parameter: &'a Parameter,
}

/// One stretch between two stops: a C2 spline of the joints (and tips).
pub(crate) struct Piece {
    /// First and last waypoint index.
    pub first: usize,
    pub last: usize,
    pub joints: Spline,
    pub tips: Option<Spline>,
}

/// A checked path: the parameter of every waypoint and the pieces.
pub(crate) struct Checked {
    pub s: Vec<f64>,
    pub pieces: Vec<Piece>,
}

pub(crate) fn check(path: &Path, limits: &Limits) -> Result<Checked> {
    let q = path.positions;
    let n = q.len();
    if n < 2 {
        return Err(Error::invalid(
            "positions",
            format!("has {n} waypoint(s): a path needs at least 2"),
        ));
    }
    let joints = q[0].len();
    if joints == 0 {
        return Err(Error::invalid("positions[0]", "has no joints"));
    }
    for (k, row) in q.iter().enumerate() {
        if row.len() != joints {
            return Err(Error::invalid(
                format!("positions[{k}]"),
                format!("has {} values, positions[0] has {joints}", row.len()),
            ));
        }
        check_finite(&format!("positions[{k}]"), row)?;
    }
    limits.check(joints)?;
    check_segments(path, n)?;
    let tips = check_tips(path, n)?;
    for k in 1..n {
        if q[k] == q[k - 1] {
            return Err(Error::invalid(
                format!("positions[{k}]"),
                "repeats the previous waypoint: drop duplicate waypoints".to_string(),
            ));
        }
    }
    let s = parameter(path, limits, tips)?;
    let stops = stop_list(path, n)?;
    let pieces = stops
        .windows(2)
        .map(|w| {
            let (a, b) = (w[0], w[1]);
            Piece {
                first: a,
                last: b,
                joints: Spline::new(&s[a..=b], &q[a..=b]),
                tips: tips.map(|t| {
                    let rows: Vec<Vec<f64>> = t[a..=b].iter().map(|p| p.to_vec()).collect();
                    Spline::new(&s[a..=b], &rows)
                }),
            }
        })
        .collect();
    Ok(Checked { s, pieces })
}

fn check_segments(path: &Path, n: usize) -> Result<()> {
    if path.segments.len() != n - 1 {
        return Err(Error::invalid(
            "segments",
            format!(
                "has {} entries for {n} waypoints (one per pair: {})",
                path.segments.len(),
                n - 1
            ),
        ));
    }
    for (k, seg) in path.segments.iter().enumerate() {
        if let Some(cap) = seg.tip_speed_cap {
            check_positive(&format!("segments[{k}].tip_speed_cap"), cap)?;
            if matches!(path.tips, Tips::None) {
                return Err(Error::invalid(
                    format!("segments[{k}].tip_speed_cap"),
                    "is set but the path has no tips to cap",
                ));
            }
        }
    }
    Ok(())
}

fn check_tips<'a>(path: &Path<'a>, n: usize) -> Result<Option<&'a [[f64; 3]]>> {
    match path.tips {
        Tips::Points(t) => {
            if t.len() != n {
                return Err(Error::invalid(
                    "tips",
                    format!("has {} points for {n} waypoints", t.len()),
                ));
            }
            for (k, p) in t.iter().enumerate() {
                check_finite(&format!("tips[{k}]"), p)?;
            }
            Ok(Some(t))
        }
        _ => Ok(None),
    }
}

/// Sorted, unique stop indices including both ends.
fn stop_list(path: &Path, n: usize) -> Result<Vec<usize>> {
    let mut stops = vec![0];
    for (i, &k) in path.stops.iter().enumerate() {
        if k >= n {
            return Err(Error::invalid(
                format!("stops[{i}]"),
                format!("is {k}, past the last waypoint {}", n - 1),
            ));
        }
        stops.push(k);
    }
    stops.push(n - 1);
    stops.sort_unstable();
    stops.dedup();
    Ok(stops)
}

fn parameter(path: &Path, limits: &Limits, tips: Option<&[[f64; 3]]>) -> Result<Vec<f64>> {
    let q = path.positions;
    let n = q.len();
    let s = match path.parameter {
        Parameter::Given(s) => {
            if s.len() != n {
                return Err(Error::invalid(
                    "parameter",
                    format!("has {} values for {n} waypoints", s.len()),
                ));
            }
            check_finite("parameter", s)?;
            s.clone()
        }
        Parameter::ScaledJointChord => cumulative(n, |k| {
            q[k].iter()
                .zip(&q[k - 1])
                .zip(&limits.velocity)
                .map(|((a, b), v)| ((a - b) / v).powi(2))
                .sum::<f64>()
                .sqrt()
        }),
        Parameter::TipChord => {
            let tip_at = |k: usize| -> [f64; 3] {
                match (tips, path.tips) {
                    (Some(t), _) => t[k],
                    (None, Tips::Kinematics(fk)) => fk(&q[k]).tip,
                    _ => [0.0; 3],
                }
            };
            if matches!(path.tips, Tips::None) {
                return Err(Error::invalid(
                    "parameter",
                    "TipChord needs tips (points or kinematics)",
                ));
            }
            cumulative(n, |k| dist(tip_at(k), tip_at(k - 1)))
        }
    };
    for k in 1..n {
        if s[k] <= s[k - 1] {
            return Err(Error::invalid(
                format!("parameter[{k}]"),
                format!(
                    "is {} after {}: the path parameter must strictly increase",
                    s[k],
                    s[k - 1]
                ),
            ));
        }
    }
    Ok(s)
}

fn cumulative(n: usize, step: impl Fn(usize) -> f64) -> Vec<f64> {
    let mut s = Vec::with_capacity(n);
    s.push(0.0);
    for k in 1..n {
        s.push(s[k - 1] + step(k));
    }
    s
}

pub(crate) fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}
