//! Topic names of the node, relative to its namespace (the node in `/cell_b`
//! reads `/cell_b/job`).

use toolpath_formats::Machine;

/// Input: NURBS surfaces, by `surface_id`.
pub const SURFACE: &str = "surface";
/// Input: pockets, by `pocket_id` (jobs name them in `surface_id`).
pub const POCKET: &str = "pocket";
/// Input: jobs.
pub const JOB: &str = "job";
/// Input: the machines' measured joint positions (sensor_msgs/JointState).
pub const JOINT_STATES: &str = "joint_states";
/// Input: a job id (std_msgs/String) whose execution is to be canceled.
pub const CANCEL: &str = "cancel";
/// Output: the planned toolpath (mm, as the result file).
pub const TOOLPATH: &str = "toolpath";
/// Output: tool poses (m, REP 103).
pub const TOOL_POSES: &str = "tool_poses";
/// Output: tool poses, one PoseArray per pass (m, REP 103).
pub const TOOL_POSE_SEGMENTS: &str = "tool_pose_segments";
/// Output: the 5-axis mill's joint trajectory.
pub const MILL5_TRAJECTORY: &str = "mill5/joint_trajectory";
/// Output: the 6-axis belt grinder's joint trajectory.
pub const BELT6_TRAJECTORY: &str = "belt6/joint_trajectory";
/// Output: every status of every job (ACCEPTED .. a final state).
pub const JOB_STATUS: &str = "job_status";
/// Output: RViz markers of the passes, degenerate points and separatrices.
pub const MARKERS: &str = "markers";
/// The PlanToolpath action (and the service of the same name).
pub const PLAN_TOOLPATH: &str = "plan_toolpath";
/// Output: the action's feedback, per goal (PlanToolpath_FeedbackMessage).
pub const PLAN_TOOLPATH_FEEDBACK: &str = "plan_toolpath/_action/feedback";
/// Output: the action's goal states (action_msgs/GoalStatusArray).
pub const PLAN_TOOLPATH_STATUS: &str = "plan_toolpath/_action/status";

/// The topic a joint trajectory of `machine` is published on.
pub fn trajectory(machine: Machine) -> &'static str {
    match machine {
        Machine::Mill5 => MILL5_TRAJECTORY,
        Machine::Belt6 => BELT6_TRAJECTORY,
    }
}

/// The absolute name of the `relative` topic in `namespace` (`/` or `/cell_b`;
/// a trailing `/` is ignored): `/job`, `/cell_b/job`.
pub fn absolute(namespace: &str, relative: &str) -> String {
    format!("{}/{relative}", namespace.trim_end_matches('/'))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn absolute_names_in_the_root_and_in_a_namespace() {
        assert_eq!(absolute("/", JOB), "/job");
        assert_eq!(absolute("", JOB), "/job");
        assert_eq!(
            absolute("/cell_b", MILL5_TRAJECTORY),
            "/cell_b/mill5/joint_trajectory"
        );
        assert_eq!(absolute("/cell_b/", JOB_STATUS), "/cell_b/job_status");
        assert_eq!(trajectory(Machine::Belt6), "belt6/joint_trajectory");
    }
}
