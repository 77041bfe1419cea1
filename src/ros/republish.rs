//! `toolpath replay BAG --publish`: republishes a bag's inputs (shapes, then
//! jobs, in recorded order) to a running node over DDS and collects what the
//! node answers, for the same comparison as a local replay.
//!
//! Outputs are told apart from earlier runs by their header stamp: the node
//! stamps every output of a job when it publishes it, so anything stamped
//! before this replay started belongs to someone else (the node's results and
//! statuses are transient-local, a new reader may be handed old ones).

use super::node::{qos, RosNode};
use crate::error::{Error, Result};
use crate::messages::{self as msgs, topics};
use crate::recording::runs::{
    compare_outputs, outputs_of, point_count, JobReplay, Recorded, ReplayReport,
};
use futures::StreamExt;
use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::ros2::QosProfile;
use std::collections::BTreeSet;
use std::net::IpAddr;
use std::path::Path;
use std::time::{Duration, Instant};

/// Where and how long to republish.
#[derive(Clone, Debug)]
pub struct PublishOptions {
    pub domain_id: u16,
    /// Namespace of the node (`/` or e.g. `/cell_b`).
    pub namespace: String,
    /// Interface addresses DDS may use (`None`: all). Loopback by default.
    pub interfaces: Option<Vec<IpAddr>>,
    /// How long to wait for the node to appear.
    pub discovery_timeout: Duration,
    /// How long to wait for every job's final status and outputs.
    pub timeout: Duration,
}

/// Readers of the node's outputs: reliable, volatile (no history of earlier
/// runs), deep enough for a whole bag.
fn reader_qos() -> QosProfile {
    QosProfile::subscription_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_secs(5)))
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10_000 })
}

fn is_ours(h: &msgs::Header, since: &msgs::Time) -> bool {
    (h.stamp.sec, h.stamp.nanosec) >= (since.sec, since.nanosec)
}

#[derive(Default)]
struct Answers {
    statuses: Vec<msgs::JobStatus>,
    toolpaths: Vec<msgs::Toolpath>,
    poses: Vec<msgs::PoseArray>,
    mill5: Vec<msgs::JointTrajectory>,
    belt6: Vec<msgs::JointTrajectory>,
}

impl Answers {
    /// Every job has a final status and, when it succeeded, all its outputs.
    fn complete(&self, jobs: &BTreeSet<String>) -> bool {
        jobs.iter().all(|id| {
            let o = outputs_of(
                id,
                &self.statuses,
                &self.toolpaths,
                &self.poses,
                &self.mill5,
                &self.belt6,
            );
            match o.state {
                Some((s, _)) if s == msgs::JobStatus::SUCCEEDED => {
                    o.toolpath.is_some() && o.poses.is_some() && o.trajectory.is_some()
                }
                Some(_) => true,
                None => false,
            }
        })
    }
}

/// Republishes the inputs of the bag at `path` to a running node and compares
/// its answers with the recording.
pub async fn republish(path: &Path, options: &PublishOptions) -> Result<ReplayReport> {
    let rec = Recorded::read(path)?;
    let ids: BTreeSet<String> = rec.jobs.iter().map(|j| j.job_id.clone()).collect();
    if ids.len() != rec.jobs.len() {
        return Err(Error::invalid(
            path.display().to_string(),
            "the bag has several jobs with the same job_id: a node's answers could not be told apart",
        ));
    }
    let mut ros = RosNode::new(
        "toolpath_replay",
        &options.namespace,
        options.domain_id,
        options.interfaces.clone(),
    )?;
    let surface_pub = ros.publisher::<msgs::Surface>(topics::SURFACE, qos::shapes())?;
    let pocket_pub = ros.publisher::<msgs::Pocket>(topics::POCKET, qos::shapes())?;
    let job_pub = ros.publisher::<msgs::Job>(topics::JOB, qos::job())?;
    let status_sub = ros.subscription::<msgs::JobStatus>(topics::JOB_STATUS, reader_qos())?;
    let toolpath_sub = ros.subscription::<msgs::Toolpath>(topics::TOOLPATH, reader_qos())?;
    let poses_sub = ros.subscription::<msgs::PoseArray>(topics::TOOL_POSES, reader_qos())?;
    let mill5_sub =
        ros.subscription::<msgs::JointTrajectory>(topics::MILL5_TRAJECTORY, reader_qos())?;
    let belt6_sub =
        ros.subscription::<msgs::JointTrajectory>(topics::BELT6_TRAJECTORY, reader_qos())?;
    tokio::time::timeout(
        options.discovery_timeout,
        job_pub.wait_for_subscription(&ros.node),
    )
    .await
    .map_err(|_| {
        Error::planning(format!(
            "no node subscribes to {}job on ROS domain {} within {:.0} s: is `toolpath node` running there (ROS_DOMAIN_ID, namespace)?",
            options.namespace.trim_end_matches('/').to_string() + "/",
            options.domain_id,
            options.discovery_timeout.as_secs_f64()
        ))
    })?;
    // Our own readers must be matched too, or early answers are lost.
    tokio::time::timeout(
        options.discovery_timeout,
        status_sub.wait_for_publisher(&ros.node),
    )
    .await
    .map_err(|_| Error::planning("the node's job_status publisher was not discovered"))?;
    let since = msgs::Time::now();
    let header = msgs::Header {
        stamp: since,
        frame_id: "workpiece".into(),
    };
    for s in &rec.surfaces {
        let mut m = s.clone();
        m.header.stamp = header.stamp;
        surface_pub
            .publish(m)
            .map_err(|e| Error::planning(format!("cannot publish surface: {e:?}")))?;
    }
    for p in &rec.pockets {
        let mut m = p.clone();
        m.header.stamp = header.stamp;
        pocket_pub
            .publish(m)
            .map_err(|e| Error::planning(format!("cannot publish pocket: {e:?}")))?;
    }
    for j in &rec.jobs {
        let mut m = j.clone();
        m.header.stamp = header.stamp;
        job_pub
            .publish(m)
            .map_err(|e| Error::planning(format!("cannot publish job {}: {e:?}", j.job_id)))?;
    }
    let mut answers = Answers::default();
    let mut statuses = Box::pin(status_sub.async_stream());
    let mut toolpaths = Box::pin(toolpath_sub.async_stream());
    let mut poses = Box::pin(poses_sub.async_stream());
    let mut mill5 = Box::pin(mill5_sub.async_stream());
    let mut belt6 = Box::pin(belt6_sub.async_stream());
    let deadline = Instant::now() + options.timeout;
    while !answers.complete(&ids) {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            break;
        }
        tokio::select! {
            Some(Ok((m, _))) = statuses.next() => {
                if is_ours(&m.header, &since) && ids.contains(&m.job_id) {
                    answers.statuses.push(m);
                }
            }
            Some(Ok((m, _))) = toolpaths.next() => {
                if is_ours(&m.header, &since) && ids.contains(&m.job_id) {
                    answers.toolpaths.push(m);
                }
            }
            Some(Ok((m, _))) = poses.next() => {
                if is_ours(&m.header, &since) {
                    answers.poses.push(m);
                }
            }
            Some(Ok((m, _))) = mill5.next() => {
                if is_ours(&m.header, &since) {
                    answers.mill5.push(m);
                }
            }
            Some(Ok((m, _))) = belt6.next() => {
                if is_ours(&m.header, &since) {
                    answers.belt6.push(m);
                }
            }
            _ = tokio::time::sleep(left) => break,
        }
    }
    let mut report = ReplayReport {
        jobs: Vec::new(),
        truncated: rec.truncated.clone(),
    };
    for j in &rec.jobs {
        let new = outputs_of(
            &j.job_id,
            &answers.statuses,
            &answers.toolpaths,
            &answers.poses,
            &answers.mill5,
            &answers.belt6,
        );
        let mut differences = compare_outputs(&rec.outputs(&j.job_id), &new);
        if new.state.is_none() {
            differences.push(format!(
                "the node gave no final status within {:.0} s",
                options.timeout.as_secs_f64()
            ));
        }
        report.jobs.push(JobReplay {
            job_id: j.job_id.clone(),
            strategy: j.strategy.clone(),
            machine: j.machine.clone(),
            points: new.toolpath.map_or(0, point_count),
            differences,
        });
    }
    Ok(report)
}
