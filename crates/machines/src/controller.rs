//! How a machine's trajectory controller (ros2_control's
//! joint_trajectory_controller, JTC) is addressed and started: its joint
//! names, its FollowJointTrajectory action, the start-time policy, the home
//! pose, and the timed move from where the machine is to the first approach
//! (docs/methods.md, "Machine kinematics and timing").

use super::axes::Axis;
use super::config::finite;
use serde::{Deserialize, Serialize};
use toolpath_kernel::error::{Error, Result};

/// When the controller starts a trajectory (`header.stamp`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum StampPolicy {
    /// Zero stamp: JTC starts the trajectory on receipt.
    #[default]
    Zero,
    /// The planning time plus `start_delay_s`: JTC starts it then (a
    /// trajectory whose end is already past is rejected).
    At,
}

/// The `controller:` section of a machine. Omitted fields take the machine's
/// defaults (see the accessors on the machine configs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ControllerConfig {
    /// The controller's joint of each axis, in axis order (X Y Z A C, or
    /// X Y Z A B C); `null` = the axis letters.
    pub joint_names: Option<Vec<String>>,
    /// The FollowJointTrajectory action; relative names go under the node's
    /// namespace. `null` = `<machine>_controller/follow_joint_trajectory`.
    pub action: Option<String>,
    pub stamp: StampPolicy,
    /// With `stamp: at`: seconds between planning and the start.
    pub start_delay_s: f64,
    /// Where the trajectory starts when no joint state is known: X Y Z in mm;
    /// `null` = above the workpiece origin at the top of Z.
    pub home_mm: Option<[f64; 3]>,
    /// Rotary axes of the home pose (A C, or A B C), degrees; `null` = zeros.
    pub home_deg: Option<Vec<f64>>,
    /// A `/joint_states` message older than this (by arrival) is stale, s.
    pub joint_states_max_age_s: f64,
    /// Send every trajectory to the controller (FollowJointTrajectory).
    pub execute: bool,
}

/// Default age limit of a joint state, s (JointState publishers run at
/// 50-1000 Hz, so a second means the publisher has stopped).
pub const JOINT_STATES_MAX_AGE_S: f64 = 1.0;

impl Default for ControllerConfig {
    fn default() -> Self {
        Self::new()
    }
}

impl ControllerConfig {
    /// The defaults of every field, as in launch_configs/default.yaml.
    pub fn new() -> Self {
        Self {
            joint_names: None,
            action: None,
            stamp: StampPolicy::Zero,
            start_delay_s: 0.0,
            home_mm: None,
            home_deg: None,
            joint_states_max_age_s: JOINT_STATES_MAX_AGE_S,
            execute: false,
        }
    }

    pub(super) fn validate(&self, field: &str, axes: &[Axis]) -> Result<()> {
        if let Some(names) = &self.joint_names {
            if names.len() != axes.len() {
                return Err(Error::invalid(
                    format!("{field}.joint_names"),
                    format!(
                        "has {} names, the machine has {} axes ({})",
                        names.len(),
                        axes.len(),
                        axes.iter()
                            .map(|l| l.name.as_str())
                            .collect::<Vec<_>>()
                            .join(" ")
                    ),
                ));
            }
            for (k, n) in names.iter().enumerate() {
                if n.trim().is_empty() {
                    return Err(Error::invalid(
                        format!("{field}.joint_names[{k}]"),
                        "must not be empty",
                    ));
                }
                if names[..k].contains(n) {
                    return Err(Error::invalid(
                        format!("{field}.joint_names[{k}]"),
                        format!("\"{n}\" is named twice: joint names must be unique"),
                    ));
                }
            }
        }
        if let Some(a) = &self.action {
            if a.trim().is_empty() || a.ends_with('/') {
                return Err(Error::invalid(
                    format!("{field}.action"),
                    format!("\"{a}\" is not an action name"),
                ));
            }
        }
        if !self.start_delay_s.is_finite() || self.start_delay_s < 0.0 {
            return Err(Error::invalid(
                format!("{field}.start_delay_s"),
                "must be a finite number >= 0",
            ));
        }
        super::config::positive(
            &format!("{field}.joint_states_max_age_s"),
            self.joint_states_max_age_s,
        )?;
        if let Some(h) = &self.home_mm {
            for (k, v) in h.iter().enumerate() {
                finite(&format!("{field}.home_mm[{k}]"), *v)?;
            }
        }
        let rotary = axes.iter().filter(|l| l.rotary).count();
        if let Some(h) = &self.home_deg {
            if h.len() != rotary {
                return Err(Error::invalid(
                    format!("{field}.home_deg"),
                    format!(
                        "has {} values, the machine has {rotary} rotary axes",
                        h.len()
                    ),
                ));
            }
            for (k, v) in h.iter().enumerate() {
                finite(&format!("{field}.home_deg[{k}]"), *v)?;
            }
        }
        Ok(())
    }

    /// [`Self::validate`], then the home pose (with `default_mm` for X Y Z)
    /// checked as a start pose: inside the travel.
    pub(super) fn validate_with_home(
        &self,
        field: &str,
        axes: &[Axis],
        default_mm: [f64; 3],
    ) -> Result<()> {
        self.validate(field, axes)?;
        check_start(
            "the home pose (home_mm, home_deg)",
            &self.home(axes, default_mm),
            axes,
            &self.joint_names(axes),
        )
        .map_err(|e| Error::invalid(field, e.to_string()))
    }

    /// The FollowJointTrajectory action of `machine`'s controller.
    pub fn action(&self, machine: &str) -> String {
        self.action
            .clone()
            .unwrap_or_else(|| format!("{machine}_controller/follow_joint_trajectory"))
    }

    /// The controller's joint names (the axis letters unless configured).
    pub fn joint_names(&self, axes: &[Axis]) -> Vec<String> {
        self.joint_names
            .clone()
            .unwrap_or_else(|| axes.iter().map(|l| l.name.clone()).collect())
    }

    /// The home pose in internal units (mm, rad), given the default X Y Z.
    pub fn home(&self, axes: &[Axis], default_mm: [f64; 3]) -> Vec<f64> {
        let mm = self.home_mm.unwrap_or(default_mm);
        let mut deg = self.home_deg.clone().unwrap_or_default().into_iter();
        let mut k = 0;
        axes.iter()
            .map(|l| {
                if l.rotary {
                    deg.next().unwrap_or(0.0).to_radians()
                } else {
                    k += 1;
                    mm[k - 1]
                }
            })
            .collect()
    }
}

/// The start-time policy of a trajectory.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Stamp {
    #[default]
    Zero,
    /// Planning time plus this many seconds.
    At(f64),
}

impl ControllerConfig {
    pub fn stamp(&self) -> Stamp {
        match self.stamp {
            StampPolicy::Zero => Stamp::Zero,
            StampPolicy::At => Stamp::At(self.start_delay_s),
        }
    }
}

/// Shortest start move, s: a first point at `time_from_start` 0 tells JTC
/// not to interpolate from the measured state, so even a machine already at
/// the approach gets a (short) move.
pub const MIN_START_MOVE_S: f64 = 0.1;

/// Duration of the move from `start` (at rest) to `target` (at rest) that JTC
/// interpolates as a cubic per joint: a cubic from rest to rest over a
/// distance d in time T peaks at 1.5 d / T in velocity (mid-way) and at
/// 6 d / T^2 in acceleration (at both ends), so T is the smallest time that
/// keeps both peaks within every joint's limits.
pub fn start_move_time(start: &[f64], target: &[f64], limits: &[Axis]) -> f64 {
    limits
        .iter()
        .enumerate()
        .map(|(j, l)| {
            let d = (target[j] - start[j]).abs();
            (1.5 * d / l.max_velocity).max((6.0 * d / l.max_acceleration).sqrt())
        })
        .fold(MIN_START_MOVE_S, f64::max)
}

/// The column of each expected joint in a message's joint list. Errors name
/// a missing or repeated joint.
pub fn match_joints(field: &str, names: &[String], expected: &[String]) -> Result<Vec<usize>> {
    for (k, n) in names.iter().enumerate() {
        if names[..k].contains(n) {
            return Err(Error::invalid(
                format!("{field}[{k}]"),
                format!("joint \"{n}\" is named twice"),
            ));
        }
    }
    expected
        .iter()
        .map(|e| {
            names.iter().position(|n| n == e).ok_or_else(|| {
                Error::invalid(
                    field,
                    format!(
                        "has no joint \"{e}\" (it names {}; the controller's joints are {})",
                        list(names),
                        list(expected)
                    ),
                )
            })
        })
        .collect()
}

fn list(names: &[String]) -> String {
    if names.is_empty() {
        "none".into()
    } else {
        names.join(" ")
    }
}

/// Checks a start pose (mm, rad) against the travel; `what` says where it
/// comes from ("the joint state", "the home pose").
pub fn check_start(what: &str, q: &[f64], limits: &[Axis], names: &[String]) -> Result<()> {
    for (j, l) in limits.iter().enumerate() {
        let x = q[j];
        if !x.is_finite() || x < l.min - 1e-9 || x > l.max + 1e-9 {
            let (v, lo, hi, unit) = l.shown(x);
            return Err(Error::planning(format!(
                "{what} has joint {} (axis {}) at {v:.3} {unit}, outside its range {lo}..{hi} {unit}: \
                 the trajectory cannot start there",
                names[j], l.name
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Mill5Config;

    /// Samples the cubic Hermite JTC interpolates between (p0, v0) and
    /// (p1, v1) over `t` and returns the largest |velocity| and
    /// |acceleration|, by finite differences of the sampled positions.
    fn hermite_peaks(p0: f64, p1: f64, t: f64) -> (f64, f64) {
        let n = 4000;
        let h = t / n as f64;
        let pos = |s: f64| {
            let u = s / t;
            p0 + (p1 - p0) * (3.0 * u * u - 2.0 * u * u * u)
        };
        let x: Vec<f64> = (0..=n).map(|k| pos(k as f64 * h)).collect();
        let v = x.windows(2).map(|w| (w[1] - w[0]) / h);
        let a = x.windows(3).map(|w| (w[2] - 2.0 * w[1] + w[0]) / (h * h));
        (
            v.map(f64::abs).fold(0.0, f64::max),
            a.map(f64::abs).fold(0.0, f64::max),
        )
    }

    #[test]
    fn start_move_keeps_the_interpolated_cubic_within_the_limits() {
        let limits = Mill5Config::default().limits();
        let start = [100.0, 2900.0, 1400.0, 0.0, -3.5];
        let target = [5900.0, 100.0, 200.0, 1.6, 3.8];
        let t = start_move_time(&start, &target, &limits);
        let mut tight = false;
        for (j, l) in limits.iter().enumerate() {
            let (v, a) = hermite_peaks(start[j], target[j], t);
            assert!(v <= l.max_velocity * (1.0 + 1e-6), "joint {j}: v {v}");
            assert!(a <= l.max_acceleration * (1.0 + 1e-3), "joint {j}: a {a}");
            // The move is no slower than it must be: some joint is at a limit.
            tight |= v > l.max_velocity * 0.999 || a > l.max_acceleration * 0.99;
        }
        assert!(tight, "{t}");
        // X: 5800 mm at 500 mm/s, cubic: 1.5 * 5800 / 500 = 17.4 s.
        assert!((t - 17.4).abs() < 1e-9, "{t}");
        // A short move is acceleration-bound: 1 mm of X at 2000 mm/s^2.
        let t = start_move_time(&[0.0; 5], &[1.0, 0.0, 0.0, 0.0, 0.0], &limits);
        assert!((t - (6.0f64 / 2000.0).sqrt().max(MIN_START_MOVE_S)).abs() < 1e-12);
        assert_eq!(
            start_move_time(&[1.0; 5], &[1.0; 5], &limits),
            MIN_START_MOVE_S
        );
    }

    #[test]
    fn joints_are_matched_by_name_and_a_missing_one_is_named() {
        let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
        let cols = match_joints(
            "name",
            &s(&["c", "a", "x", "z", "y"]),
            &s(&["x", "y", "z", "a", "c"]),
        )
        .unwrap();
        assert_eq!(cols, [2, 4, 3, 1, 0]);
        let e = match_joints(
            "name",
            &s(&["x", "y", "z", "a"]),
            &s(&["x", "y", "z", "a", "c"]),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("name: has no joint \"c\" (it names x y z a"),
            "{e}"
        );
        let e = match_joints("name", &s(&["x", "x"]), &s(&["x"]))
            .unwrap_err()
            .to_string();
        assert!(e.contains("name[1]: joint \"x\" is named twice"), "{e}");
    }

    #[test]
    fn config_errors_name_the_field() {
        let limits = Mill5Config::default().limits();
        let mut c = ControllerConfig::new();
        c.joint_names = Some(vec!["x".into(), "y".into(), "z".into(), "a".into()]);
        let e = c
            .validate("mill5.controller", &limits)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(
                "mill5.controller.joint_names: has 4 names, the machine has 5 axes (X Y Z A C)"
            ),
            "{e}"
        );
        c.joint_names = Some(["x", "y", "z", "a", "x"].map(String::from).to_vec());
        let e = c
            .validate("mill5.controller", &limits)
            .unwrap_err()
            .to_string();
        assert!(e.contains("joint_names[4]: \"x\" is named twice"), "{e}");
        let mut c = ControllerConfig::new();
        c.home_deg = Some(vec![0.0]);
        let e = c
            .validate("mill5.controller", &limits)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("home_deg: has 1 values, the machine has 2 rotary axes"),
            "{e}"
        );
        let mut c = ControllerConfig::new();
        c.start_delay_s = -1.0;
        assert!(c.validate("m", &limits).is_err());
    }

    #[test]
    fn home_pose_orders_linear_and_rotary_axes() {
        let limits = Mill5Config::default().limits();
        let mut c = ControllerConfig::new();
        c.home_deg = Some(vec![90.0, -180.0]);
        let h = c.home(&limits, [1.0, 2.0, 3.0]);
        assert_eq!(&h[..3], &[1.0, 2.0, 3.0]);
        assert!((h[3] - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        assert!((h[4] + std::f64::consts::PI).abs() < 1e-15);
        let names = c.joint_names(&limits);
        let e = check_start(
            "the joint state",
            &[1.0, 2.0, 3.0, 0.0, 4.0],
            &limits,
            &names,
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("joint C (axis C) at 229.183 deg, outside its range -220..220 deg"),
            "{e}"
        );
    }
}
