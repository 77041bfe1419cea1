//! toolpath_msgs/action/PlanToolpath and toolpath_msgs/srv/PlanToolpath:
//! one job planned on request, with feedback (action) or synchronously
//! (service). The service's request and response carry what the action's
//! goal and result carry, so one pair of structs serves both (CDR has no
//! type names).

use super::msgs::{ros_message, Job, JobStatus, Pocket, Surface, Toolpath, ToolpathStats, Uuid};
use serde::{Deserialize, Serialize};
use std::sync::LazyLock;

/// Package and name of the action and of the service type.
pub const PACKAGE: &str = "toolpath_msgs";
pub const NAME: &str = "PlanToolpath";

/// The .action text (goal, result, feedback, separated by `---`).
pub const ACTION_DEFINITION: &str = include_str!("../../../msg/action/PlanToolpath.action");
/// The .srv text (request, response).
pub const SERVICE_DEFINITION: &str = include_str!("../../../msg/srv/PlanToolpath.srv");

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
    /// Planning: estimated seconds left; negative: not known.
    pub eta_s: f32,
}

/// What the action's feedback topic (`plan_toolpath/_action/feedback`)
/// carries: the feedback and the goal it belongs to, as rosidl derives
/// `PlanToolpath_FeedbackMessage` from the .action file.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FeedbackMessage {
    pub goal_id: Uuid,
    pub feedback: Feedback,
}
ros_message!(
    FeedbackMessage,
    "toolpath_msgs",
    "action",
    "PlanToolpath_FeedbackMessage"
);

/// The .msg text rosidl generates for `PlanToolpath_FeedbackMessage`; the
/// feedback's type is named with its `action` namespace, as readers resolve it.
const FEEDBACK_MESSAGE_DEFINITION: &str =
    "unique_identifier_msgs/UUID goal_id\ntoolpath_msgs/action/PlanToolpath_Feedback feedback\n";

/// The feedback section of the .action text: `PlanToolpath_Feedback`'s fields.
static FEEDBACK_DEFINITION: LazyLock<String> = LazyLock::new(|| {
    sections(ACTION_DEFINITION)
        .into_iter()
        .nth(2)
        .unwrap_or_default()
});

/// The .msg texts of the types rosidl derives from the .action file: the
/// feedback message by `pkg/Type`, the feedback by `pkg/action/Type`.
pub fn derived_definition(full_name: &str) -> Option<&'static str> {
    match full_name {
        "toolpath_msgs/action/PlanToolpath_Feedback" => Some(FEEDBACK_DEFINITION.as_str()),
        "toolpath_msgs/PlanToolpath_FeedbackMessage" => Some(FEEDBACK_MESSAGE_DEFINITION),
        _ => None,
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{schema_text, RosMessage};

    #[test]
    fn the_feedback_message_schema_is_the_goal_id_and_the_action_feedback_section() {
        assert_eq!(
            FeedbackMessage::type_name(),
            "toolpath_msgs/action/PlanToolpath_FeedbackMessage"
        );
        let text = schema_text(&FeedbackMessage::full_name()).unwrap();
        let sep = "=".repeat(80);
        let parts: Vec<&str> = text.split(&sep).collect();
        assert_eq!(parts.len(), 3, "{text}");
        assert!(parts[1].starts_with("\nMSG: unique_identifier_msgs/UUID\n"));
        assert!(parts[1].contains("\nuint8[16] uuid\n"));
        // The feedback's fields as the .action file writes them, comments kept.
        assert!(parts[2].starts_with("\nMSG: toolpath_msgs/action/PlanToolpath_Feedback\n"));
        let fields: Vec<&str> = parts[2]
            .lines()
            .skip(2)
            .map(|l| l.split('#').next().unwrap_or("").trim())
            .filter(|l| !l.is_empty())
            .collect();
        assert_eq!(
            fields,
            ["string stage", "float32 progress", "float32 eta_s"]
        );
    }
}
