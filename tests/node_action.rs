//! The PlanToolpath action and service of the node (a child process, one
//! worker), driven by ros2-client clients: a goal reports feedback and ends
//! SUCCEEDED with its toolpath; a goal canceled behind a running one ends
//! CANCELED, publishes nothing and frees the worker; goals with a bad job or
//! an unknown shape end REJECTED with the reason; a cancel naming an unknown
//! goal is refused; the service answers as the action does. The same job
//! sent on topic `job`, as a goal and as a service request gives the same
//! toolpath bytes (CDR), the job id, stamp and planning time aside.
//! Loopback only, a random domain, the node killed by pid.

#[path = "common/node_process.rs"]
mod node_process;

use futures::StreamExt;
use node_process::NodeProcess;
use ros2_client::action::GoalStatusEnum;
use ros2_client::action_msgs::CancelGoalResponseEnum;
use ros2_client::builtin_interfaces::Time;
use ros2_client::unique_identifier_msgs::UUID;
use std::collections::BTreeSet;
use std::net::{IpAddr, Ipv4Addr};
use std::time::{Duration, Instant};
use toolpath_planner::formats::Shape;
use toolpath_planner::messages::plan_toolpath::{Goal, GoalResult};
use toolpath_planner::messages::{self as msgs, convert, topics};
use toolpath_planner::recording::to_cdr;
use toolpath_planner::ros::node::{qos, RosNode};
use toolpath_planner::ros::plan_action::{self, PlanToolpathClient};

const CONFIG: &str = "node:\n  verify: false\n  workers: 1\n";
const WAIT: Duration = Duration::from_secs(180);

/// The CDR bytes of a toolpath without what differs between two runs of
/// one job: its job id, stamp and planning time.
fn plan_bytes(t: &msgs::Toolpath) -> Vec<u8> {
    let mut t = t.clone();
    t.job_id.clear();
    t.header.stamp = Default::default();
    t.stats.compute_ms = 0.0;
    to_cdr(&t).unwrap()
}

/// Sends `goal`; its feedback (stage, progress) and result.
async fn run_goal(
    client: &PlanToolpathClient,
    goal: Goal,
) -> (Vec<(String, f32)>, GoalStatusEnum, GoalResult) {
    let (id, response) = tokio::time::timeout(WAIT, client.async_send_goal(goal))
        .await
        .expect("no goal response")
        .unwrap();
    assert!(response.accepted, "every goal is accepted");
    let result = client.async_request_result(id);
    let feedback = client.feedback_stream(id);
    futures::pin_mut!(result, feedback);
    let mut seen = Vec::new();
    let deadline = tokio::time::sleep(WAIT);
    tokio::pin!(deadline);
    loop {
        tokio::select! {
            r = &mut result => {
                let (status, r) = r.unwrap();
                return (seen, status, r);
            }
            Some(Ok(f)) = feedback.next() => seen.push((f.stage, f.progress)),
            _ = &mut deadline => panic!("no result within {WAIT:?}"),
        }
    }
}

fn goal(job: &msgs::Job, job_id: &str) -> Goal {
    let mut job = job.clone();
    job.job_id = job_id.into();
    Goal {
        job,
        ..Default::default()
    }
}

#[test]
fn action_and_service_plan_cancel_and_refuse_with_reasons() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("node.yaml");
    std::fs::write(&config, CONFIG).unwrap();
    let d = node_process::fresh_domain(0);
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let (_node, ready) = NodeProcess::spawn(&config, d);
        assert!(ready.starts_with("ready"), "node said {ready:?}");
        let lo = Some(vec![IpAddr::V4(Ipv4Addr::LOCALHOST)]);
        let mut ros = RosNode::new("action_client", "/", d, lo).unwrap();
        let action = plan_action::action_client(&mut ros).unwrap();
        let service = plan_action::service_client(&mut ros).unwrap();
        let surfaces = ros
            .publisher::<msgs::Surface>(topics::SURFACE, qos::shapes())
            .unwrap();
        let jobs = ros.publisher::<msgs::Job>(topics::JOB, qos::job()).unwrap();
        let toolpaths = ros
            .subscription::<msgs::Toolpath>(topics::TOOLPATH, qos::results())
            .unwrap();
        let segments = ros
            .subscription::<msgs::ToolPoseSegments>(topics::TOOL_POSE_SEGMENTS, qos::results())
            .unwrap();
        let found = async {
            jobs.wait_for_subscription(&ros.node).await;
            action.goal_client().wait_for_service(&ros.node).await;
            action.result_client().wait_for_service(&ros.node).await;
            action.cancel_client().wait_for_service(&ros.node).await;
            service.wait_for_service(&ros.node).await;
        };
        tokio::time::timeout(Duration::from_secs(30), found)
            .await
            .expect("the node's job reader, action and service were not discovered");

        let plane = toolpath_planner::samples::job("plane").unwrap();
        let Shape::Surface(plane_surface) = &plane.shape else {
            panic!("plane is a surface job")
        };
        let surface =
            convert::surface_to_msg("plane_shape", plane_surface, msgs::Header::default());
        surfaces.publish(surface.clone()).unwrap();
        let job = convert::job_to_msg(&plane, "plane_shape", msgs::Header::default());

        // The job on topic `job`: its toolpath on topic `toolpath`.
        let mut topic_job = job.clone();
        topic_job.job_id = "by_topic".into();
        jobs.publish(topic_job).unwrap();
        let mut stream = Box::pin(toolpaths.async_stream());
        let mut published = Vec::new();
        let by_topic = loop {
            let (t, _) = tokio::time::timeout(WAIT, stream.next())
                .await
                .expect("no toolpath of job by_topic")
                .unwrap()
                .unwrap();
            published.push(t.job_id.clone());
            if t.job_id == "by_topic" {
                break t;
            }
        };

        // A goal on the received shape: feedback, then SUCCEEDED.
        let (feedback, status, r) = run_goal(&action, goal(&job, "by_action")).await;
        assert_eq!(status, GoalStatusEnum::Succeeded, "{}", r.reason);
        assert_eq!(r.status, msgs::JobStatus::SUCCEEDED);
        let stages: BTreeSet<&str> = feedback.iter().map(|(s, _)| s.as_str()).collect();
        assert!(
            stages.contains("queued") && stages.contains("planning"),
            "{feedback:?}"
        );
        assert!(feedback.iter().all(|(_, p)| (0.0..=1.0).contains(p)));
        assert!(!r.toolpath_omitted);
        assert_eq!(r.toolpath_topic, "/toolpath");
        assert_eq!(r.toolpath.job_id, "by_action");
        assert_eq!(
            to_cdr(&r.stats).unwrap(),
            to_cdr(&r.toolpath.stats).unwrap()
        );
        assert_eq!(r.stats.passes as usize, r.toolpath.passes.len());
        assert!(r.toolpath.passes.len() >= 2);
        assert_eq!(plan_bytes(&r.toolpath), plan_bytes(&by_topic));
        // Its poses on tool_pose_segments: one PoseArray per pass, with as
        // many poses as the pass has points, the toolpath's stamp.
        let mut seg_stream = Box::pin(segments.async_stream());
        let seg = loop {
            let (s, _) = tokio::time::timeout(WAIT, seg_stream.next())
                .await
                .expect("no tool_pose_segments of job by_action")
                .unwrap()
                .unwrap();
            if s.job_id == "by_action" {
                break s;
            }
        };
        assert_eq!(seg.header, r.toolpath.header);
        let lens: Vec<usize> = seg.segments.iter().map(|s| s.poses.len()).collect();
        let pass_lens: Vec<usize> = r.toolpath.passes.iter().map(|p| p.points.len()).collect();
        assert_eq!(lens, pass_lens);

        cancels_and_bad_goals_end_with_their_reasons(&action, &job).await;

        // The service, with the shape inline: the same toolpath again, and
        // the worker is free after the cancel.
        let mut request = goal(&job, "by_service");
        request.surface = vec![surface];
        let r = tokio::time::timeout(WAIT, service.async_call_service(request))
            .await
            .expect("no service response")
            .unwrap();
        assert_eq!(r.status, msgs::JobStatus::SUCCEEDED, "{}", r.reason);
        assert_eq!(r.toolpath.job_id, "by_service");
        assert_eq!(plan_bytes(&r.toolpath), plan_bytes(&by_topic));

        // Every planned job published its toolpath; the canceled one none.
        let deadline = Instant::now() + Duration::from_secs(5);
        while !published.iter().any(|j| j == "by_service") && Instant::now() < deadline {
            if let Ok(Some(Ok((t, _)))) =
                tokio::time::timeout(Duration::from_millis(500), stream.next()).await
            {
                published.push(t.job_id);
            }
        }
        for id in ["by_action", "busy", "by_service"] {
            assert!(published.iter().any(|j| j == id), "{id}: {published:?}");
        }
        assert!(!published.iter().any(|j| j == "canceled"), "{published:?}");
    });
}

/// Two goals for one worker, the second canceled while it waits; a cancel
/// naming no goal; goals the node must refuse with their reason.
async fn cancels_and_bad_goals_end_with_their_reasons(
    action: &PlanToolpathClient,
    job: &msgs::Job,
) {
    // Two goals for one worker: the second, canceled while it waits,
    // ends CANCELED and is never planned; the first runs through.
    let (busy_id, busy_response) = action.async_send_goal(goal(job, "busy")).await.unwrap();
    let (late_id, late_response) = action.async_send_goal(goal(job, "canceled")).await.unwrap();
    assert!(busy_response.accepted && late_response.accepted);
    let cancel = action.async_cancel_goal(late_id, Time::ZERO).await.unwrap();
    assert_eq!(cancel.return_code, CancelGoalResponseEnum::None);
    assert_eq!(cancel.goals_canceling.len(), 1);
    assert_eq!(cancel.goals_canceling[0].goal_id, late_id);
    let (status, r) = tokio::time::timeout(WAIT, action.async_request_result(late_id))
        .await
        .unwrap()
        .unwrap();
    assert_eq!(status, GoalStatusEnum::Canceled, "{}", r.reason);
    assert_eq!(r.status, msgs::JobStatus::CANCELED);
    assert!(
        r.reason.starts_with("canceled: job canceled"),
        "{}",
        r.reason
    );
    assert!(r.toolpath.passes.is_empty());
    let (status, r) = tokio::time::timeout(WAIT, action.async_request_result(busy_id))
        .await
        .unwrap()
        .unwrap();
    assert_eq!(status, GoalStatusEnum::Succeeded, "{}", r.reason);

    // A cancel naming no goal of the node is refused; nothing changes.
    let cancel = action
        .async_cancel_goal(UUID::new_random(), Time::ZERO)
        .await
        .unwrap();
    assert_eq!(cancel.return_code, CancelGoalResponseEnum::Rejected);
    assert!(cancel.goals_canceling.is_empty());

    // Bad goals end at once with the reason.
    let mut bad = goal(job, "bad_tool");
    bad.job.tool.radius = -1.0;
    let (_, status, r) = run_goal(&action, bad).await;
    assert_eq!(status, GoalStatusEnum::Aborted);
    assert_eq!(r.status, msgs::JobStatus::REJECTED);
    assert_eq!(
        r.reason,
        "invalid input: tool.radius: must be positive, got -1"
    );
    let mut unknown = goal(job, "unknown_shape");
    unknown.job.surface_id = "never_sent".into();
    let (_, status, r) = run_goal(&action, unknown).await;
    assert_eq!(status, GoalStatusEnum::Aborted);
    assert_eq!(r.status, msgs::JobStatus::REJECTED);
    assert!(
        r.reason
            .contains("no surface or pocket \"never_sent\" has been received"),
        "{}",
        r.reason
    );
}
