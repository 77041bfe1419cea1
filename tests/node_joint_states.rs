//! The node starts each trajectory where `/joint_states` says the machine is:
//! a complete, fresh joint state gives a first point after the limit-
//! respecting move from there (checked with the controller rules from that
//! pose); a joint state missing a joint, outside the travel or stale fails
//! the job with that reason. The node runs on loopback on a domain of its
//! own and is killed by pid.

#[path = "common/node_process.rs"]
mod node_process;

use futures::StreamExt;
use node_process::NodeProcess;
use std::net::{IpAddr, Ipv4Addr};
use std::time::{Duration, Instant};
use toolpath_planner::machines::{controller, jtc, Machines};
use toolpath_planner::messages::{self as msgs, convert, topics};
use toolpath_planner::ros::node::{qos, RosNode};

const CONFIG: &str =
    "node:\n  verify: false\nmill5:\n  controller:\n    joint_states_max_age_s: 0.5\n";

fn joint_state(names: &[&str], position: &[f64]) -> msgs::JointState {
    msgs::JointState {
        header: msgs::Header::default(),
        name: names.iter().map(|s| s.to_string()).collect(),
        position: position.to_vec(),
        velocity: vec![0.0; position.len()],
        effort: Vec::new(),
    }
}

#[test]
fn trajectories_start_from_the_joint_state_or_fail_with_its_reason() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("node.yaml");
    std::fs::write(&config, CONFIG).unwrap();
    let d = node_process::fresh_domain(0);
    let (_node, ready) = NodeProcess::spawn(&config, d);
    assert!(ready.starts_with("ready"), "node said {ready:?}");
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let lo = Some(vec![IpAddr::V4(Ipv4Addr::LOCALHOST)]);
        let mut client = RosNode::new("joint_states_client", "/", d, lo).unwrap();
        let surfaces = client
            .publisher::<msgs::Surface>(topics::SURFACE, qos::shapes())
            .unwrap();
        let jobs = client
            .publisher::<msgs::Job>(topics::JOB, qos::job())
            .unwrap();
        let states = client
            .publisher::<msgs::JointState>(topics::JOINT_STATES, qos::job())
            .unwrap();
        let status = client
            .subscription::<msgs::JobStatus>(topics::JOB_STATUS, qos::status_reader())
            .unwrap();
        let trajectories = client
            .subscription::<msgs::JointTrajectory>(topics::MILL5_TRAJECTORY, qos::results())
            .unwrap();
        tokio::time::timeout(
            Duration::from_secs(20),
            jobs.wait_for_subscription(&client.node),
        )
        .await
        .expect("the node's job reader was not discovered");
        tokio::time::timeout(
            Duration::from_secs(20),
            states.wait_for_subscription(&client.node),
        )
        .await
        .expect("the node's joint_states reader was not discovered");
        let job = toolpath_planner::samples::job("plane").unwrap();
        let toolpath_planner::formats::Shape::Surface(s) = &job.shape else {
            panic!("plane is a surface job")
        };
        surfaces
            .publish(convert::surface_to_msg(
                "plane_shape",
                s,
                msgs::Header::default(),
            ))
            .unwrap();
        let mut status_stream = Box::pin(status.async_stream());
        let mut traj_stream = Box::pin(trajectories.async_stream());
        // Sends job `id` while publishing `state` every 50 ms; its final status.
        let mut run = async |id: &str, state: Option<msgs::JointState>| -> msgs::JobStatus {
            if let Some(s) = &state {
                states.publish(s.clone()).unwrap();
                tokio::time::sleep(Duration::from_millis(200)).await;
            }
            let mut m = convert::job_to_msg(&job, "plane_shape", msgs::Header::default());
            m.job_id = id.into();
            jobs.publish(m).unwrap();
            let deadline = Instant::now() + Duration::from_secs(60);
            let mut tick = tokio::time::interval(Duration::from_millis(50));
            loop {
                tokio::select! {
                    Some(Ok((st, _))) = status_stream.next() => {
                        if st.job_id == id && st.is_final() {
                            return st;
                        }
                    }
                    _ = tick.tick() => {
                        assert!(Instant::now() < deadline, "no final status of {id}");
                        if let Some(s) = &state {
                            states.publish(s.clone()).unwrap();
                        }
                    }
                }
            }
        };
        // X Y Z A without C: the missing joint is named.
        let partial = joint_state(&["X", "Y", "Z", "A"], &[1.0, 2.0, 1.2, 0.0]);
        let st = run("missing", Some(partial)).await;
        assert_eq!(st.state, msgs::JobStatus::FAILED);
        assert!(
            st.message.contains("joint_states has no joint C"),
            "{}",
            st.message
        );
        // Z beyond its travel (1.5 m).
        let high = joint_state(&["X", "Y", "Z", "A", "C"], &[1.0, 2.0, 1.6, 0.0, 0.0]);
        let st = run("outside", Some(high)).await;
        assert_eq!(st.state, msgs::JobStatus::FAILED);
        assert!(
            st.message
                .contains("joint Z (axis Z) at 1600.000 mm, outside its range 0..1500 mm"),
            "{}",
            st.message
        );
        // A complete, fresh state (m, rad) far from home.
        let pose = [1.0, 2.0, 1.2, 0.3, -1.0];
        let good = joint_state(&["C", "A", "Z", "Y", "X"], &[-1.0, 0.3, 1.2, 2.0, 1.0]);
        let st = run("fresh", Some(good)).await;
        assert_eq!(st.state, msgs::JobStatus::SUCCEEDED, "{}", st.message);
        let (traj, _) = tokio::time::timeout(Duration::from_secs(10), traj_stream.next())
            .await
            .expect("no trajectory")
            .unwrap()
            .unwrap();
        assert_eq!(traj.header.stamp, msgs::Time::ZERO);
        assert_starts_from(&traj, &pose);
        // The publisher stops: after 0.5 s the state is stale.
        tokio::time::sleep(Duration::from_millis(800)).await;
        let st = run("stale", None).await;
        assert_eq!(st.state, msgs::JobStatus::FAILED);
        assert!(
            st.message.contains("the joint state of X is stale"),
            "{}",
            st.message
        );
    });
}

/// The trajectory passes the controller's rules from `pose` (m, rad), and
/// its first point comes after the start move from there.
fn assert_starts_from(traj: &msgs::JointTrajectory, pose: &[f64]) {
    let m = Machines::default();
    let (names, limits) = (m.mill5.joint_names(), m.mill5.limits());
    let start: Vec<f64> = pose
        .iter()
        .enumerate()
        .map(|(j, x)| if limits[j].rotary { *x } else { x * 1e3 })
        .collect();
    let points = convert::trajectory_points(&traj, &names, &limits);
    jtc::check(&points, &names, &limits, Some(&start)).unwrap();
    let t0 = controller::start_move_time(&start, &points.positions[0], &limits);
    assert!(
        (points.times[0] - t0).abs() < 1e-6,
        "{} vs {t0}",
        points.times[0]
    );
    // X from 1000 to about 2500 mm dominates: well over the home move.
    assert!(t0 > 4.0, "{t0}");
}
