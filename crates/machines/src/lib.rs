//! Machine kinematics (mill5, belt6) and timed joint trajectories
//! (docs/methods.md, "Machine kinematics and timing").
//!
//! Every machine is an [`AxisSet`] with [`Kinematics`] (forward, inverse
//! along a path, a head's other branch) and, as a machine of a cell, a
//! [`Machine`] (controller, home, retract and feed limits); the trajectory
//! code ([`trajectory::trajectory_on`]) sees only these traits.
//!
//! A planned toolpath becomes one joint trajectory per job: every pass is
//! entered and left along the tool axis (mill) or contact normal (belt) by the
//! machine's retract distance, cutting moves run at the job's feed, links
//! between passes are joint-limited rapids. Rotary joints are unwrapped to stay
//! continuous and then shifted by whole turns into their travel; a pose that
//! needs a joint outside its limits fails the job with a reason naming the
//! joint, the value, the range, the pass and the point.

pub mod axes;
pub mod belt6;
pub mod config;
pub mod controller;
pub mod five_axis;
pub mod jtc;
pub mod machine;
pub mod mill5;
pub mod placement;
pub mod timing;
pub mod trajectory;

pub use axes::{Axis, AxisSet};
pub use config::{Belt6Config, LinearAxis, Machines, Mill5Config, RotaryAxis};
pub use controller::{ControllerConfig, Stamp, StampPolicy};
pub use five_axis::{FiveAxis, FiveAxisConfig, FiveAxisKind};
pub use machine::{BranchFlip, Kinematics, Machine, TipAxis};
pub use placement::Placement;

use timing::Timed;
use toolpath_formats::{Job, PlanResult};
use toolpath_kernel::error::Result;

/// One tool pose of a toolpath: `tip` is the tool tip (belt: wheel centre),
/// `axis` the tool axis (belt: wheel axis), `normal` the contact normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToolPose {
    pub tip: [f64; 3],
    pub axis: [f64; 3],
    pub normal: [f64; 3],
}

/// A job's timed joint trajectory in internal units (mm, rad, s), as its
/// controller executes it: the first point (the first approach) comes after
/// the move from `start`, which JTC interpolates from the measured state.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct JointTrajectory {
    pub machine: String,
    /// The controller's joint names, in axis order.
    pub joint_names: Vec<String>,
    /// Per joint: true for rotary (rad), false for linear (mm).
    pub rotary: Vec<bool>,
    pub limits: Vec<Axis>,
    /// When the controller starts it.
    pub stamp: Stamp,
    /// The pose the machine starts from (a joint state or the home pose).
    pub start: Vec<f64>,
    /// Duration of the move from `start` to the first point, s.
    pub start_move_s: f64,
    /// Index of each pass's first waypoint (its approach) in `timed`: the
    /// machine is at rest there and at the retract before it.
    pub pass_starts: Vec<usize>,
    pub timed: Timed,
}

impl JointTrajectory {
    pub fn duration(&self) -> f64 {
        self.timed.times.last().copied().unwrap_or(0.0)
    }

    /// The trajectory as the controller receives it.
    pub fn points(&self) -> jtc::Points {
        jtc::Points {
            joint_names: self.joint_names.clone(),
            times: self.timed.times.clone(),
            positions: self.timed.positions.clone(),
            velocities: self.timed.velocities.clone(),
            accelerations: Vec::new(),
        }
    }
}

pub(crate) fn normalise(v: [f64; 3]) -> Option<[f64; 3]> {
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

/// Builds the timed joint trajectory of a planned job on its machine,
/// starting from the machine's home pose.
pub fn trajectory(job: &Job, result: &PlanResult, machines: &Machines) -> Result<JointTrajectory> {
    trajectory_from(job, result, machines, None)
}

/// Builds the timed joint trajectory of a planned job on its machine,
/// starting from `start` (a measured joint state, mm and rad in axis order;
/// `None` = the machine's home pose).
pub fn trajectory_from(
    job: &Job,
    result: &PlanResult,
    machines: &Machines,
    start: Option<&[f64]>,
) -> Result<JointTrajectory> {
    trajectory::trajectory_on(machines.machine(job.machine), job, result, start)
}

/// Rejects a feed rate (mm/min) above the machine's maximum.
pub fn check_feed_rate(
    machine: toolpath_formats::Machine,
    feed_rate: f64,
    machines: &Machines,
) -> Result<()> {
    trajectory::check_feed_rate(machines.machine(machine), feed_rate)
}
