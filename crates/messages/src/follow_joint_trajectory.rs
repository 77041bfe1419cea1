//! control_msgs/action/FollowJointTrajectory (ROS 2 Jazzy, control_msgs 5.x)
//! and the standard types it nests, in .msg field order. The node sends its
//! trajectories to a joint_trajectory_controller with it; the test controller
//! serves it.

use super::msgs::ros_message;
use super::msgs::{Duration, Header, JointTrajectory, JointTrajectoryPoint, Quaternion, Vector3};
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    pub translation: Vector3,
    pub rotation: Quaternion,
}
ros_message!(Transform, "geometry_msgs", "Transform");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Twist {
    pub linear: Vector3,
    pub angular: Vector3,
}
ros_message!(Twist, "geometry_msgs", "Twist");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MultiDOFJointTrajectoryPoint {
    pub transforms: Vec<Transform>,
    pub velocities: Vec<Twist>,
    pub accelerations: Vec<Twist>,
    pub time_from_start: Duration,
}
ros_message!(
    MultiDOFJointTrajectoryPoint,
    "trajectory_msgs",
    "MultiDOFJointTrajectoryPoint"
);

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MultiDOFJointTrajectory {
    pub header: Header,
    pub joint_names: Vec<String>,
    pub points: Vec<MultiDOFJointTrajectoryPoint>,
}
ros_message!(
    MultiDOFJointTrajectory,
    "trajectory_msgs",
    "MultiDOFJointTrajectory"
);

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JointTolerance {
    pub name: String,
    pub position: f64,
    pub velocity: f64,
    pub acceleration: f64,
}
ros_message!(JointTolerance, "control_msgs", "JointTolerance");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JointComponentTolerance {
    pub joint_name: String,
    pub component: u16,
    pub position: f64,
    pub velocity: f64,
    pub acceleration: f64,
}
ros_message!(
    JointComponentTolerance,
    "control_msgs",
    "JointComponentTolerance"
);

/// The goal: a trajectory; empty tolerances take the controller's defaults.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Goal {
    pub trajectory: JointTrajectory,
    pub multi_dof_trajectory: MultiDOFJointTrajectory,
    pub path_tolerance: Vec<JointTolerance>,
    pub component_path_tolerance: Vec<JointComponentTolerance>,
    pub goal_tolerance: Vec<JointTolerance>,
    pub component_goal_tolerance: Vec<JointComponentTolerance>,
    pub goal_time_tolerance: Duration,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GoalResult {
    pub error_code: i32,
    pub error_string: String,
}

impl GoalResult {
    pub const SUCCESSFUL: i32 = 0;
    pub const INVALID_GOAL: i32 = -1;
    pub const INVALID_JOINTS: i32 = -2;
    pub const OLD_HEADER_TIMESTAMP: i32 = -3;
    pub const PATH_TOLERANCE_VIOLATED: i32 = -4;
    pub const GOAL_TOLERANCE_VIOLATED: i32 = -5;

    /// The constant's name of an error code.
    pub fn code_name(code: i32) -> &'static str {
        match code {
            0 => "SUCCESSFUL",
            -1 => "INVALID_GOAL",
            -2 => "INVALID_JOINTS",
            -3 => "OLD_HEADER_TIMESTAMP",
            -4 => "PATH_TOLERANCE_VIOLATED",
            -5 => "GOAL_TOLERANCE_VIOLATED",
            _ => "unknown",
        }
    }
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Feedback {
    pub header: Header,
    pub joint_names: Vec<String>,
    pub desired: JointTrajectoryPoint,
    pub actual: JointTrajectoryPoint,
    pub error: JointTrajectoryPoint,
    pub multi_dof_joint_names: Vec<String>,
    pub multi_dof_desired: MultiDOFJointTrajectoryPoint,
    pub multi_dof_actual: MultiDOFJointTrajectoryPoint,
    pub multi_dof_error: MultiDOFJointTrajectoryPoint,
}

/// Package and name of the action type.
pub const ACTION_PACKAGE: &str = "control_msgs";
pub const ACTION_NAME: &str = "FollowJointTrajectory";

/// std_msgs/String (the node's `cancel` topic carries a job id in it).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StringMsg {
    pub data: String,
}
ros_message!(StringMsg, "std_msgs", "String");
