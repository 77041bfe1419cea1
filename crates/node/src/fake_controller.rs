//! A stand-in for a machine's joint_trajectory_controller, for tests: a
//! FollowJointTrajectory action server that rejects a goal breaking the
//! controller rules (`machines::jtc`, from the pose it is at; a non-zero
//! stamp whose trajectory has already ended), "executes" an accepted goal by
//! following its timing (optionally faster), publishes feedback and
//! `joint_states` as it goes, and can be told to abort or reject a goal.

use super::dds::{topic_name, RosNode};
use super::execute::{action_type, server_qos};
use futures::FutureExt;
use ros2_client::action::{AsyncActionServer, ExecutingGoalHandle, GoalEndStatus};
use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::ros2::QosProfile;
use ros2_client::Publisher;
use std::sync::{Arc, Mutex};
use std::time::Duration;
use toolpath_kernel::error::{Error, Result};
use toolpath_machines::{jtc, Axis};
use toolpath_messages::follow_joint_trajectory::{Feedback, Goal, GoalResult};
use toolpath_messages::{self as msgs, convert, topics};

/// What the fake controller serves and how it misbehaves on request.
#[derive(Clone, Debug)]
pub struct FakeOptions {
    /// Action name (relative names go under the namespace).
    pub action: String,
    pub joint_names: Vec<String>,
    pub limits: Vec<Axis>,
    /// The pose it starts at (mm, rad).
    pub start: Vec<f64>,
    pub behaviour: Behaviour,
}

/// How the fake controller behaves; changeable while it runs.
#[derive(Clone, Debug, Default)]
pub struct Behaviour {
    /// Wall-clock seconds per trajectory second (0.01 = 100 times faster).
    pub time_scale: f64,
    /// Reject the goal with this index (0 = the first received).
    pub reject_goal: Option<usize>,
    /// Abort the goal with this index half-way, PATH_TOLERANCE_VIOLATED.
    pub abort_goal: Option<usize>,
}

/// What happened to one goal.
#[derive(Clone, Debug, PartialEq)]
pub struct GoalRecord {
    pub accepted: bool,
    /// Why it was rejected, or how it ended (succeeded, canceled, aborted).
    pub outcome: String,
    pub points: usize,
    /// The goal's trajectory as received, internal units.
    pub trajectory: jtc::Points,
}

/// A running fake controller: its goals so far.
pub struct FakeController {
    pub goals: Arc<Mutex<Vec<GoalRecord>>>,
    pub pose: Arc<Mutex<Vec<f64>>>,
    pub behaviour: Arc<Mutex<Behaviour>>,
}

impl FakeController {
    /// The goals received so far.
    pub fn goals(&self) -> Vec<GoalRecord> {
        lock(&self.goals).clone()
    }
    pub fn set(&self, b: Behaviour) {
        *lock(&self.behaviour) = b;
    }
}

const MM: f64 = 1e-3;

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    match m.lock() {
        Ok(g) => g,
        Err(p) => p.into_inner(),
    }
}

fn joint_state(o: &FakeOptions, q: &[f64]) -> msgs::JointState {
    msgs::JointState {
        header: msgs::Header {
            stamp: msgs::Time::now(),
            frame_id: String::new(),
        },
        name: o.joint_names.clone(),
        position: q
            .iter()
            .zip(&o.limits)
            .map(|(x, l)| if l.rotary { *x } else { x * MM })
            .collect(),
        velocity: vec![0.0; q.len()],
        effort: Vec::new(),
    }
}

/// The controller's checks of a goal against the pose it is at.
fn validate(o: &FakeOptions, goal: &Goal, at: &[f64]) -> std::result::Result<jtc::Points, String> {
    let t = &goal.trajectory;
    let points = convert::trajectory_points(t, &o.joint_names, &o.limits);
    if t.header.stamp != msgs::Time::ZERO {
        let end = t.header.stamp.as_secs_f64() + points.times.last().copied().unwrap_or(0.0);
        if end < msgs::Time::now().as_secs_f64() {
            return Err(format!(
                "OLD_HEADER_TIMESTAMP: the trajectory ended at {end:.3} s, before now"
            ));
        }
    }
    jtc::check(&points, &o.joint_names, &o.limits, Some(at)).map_err(|e| e.to_string())?;
    Ok(points)
}

type Server = AsyncActionServer<Goal, GoalResult, Feedback>;
type Executing = ExecutingGoalHandle<Goal>;

/// "Executes" an accepted goal: follows its timing (`time_scale` wall
/// seconds per trajectory second), moves `pose` and publishes feedback point
/// by point; aborts at point `abort_at`, stops on a cancel of this goal.
async fn follow(
    server: &Server,
    executing: &Executing,
    goal: &Goal,
    points: &jtc::Points,
    pose: &Mutex<Vec<f64>>,
    time_scale: f64,
    abort_at: Option<usize>,
) -> (GoalEndStatus, GoalResult, &'static str) {
    let mut previous = 0.0;
    for k in 0..points.times.len() {
        if abort_at == Some(k) {
            let result = GoalResult {
                error_code: GoalResult::PATH_TOLERANCE_VIOLATED,
                error_string: format!("told to abort at point {k}"),
            };
            return (GoalEndStatus::Aborted, result, "aborted");
        }
        let wait = (points.times[k] - previous) * time_scale;
        previous = points.times[k];
        let sleep = tokio::time::sleep(Duration::from_secs_f64(wait)).fuse();
        futures::pin_mut!(sleep);
        loop {
            tokio::select! {
                _ = &mut sleep => break,
                c = server.receive_cancel_request() => {
                    if let Ok(c) = c {
                        if c.contains_goal(&executing.goal_id()) {
                            let mine = std::iter::once(executing.goal_id());
                            let _ = server.respond_to_cancel_requests(&c, mine).await;
                            return (GoalEndStatus::Canceled, GoalResult::default(), "canceled");
                        }
                    }
                }
            }
        }
        *lock(pose) = points.positions[k].clone();
        let desired = goal.trajectory.points[k].clone();
        let fb = Feedback {
            header: msgs::Header {
                stamp: msgs::Time::now(),
                frame_id: String::new(),
            },
            joint_names: goal.trajectory.joint_names.clone(),
            actual: desired.clone(),
            desired,
            ..Default::default()
        };
        let _ = server.publish_feedback(executing.clone(), fb).await;
    }
    (GoalEndStatus::Succeeded, GoalResult::default(), "succeeded")
}

/// Starts the fake controller on `ros` (its action server and a
/// `joint_states` publisher at 50 Hz).
pub fn spawn(ros: &mut RosNode, options: FakeOptions) -> Result<FakeController> {
    let name = topic_name(&ros.namespace, &options.action)?;
    let server = ros
        .node
        .create_action_server::<Goal, GoalResult, Feedback>(
            ros.service_mapping,
            &name,
            &action_type(),
            server_qos(),
        )
        .map_err(|e| Error::dds(format!("cannot serve {}: {e:?}", options.action)))?;
    let server = Arc::new(AsyncActionServer::new(server));
    let qos = QosProfile::subscription_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_secs(1)))
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 });
    let states: Publisher<msgs::JointState> = ros.publisher(topics::JOINT_STATES, qos)?;
    let goals = Arc::new(Mutex::new(Vec::new()));
    let pose = Arc::new(Mutex::new(options.start.clone()));
    let (o, p) = (options.clone(), Arc::clone(&pose));
    tokio::spawn(async move {
        let mut tick = tokio::time::interval(Duration::from_millis(20));
        loop {
            tick.tick().await;
            let q = lock(&p).clone();
            let _ = states.publish(joint_state(&o, &q));
        }
    });
    let behaviour = Arc::new(Mutex::new(options.behaviour.clone()));
    let controller = FakeController {
        goals,
        pose,
        behaviour,
    };
    tokio::spawn(serve_goals(server, options, controller.shared()));
    Ok(controller)
}

impl FakeController {
    fn shared(&self) -> FakeController {
        FakeController {
            goals: Arc::clone(&self.goals),
            pose: Arc::clone(&self.pose),
            behaviour: Arc::clone(&self.behaviour),
        }
    }
}

/// The goal loop: checks each goal against the pose the controller is at,
/// rejects it (or as told), else follows it to its end and sends the result.
async fn serve_goals(server: Arc<Server>, options: FakeOptions, state: FakeController) {
    let FakeController {
        goals: g,
        pose: p,
        behaviour: b,
    } = state;
    let mut index = 0usize;
    loop {
        let Ok(handle) = server.receive_new_goal().await else {
            continue;
        };
        let Some(goal) = server.get_new_goal(handle.clone()) else {
            continue;
        };
        let at = lock(&p).clone();
        let checked = validate(&options, &goal, &at);
        let this = index;
        index += 1;
        let now = lock(&b).clone();
        let points = match checked {
            Ok(points) if now.reject_goal != Some(this) => points,
            other => {
                let why = other.err().unwrap_or_else(|| "told to reject".into());
                lock(&g).push(GoalRecord {
                    accepted: false,
                    outcome: why,
                    points: goal.trajectory.points.len(),
                    trajectory: convert::trajectory_points(
                        &goal.trajectory,
                        &options.joint_names,
                        &options.limits,
                    ),
                });
                let _ = server.reject_goal(handle).await;
                continue;
            }
        };
        let Ok(accepted) = server.accept_goal(handle).await else {
            continue;
        };
        let Ok(executing) = server.start_executing_goal(accepted).await else {
            continue;
        };
        let abort_at = (now.abort_goal == Some(this)).then_some(points.times.len() / 2);
        let end = follow(
            &server,
            &executing,
            &goal,
            &points,
            &p,
            now.time_scale,
            abort_at,
        )
        .await;
        lock(&g).push(GoalRecord {
            accepted: true,
            outcome: end.2.to_string(),
            points: points.times.len(),
            trajectory: points,
        });
        let _ = tokio::time::timeout(
            Duration::from_secs(10),
            server.send_result_response(executing, end.0, end.1),
        )
        .await;
    }
}
