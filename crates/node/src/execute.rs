//! Execution of planned trajectories through a controller's
//! FollowJointTrajectory action (on with `controller.execute: true`): one
//! goal per pass, each sent when the previous one succeeded; acceptance,
//! progress (feedback) and the result go into the job's status; a rejected,
//! aborted or canceled pass ends the job with the controller's error code.
//! A cancel of the job (topic `cancel`, or the node stopping) is forwarded to
//! the controller.

use super::dds::RosNode;
use futures::{FutureExt, StreamExt};
use ros2_client::action::{ActionClient, ActionClientQosPolicies, ActionServerQosPolicies};
use ros2_client::action_msgs::GoalStatusEnum;
use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::ros2::QosProfile;
use ros2_client::ActionTypeName;
use std::collections::BTreeSet;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use toolpath_kernel::error::{Error, Result};
use toolpath_messages::follow_joint_trajectory::{
    Feedback, Goal, GoalResult, ACTION_NAME, ACTION_PACKAGE,
};
use toolpath_messages::{self as msgs, topics};

pub type FollowJointTrajectoryClient = ActionClient<Goal, GoalResult, Feedback>;

/// How long the controller has to answer a goal or a cancel.
pub const ANSWER_TIMEOUT: Duration = Duration::from_secs(10);

/// rcl's defaults for action services and topics: reliable, volatile, keep
/// last 10; the status topic transient-local, keep last 1.
fn service_qos() -> QosProfile {
    QosProfile::subscription_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_secs(1)))
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
}

pub fn client_qos() -> ActionClientQosPolicies {
    ActionClientQosPolicies {
        goal_service: service_qos(),
        result_service: service_qos(),
        cancel_service: service_qos(),
        feedback_subscription: service_qos(),
        status_subscription: service_qos(),
    }
}

pub fn server_qos() -> ActionServerQosPolicies {
    ActionServerQosPolicies {
        goal_service: service_qos(),
        result_service: service_qos(),
        cancel_service: service_qos(),
        feedback_publisher: service_qos(),
        status_publisher: service_qos()
            .durability(Durability::TransientLocal)
            .history(History::KeepLast { depth: 1 }),
    }
}

pub fn action_type() -> ActionTypeName {
    ActionTypeName::new(ACTION_PACKAGE, ACTION_NAME)
}

/// The action client of `action` (relative names go under the namespace).
pub fn client(ros: &mut RosNode, action: &str) -> Result<FollowJointTrajectoryClient> {
    let name = super::dds::topic_name(&ros.namespace, action)?;
    ros.node
        .create_action_client(ros.service_mapping, &name, &action_type(), client_qos())
        .map_err(|e| Error::dds(format!("cannot create action client {action}: {e:?}")))
}

/// One job to execute: its passes, and where the outcome goes (the worker
/// that planned it waits for it).
pub struct Execution {
    pub job_id: String,
    pub chunks: Vec<msgs::JointTrajectory>,
    pub reply: std::sync::mpsc::Sender<Result<String>>,
}

/// Cancel requests by job id; `all` after the node was told to stop.
#[derive(Default)]
pub struct Cancels {
    ids: Mutex<(BTreeSet<String>, bool)>,
    wake: tokio::sync::Notify,
}

impl Cancels {
    pub fn cancel(&self, job_id: &str) {
        self.lock().0.insert(job_id.to_string());
        self.wake.notify_waiters();
    }
    pub fn cancel_all(&self) {
        self.lock().1 = true;
        self.wake.notify_waiters();
    }
    /// Whether `job_id` itself was canceled (not everything at shut-down:
    /// planning finishes then, as before).
    pub fn requested(&self, job_id: &str) -> bool {
        self.lock().0.contains(job_id)
    }
    /// Drops the cancel of a job that has ended.
    pub fn forget(&self, job_id: &str) {
        self.lock().0.remove(job_id);
    }
    fn is_canceled(&self, job_id: &str) -> bool {
        let g = self.lock();
        g.1 || g.0.contains(job_id)
    }
    fn lock(&self) -> std::sync::MutexGuard<'_, (BTreeSet<String>, bool)> {
        match self.ids.lock() {
            Ok(g) => g,
            Err(p) => p.into_inner(),
        }
    }
}

/// Progress report of an execution: fraction done and a status text.
pub type Report<'a> = dyn Fn(f32, String) + Send + Sync + 'a;

fn duration_of(t: &msgs::JointTrajectory) -> f64 {
    t.points
        .last()
        .map_or(0.0, |p| p.time_from_start.as_secs_f64())
}

fn answer<T>(
    what: &str,
    action: &str,
    r: std::result::Result<
        std::result::Result<T, impl std::fmt::Debug>,
        tokio::time::error::Elapsed,
    >,
) -> Result<T> {
    r.map_err(|_| {
        Error::execution(format!(
            "{action}: no answer to {what} within {} s: is the controller running?",
            ANSWER_TIMEOUT.as_secs()
        ))
    })?
    .map_err(|e| Error::execution(format!("{action}: {what} failed: {e:?}")))
}

/// Executes `e` pass by pass on `client`; the summary of a full run, or why
/// it stopped (naming the pass and the controller's error code).
pub async fn execute(
    client: &FollowJointTrajectoryClient,
    action: &str,
    e: &Execution,
    cancels: &Cancels,
    report: &Report<'_>,
) -> Result<String> {
    let n = e.chunks.len();
    let total: f64 = e.chunks.iter().map(duration_of).sum::<f64>().max(1e-9);
    let started = Instant::now();
    let mut done = 0.0;
    for (i, chunk) in e.chunks.iter().enumerate() {
        let pass = Pass {
            name: format!("pass {}/{n}", i + 1),
            action,
            done,
            total,
        };
        if cancels.is_canceled(&e.job_id) {
            return Err(Error::execution(format!(
                "canceled before {}: not sent to {action}",
                pass.name
            )));
        }
        follow_pass(client, &pass, chunk, &e.job_id, cancels, report).await?;
        done += duration_of(chunk);
    }
    Ok(format!(
        "executed {n} passes on {action} in {:.1} s",
        started.elapsed().as_secs_f64()
    ))
}

/// One pass of an execution: its name, the controller's action, and the
/// trajectory seconds before it and in all (for the progress fraction).
struct Pass<'a> {
    name: String,
    action: &'a str,
    done: f64,
    total: f64,
}

/// Sends one pass to the controller and follows it to its end: feedback as
/// progress, a cancel of the job forwarded to the controller.
async fn follow_pass(
    client: &FollowJointTrajectoryClient,
    pass: &Pass<'_>,
    chunk: &msgs::JointTrajectory,
    job_id: &str,
    cancels: &Cancels,
    report: &Report<'_>,
) -> Result<()> {
    let (action, name, total) = (pass.action, &pass.name, pass.total);
    let goal = Goal {
        trajectory: chunk.clone(),
        ..Default::default()
    };
    let (goal_id, response) = answer(
        &format!("the goal of {name}"),
        action,
        tokio::time::timeout(ANSWER_TIMEOUT, client.async_send_goal(goal)).await,
    )?;
    if !response.accepted {
        return Err(Error::execution(format!(
            "{action} rejected {name} (the trajectory breaks one of its rules or it is busy)"
        )));
    }
    report(
        (pass.done / total) as f32,
        format!("executing {name} on {action}: accepted"),
    );
    let result = client.async_request_result(goal_id).fuse();
    let feedback = client.feedback_stream(goal_id);
    futures::pin_mut!(result, feedback);
    let mut last_report = Instant::now();
    let mut cancel_sent = false;
    let outcome = loop {
        tokio::select! {
            r = &mut result => break r,
            Some(Ok(fb)) = feedback.next() => {
                if last_report.elapsed() >= Duration::from_millis(200) {
                    last_report = Instant::now();
                    let t = fb.desired.time_from_start.as_secs_f64();
                    report(
                        ((pass.done + t) / total).min(1.0) as f32,
                        format!("executing {name} on {action}: {t:.1} of {:.1} s", duration_of(chunk)),
                    );
                }
            }
            _ = cancels.wake.notified(), if !cancel_sent => {
                if cancels.is_canceled(job_id) {
                    cancel_sent = true;
                    let zero = ros2_client::builtin_interfaces::Time::ZERO;
                    answer(
                        "the cancel request",
                        action,
                        tokio::time::timeout(ANSWER_TIMEOUT, client.async_cancel_goal(goal_id, zero)).await,
                    )?;
                }
            }
        }
    };
    let (status, r) = outcome
        .map_err(|err| Error::execution(format!("{action}: no result of {name}: {err:?}")))?;
    pass_outcome(status, &r, name, action)
}

/// Whether a pass the controller ended with `status` and result `r` succeeded.
fn pass_outcome(status: GoalStatusEnum, r: &GoalResult, pass: &str, action: &str) -> Result<()> {
    match status {
        GoalStatusEnum::Succeeded => Ok(()),
        GoalStatusEnum::Canceled => Err(Error::execution(format!(
            "canceled during {pass}: {action} stopped it"
        ))),
        GoalStatusEnum::Aborted => Err(Error::execution(format!(
            "{action} aborted {pass}: error_code {} ({}){}",
            r.error_code,
            GoalResult::code_name(r.error_code),
            if r.error_string.is_empty() {
                String::new()
            } else {
                format!(": {}", r.error_string)
            }
        ))),
        other => Err(Error::execution(format!(
            "{action} ended {pass} in state {other:?}"
        ))),
    }
}

/// The task executing one machine's jobs one after another.
pub async fn executor(
    client: Arc<FollowJointTrajectoryClient>,
    action: String,
    mut jobs: tokio::sync::mpsc::UnboundedReceiver<(Execution, Arc<Report<'static>>)>,
    cancels: Arc<Cancels>,
) {
    while let Some((e, report)) = jobs.recv().await {
        let r = execute(&client, &action, &e, &cancels, report.as_ref()).await;
        let _ = e.reply.send(r);
    }
}

/// The relative topic the node takes job ids to cancel from.
pub const CANCEL_TOPIC: &str = topics::CANCEL;
