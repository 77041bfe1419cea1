//! The rules a trajectory must meet for ros2_control's
//! joint_trajectory_controller (JTC) to execute it on this machine, checked
//! on the trajectory as sent (internal units: mm, rad, s): what the node
//! asserts before it sends, and what the test controller applies to a goal.
//!
//! JTC's own checks: joint names are the controller's and unique; every point
//! has positions (and velocities, accelerations if any are given) of the
//! joints' length; `time_from_start` strictly increases. The machine's: the
//! first point comes after 0 (JTC then interpolates from the measured state);
//! the last point is at rest; positions stay in the travel; velocity and
//! acceleration limits hold between consecutive points by finite differences
//! and on the cubic the controller interpolates between them;
//! a rotary joint never turns further between two points than it can in that
//! time (a C unwrapped the wrong way or a spin at the A = 0 singularity).

use super::axes::Axis;
use super::controller::match_joints;
use super::timing::hermite_peaks;
use toolpath_kernel::error::{Error, Result};

/// A trajectory as the controller receives it, in internal units.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Points {
    pub joint_names: Vec<String>,
    /// `time_from_start` of each point, s.
    pub times: Vec<f64>,
    pub positions: Vec<Vec<f64>>,
    pub velocities: Vec<Vec<f64>>,
    /// Empty, or one row per point.
    pub accelerations: Vec<Vec<f64>>,
}

/// Relative slack of the limit checks: times travel as whole nanoseconds, so
/// a segment of 0.1 ms timed exactly at a limit is off by up to 1e-5.
pub const LIMIT_SLACK: f64 = 1e-4;

/// Checks `p` against the controller's joints `names` (with `limits` in that
/// order). `start`, the pose the machine is at (at rest), adds the move from
/// it to the first point to the limit checks. Returns the trajectory's
/// columns reordered to the controller's joints, or the first broken rule
/// naming the point and the joint.
pub fn check(
    p: &Points,
    names: &[String],
    limits: &[Axis],
    start: Option<&[f64]>,
) -> Result<Points> {
    let cols = match_joints("joint_names", &p.joint_names, names)?;
    if p.joint_names.len() != names.len() {
        return Err(Error::invalid(
            "joint_names",
            format!(
                "names {} joints, the controller has {} ({})",
                p.joint_names.len(),
                names.len(),
                names.join(" ")
            ),
        ));
    }
    let n = p.times.len();
    if n == 0 {
        return Err(Error::invalid("points", "is empty"));
    }
    let rows = |what: &str, rows: &[Vec<f64>], optional: bool| {
        controller_columns(what, rows, optional, n, &cols)
    };
    let q = rows("positions", &p.positions, false)?;
    let v = rows("velocities", &p.velocities, false)?;
    let a = rows("accelerations", &p.accelerations, true)?;
    check_times(&p.times)?;
    let joints = Joints {
        names,
        t: &p.times,
        q: &q,
        v: &v,
        a: &a,
    };
    for (j, l) in limits.iter().enumerate() {
        joints.check_points(j, l)?;
        joints.check_segments(j, l, start.map(|s| s[j]))?;
    }
    Ok(Points {
        joint_names: names.to_vec(),
        times: p.times.clone(),
        positions: q,
        velocities: v,
        accelerations: a,
    })
}

/// One of the point lists (`what`) reordered to the controller's joint
/// order `cols`: one row per time, every value finite. An `optional` list
/// may be empty.
fn controller_columns(
    what: &str,
    rows: &[Vec<f64>],
    optional: bool,
    n: usize,
    cols: &[usize],
) -> Result<Vec<Vec<f64>>> {
    if optional && rows.is_empty() {
        return Ok(Vec::new());
    }
    if rows.len() != n {
        return Err(Error::invalid(
            "points",
            format!("{} points have {what}, {n} have times", rows.len()),
        ));
    }
    let joints = cols.len();
    rows.iter()
        .enumerate()
        .map(|(k, r)| {
            if r.len() != joints {
                return Err(Error::invalid(
                    format!("points[{k}].{what}"),
                    format!("has {} values for {joints} joints", r.len()),
                ));
            }
            if let Some(j) = r.iter().position(|x| !x.is_finite()) {
                return Err(Error::invalid(
                    format!("points[{k}].{what}[{j}]"),
                    "is not a finite number",
                ));
            }
            Ok(cols.iter().map(|&c| r[c]).collect())
        })
        .collect()
}

/// JTC's timing rules: the first point after 0 (else it skips the move from
/// the measured state), times strictly increasing.
fn check_times(t: &[f64]) -> Result<()> {
    if !(t[0].is_finite() && t[0] > 0.0) {
        return Err(Error::invalid(
            "points[0].time_from_start",
            format!(
                "is {} s: a first point at 0 makes JTC skip the move from the measured state",
                t[0]
            ),
        ));
    }
    for k in 1..t.len() {
        if !(t[k].is_finite() && t[k] > t[k - 1]) {
            return Err(Error::invalid(
                format!("points[{k}].time_from_start"),
                format!(
                    "{} s does not come after the previous point's {} s",
                    t[k],
                    t[k - 1]
                ),
            ));
        }
    }
    Ok(())
}

/// A trajectory in the controller's joint order, checked joint by joint.
struct Joints<'a> {
    names: &'a [String],
    t: &'a [f64],
    q: &'a [Vec<f64>],
    v: &'a [Vec<f64>],
    a: &'a [Vec<f64>],
}

impl Joints<'_> {
    /// Joint `j` at every point: at rest at the end, within its travel,
    /// velocity and acceleration limits.
    fn check_points(&self, j: usize, l: &Axis) -> Result<()> {
        let (n, name, slack) = (self.t.len(), &self.names[j], 1.0 + LIMIT_SLACK);
        if self.v[n - 1][j] != 0.0 || self.a.last().is_some_and(|r| r[j] != 0.0) {
            return Err(Error::invalid(
                format!("points[{}]", n - 1),
                format!("joint {name} is not at rest at the last point"),
            ));
        }
        for (k, row) in self.q.iter().enumerate() {
            if row[j] < l.min - 1e-6 || row[j] > l.max + 1e-6 {
                let (x, lo, hi, unit) = l.shown(row[j]);
                return Err(Error::invalid(
                    format!("points[{k}].positions"),
                    format!("joint {name} at {x:.4} {unit} is outside its range {lo}..{hi} {unit}"),
                ));
            }
            if self.v[k][j].abs() > l.max_velocity * slack {
                return Err(Error::invalid(
                    format!("points[{k}].velocities"),
                    format!(
                        "joint {name} at {:.4} per s exceeds its velocity limit {:.4}",
                        self.v[k][j], l.max_velocity
                    ),
                ));
            }
            if self
                .a
                .get(k)
                .is_some_and(|r| r[j].abs() > l.max_acceleration * slack)
            {
                return Err(Error::invalid(
                    format!("points[{k}].accelerations"),
                    format!(
                        "joint {name} exceeds its acceleration limit {}",
                        l.max_acceleration
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Joint `j` between consecutive points, and from `start` (at rest, time
    /// 0) to the first: finite-difference velocity and acceleration, the
    /// turn of a rotary axis, and the peaks of the cubic JTC interpolates.
    fn check_segments(&self, j: usize, l: &Axis, start: Option<f64>) -> Result<()> {
        let (t, q, v) = (self.t, self.q, self.v);
        let (name, slack) = (&self.names[j], 1.0 + LIMIT_SLACK);
        let first = start.map(|s| (None, (s, 0.0, 0.0)));
        let segments = first
            .into_iter()
            .chain((1..t.len()).map(|k| (Some(k - 1), (q[k - 1][j], v[k - 1][j], t[k - 1]))));
        for (from, (q0, v0, t0)) in segments {
            let k = from.map_or(0, |f| f + 1);
            let dt = t[k] - t0;
            let at = match from {
                None => format!("the start and points[0] ({dt:.4} s)"),
                Some(f) => format!("points[{f}] and [{k}] ({dt:.4} s)"),
            };
            let dq = q[k][j] - q0;
            if l.rotary && dq.abs() > l.max_velocity * dt * slack {
                let (d, _, _, unit) = l.shown(dq);
                return Err(Error::invalid(
                    format!("points[{k}].positions"),
                    format!(
                        "joint {name} turns {d:.3} {unit} between {at}, more than the {:.3} {unit} it can turn in that time",
                        l.shown(l.max_velocity * dt).0
                    ),
                ));
            }
            if dq.abs() > l.max_velocity * dt * slack {
                return Err(Error::invalid(
                    format!("points[{k}].positions"),
                    format!(
                        "joint {name} moves at {:.4} per s between {at}, over its velocity limit {:.4}",
                        dq.abs() / dt,
                        l.max_velocity
                    ),
                ));
            }
            let acc = (v[k][j] - v0).abs() / dt;
            if acc > l.max_acceleration * slack {
                return Err(Error::invalid(
                    format!("points[{k}].velocities"),
                    format!(
                        "joint {name} accelerates at {acc:.4} per s^2 between {at}, over its limit {:.4}",
                        l.max_acceleration
                    ),
                ));
            }
            let (vp, ap) = hermite_peaks(q0, q[k][j], v0, v[k][j], dt);
            if vp > l.max_velocity * slack || ap > l.max_acceleration * slack {
                return Err(Error::invalid(
                    format!("points[{k}]"),
                    format!(
                        "the cubic the controller interpolates between {at} takes joint {name} to \
                         {vp:.4} per s and {ap:.4} per s^2, over its limits {:.4} and {:.4}",
                        l.max_velocity, l.max_acceleration
                    ),
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Mill5Config;

    fn names() -> Vec<String> {
        ["X", "Y", "Z", "A", "C"].map(String::from).to_vec()
    }

    /// Three points of a slow, valid mill5 move (mm, rad, s).
    fn good() -> Points {
        Points {
            joint_names: names(),
            times: vec![1.0, 2.0, 3.0],
            positions: vec![
                vec![100.0, 100.0, 100.0, 0.0, 0.0],
                vec![150.0, 100.0, 100.0, 0.1, 0.2],
                vec![200.0, 100.0, 100.0, 0.2, 0.4],
            ],
            velocities: vec![vec![0.0; 5], vec![50.0, 0.0, 0.0, 0.1, 0.2], vec![0.0; 5]],
            accelerations: Vec::new(),
        }
    }

    fn err(p: &Points, start: Option<&[f64]>) -> String {
        let limits = Mill5Config::default().limits();
        check(p, &names(), &limits, start).unwrap_err().to_string()
    }

    #[test]
    fn a_valid_trajectory_passes_in_any_joint_order() {
        let limits = Mill5Config::default().limits();
        let p = good();
        assert_eq!(check(&p, &names(), &limits, None).unwrap(), p);
        // Columns in another order are mapped back by name.
        let order = [4, 0, 3, 1, 2];
        let pick = |r: &Vec<f64>| order.iter().map(|&c| r[c]).collect::<Vec<f64>>();
        let shuffled = Points {
            joint_names: order.iter().map(|&c| names()[c].clone()).collect(),
            positions: p.positions.iter().map(pick).collect(),
            velocities: p.velocities.iter().map(pick).collect(),
            ..p.clone()
        };
        assert_eq!(check(&shuffled, &names(), &limits, None).unwrap(), p);
    }

    #[test]
    fn names_must_be_the_controllers_and_unique() {
        let mut p = good();
        p.joint_names[4] = "C2".into();
        assert!(err(&p, None).contains("joint_names: has no joint \"C\""));
        p.joint_names[4] = "X".into();
        assert!(err(&p, None).contains("joint_names[4]: joint \"X\" is named twice"));
        let mut p = good();
        p.joint_names.push("W".into());
        p.positions.iter_mut().for_each(|r| r.push(0.0));
        p.velocities.iter_mut().for_each(|r| r.push(0.0));
        assert!(err(&p, None).contains("names 6 joints, the controller has 5"));
    }

    #[test]
    fn every_point_has_values_for_every_joint() {
        let mut p = good();
        p.positions[1].pop();
        assert!(err(&p, None).contains("points[1].positions: has 4 values for 5 joints"));
        let mut p = good();
        p.velocities[2] = Vec::new();
        assert!(err(&p, None).contains("points[2].velocities: has 0 values for 5 joints"));
        let mut p = good();
        p.velocities.pop();
        assert!(err(&p, None).contains("2 points have velocities, 3 have times"));
        let mut p = good();
        p.accelerations = vec![vec![0.0; 5], vec![0.0; 4], vec![0.0; 5]];
        assert!(err(&p, None).contains("points[1].accelerations: has 4 values"));
        let mut p = good();
        p.positions[0][2] = f64::NAN;
        assert!(err(&p, None).contains("points[0].positions[2]: is not a finite number"));
    }

    #[test]
    fn times_start_after_zero_and_strictly_increase() {
        let mut p = good();
        p.times[0] = 0.0;
        assert!(err(&p, None).contains("points[0].time_from_start: is 0 s"));
        let mut p = good();
        p.times[2] = 2.0;
        assert!(err(&p, None).contains("points[2].time_from_start: 2 s does not come after"));
    }

    #[test]
    fn the_last_point_is_at_rest() {
        let mut p = good();
        p.velocities[2][1] = 1e-6;
        assert!(err(&p, None).contains("points[2]: joint Y is not at rest at the last point"));
    }

    #[test]
    fn positions_stay_in_the_travel() {
        let mut p = good();
        p.positions[1][3] = 96f64.to_radians();
        p.positions[2][3] = 96f64.to_radians();
        let e = err(&p, None);
        assert!(
            e.contains(
                "points[1].positions: joint A at 96.0000 deg is outside its range -95..95 deg"
            ),
            "{e}"
        );
    }

    #[test]
    fn velocity_and_acceleration_hold_by_finite_differences() {
        // X 600 mm in 1 s: over 500 mm/s.
        let mut p = good();
        p.positions[1][0] = 700.0;
        p.positions[2][0] = 700.0;
        let e = err(&p, None);
        assert!(
            e.contains(
                "points[1].positions: joint X moves at 600.0000 per s between points[0] and [1]"
            ),
            "{e}"
        );
        // Y from rest to 400 mm/s and back in 0.1 s: 4000 mm/s^2 > 2000.
        let mut p = good();
        p.times = vec![1.0, 1.1, 1.2];
        p.positions = vec![
            vec![100.0, 100.0, 100.0, 0.0, 0.0],
            vec![100.0, 120.0, 100.0, 0.0, 0.0],
            vec![100.0, 140.0, 100.0, 0.0, 0.0],
        ];
        p.velocities = vec![vec![0.0; 5], vec![0.0, 400.0, 0.0, 0.0, 0.0], vec![0.0; 5]];
        let e = err(&p, None);
        assert!(
            e.contains("points[1].velocities: joint Y accelerates at 4000.0000 per s^2"),
            "{e}"
        );
        // A point's own velocity over the limit.
        let mut p = good();
        p.velocities[1][2] = 301.0;
        assert!(err(&p, None).contains("points[1].velocities: joint Z at 301.0000 per s exceeds"));
        // The move from the start pose counts: 900 mm of Y in the first second.
        let e = err(&good(), Some(&[100.0, 1000.0, 100.0, 0.0, 0.0]));
        assert!(
            e.contains("joint Y moves at 900.0000 per s between the start and points[0]"),
            "{e}"
        );
    }

    #[test]
    fn the_interpolated_cubic_stays_within_the_limits() {
        // X from rest to rest, 400 mm in 1 s: the mean 400 mm/s is under
        // 500, but the cubic peaks at 1.5 x 400 = 600 mm/s mid-way.
        let mut p = good();
        p.positions[1][0] = 500.0;
        p.positions[2][0] = 500.0;
        p.velocities[1] = vec![0.0; 5];
        let e = err(&p, None);
        assert!(
            e.contains("points[1]: the cubic the controller interpolates between points[0] and [1] (1.0000 s) takes joint X to 600.0000 per s"),
            "{e}"
        );
    }

    #[test]
    fn a_rotary_joint_never_spins_between_points() {
        // C unwrapped the wrong way: a whole turn less 1 deg in 0.5 s (180 deg/s max).
        let mut p = good();
        p.positions[0][4] = (-190f64).to_radians();
        p.positions[1][4] = 165f64.to_radians();
        p.positions[2][4] = 165f64.to_radians();
        p.times = vec![1.0, 1.5, 3.0];
        p.velocities[1] = vec![0.0; 5];
        let e = err(&p, None);
        assert!(
            e.contains("points[1].positions: joint C turns 355.000 deg between points[0] and [1] (0.5000 s), more than the 90.000 deg it can turn"),
            "{e}"
        );
    }
}
