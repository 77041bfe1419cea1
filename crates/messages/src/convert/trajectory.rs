//! Joint trajectories as messages, whole and per pass, and back.

use super::MM;
use crate as msgs;
use toolpath_machines::{self as machines, JointTrajectory};

/// The joint trajectory as a ROS message: metres and radians (REP 103). Its
/// stamp follows the machine's start policy: zero (JTC starts on receipt) or
/// `header`'s stamp plus the start delay.
pub fn joint_trajectory_msg(t: &JointTrajectory, header: msgs::Header) -> msgs::JointTrajectory {
    let header = msgs::Header {
        stamp: match t.stamp {
            machines::Stamp::Zero => msgs::Time::ZERO,
            machines::Stamp::At(delay_s) => header.stamp.plus_secs(delay_s),
        },
        ..header
    };
    let scale: Vec<f64> = t.rotary.iter().map(|r| if *r { 1.0 } else { MM }).collect();
    let points = t
        .timed
        .times
        .iter()
        .enumerate()
        .map(|(k, time)| msgs::JointTrajectoryPoint {
            positions: t.timed.positions[k]
                .iter()
                .zip(&scale)
                .map(|(x, s)| x * s)
                .collect(),
            velocities: t.timed.velocities[k]
                .iter()
                .zip(&scale)
                .map(|(x, s)| x * s)
                .collect(),
            accelerations: Vec::new(),
            effort: Vec::new(),
            time_from_start: msgs::Duration::from_secs_f64(*time),
        })
        .collect();
    msgs::JointTrajectory {
        header,
        joint_names: t.joint_names.iter().map(|s| s.to_string()).collect(),
        points,
    }
}

/// The trajectory message cut into one trajectory per pass, for a controller
/// that executes each when the previous one succeeded: each runs from a
/// pass's approach to its retract (at rest at both), its times counted from
/// the end of the previous pass, so its first point comes after the link
/// from where the previous pass left the machine.
pub fn trajectory_chunks(
    t: &JointTrajectory,
    m: &msgs::JointTrajectory,
) -> Vec<msgs::JointTrajectory> {
    let mut starts = t.pass_starts.clone();
    if starts.first() != Some(&0) {
        starts.insert(0, 0);
    }
    starts.push(m.points.len());
    starts
        .windows(2)
        .filter(|w| w[1] > w[0])
        .map(|w| {
            let origin = if w[0] == 0 {
                0.0
            } else {
                t.timed.times[w[0] - 1]
            };
            msgs::JointTrajectory {
                header: m.header.clone(),
                joint_names: m.joint_names.clone(),
                points: m.points[w[0]..w[1]]
                    .iter()
                    .zip(&t.timed.times[w[0]..w[1]])
                    .map(|(p, time)| msgs::JointTrajectoryPoint {
                        time_from_start: msgs::Duration::from_secs_f64(time - origin),
                        ..p.clone()
                    })
                    .collect(),
            }
        })
        .collect()
}

/// A JointTrajectory message in internal units (mm, rad), for the joints
/// `names` with `limits` (a joint not among them is left unscaled; the
/// controller rules reject it by name).
pub fn trajectory_points(
    m: &msgs::JointTrajectory,
    names: &[String],
    limits: &[machines::Axis],
) -> machines::jtc::Points {
    let scale: Vec<f64> = m
        .joint_names
        .iter()
        .map(|n| match names.iter().position(|x| x == n) {
            Some(j) if !limits[j].rotary => 1.0 / MM,
            _ => 1.0,
        })
        .collect();
    let rows = |r: &[f64]| -> Vec<f64> {
        r.iter()
            .zip(scale.iter().chain(std::iter::repeat(&1.0)))
            .map(|(x, s)| x * s)
            .collect()
    };
    let accelerations: Vec<Vec<f64>> = m.points.iter().map(|p| rows(&p.accelerations)).collect();
    machines::jtc::Points {
        joint_names: m.joint_names.clone(),
        times: m
            .points
            .iter()
            .map(|p| p.time_from_start.as_secs_f64())
            .collect(),
        positions: m.points.iter().map(|p| rows(&p.positions)).collect(),
        velocities: m.points.iter().map(|p| rows(&p.velocities)).collect(),
        accelerations: if accelerations.iter().all(|a| a.is_empty()) {
            Vec::new()
        } else {
            accelerations
        },
    }
}
