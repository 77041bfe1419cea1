//! A planned job as one timed joint trajectory on its machine, through the
//! [`Machine`] interface (docs/methods.md, "Machine kinematics and timing").

use crate::axes::Axis;
use crate::controller;
use crate::jtc;
use crate::machine::{BranchFlip, Machine};
use crate::timing::{self, Segment};
use crate::{tool_poses, JointTrajectory, ToolPose};
use std::f64::consts::PI;
use toolpath_formats::{Job, PlanResult};
use toolpath_kernel::error::{Error, Result};

/// Where a waypoint comes from, for error messages.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Origin {
    Approach(usize),
    Point(usize, usize),
    Retract(usize),
}

impl std::fmt::Display for Origin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Origin::Approach(p) => write!(f, "the approach to pass {p}"),
            Origin::Point(p, k) => write!(f, "pass {p} point {k}"),
            Origin::Retract(p) => write!(f, "the retract after pass {p}"),
        }
    }
}

fn offset(p: [f64; 3], d: [f64; 3], s: f64) -> [f64; 3] {
    [p[0] + s * d[0], p[1] + s * d[1], p[2] + s * d[2]]
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The shift (`offset` plus whole turns, smallest) that brings joint `j` of
/// every row into its travel, if one does.
fn turn_shift(rows: &[Vec<f64>], j: usize, l: &Axis, offset: f64) -> Option<f64> {
    let lo = rows.iter().map(|r| r[j]).fold(f64::INFINITY, f64::min) + offset;
    let hi = rows.iter().map(|r| r[j]).fold(f64::NEG_INFINITY, f64::max) + offset;
    let turn = 2.0 * PI;
    let k_lo = ((l.min - lo) / turn - 1e-12).ceil();
    let k_hi = ((l.max - hi) / turn + 1e-12).floor();
    (k_lo <= k_hi).then(|| offset + turn * k_lo.max(0.0).min(k_hi))
}

/// Shifts the rotary joints of each pass (with its approach and retract) by
/// whole turns into their travel: the machine may rewind between passes, but
/// never inside one. `flip`: a head whose other branch
/// (-A, C + pi) may be taken for a whole pass when no whole-turn shift fits.
/// Then checks every joint against its limits.
fn fit_limits(
    machine: &str,
    q: &mut [Vec<f64>],
    limits: &[Axis],
    origins: &[Origin],
    flip: Option<BranchFlip>,
) -> Result<()> {
    let mut starts: Vec<usize> = origins
        .iter()
        .enumerate()
        .filter(|(_, o)| matches!(o, Origin::Approach(_)))
        .map(|(k, _)| k)
        .collect();
    if starts.first() != Some(&0) {
        starts.insert(0, 0);
    }
    for (b, &start) in starts.iter().enumerate() {
        let end = starts.get(b + 1).copied().unwrap_or(q.len());
        let block = &mut q[start..end];
        for (j, l) in limits.iter().enumerate() {
            if !l.rotary || block.is_empty() {
                continue;
            }
            let lo = block.iter().map(|r| r[j]).fold(f64::INFINITY, f64::min);
            let hi = block.iter().map(|r| r[j]).fold(f64::NEG_INFINITY, f64::max);
            if hi - lo > l.max - l.min + 1e-9 {
                return Err(Error::planning(format!(
                    "{machine}: {} turns joint {} through {:.1} deg, more than its travel {:.1}..{:.1} deg",
                    origins.get(start).map_or("the toolpath".to_string(), |o| format!("{o} onwards")),
                    l.name,
                    (hi - lo).to_degrees(),
                    l.min.to_degrees(),
                    l.max.to_degrees()
                )));
            }
            if let Some(shift) = turn_shift(block, j, l, 0.0) {
                block.iter_mut().for_each(|r| r[j] += shift);
            } else if let Some(BranchFlip { tilt: a, .. }) = flip.filter(|f| f.turn == j) {
                if let Some(shift) = turn_shift(block, j, l, PI) {
                    block.iter_mut().for_each(|r| {
                        r[j] += shift;
                        r[a] = -r[a];
                    });
                }
            }
        }
    }
    for (k, row) in q.iter().enumerate() {
        for (j, l) in limits.iter().enumerate() {
            let x = row[j];
            if x < l.min - 1e-9 || x > l.max + 1e-9 {
                let (val, lo, hi, unit) = if l.rotary {
                    (
                        x.to_degrees(),
                        l.min.to_degrees(),
                        l.max.to_degrees(),
                        "deg",
                    )
                } else {
                    (x, l.min, l.max, "mm")
                };
                return Err(Error::planning(format!(
                    "{machine}: {} needs joint {} = {val:.3} {unit}, outside its range {lo}..{hi} {unit}",
                    origins[k], l.name
                )));
            }
        }
    }
    Ok(())
}

/// Rejects a feed rate (mm/min) above the machine's maximum.
pub fn check_feed_rate(machine: &dyn Machine, feed_rate: f64) -> Result<()> {
    let max_feed = machine.max_feed_rate_mm_min();
    if feed_rate > max_feed {
        return Err(Error::invalid(
            "feed_rate",
            format!(
                "{feed_rate} mm/min exceeds {}'s maximum feed rate {max_feed} mm/min",
                machine.name()
            ),
        ));
    }
    Ok(())
}

/// The timed joint trajectory of a planned job on `machine`, starting from
/// `start` (a measured joint state, mm and rad in axis order; `None` = the
/// machine's home pose).
pub fn trajectory_on(
    machine: &dyn Machine,
    job: &Job,
    result: &PlanResult,
    start: Option<&[f64]>,
) -> Result<JointTrajectory> {
    check_feed_rate(machine, job.feed_rate)?;
    let machine_name = machine.name();
    let feed = job.feed_rate / 60.0;
    let w = Waypoints::of(machine, &tool_poses(result));
    let axes = machine.axes();
    let limits = axes.as_slice();
    let mut q = machine.inverse_path(job.tool_length(), &w.poses)?;
    fit_limits(
        machine_name,
        &mut q,
        limits,
        &w.origins,
        machine.branch_flip(),
    )?;
    let segments: Vec<Segment> = (1..w.poses.len())
        .map(|k| Segment {
            length: dist(w.poses[k - 1].tip, w.poses[k].tip),
            max_speed: (!w.rapid_before[k]).then_some(feed),
        })
        .collect();
    let mut timed = timing::parameterise(q, &segments, &w.stops, limits);
    let (start, what) = match start {
        Some(s) => (s.to_vec(), "the joint state"),
        None => (machine.home(), "the home pose"),
    };
    let joint_names = machine.joint_names();
    if start.len() != limits.len() {
        return Err(Error::planning(format!(
            "{machine_name}: {what} has {} joints, the machine has {} axes",
            start.len(),
            limits.len()
        )));
    }
    controller::check_start(
        &format!("{machine_name}: {what}"),
        &start,
        limits,
        &joint_names,
    )?;
    let start_move_s = match timed.positions.first() {
        Some(first) => controller::start_move_time(&start, first, limits),
        None => 0.0,
    };
    timed.times.iter_mut().for_each(|t| *t += start_move_s);
    let pass_starts = w
        .origins
        .iter()
        .enumerate()
        .filter(|(_, o)| matches!(o, Origin::Approach(_)))
        .map(|(k, _)| k)
        .collect();
    let trajectory = JointTrajectory {
        machine: machine_name.to_string(),
        joint_names,
        rotary: axes.rotary(),
        limits: axes.into_vec(),
        stamp: machine.controller().stamp(),
        start,
        start_move_s,
        pass_starts,
        timed,
    };
    if !trajectory.timed.times.is_empty() {
        // The timing guarantees these rules; a breach is a bug, not bad input.
        jtc::check(
            &trajectory.points(),
            &trajectory.joint_names,
            &trajectory.limits,
            Some(&trajectory.start),
        )
        .map_err(|e| {
            Error::planning(format!(
                "{machine_name}: internal error, the trajectory breaks a controller rule (please report): {e}"
            ))
        })?;
    }
    Ok(trajectory)
}

/// The tool poses a trajectory visits: per pass an approach `retract` mm
/// above its first point (a stop, reached by a rapid move), its points at
/// feed, and a retract above its last point (a stop).
struct Waypoints {
    poses: Vec<ToolPose>,
    origins: Vec<Origin>,
    stops: Vec<bool>,
    /// The segment ending at this waypoint is a rapid move.
    rapid_before: Vec<bool>,
}

impl Waypoints {
    fn of(machine: &dyn Machine, passes: &[Vec<ToolPose>]) -> Self {
        let retract = machine.retract_mm();
        let mut w = Waypoints {
            poses: Vec::new(),
            origins: Vec::new(),
            stops: Vec::new(),
            rapid_before: Vec::new(),
        };
        let lift = |t: &ToolPose| machine.retract_direction(t);
        for (p, pass) in passes.iter().enumerate() {
            let (Some(first), Some(last)) = (pass.first(), pass.last()) else {
                continue;
            };
            let approach = ToolPose {
                tip: offset(first.tip, lift(first), retract),
                ..*first
            };
            let leave = ToolPose {
                tip: offset(last.tip, lift(last), retract),
                ..*last
            };
            w.push(approach, Origin::Approach(p), true, true);
            for (k, t) in pass.iter().enumerate() {
                w.push(*t, Origin::Point(p, k), false, false);
            }
            w.push(leave, Origin::Retract(p), true, false);
        }
        w
    }

    fn push(&mut self, pose: ToolPose, origin: Origin, stop: bool, rapid_before: bool) {
        self.poses.push(pose);
        self.origins.push(origin);
        self.stops.push(stop);
        self.rapid_before.push(rapid_before);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{trajectory, Machines, Mill5Config};
    use toolpath_formats::{JobFile, Pass, PathPoint, Shape, Strategy};
    use toolpath_kernel::tools::Tool;

    fn job(strategy: Strategy, tool: Tool, feed: f64) -> Job {
        let file = JobFile {
            scallop: Some(0.05),
            tolerance: Some(0.01),
            feed_rate: Some(feed),
            ..JobFile::new("t", strategy, Some(tool))
        };
        Job::new(file, Shape::Surface(toolpath_samples::surfaces::plane())).unwrap()
    }

    fn straight_pass(n: usize, axis: [f64; 3]) -> PlanResult {
        let points = (0..n)
            .map(|k| PathPoint {
                cc: [k as f64, 0.0, 0.0],
                cl: [k as f64, 0.0, 0.0],
                axis,
                normal: Some([0.0, 0.0, 1.0]),
                ..Default::default()
            })
            .collect();
        PlanResult {
            passes: vec![Pass {
                region: 0,
                points,
                min_strip_width: None,
            }],
            ..Default::default()
        }
    }

    #[test]
    fn mill_trajectory_runs_at_feed_with_retracts() {
        let j = job(
            Strategy::IsoParametric,
            Tool::FlatEnd {
                radius: 2.5,
                length: Some(30.0),
            },
            600.0,
        );
        let r = straight_pass(101, [0.0, 0.0, 1.0]);
        let m = Machines::default();
        let t = trajectory(&j, &r, &m).unwrap();
        assert_eq!(t.joint_names, ["X", "Y", "Z", "A", "C"]);
        assert_eq!(t.timed.times.len(), 103);
        // Pivot height = origin z + pivot length + tool length on the pass.
        let z_cut = m.mill5.workpiece_origin_mm[2] + 250.0 + 30.0;
        assert!((t.timed.positions[1][2] - z_cut).abs() < 1e-9);
        assert!((t.timed.positions[0][2] - (z_cut + 10.0)).abs() < 1e-9);
        // 100 mm at 600 mm/min = 10 s of cutting, plus plunge and retract.
        let cut = t.timed.times[101] - t.timed.times[1];
        assert!((cut - 10.0).abs() < 1e-6, "{cut}");
        assert!(t.timed.velocities[50][0] > 9.99 && t.timed.velocities[50][0] < 10.01);
    }

    #[test]
    fn joint_out_of_range_fails_with_the_place() {
        let j = job(
            Strategy::IsoParametric,
            Tool::Ball {
                radius: 3.0,
                length: None,
            },
            1000.0,
        );
        // Axis tilted 100 deg from vertical: beyond A +-95.
        let t = 100f64.to_radians();
        let r = straight_pass(5, [t.sin(), 0.0, t.cos()]);
        let e = trajectory(&j, &r, &Machines::default())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("joint A") && e.contains("outside its range -95..95 deg"),
            "{e}"
        );
        assert!(e.contains("approach to pass 0"), "{e}");
    }

    #[test]
    fn feed_above_the_machine_maximum_is_rejected() {
        let j = job(
            Strategy::IsoParametric,
            Tool::Ball {
                radius: 3.0,
                length: None,
            },
            5000.0,
        );
        let e =
            trajectory(&j, &straight_pass(3, [0.0, 0.0, 1.0]), &Machines::default()).unwrap_err();
        assert!(matches!(e, Error::Invalid { .. }));
        assert!(
            e.to_string()
                .contains("exceeds mill5's maximum feed rate 4000"),
            "{e}"
        );
    }

    #[test]
    fn c_is_shifted_by_whole_turns_into_its_travel() {
        let mut q = vec![vec![0.0, 0.0, 0.0, 0.3, 5.0], vec![0.0, 0.0, 0.0, 0.3, 5.2]];
        let limits = Mill5Config::default().limits();
        let o = [Origin::Point(0, 0), Origin::Point(0, 1)];
        fit_limits(
            "mill5",
            &mut q,
            &limits,
            &o,
            Some(BranchFlip { tilt: 3, turn: 4 }),
        )
        .unwrap();
        assert!((q[0][4] - (5.0 - 2.0 * PI)).abs() < 1e-12);
        let mut q = vec![vec![0.0, 0.0, 0.0, 0.3, 0.0], vec![0.0, 0.0, 0.0, 0.3, 8.0]];
        let e = fit_limits(
            "mill5",
            &mut q,
            &limits,
            &o,
            Some(BranchFlip { tilt: 3, turn: 4 }),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("pass 0 point 0 onwards turns joint C through 458.4 deg"),
            "{e}"
        );
    }

    #[test]
    fn a_pass_takes_the_other_head_branch_when_no_whole_turn_fits() {
        // C from -10 to 320 deg: no whole-turn shift fits -220..220, (-A, C - 180) does.
        let c = |d: f64| d.to_radians();
        let mut q = vec![
            vec![0.0, 0.0, 0.0, 0.3, c(-10.0)],
            vec![0.0, 0.0, 0.0, 0.3, c(320.0)],
        ];
        let limits = Mill5Config::default().limits();
        let o = [Origin::Approach(0), Origin::Point(0, 0)];
        fit_limits(
            "mill5",
            &mut q,
            &limits,
            &o,
            Some(BranchFlip { tilt: 3, turn: 4 }),
        )
        .unwrap();
        assert!(
            (q[0][4] - c(-190.0)).abs() < 1e-12 && (q[1][4] - c(140.0)).abs() < 1e-12,
            "{q:?}"
        );
        assert_eq!((q[0][3], q[1][3]), (-0.3, -0.3));
        // Same axis: (sin A sin C, -sin A cos C, cos A) is unchanged by the flip.
        let axis = |a: f64, cc: f64| [a.sin() * cc.sin(), -a.sin() * cc.cos(), a.cos()];
        let (before, after) = (axis(0.3, c(320.0)), axis(q[1][3], q[1][4]));
        assert!((0..3).all(|k| (before[k] - after[k]).abs() < 1e-12));
        // Each pass is fitted on its own: the machine rewinds C between passes.
        let mut q = vec![
            vec![0.0, 0.0, 0.0, 0.3, c(200.0)],
            vec![0.0, 0.0, 0.0, 0.3, c(210.0)],
            vec![0.0, 0.0, 0.0, 0.3, c(350.0)],
            vec![0.0, 0.0, 0.0, 0.3, c(360.0)],
        ];
        let o = [
            Origin::Approach(0),
            Origin::Retract(0),
            Origin::Approach(1),
            Origin::Retract(1),
        ];
        fit_limits(
            "mill5",
            &mut q,
            &limits,
            &o,
            Some(BranchFlip { tilt: 3, turn: 4 }),
        )
        .unwrap();
        assert!(
            (q[0][4] - c(200.0)).abs() < 1e-12 && (q[2][4] - c(-10.0)).abs() < 1e-12,
            "{q:?}"
        );
    }
}

#[cfg(test)]
mod controller_tests {
    //! The trajectories the machines build, checked against the controller
    //! rules by finite differences computed here, independently of
    //! [`jtc::check`] and of the timing.
    use super::*;
    use crate::{trajectory, trajectory_from, Machines, Stamp, StampPolicy};
    use toolpath_formats::{Machine, Pass, PathPoint};
    use toolpath_planners::NoProgress;

    /// Every rule of `jtc` recomputed from the raw trajectory: `Err` names the
    /// first breach.
    fn breaches(t: &JointTrajectory, limits: &[Axis]) -> Vec<String> {
        let mut out = Vec::new();
        let (times, q, v) = (&t.timed.times, &t.timed.positions, &t.timed.velocities);
        let n = times.len();
        if times[0] <= 0.0 {
            out.push(format!("first time {}", times[0]));
        }
        let mut names = t.joint_names.clone();
        names.sort();
        names.dedup();
        if names.len() != limits.len() {
            out.push("joint names not unique".into());
        }
        // The start move as JTC interpolates it (cubic from rest to rest),
        // sampled densely.
        let t0 = times[0];
        for (j, l) in limits.iter().enumerate() {
            let d = q[0][j] - t.start[j];
            let m = 2000;
            let pos = |s: f64| t.start[j] + d * (3.0 * s * s - 2.0 * s * s * s);
            let h = t0 / m as f64;
            for k in 1..m {
                let s = k as f64 / m as f64;
                let vel = (pos(s + 1.0 / m as f64) - pos(s - 1.0 / m as f64)) / (2.0 * h);
                let acc =
                    (pos(s + 1.0 / m as f64) - 2.0 * pos(s) + pos(s - 1.0 / m as f64)) / (h * h);
                if vel.abs() > l.max_velocity * 1.0001 || acc.abs() > l.max_acceleration * 1.01 {
                    out.push(format!("start move {} at {s}: v {vel} a {acc}", l.name));
                    break;
                }
            }
        }
        for k in 0..n {
            if k > 0 && times[k] <= times[k - 1] {
                out.push(format!("time {k}"));
            }
            for (j, l) in limits.iter().enumerate() {
                if q[k].len() != limits.len() || v[k].len() != limits.len() {
                    out.push(format!("point {k} lengths"));
                }
                if q[k][j] < l.min - 1e-6 || q[k][j] > l.max + 1e-6 {
                    out.push(format!("point {k} {} = {} outside", l.name, q[k][j]));
                }
                if k > 0 {
                    let dt = times[k] - times[k - 1];
                    let fd_v = (q[k][j] - q[k - 1][j]) / dt;
                    let fd_a = (v[k][j] - v[k - 1][j]) / dt;
                    if fd_v.abs() > l.max_velocity * 1.0001 {
                        out.push(format!("point {k} {} fd velocity {fd_v}", l.name));
                    }
                    if fd_a.abs() > l.max_acceleration * 1.0001 {
                        out.push(format!("point {k} {} fd acceleration {fd_a}", l.name));
                    }
                }
            }
        }
        if v[n - 1].iter().any(|x| *x != 0.0) {
            out.push("last point moving".into());
        }
        // The cubic Hermite the controller interpolates on every segment,
        // sampled and differenced numerically.
        for k in 1..n {
            let h = times[k] - times[k - 1];
            for (j, l) in limits.iter().enumerate() {
                let (p0, p1, m0, m1) = (q[k - 1][j], q[k][j], v[k - 1][j] * h, v[k][j] * h);
                let pos = |s: f64| {
                    let (s2, s3) = (s * s, s * s * s);
                    (2.0 * s3 - 3.0 * s2 + 1.0) * p0
                        + (s3 - 2.0 * s2 + s) * m0
                        + (-2.0 * s3 + 3.0 * s2) * p1
                        + (s3 - s2) * m1
                };
                let m = 64;
                let e = 1.0 / m as f64;
                for i in 0..=m {
                    let s = (i as f64 * e).clamp(e, 1.0 - e);
                    let vel = (pos(s + e) - pos(s - e)) / (2.0 * e * h);
                    let acc = (pos(s + e) - 2.0 * pos(s) + pos(s - e)) / (e * e * h * h);
                    if vel.abs() > l.max_velocity * 1.001 || acc.abs() > l.max_acceleration * 1.05 {
                        out.push(format!("segment {k} {} cubic v {vel} a {acc}", l.name));
                        break;
                    }
                }
            }
        }
        out
    }

    fn planned(name: &str) -> (Job, PlanResult) {
        let job = toolpath_samples::job(name).unwrap();
        let result = toolpath_planners::plan(&job, &NoProgress).unwrap();
        (job, result)
    }

    #[test]
    fn sample_trajectories_of_both_machines_meet_the_controller_rules() {
        let m = Machines::default();
        for name in ["plane", "sine_wave"] {
            let (job, result) = planned(name);
            let t = trajectory(&job, &result, &m).unwrap();
            let limits = match job.machine {
                Machine::Mill5 => m.mill5.limits(),
                Machine::Belt6 => m.belt6.limits(),
            };
            let b = breaches(&t, &limits);
            assert!(b.is_empty(), "{name}: {b:?}");
            assert!(t.timed.times[0] > 0.0 && t.start_move_s == t.timed.times[0]);
            assert_eq!(t.stamp, Stamp::Zero);
            // A joint state elsewhere: the move is longer, the rest the same.
            let mut start = t.start.clone();
            start[0] += 2000.0;
            let u = trajectory_from(&job, &result, &m, Some(&start)).unwrap();
            assert!(breaches(&u, &limits).is_empty(), "{name}");
            let shift = u.timed.times[0] - t.timed.times[0];
            assert!(shift > 0.0);
            assert!(u
                .timed
                .times
                .iter()
                .zip(&t.timed.times)
                .all(|(a, b)| (a - b - shift).abs() < 1e-9));
            assert_eq!(u.timed.positions, t.timed.positions);
        }
    }

    #[test]
    fn configured_joint_names_and_stamp_policy_reach_the_trajectory() {
        let mut m = Machines::default();
        m.mill5.controller.joint_names =
            Some(["gx", "gy", "gz", "ha", "hc"].map(String::from).to_vec());
        m.mill5.controller.stamp = StampPolicy::At;
        m.mill5.controller.start_delay_s = 0.5;
        let (job, result) = planned("plane");
        let t = trajectory(&job, &result, &m).unwrap();
        assert_eq!(t.joint_names, ["gx", "gy", "gz", "ha", "hc"]);
        assert_eq!(t.stamp, Stamp::At(0.5));
    }

    #[test]
    fn a_joint_state_outside_the_travel_is_refused_by_name() {
        let m = Machines::default();
        let (job, result) = planned("plane");
        let mut start = m.mill5.home();
        start[2] = 1600.0;
        let e = trajectory_from(&job, &result, &m, Some(&start))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("mill5: the joint state has joint Z (axis Z) at 1600.000 mm, outside its range 0..1500 mm"),
            "{e}"
        );
    }

    /// A straight mill5 cut whose tool axis sweeps from tilted towards -y,
    /// past vertical (missing it by `miss` rad in x), to tilted towards +y.
    fn sweep_past_vertical(miss: f64) -> PlanResult {
        let n = 201;
        let points = (0..n)
            .map(|k| {
                let s = k as f64 / (n - 1) as f64;
                let tilt = (s - 0.5) * 0.6;
                let axis = [miss.sin(), tilt.sin(), tilt.cos()];
                PathPoint {
                    cc: [s * 100.0, 0.0, 0.0],
                    cl: [s * 100.0, 0.0, 0.0],
                    axis,
                    normal: Some([0.0, 0.0, 1.0]),
                    ..Default::default()
                }
            })
            .collect();
        PlanResult {
            passes: vec![Pass {
                region: 0,
                points,
                min_strip_width: None,
            }],
            ..Default::default()
        }
    }

    #[test]
    fn passing_near_a_equal_zero_slows_down_or_flips_never_spins() {
        let m = Machines::default();
        let limits = m.mill5.limits();
        let (job, _) = planned("plane");
        for miss in [0.0, 1e-3, 2e-2] {
            let t = trajectory(&job, &sweep_past_vertical(miss), &m).unwrap();
            let b = breaches(&t, &limits);
            assert!(b.is_empty(), "miss {miss}: {b:?}");
            // C turns at most half a turn through the cut (the axis swings
            // from -y to +y), never a whole turn.
            let c: Vec<f64> = t.timed.positions.iter().map(|r| r[4]).collect();
            let span = c.iter().cloned().fold(f64::MIN, f64::max)
                - c.iter().cloned().fold(f64::MAX, f64::min);
            assert!(
                span <= std::f64::consts::PI + 1e-6,
                "miss {miss}: C spans {span}"
            );
        }
        // Through vertical exactly, A changes sign and C holds.
        let t = trajectory(&job, &sweep_past_vertical(0.0), &m).unwrap();
        let c: Vec<f64> = t.timed.positions.iter().map(|r| r[4]).collect();
        assert!(c.iter().all(|x| (x - c[0]).abs() < 1e-9), "{c:?}");
        let a: Vec<f64> = t.timed.positions.iter().map(|r| r[3]).collect();
        assert!(a[1] * a[a.len() - 2] < 0.0);
        // Missing it by 1 mrad, C must swing about half a turn near the
        // middle: the timing slows the cut there below the feed.
        let t = trajectory(&job, &sweep_past_vertical(1e-3), &m).unwrap();
        let dt = |k: usize| t.timed.times[k + 1] - t.timed.times[k];
        assert!(dt(101) > 2.0 * dt(20), "{} vs {}", dt(101), dt(20));
    }
}
