//! `toolpath replay BAG --publish`: republishes a bag's inputs (shapes, then
//! jobs, in recorded order) to a running node over DDS and collects what the
//! node answers, for the same comparison as a local replay.
//!
//! Outputs are told apart from earlier runs by their header stamp: the node
//! stamps every output of a job when it publishes it, so anything stamped
//! before this replay started belongs to someone else (the node's results and
//! statuses are transient-local, a new reader may be handed old ones).

use super::dds::RosNode;
use super::qos;
use futures::StreamExt;
use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::ros2::QosProfile;
use ros2_client::{Publisher, Subscription};
use std::collections::BTreeSet;
use std::net::IpAddr;
use std::path::Path;
use std::time::{Duration, Instant};
use toolpath_kernel::error::{Error, Result};
use toolpath_messages::{self as msgs, topics};
use toolpath_recording::runs::{
    compare_outputs, outputs_of, point_count, JobReplay, Recorded, ReplayReport,
};

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

/// The replay's participant: publishers of the node's inputs and readers of
/// its outputs, all matched before anything is sent.
struct Link {
    surface_pub: Publisher<msgs::Surface>,
    pocket_pub: Publisher<msgs::Pocket>,
    job_pub: Publisher<msgs::Job>,
    status_sub: Subscription<msgs::JobStatus>,
    toolpath_sub: Subscription<msgs::Toolpath>,
    poses_sub: Subscription<msgs::PoseArray>,
    mill5_sub: Subscription<msgs::JointTrajectory>,
    belt6_sub: Subscription<msgs::JointTrajectory>,
    /// Last: dropped after the endpoints that belong to it.
    ros: RosNode,
}

impl Link {
    /// Creates the topics and waits until the node reads `job` and our
    /// `job_status` reader is matched (or else early answers are lost).
    async fn connect(options: &PublishOptions) -> Result<Self> {
        let mut ros = RosNode::new(
            "toolpath_replay",
            &options.namespace,
            options.domain_id,
            options.interfaces.clone(),
        )?;
        let link = Link {
            surface_pub: ros.publisher(topics::SURFACE, qos::shapes())?,
            pocket_pub: ros.publisher(topics::POCKET, qos::shapes())?,
            job_pub: ros.publisher(topics::JOB, qos::job())?,
            status_sub: ros.subscription(topics::JOB_STATUS, reader_qos())?,
            toolpath_sub: ros.subscription(topics::TOOLPATH, reader_qos())?,
            poses_sub: ros.subscription(topics::TOOL_POSES, reader_qos())?,
            mill5_sub: ros.subscription(topics::MILL5_TRAJECTORY, reader_qos())?,
            belt6_sub: ros.subscription(topics::BELT6_TRAJECTORY, reader_qos())?,
            ros,
        };
        tokio::time::timeout(
            options.discovery_timeout,
            link.job_pub.wait_for_subscription(&link.ros.node),
        )
        .await
        .map_err(|_| {
            Error::dds(format!(
                "no node subscribes to {}job on ROS domain {} within {:.0} s: is `toolpath node` running there (ROS_DOMAIN_ID, namespace)?",
                options.namespace.trim_end_matches('/').to_string() + "/",
                options.domain_id,
                options.discovery_timeout.as_secs_f64()
            ))
        })?;
        tokio::time::timeout(
            options.discovery_timeout,
            link.status_sub.wait_for_publisher(&link.ros.node),
        )
        .await
        .map_err(|_| Error::dds("the node's job_status publisher was not discovered"))?;
        Ok(link)
    }

    /// Publishes the bag's shapes, then its jobs, every header stamped `since`.
    fn publish_inputs(&self, rec: &Recorded, since: msgs::Time) -> Result<()> {
        for s in &rec.surfaces {
            let mut m = s.clone();
            m.header.stamp = since;
            self.surface_pub
                .publish(m)
                .map_err(|e| Error::dds(format!("cannot publish surface: {e:?}")))?;
        }
        for p in &rec.pockets {
            let mut m = p.clone();
            m.header.stamp = since;
            self.pocket_pub
                .publish(m)
                .map_err(|e| Error::dds(format!("cannot publish pocket: {e:?}")))?;
        }
        for j in &rec.jobs {
            let mut m = j.clone();
            m.header.stamp = since;
            self.job_pub
                .publish(m)
                .map_err(|e| Error::dds(format!("cannot publish job {}: {e:?}", j.job_id)))?;
        }
        Ok(())
    }

    /// Collects the node's outputs stamped at or after `since` until every
    /// job in `ids` is complete or `timeout` passes.
    async fn collect(
        &self,
        ids: &BTreeSet<String>,
        since: &msgs::Time,
        timeout: Duration,
    ) -> Answers {
        let mut answers = Answers::default();
        let mut statuses = Box::pin(self.status_sub.async_stream());
        let mut toolpaths = Box::pin(self.toolpath_sub.async_stream());
        let mut poses = Box::pin(self.poses_sub.async_stream());
        let mut mill5 = Box::pin(self.mill5_sub.async_stream());
        let mut belt6 = Box::pin(self.belt6_sub.async_stream());
        let deadline = Instant::now() + timeout;
        while !answers.complete(ids) {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break;
            }
            tokio::select! {
                Some(Ok((m, _))) = statuses.next() => {
                    if is_ours(&m.header, since) && ids.contains(&m.job_id) {
                        answers.statuses.push(m);
                    }
                }
                Some(Ok((m, _))) = toolpaths.next() => {
                    if is_ours(&m.header, since) && ids.contains(&m.job_id) {
                        answers.toolpaths.push(m);
                    }
                }
                Some(Ok((m, _))) = poses.next() => {
                    if is_ours(&m.header, since) {
                        answers.poses.push(m);
                    }
                }
                Some(Ok((m, _))) = mill5.next() => {
                    // A trajectory's stamp is its start time: zero means on receipt.
                    if is_ours(&m.header, since) || m.header.stamp == msgs::Time::ZERO {
                        answers.mill5.push(m);
                    }
                }
                Some(Ok((m, _))) = belt6.next() => {
                    // A trajectory's stamp is its start time: zero means on receipt.
                    if is_ours(&m.header, since) || m.header.stamp == msgs::Time::ZERO {
                        answers.belt6.push(m);
                    }
                }
                _ = tokio::time::sleep(left) => break,
            }
        }
        answers
    }
}

/// Compares the node's answers with the recording, job by job; a job without
/// a final status within `timeout` is a difference.
fn report(rec: &Recorded, answers: &Answers, timeout: Duration) -> ReplayReport {
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
                timeout.as_secs_f64()
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
    report
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
    let link = Link::connect(options).await?;
    let since = msgs::Time::now();
    link.publish_inputs(&rec, since)?;
    let answers = link.collect(&ids, &since, options.timeout).await;
    Ok(report(&rec, &answers, options.timeout))
}
