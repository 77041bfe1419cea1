//! The PlanToolpath action and service of the node (`plan_toolpath` in its
//! namespace): a goal or a request is one job, queued for the node's
//! workers exactly like a job from topic `job` (the same statuses on
//! `job_status`, the same outputs on the result topics), and answered with
//! the job's final state, reason, statistics and toolpath.
//!
//! Every goal is accepted at the action level; a bad one (bad job, bad or
//! unknown shape, job_id in use) ends at once with status REJECTED and the
//! reason, since an action rejection carries none. Canceling a goal cancels
//! its job: a queued job leaves the queue at once, a job being planned stops
//! at the planner's next progress check ([`toolpath_planners::Progress::check`]),
//! an executing job is canceled at the controller; it ends CANCELED.
//!
//! This module is the DDS side; [`GoalQueue`] is how it hands jobs to the
//! node's queue, and [`GoalLink`] how the worker reports back.

use super::dds::{topic_name, RosNode};
use super::execute::{client_qos, server_qos};
use ros2_client::action::ActionClient;
use ros2_client::action::{AsyncActionServer, ExecutingGoalHandle, GoalEndStatus, GoalId};
use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::ros2::QosProfile;
use ros2_client::{ActionTypeName, Client, Server, ServiceTypeName};
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use toolpath_kernel::error::{Error, Result};
use toolpath_messages::plan_toolpath::{
    Feedback, FeedbackMessage, Goal, GoalResult, NAME, PACKAGE,
};
use toolpath_messages::{self as msgs, final_state, topics};

/// The action's and the service's name, relative to the node's namespace.
pub const ACTION: &str = topics::PLAN_TOOLPATH;
/// The service's name (services and actions have separate names in ROS 2).
pub const SERVICE: &str = topics::PLAN_TOOLPATH;

/// How long a finished goal waits for its client to ask for the result.
pub const RESULT_WAIT: Duration = Duration::from_secs(300);

pub fn action_type() -> ActionTypeName {
    ActionTypeName::new(PACKAGE, NAME)
}

pub fn service_type() -> ServiceTypeName {
    ServiceTypeName::new(PACKAGE, NAME)
}

/// rcl's default QoS of services: reliable, volatile, keep last 10.
pub fn service_qos() -> QosProfile {
    QosProfile::subscription_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_secs(1)))
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
}

/// A client of the node's PlanToolpath action.
pub type PlanToolpathClient = ActionClient<Goal, GoalResult, Feedback>;

/// A client of the action `plan_toolpath` of a node in `ros`'s namespace.
pub fn action_client(ros: &mut RosNode) -> Result<PlanToolpathClient> {
    let name = topic_name(&ros.namespace, ACTION)?;
    ros.node
        .create_action_client(ros.service_mapping, &name, &action_type(), client_qos())
        .map_err(|e| Error::dds(format!("cannot create action client {ACTION}: {e:?}")))
}

/// A client of the service `plan_toolpath` of a node in `ros`'s namespace.
pub fn service_client(ros: &mut RosNode) -> Result<Client<Goal, GoalResult>> {
    let name = topic_name(&ros.namespace, SERVICE)?;
    ros.node
        .create_client(
            ros.service_mapping,
            &name,
            &service_type(),
            service_qos(),
            service_qos(),
        )
        .map_err(|e| Error::dds(format!("cannot create service client {SERVICE}: {e:?}")))
}

/// What the worker reports to a goal's task.
#[derive(Debug)]
pub enum GoalEvent {
    Feedback(Feedback),
    /// The job's final state and its reason (the final JobStatus).
    Done(u8, String),
}

/// A goal's (or a service request's) job as the node's queue and workers see
/// it: whether its client canceled it, where progress and the end go, and
/// the toolpath it published.
pub struct GoalLink {
    pub job_id: String,
    /// The goal's id (`None`: a service request).
    pub goal_id: Option<[u8; 16]>,
    canceled: AtomicBool,
    executing: AtomicBool,
    done: AtomicBool,
    events: tokio::sync::mpsc::UnboundedSender<GoalEvent>,
    toolpath: Mutex<Option<msgs::Toolpath>>,
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    match m.lock() {
        Ok(g) => g,
        Err(p) => p.into_inner(),
    }
}

impl GoalLink {
    pub fn new(job_id: &str) -> (Arc<Self>, tokio::sync::mpsc::UnboundedReceiver<GoalEvent>) {
        Self::of_goal(job_id, None)
    }

    /// The link of the goal `goal_id` (`None`: a service request).
    pub fn of_goal(
        job_id: &str,
        goal_id: Option<[u8; 16]>,
    ) -> (Arc<Self>, tokio::sync::mpsc::UnboundedReceiver<GoalEvent>) {
        let (events, rx) = tokio::sync::mpsc::unbounded_channel();
        let link = Self {
            job_id: job_id.to_string(),
            goal_id,
            canceled: AtomicBool::new(false),
            executing: AtomicBool::new(false),
            done: AtomicBool::new(false),
            events,
            toolpath: Mutex::new(None),
        };
        (Arc::new(link), rx)
    }

    /// The client asked to cancel: the worker's progress checks see it.
    pub fn cancel(&self) {
        self.canceled.store(true, Ordering::SeqCst);
    }

    pub fn is_canceled(&self) -> bool {
        self.canceled.load(Ordering::SeqCst)
    }

    /// `Err(Error::Stopped)` once the client has canceled: a planner stops at
    /// its next progress check.
    pub fn check(&self) -> Result<()> {
        if self.is_canceled() {
            return Err(Error::canceled(format!(
                "job {}: its PlanToolpath goal was canceled by the client",
                self.job_id
            )));
        }
        Ok(())
    }

    /// Feedback of the goal: its stage, the progress within it and the
    /// estimated seconds left (negative: not known).
    pub fn feedback(&self, stage: &str, progress: f32, eta_s: f32) {
        let _ = self.events.send(GoalEvent::Feedback(Feedback {
            stage: stage.to_string(),
            progress,
            eta_s,
        }));
    }

    /// The job's passes went to the controller: a cancel goes there too.
    pub fn set_executing(&self) {
        self.executing.store(true, Ordering::SeqCst);
    }

    pub fn is_executing(&self) -> bool {
        self.executing.load(Ordering::SeqCst)
    }

    /// Keeps the toolpath message the job published, for the result.
    pub fn keep_toolpath(&self, toolpath: &msgs::Toolpath) {
        *lock(&self.toolpath) = Some(toolpath.clone());
    }

    /// The job has ended (its final status was published). Once only.
    pub fn finish(&self, state: u8, reason: String) {
        if !self.done.swap(true, Ordering::SeqCst) {
            let _ = self.events.send(GoalEvent::Done(state, reason));
        }
    }

    pub fn is_done(&self) -> bool {
        self.done.load(Ordering::SeqCst)
    }

    fn take_toolpath(&self) -> Option<msgs::Toolpath> {
        lock(&self.toolpath).take()
    }
}

/// The node's side: its job queue.
pub trait GoalQueue: Send + Sync {
    /// Checks a goal's job and queues it with `link` (an ACCEPTED status on
    /// `job_status`); an error is why it was refused (its final status has
    /// been published).
    fn submit(&self, goal: Goal, link: &Arc<GoalLink>) -> Result<()>;
    /// Cancels the job of `link`: removed from the queue (and finished
    /// CANCELED) when it has not started, else stopped by its progress
    /// checks or at the controller.
    fn cancel(&self, link: &Arc<GoalLink>);
    /// The action published `msg` on its feedback topic (for the recording).
    fn feedback_published(&self, _msg: &FeedbackMessage) {}
    /// The action published `msg` on its status topic (for the recording).
    fn status_published(&self, _msg: &msgs::GoalStatusArray) {}
}

/// ros2-client's goal id as the message type.
fn goal_uuid(id: &GoalId) -> msgs::Uuid {
    msgs::Uuid {
        uuid: id.uuid.into_bytes(),
    }
}

/// ros2-client's status array as the message type (the same CDR bytes).
fn status_array(a: &ros2_client::action_msgs::GoalStatusArray) -> msgs::GoalStatusArray {
    msgs::GoalStatusArray {
        status_list: a
            .status_list
            .iter()
            .map(|s| msgs::GoalStatus {
                goal_info: msgs::GoalInfo {
                    goal_id: goal_uuid(&s.goal_info.goal_id),
                    stamp: {
                        let ns = s.goal_info.stamp.to_nanos();
                        msgs::Time {
                            sec: i32::try_from(ns.div_euclid(1_000_000_000)).unwrap_or(i32::MAX),
                            nanosec: ns.rem_euclid(1_000_000_000) as u32,
                        }
                    },
                },
                status: s.status as i8,
            })
            .collect(),
    }
}

type PlanServer = AsyncActionServer<Goal, GoalResult, Feedback>;

/// Submits `goal`, then waits for its end, publishing feedback on `action`
/// (none for a service request); the result to send.
async fn run_job(
    queue: &dyn GoalQueue,
    goal: Goal,
    link: &Arc<GoalLink>,
    mut events: tokio::sync::mpsc::UnboundedReceiver<GoalEvent>,
    toolpath_topic: &str,
    action: Option<(&PlanServer, ExecutingGoalHandle<Goal>)>,
) -> GoalResult {
    let on_feedback = async |f: Feedback| {
        if let Some((server, handle)) = &action {
            let msg = FeedbackMessage {
                goal_id: goal_uuid(&handle.goal_id()),
                feedback: f.clone(),
            };
            // A goal being canceled takes no feedback: ignore the refusal.
            if server.publish_feedback(handle.clone(), f).await.is_ok() {
                queue.feedback_published(&msg);
            }
        }
    };
    if let Err(e) = queue.submit(goal, link) {
        return GoalResult::new(final_state(&e), e.to_string(), None, toolpath_topic);
    }
    on_feedback(Feedback {
        stage: "queued".into(),
        progress: 0.0,
        eta_s: -1.0,
    })
    .await;
    let (state, reason) = loop {
        match events.recv().await {
            Some(GoalEvent::Feedback(f)) => on_feedback(f).await,
            Some(GoalEvent::Done(state, reason)) => break (state, reason),
            None => {
                break (
                    msgs::JobStatus::FAILED,
                    "the node stopped before the job ended".to_string(),
                )
            }
        }
    };
    let toolpath = (state == msgs::JobStatus::SUCCEEDED)
        .then(|| link.take_toolpath())
        .flatten();
    GoalResult::new(state, reason, toolpath, toolpath_topic)
}

/// The goals being served, by goal id.
type Goals = Arc<Mutex<BTreeMap<GoalId, Arc<GoalLink>>>>;

/// Serves one accepted goal to its end.
async fn serve_goal(
    server: Arc<PlanServer>,
    executing: ExecutingGoalHandle<Goal>,
    goal: Goal,
    queue: Arc<dyn GoalQueue>,
    goals: Goals,
    toolpath_topic: String,
) {
    let goal_id = executing.goal_id();
    let (link, events) = GoalLink::of_goal(&goal.job.job_id, Some(goal_id.uuid.into_bytes()));
    lock(&goals).insert(goal_id, Arc::clone(&link));
    let result = run_job(
        queue.as_ref(),
        goal,
        &link,
        events,
        &toolpath_topic,
        Some((&server, executing.clone())),
    )
    .await;
    let end = match result.status {
        msgs::JobStatus::SUCCEEDED => GoalEndStatus::Succeeded,
        msgs::JobStatus::CANCELED => GoalEndStatus::Canceled,
        _ => GoalEndStatus::Aborted,
    };
    // The result goes out when the client asks for it. Several goals wait
    // on one result-request reader and park each other's requests, so wait
    // in short rounds that look at the parked requests again.
    let deadline = Instant::now() + RESULT_WAIT;
    loop {
        let send = server.send_result_response(executing.clone(), end, result.clone());
        match tokio::time::timeout(Duration::from_millis(200), send).await {
            Ok(Ok(())) => break,
            Ok(Err(e)) => {
                log::warn!(
                    "PlanToolpath goal of job {}: cannot send the result: {e:?}",
                    link.job_id
                );
                break;
            }
            Err(_) if Instant::now() < deadline => continue,
            Err(_) => {
                log::warn!(
                    "PlanToolpath goal of job {}: its client did not ask for the result within {} s",
                    link.job_id,
                    RESULT_WAIT.as_secs()
                );
                break;
            }
        }
    }
    lock(&goals).remove(&goal_id);
}

/// Accepts every goal and serves each on a task of its own.
async fn accept_goals(
    server: Arc<PlanServer>,
    queue: Arc<dyn GoalQueue>,
    goals: Goals,
    toolpath_topic: String,
) {
    loop {
        let handle = match server.receive_new_goal().await {
            Ok(h) => h,
            Err(e) => {
                log::warn!("PlanToolpath: undecodable goal request: {e:?}");
                continue;
            }
        };
        let Some(goal) = server.get_new_goal(handle.clone()) else {
            continue;
        };
        let accepted = match server.accept_goal(handle).await {
            Ok(a) => a,
            Err(e) => {
                log::warn!("PlanToolpath: cannot accept a goal: {e:?}");
                continue;
            }
        };
        let executing = match server.start_executing_goal(accepted).await {
            Ok(x) => x,
            Err(e) => {
                log::warn!("PlanToolpath: cannot start a goal: {e:?}");
                continue;
            }
        };
        tokio::spawn(serve_goal(
            Arc::clone(&server),
            executing,
            goal,
            Arc::clone(&queue),
            Arc::clone(&goals),
            toolpath_topic.clone(),
        ));
    }
}

/// Answers cancel requests: the goals it names that are still running are
/// canceled (the answer lists them); a request naming no running goal (an
/// unknown or finished one) is answered with an empty list and return code
/// ERROR_REJECTED, and nothing changes.
async fn answer_cancels(server: Arc<PlanServer>, queue: Arc<dyn GoalQueue>, goals: Goals) {
    loop {
        let request = match server.receive_cancel_request().await {
            Ok(r) => r,
            Err(e) => {
                log::warn!("PlanToolpath: undecodable cancel request: {e:?}");
                continue;
            }
        };
        let links: Vec<(GoalId, Arc<GoalLink>)> = {
            let g = lock(&goals);
            request
                .goals()
                .filter_map(|id| g.get(&id).map(|l| (id, Arc::clone(l))))
                .filter(|(_, l)| !l.is_done())
                .collect()
        };
        if links.is_empty() {
            log::info!("PlanToolpath: cancel request names no running goal");
        }
        // Answer first: the goals go to CANCELING before their end is sent.
        if let Err(e) = server
            .respond_to_cancel_requests(&request, links.iter().map(|(id, _)| *id))
            .await
        {
            log::warn!("PlanToolpath: cannot answer a cancel request: {e:?}");
        }
        for (_, link) in links {
            log::info!("PlanToolpath: cancel of job {} requested", link.job_id);
            queue.cancel(&link);
        }
    }
}

/// Answers service requests, each on a task of its own (responses carry
/// their request's id, so they may go out in any order).
async fn answer_requests(
    server: Arc<Server<Goal, GoalResult>>,
    queue: Arc<dyn GoalQueue>,
    toolpath_topic: String,
) {
    loop {
        let (id, request) = match server.async_receive_request().await {
            Ok(r) => r,
            Err(e) => {
                log::warn!("PlanToolpath service: undecodable request: {e:?}");
                continue;
            }
        };
        let (server, queue, topic) = (
            Arc::clone(&server),
            Arc::clone(&queue),
            toolpath_topic.clone(),
        );
        tokio::spawn(async move {
            let (link, events) = GoalLink::new(&request.job.job_id);
            let result = run_job(queue.as_ref(), request, &link, events, &topic, None).await;
            if let Err(e) = server.async_send_response(id, result).await {
                log::warn!(
                    "PlanToolpath service: cannot answer job {}: {e:?}",
                    link.job_id
                );
            }
        });
    }
}

/// Creates the action server and the service server on `ros` and starts
/// serving them from `queue`.
pub fn serve(ros: &mut RosNode, queue: Arc<dyn GoalQueue>) -> Result<()> {
    let action = topic_name(&ros.namespace, ACTION)?;
    let server = ros
        .node
        .create_action_server::<Goal, GoalResult, Feedback>(
            ros.service_mapping,
            &action,
            &action_type(),
            server_qos(),
        )
        .map_err(|e| Error::dds(format!("cannot serve action {ACTION}: {e:?}")))?;
    let observer = {
        let queue = Arc::clone(&queue);
        move |a: &ros2_client::action_msgs::GoalStatusArray| {
            queue.status_published(&status_array(a))
        }
    };
    let server = Arc::new(AsyncActionServer::new(server).with_status_observer(Box::new(observer)));
    let service = topic_name(&ros.namespace, SERVICE)?;
    let service_server = ros
        .node
        .create_server::<Goal, GoalResult>(
            ros.service_mapping,
            &service,
            &service_type(),
            service_qos(),
            service_qos(),
        )
        .map_err(|e| Error::dds(format!("cannot serve service {SERVICE}: {e:?}")))?;
    let toolpath_topic = topics::absolute(&ros.namespace, topics::TOOLPATH);
    let goals: Goals = Arc::default();
    tokio::spawn(accept_goals(
        Arc::clone(&server),
        Arc::clone(&queue),
        Arc::clone(&goals),
        toolpath_topic.clone(),
    ));
    tokio::spawn(answer_cancels(server, Arc::clone(&queue), goals));
    tokio::spawn(answer_requests(
        Arc::new(service_server),
        queue,
        toolpath_topic,
    ));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_canceled_goal_stops_progress_checks_and_ends_canceled() {
        let (link, mut events) = GoalLink::new("j1");
        assert!(link.check().is_ok());
        link.feedback("planning", 0.25, 3.0);
        link.cancel();
        let e = link.check().unwrap_err();
        assert!(matches!(e, Error::Stopped { canceled: true, .. }), "{e:?}");
        assert_eq!(final_state(&e), msgs::JobStatus::CANCELED);
        assert_eq!(
            e.to_string(),
            "canceled: job j1: its PlanToolpath goal was canceled by the client"
        );
        // The end is reported once: a second finish is dropped.
        link.finish(msgs::JobStatus::CANCELED, e.to_string());
        link.finish(msgs::JobStatus::SUCCEEDED, String::new());
        assert!(matches!(
            events.try_recv(),
            Ok(GoalEvent::Feedback(Feedback { ref stage, progress, eta_s })) if stage == "planning" && progress == 0.25 && eta_s == 3.0
        ));
        assert!(matches!(
            events.try_recv(),
            Ok(GoalEvent::Done(msgs::JobStatus::CANCELED, _))
        ));
        assert!(events.try_recv().is_err());
    }
}
