//! Messages <-> the crate's formats: incoming surfaces, pockets and jobs are
//! validated with the same checks and reasons as the CLI's files; results
//! become Toolpath, PoseArray, JointTrajectory and MarkerArray messages.
//!
//! | module | what |
//! | --- | --- |
//! | `shapes` | surfaces (with their trims) and pockets, both ways |
//! | `jobs` | jobs and tools, both ways, checked as job files are |
//! | `toolpath` | the Toolpath message of a plan and its tool poses |
//! | `trajectory` | joint trajectories, whole and per pass, both ways |
//! | `markers` | the RViz markers of a plan |

mod jobs;
mod markers;
mod shapes;
mod toolpath;
mod trajectory;

pub use jobs::{job_file_from_msg, job_from_msg, job_to_msg, prevalidate_job, tool_to_msg};
pub use markers::markers;
pub use shapes::{pocket_from_msg, pocket_to_msg, surface_from_msg, surface_to_msg};
pub use toolpath::{pose_array, pose_segments, toolpath_msg};
pub use trajectory::{joint_trajectory_msg, trajectory_chunks, trajectory_points};

use crate as msgs;

/// Metres per mm: messages carry SI units (REP 103).
const MM: f64 = 1e-3;

fn vec3(v: Option<[f64; 3]>) -> msgs::Vector3 {
    msgs::Vector3::from_array(v.unwrap_or([0.0; 3]))
}
