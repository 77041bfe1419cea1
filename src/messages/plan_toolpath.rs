//! toolpath_msgs/action/PlanToolpath and toolpath_msgs/srv/PlanToolpath:
//! one job planned on request, with feedback (action) or synchronously
//! (service). The service's request and response carry what the action's
//! goal and result carry, so one pair of structs serves both (CDR has no
//! type names).

use super::msgs::{Job, JobStatus, Pocket, Surface, Toolpath, ToolpathStats};
use serde::{Deserialize, Serialize};

/// Package and name of the action and of the service type.
pub const PACKAGE: &str = "toolpath_msgs";
pub const NAME: &str = "PlanToolpath";

/// The .action text (goal, result, feedback, separated by `---`).
pub const ACTION_DEFINITION: &str = include_str!("../../msg/action/PlanToolpath.action");
/// The .srv text (request, response).
pub const SERVICE_DEFINITION: &str = include_str!("../../msg/srv/PlanToolpath.srv");

/// A result carries the toolpath's passes up to this many points (a
/// ToolpathPoint is 176 bytes of CDR: about 18 MB); a larger toolpath is
/// taken from the toolpath topic.
pub const MAX_RESULT_POINTS: usize = 100_000;

/// The goal (and the service request): the job, and its shape inline or not.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Goal {
    pub job: Job,
    /// At most one: the surface inline.
    pub surface: Vec<Surface>,
    /// At most one: the pocket inline.
    pub pocket: Vec<Pocket>,
}

/// The service request.
pub type Request = Goal;

/// The result (and the service response).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GoalResult {
    /// [`JobStatus`] SUCCEEDED, FAILED, REJECTED or CANCELED.
    pub status: u8,
    pub reason: String,
    pub stats: ToolpathStats,
    pub warnings: Vec<String>,
    pub toolpath_omitted: bool,
    pub toolpath_topic: String,
    pub toolpath: Toolpath,
}

/// The service response.
pub type Response = GoalResult;

impl GoalResult {
    /// The result of a job that ended in `status` with `reason` (the final
    /// JobStatus message); `toolpath` is the message published on
    /// `toolpath_topic` when the job succeeded. Its passes are left out
    /// beyond [`MAX_RESULT_POINTS`].
    pub fn new(
        status: u8,
        reason: String,
        toolpath: Option<Toolpath>,
        toolpath_topic: &str,
    ) -> Self {
        let mut toolpath = toolpath.unwrap_or_default();
        let points: usize = toolpath.passes.iter().map(|p| p.points.len()).sum();
        let toolpath_omitted = points > MAX_RESULT_POINTS;
        if toolpath_omitted {
            toolpath.passes.clear();
        }
        Self {
            status,
            reason,
            stats: toolpath.stats.clone(),
            warnings: toolpath.warnings.clone(),
            toolpath_omitted,
            toolpath_topic: toolpath_topic.to_string(),
            toolpath,
        }
    }

    pub fn succeeded(&self) -> bool {
        self.status == JobStatus::SUCCEEDED
    }
}

/// Feedback: the stage and the progress within it.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Feedback {
    pub stage: String,
    pub progress: f32,
}

/// The sections of an .action or .srv text, split at its `---` lines.
pub fn sections(text: &str) -> Vec<String> {
    let mut out = vec![String::new()];
    for line in text.lines() {
        if line.trim() == "---" {
            out.push(String::new());
        } else if let Some(last) = out.last_mut() {
            last.push_str(line);
            last.push('\n');
        }
    }
    out
}
