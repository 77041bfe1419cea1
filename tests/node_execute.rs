//! End to end execution: the node (a child process, `execute: true` for both
//! machines) sends each job pass by pass to fake FollowJointTrajectory
//! controllers running here, which reject any goal that breaks the
//! controller rules from the pose they are at. Checks a mill5 and a belt6 job
//! run through, an abort and a rejection stop the job with the controller's
//! reason, a cancel is forwarded, and a job after an abort starts from where
//! the machine stopped. A PlanToolpath goal's `job.execute` overrides its
//! machine's default both ways. Loopback only, a random domain, the node
//! killed by pid.

#[path = "common/node_client.rs"]
mod node_client;
#[path = "common/node_process.rs"]
mod node_process;

use futures::StreamExt;
use node_process::NodeProcess;
use std::net::{IpAddr, Ipv4Addr};
use std::time::{Duration, Instant};
use toolpath_planner::formats::Shape;
use toolpath_planner::machines::Machines;
use toolpath_planner::messages::follow_joint_trajectory::StringMsg;
use toolpath_planner::messages::plan_toolpath::{Goal, GoalResult};
use toolpath_planner::messages::{self as msgs, convert};
use toolpath_planner::ros::fake_controller::{self, Behaviour, FakeController, FakeOptions};
use toolpath_planner::ros::node::RosNode;
use toolpath_planner::ros::plan_action::{self, PlanToolpathClient};

// Both machines publish on one /joint_states, so the belt's joints get names
// of their own (the node refuses two executing machines sharing a name).
const CONFIG: &str = "node:\n  verify: false\nmill5:\n  controller:\n    execute: true\nbelt6:\n  controller:\n    execute: true\n    joint_names: [belt_X, belt_Y, belt_Z, belt_A, belt_B, belt_C]\n";

fn fast() -> Behaviour {
    Behaviour {
        time_scale: 0.01,
        ..Default::default()
    }
}

/// The fake controllers of both machines on `cell`: the mill's joints as
/// configured, the belt grinder's renamed `belt_X` .. `belt_C` (the node's
/// config in these tests names them so).
fn spawn_controllers(cell: &mut RosNode, m: &Machines) -> (FakeController, FakeController) {
    let spawn = |cell: &mut RosNode, action: &str, joint_names, limits, start| {
        fake_controller::spawn(
            cell,
            FakeOptions {
                action: action.into(),
                joint_names,
                limits,
                start,
                behaviour: fast(),
            },
        )
        .unwrap()
    };
    let mill = spawn(
        cell,
        "mill5_controller/follow_joint_trajectory",
        m.mill5.joint_names(),
        m.mill5.limits(),
        m.mill5.home(),
    );
    let belt_joints = ["X", "Y", "Z", "A", "B", "C"]
        .iter()
        .map(|j| format!("belt_{j}"))
        .collect();
    let belt = spawn(
        cell,
        "belt6_controller/follow_joint_trajectory",
        belt_joints,
        m.belt6.limits(),
        m.belt6.home(),
    );
    (mill, belt)
}

#[test]
fn jobs_execute_pass_by_pass_and_stop_on_abort_reject_and_cancel() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("node.yaml");
    std::fs::write(&config, CONFIG).unwrap();
    let d = node_process::fresh_domain(0);
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let lo = Some(vec![IpAddr::V4(Ipv4Addr::LOCALHOST)]);
        let mut cell = RosNode::new("fake_cell", "/", d, lo).unwrap();
        let m = Machines::default();
        let (mill, belt) = spawn_controllers(&mut cell, &m);
        let (_node, ready) = NodeProcess::spawn(&config, d);
        assert!(ready.starts_with("ready"), "node said {ready:?}");
        let client = node_client::NodeClient::connect("execute_client", d).await;
        let node_client::NodeClient {
            surfaces,
            jobs,
            cancel,
            status,
            ..
        } = client;
        // The node's action clients find the servers in the meantime.
        tokio::time::sleep(Duration::from_secs(2)).await;
        let plane = toolpath_planner::samples::job("plane").unwrap();
        let sine = toolpath_planner::samples::job("sine_wave").unwrap();
        for (id, job) in [("plane_shape", &plane), ("sine_shape", &sine)] {
            let Shape::Surface(s) = &job.shape else {
                panic!("surface jobs")
            };
            surfaces
                .publish(convert::surface_to_msg(id, s, msgs::Header::default()))
                .unwrap();
        }
        let mut statuses = Box::pin(status.async_stream());
        // Sends a job; returns its final status. With `cancel_at`, cancels
        // the job once a status text contains it.
        let mut run = async |id: &str,
                             job: &toolpath_planner::formats::Job,
                             shape: &str,
                             cancel_at: Option<&str>| {
            let mut msg = convert::job_to_msg(job, shape, msgs::Header::default());
            msg.job_id = id.into();
            jobs.publish(msg).unwrap();
            let deadline = Instant::now() + Duration::from_secs(120);
            let mut canceled = false;
            loop {
                let st = node_client::next_status_of(&mut statuses, id, deadline).await;
                if let (Some(text), false) = (cancel_at, canceled) {
                    if st.message.contains(text) {
                        cancel.publish(StringMsg { data: id.into() }).unwrap();
                        canceled = true;
                    }
                }
                if st.is_final() {
                    return st;
                }
            }
        };

        // A mill5 job runs through, one accepted goal per pass.
        let st = run("mill_ok", &plane, "plane_shape", None).await;
        assert_eq!(st.state, msgs::JobStatus::SUCCEEDED, "{}", st.message);
        let passes = assert_ran_pass_by_pass(&st, &mill);

        // A belt6 job runs through on its own controller.
        let st = run("belt_ok", &sine, "sine_shape", None).await;
        assert_eq!(
            st.state,
            msgs::JobStatus::SUCCEEDED,
            "{} {:?}",
            st.message,
            belt.goals()
        );
        assert_ran_on_belt6(&st, &belt);

        // Aborted in its second pass: FAILED with the controller's error code.
        mill.set(Behaviour {
            abort_goal: Some(passes + 1),
            ..fast()
        });
        let st = run("mill_abort", &plane, "plane_shape", None).await;
        assert_eq!(st.state, msgs::JobStatus::FAILED);
        assert!(
            st.message.contains(&format!(
                "aborted pass 2/{passes}: error_code -4 (PATH_TOLERANCE_VIOLATED)"
            )),
            "{}",
            st.message
        );
        assert_eq!(
            mill.goals().len(),
            passes + 2,
            "no pass is sent after the abort"
        );
        let stopped_at = mill.pose.lock().unwrap().clone();

        // The next job starts from where the abort left the machine (its
        // first goal passes the rules from that pose), then the controller
        // rejects its first pass.
        mill.set(Behaviour {
            reject_goal: Some(passes + 2),
            ..fast()
        });
        let st = run("mill_reject", &plane, "plane_shape", None).await;
        assert_eq!(st.state, msgs::JobStatus::FAILED);
        assert!(
            st.message.contains(&format!("rejected pass 1/{passes}")),
            "{}",
            st.message
        );
        let rejected = mill.goals()[passes + 2].clone();
        assert!(
            !rejected.accepted && rejected.outcome == "told to reject",
            "{rejected:?}"
        );
        let limits = m.mill5.limits();
        toolpath_planner::machines::jtc::check(
            &rejected.trajectory,
            &m.mill5.joint_names(),
            &limits,
            Some(&stopped_at),
        )
        .expect("the move starts from the stopped pose");

        // Canceled during its second pass (real time): the controller stops it.
        mill.set(Behaviour {
            time_scale: 1.0,
            ..Default::default()
        });
        let st = run(
            "mill_cancel",
            &plane,
            "plane_shape",
            Some("executing pass 2/"),
        )
        .await;
        assert_eq!(st.state, msgs::JobStatus::FAILED);
        assert!(
            st.message
                .contains(&format!("canceled during pass 2/{passes}")),
            "{}",
            st.message
        );
        assert_eq!(mill.goals().last().unwrap().outcome, "canceled");
    });
}

/// mill5 plans only by default, belt6 executes by default.
const MIXED: &str = "node:\n  verify: false\nbelt6:\n  controller:\n    execute: true\n    joint_names: [belt_X, belt_Y, belt_Z, belt_A, belt_B, belt_C]\n";

/// Sends a goal; its feedback stages and its result.
async fn run_goal(client: &PlanToolpathClient, goal: Goal) -> (Vec<String>, GoalResult) {
    let wait = Duration::from_secs(120);
    let (id, response) = tokio::time::timeout(wait, client.async_send_goal(goal))
        .await
        .expect("no goal response")
        .unwrap();
    assert!(response.accepted);
    let result = client.async_request_result(id);
    let feedback = client.feedback_stream(id);
    futures::pin_mut!(result, feedback);
    let mut stages = Vec::new();
    let deadline = tokio::time::sleep(wait);
    tokio::pin!(deadline);
    loop {
        tokio::select! {
            r = &mut result => return (stages, r.unwrap().1),
            Some(Ok(f)) = feedback.next() => stages.push(f.stage),
            _ = &mut deadline => panic!("no result within {wait:?}"),
        }
    }
}

#[test]
fn a_goal_executes_or_plans_only_whatever_its_machine_default() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("node.yaml");
    std::fs::write(&config, MIXED).unwrap();
    let d = node_process::fresh_domain(1);
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let lo = Some(vec![IpAddr::V4(Ipv4Addr::LOCALHOST)]);
        let mut cell = RosNode::new("fake_cell", "/", d, lo.clone()).unwrap();
        let m = Machines::default();
        let (mill, belt) = spawn_controllers(&mut cell, &m);
        let (_node, ready) = NodeProcess::spawn(&config, d);
        assert!(ready.starts_with("ready"), "node said {ready:?}");
        let mut ros = RosNode::new("goal_client", "/", d, lo).unwrap();
        let action = plan_action::action_client(&mut ros).unwrap();
        let found = async {
            action.goal_client().wait_for_service(&ros.node).await;
            action.result_client().wait_for_service(&ros.node).await;
        };
        tokio::time::timeout(Duration::from_secs(30), found)
            .await
            .expect("the node's action was not discovered");
        // The node's action clients find the controllers in the meantime.
        tokio::time::sleep(Duration::from_secs(2)).await;
        let goal = |sample: &str, id: &str, execute: u8| {
            let job = toolpath_planner::samples::job(sample).unwrap();
            let Shape::Surface(s) = &job.shape else {
                panic!("surface jobs")
            };
            let mut msg = convert::job_to_msg(&job, "shape", msgs::Header::default());
            msg.job_id = id.into();
            msg.surface_id = format!("{id}_shape");
            msg.execute = execute;
            Goal {
                surface: vec![convert::surface_to_msg(
                    &msg.surface_id,
                    s,
                    msgs::Header::default(),
                )],
                job: msg,
                ..Default::default()
            }
        };

        // execute = 1 on mill5, which only plans by default: every pass goes
        // to its controller, and the feedback and result say so.
        let (stages, r) = run_goal(&action, goal("plane", "mill_goal", msgs::Job::EXECUTE)).await;
        assert_eq!(r.status, msgs::JobStatus::SUCCEEDED, "{}", r.reason);
        let passes = mill.goals().len();
        assert_eq!(passes, r.toolpath.passes.len(), "one goal per pass");
        assert!(mill.goals().iter().all(|g| g.accepted && g.outcome == "succeeded"));
        assert!(
            r.reason.contains(&format!(
                "executed {passes} passes on mill5_controller/follow_joint_trajectory"
            )),
            "{}",
            r.reason
        );
        assert!(
            stages.iter().any(|s| s.contains("executing pass 1/")),
            "{stages:?}"
        );

        // execute = 0 on mill5: its default, plan only.
        let (stages, r) = run_goal(
            &action,
            goal("plane", "mill_default", msgs::Job::EXECUTE_MACHINE_DEFAULT),
        )
        .await;
        assert_eq!(r.status, msgs::JobStatus::SUCCEEDED, "{}", r.reason);
        assert!(!r.reason.contains("executed"), "{}", r.reason);
        assert!(!stages.iter().any(|s| s.contains("executing")), "{stages:?}");
        assert_eq!(mill.goals().len(), passes, "nothing sent to mill5");

        // execute = 2 on belt6, which executes by default: plan only.
        let (stages, r) =
            run_goal(&action, goal("sine_wave", "belt_plan", msgs::Job::PLAN_ONLY)).await;
        assert_eq!(r.status, msgs::JobStatus::SUCCEEDED, "{}", r.reason);
        assert!(!r.reason.contains("executed"), "{}", r.reason);
        assert!(!stages.iter().any(|s| s.contains("executing")), "{stages:?}");
        assert!(belt.goals().is_empty(), "{:?}", belt.goals());

        // A value outside 0..2 is refused with the reason.
        let (_, r) = run_goal(&action, goal("plane", "bad_execute", 7)).await;
        assert_eq!(r.status, msgs::JobStatus::REJECTED);
        assert_eq!(
            r.reason,
            "invalid input: execute: 7 is not 0 (the machine's default), 1 (execute) or 2 (plan only)"
        );
        assert_eq!(mill.goals().len(), passes);
    });
}

/// A job that ran through mill5: one accepted goal per pass, each starting
/// after 0 and ending at rest, and a status naming them; the pass count.
fn assert_ran_pass_by_pass(st: &msgs::JobStatus, mill: &FakeController) -> usize {
    let goals = mill.goals();
    let passes = goals.len();
    assert!(passes >= 2, "{goals:?}");
    assert!(
        goals.iter().all(|g| g.accepted && g.outcome == "succeeded"),
        "{goals:?}"
    );
    assert!(
        st.message.contains(&format!(
            "executed {passes} passes on mill5_controller/follow_joint_trajectory"
        )),
        "{}",
        st.message
    );
    // Every goal's first point comes after 0 and its last is at rest
    // (the fake checked all rules on receipt).
    assert!(goals.iter().all(|g| g.trajectory.times[0] > 0.0));
    assert!(goals.iter().all(|g| g
        .trajectory
        .velocities
        .last()
        .unwrap()
        .iter()
        .all(|v| *v == 0.0)));
    passes
}

/// A job that ran through belt6 on its own controller.
fn assert_ran_on_belt6(st: &msgs::JobStatus, belt: &FakeController) {
    let bg = belt.goals();
    assert!(
        !bg.is_empty() && bg.iter().all(|g| g.accepted && g.outcome == "succeeded"),
        "{bg:?}"
    );
    assert!(
        st.message
            .contains(&format!("executed {} passes on belt6_controller", bg.len())),
        "{}",
        st.message
    );
}
