//! Machine kinematics (mill5, belt6) and timed joint trajectories
//! (docs/methods.md, "Machine kinematics and timing").
//!
//! A planned toolpath becomes one joint trajectory per job: every pass is
//! entered and left along the tool axis (mill) or contact normal (belt) by the
//! machine's retract distance, cutting moves run at the job's feed, links
//! between passes are joint-limited rapids. Rotary joints are unwrapped to stay
//! continuous and then shifted by whole turns into their travel; a pose that
//! needs a joint outside its limits fails the job with a reason naming the
//! joint, the value, the range, the pass and the point.

pub mod belt6;
pub mod config;
pub mod five_axis;
pub mod mill5;
pub mod timing;

pub use config::{Belt6Config, JointLimit, Machines, Mill5Config};
pub use five_axis::{FiveAxis, FiveAxisConfig, Kinematics};

use crate::error::{Error, Result};
use crate::formats::{Job, Machine, PlanResult};
use std::f64::consts::PI;
use timing::{Segment, Timed};

/// One tool pose of a toolpath: `tip` is the tool tip (belt: wheel centre),
/// `axis` the tool axis (belt: wheel axis), `normal` the contact normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToolPose {
    pub tip: [f64; 3],
    pub axis: [f64; 3],
    pub normal: [f64; 3],
}

/// Where a waypoint comes from, for error messages.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Origin {
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

/// A job's timed joint trajectory in internal units (mm, rad, s).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct JointTrajectory {
    pub machine: String,
    pub joint_names: Vec<&'static str>,
    /// Per joint: true for rotary (rad), false for linear (mm).
    pub rotary: Vec<bool>,
    pub timed: Timed,
}

impl JointTrajectory {
    pub fn duration(&self) -> f64 {
        self.timed.times.last().copied().unwrap_or(0.0)
    }
}

fn normalise(v: [f64; 3]) -> Option<[f64; 3]> {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    (n.is_finite() && n > 1e-12).then(|| [v[0] / n, v[1] / n, v[2] / n])
}

/// The tool poses of a result, pass by pass (pockets: tool-centre paths at z = 0
/// with a vertical axis, stage by stage).
pub fn tool_poses(result: &PlanResult) -> Vec<Vec<ToolPose>> {
    if let Some(tools) = &result.tools {
        return tools
            .iter()
            .flat_map(|t| t.passes.iter())
            .map(|pass| {
                pass.iter()
                    .map(|p| ToolPose {
                        tip: [p[0], p[1], 0.0],
                        axis: [0.0, 0.0, 1.0],
                        normal: [0.0, 0.0, 1.0],
                    })
                    .collect()
            })
            .collect();
    }
    result
        .passes
        .iter()
        .map(|pass| {
            pass.points
                .iter()
                .map(|p| {
                    let normal = p
                        .normal
                        .and_then(normalise)
                        .or_else(|| {
                            normalise([p.cl[0] - p.cc[0], p.cl[1] - p.cc[1], p.cl[2] - p.cc[2]])
                        })
                        .unwrap_or([0.0, 0.0, 1.0]);
                    ToolPose {
                        tip: p.cl,
                        axis: p.axis,
                        normal,
                    }
                })
                .collect()
        })
        .collect()
}

fn offset(p: [f64; 3], d: [f64; 3], s: f64) -> [f64; 3] {
    [p[0] + s * d[0], p[1] + s * d[1], p[2] + s * d[2]]
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The shift (`offset` plus whole turns, smallest) that brings joint `j` of
/// every row into its travel, if one does.
fn turn_shift(rows: &[Vec<f64>], j: usize, l: &JointLimit, offset: f64) -> Option<f64> {
    let lo = rows.iter().map(|r| r[j]).fold(f64::INFINITY, f64::min) + offset;
    let hi = rows.iter().map(|r| r[j]).fold(f64::NEG_INFINITY, f64::max) + offset;
    let turn = 2.0 * PI;
    let k_lo = ((l.min - lo) / turn - 1e-12).ceil();
    let k_hi = ((l.max - hi) / turn + 1e-12).floor();
    (k_lo <= k_hi).then(|| offset + turn * k_lo.max(0.0).min(k_hi))
}

/// Shifts the rotary joints of each pass (with its approach and retract) by
/// whole turns into their travel: the machine may rewind between passes, but
/// never inside one. `flip` = (A, C) indices of a head whose other branch
/// (-A, C + pi) may be taken for a whole pass when no whole-turn shift fits.
/// Then checks every joint against its limits.
fn fit_limits(
    machine: &str,
    q: &mut [Vec<f64>],
    limits: &[JointLimit],
    origins: &[Origin],
    flip: Option<(usize, usize)>,
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
            } else if let Some((a, _)) = flip.filter(|f| f.1 == j) {
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
pub fn check_feed_rate(machine: Machine, feed_rate: f64, machines: &Machines) -> Result<()> {
    let max_feed = match machine {
        Machine::Mill5 => machines.mill5.max_feed_rate_mm_min,
        Machine::Belt6 => machines.belt6.max_feed_rate_mm_min,
    };
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

/// Builds the timed joint trajectory of a planned job on its machine.
pub fn trajectory(job: &Job, result: &PlanResult, machines: &Machines) -> Result<JointTrajectory> {
    let passes = tool_poses(result);
    check_feed_rate(job.machine, job.feed_rate, machines)?;
    let (retract, machine_name) = match job.machine {
        Machine::Mill5 => (machines.mill5.retract_mm, "mill5"),
        Machine::Belt6 => (machines.belt6.retract_mm, "belt6"),
    };
    let feed = job.feed_rate / 60.0;
    // Waypoints: (pose, origin, stop) and the segments between them.
    let mut poses: Vec<ToolPose> = Vec::new();
    let mut origins: Vec<Origin> = Vec::new();
    let mut stops: Vec<bool> = Vec::new();
    let mut rapid_before: Vec<bool> = Vec::new();
    for (p, pass) in passes.iter().enumerate() {
        let (Some(first), Some(last)) = (pass.first(), pass.last()) else {
            continue;
        };
        let lift = |t: &ToolPose| match job.machine {
            Machine::Mill5 => normalise(t.axis).unwrap_or([0.0, 0.0, 1.0]),
            Machine::Belt6 => t.normal,
        };
        let approach = ToolPose {
            tip: offset(first.tip, lift(first), retract),
            ..*first
        };
        let leave = ToolPose {
            tip: offset(last.tip, lift(last), retract),
            ..*last
        };
        poses.push(approach);
        origins.push(Origin::Approach(p));
        stops.push(true);
        rapid_before.push(true);
        for (k, t) in pass.iter().enumerate() {
            poses.push(*t);
            origins.push(Origin::Point(p, k));
            stops.push(false);
            rapid_before.push(false);
        }
        poses.push(leave);
        origins.push(Origin::Retract(p));
        stops.push(true);
        rapid_before.push(false);
    }
    let (joint_names, limits, mut q): (Vec<&'static str>, Vec<JointLimit>, Vec<Vec<f64>>) =
        match job.machine {
            Machine::Mill5 => {
                let cfg = &machines.mill5;
                let l = cfg.pivot_length_mm + job.tool_length();
                let input: Vec<([f64; 3], [f64; 3])> =
                    poses.iter().map(|t| (t.tip, t.axis)).collect();
                let q = mill5::inverse_path(cfg, l, &input)?;
                (
                    vec!["X", "Y", "Z", "A", "C"],
                    cfg.limits(),
                    q.into_iter().map(|r| r.to_vec()).collect(),
                )
            }
            Machine::Belt6 => {
                let cfg = &machines.belt6;
                let input: Vec<([f64; 3], [f64; 3], [f64; 3])> =
                    poses.iter().map(|t| (t.tip, t.axis, t.normal)).collect();
                let q = belt6::inverse_path(cfg, &input)?;
                (
                    vec!["X", "Y", "Z", "A", "B", "C"],
                    cfg.limits(),
                    q.into_iter().map(|r| r.to_vec()).collect(),
                )
            }
        };
    let flip = (job.machine == Machine::Mill5).then_some((3, 4));
    fit_limits(machine_name, &mut q, &limits, &origins, flip)?;
    let segments: Vec<Segment> = (1..poses.len())
        .map(|k| Segment {
            length: dist(poses[k - 1].tip, poses[k].tip),
            max_speed: (!rapid_before[k]).then_some(feed),
        })
        .collect();
    let rotary = limits.iter().map(|l| l.rotary).collect();
    let timed = timing::parameterise(q, &segments, &stops, &limits);
    Ok(JointTrajectory {
        machine: machine_name.to_string(),
        joint_names,
        rotary,
        timed,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::{JobFile, Pass, PathPoint, Shape, Strategy};
    use crate::tools::Tool;

    fn job(strategy: Strategy, tool: Tool, feed: f64) -> Job {
        let file = JobFile {
            job_id: "t".into(),
            surface: serde_json::Value::Null,
            strategy,
            tool: Some(tool),
            machine: None,
            scallop: Some(0.05),
            tolerance: Some(0.01),
            lead_angle_deg: None,
            side_tilt_deg: None,
            feed_direction: None,
            feed_rate: Some(feed),
            tool_catalogue: None,
            section_normal: None,
            simulation_resolution: None,
            grinding: None,
        };
        Job::new(file, Shape::Surface(crate::samples::surfaces::plane())).unwrap()
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
        fit_limits("mill5", &mut q, &limits, &o, Some((3, 4))).unwrap();
        assert!((q[0][4] - (5.0 - 2.0 * PI)).abs() < 1e-12);
        let mut q = vec![vec![0.0, 0.0, 0.0, 0.3, 0.0], vec![0.0, 0.0, 0.0, 0.3, 8.0]];
        let e = fit_limits("mill5", &mut q, &limits, &o, Some((3, 4)))
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
        fit_limits("mill5", &mut q, &limits, &o, Some((3, 4))).unwrap();
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
        fit_limits("mill5", &mut q, &limits, &o, Some((3, 4))).unwrap();
        assert!(
            (q[0][4] - c(200.0)).abs() < 1e-12 && (q[2][4] - c(-10.0)).abs() < 1e-12,
            "{q:?}"
        );
    }
}
