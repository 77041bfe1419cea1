//! A client of `toolpath node` for the node tests, built on ros2-client as a
//! cell's own node would be: publishers of surface, pocket, job and cancel
//! and a reader of job_status, connected on loopback once the node's job and
//! cancel readers are discovered. Each test binary uses the parts it needs.
#![allow(dead_code)]

use std::net::{IpAddr, Ipv4Addr};
use std::time::Duration;
use toolpath_planner::messages::follow_joint_trajectory::StringMsg;
use toolpath_planner::messages::{self as msgs, topics};
use toolpath_planner::ros::node::{qos, RosNode};

pub struct NodeClient {
    pub ros: RosNode,
    pub surfaces: ros2_client::Publisher<msgs::Surface>,
    pub pockets: ros2_client::Publisher<msgs::Pocket>,
    pub jobs: ros2_client::Publisher<msgs::Job>,
    pub cancel: ros2_client::Publisher<StringMsg>,
    pub status: ros2_client::Subscription<msgs::JobStatus>,
}

impl NodeClient {
    /// A client named `name` on `domain` (loopback), once the node's job and
    /// cancel readers are discovered (20 s at most each).
    pub async fn connect(name: &str, domain: u16) -> NodeClient {
        Self::connect_secured(name, domain, None).await
    }

    /// [`NodeClient::connect`] with DDS Security from an SROS2 enclave
    /// directory (`None`: unsecured).
    pub async fn connect_secured(
        name: &str,
        domain: u16,
        enclave_dir: Option<&std::path::Path>,
    ) -> NodeClient {
        let client = Self::unconnected(name, domain, enclave_dir);
        tokio::time::timeout(
            Duration::from_secs(20),
            client.jobs.wait_for_subscription(&client.ros.node),
        )
        .await
        .expect("the node's job reader was not discovered");
        tokio::time::timeout(
            Duration::from_secs(20),
            client.cancel.wait_for_subscription(&client.ros.node),
        )
        .await
        .expect("the node's cancel reader was not discovered");
        client
    }

    /// The client's publishers and reader, without waiting for the node.
    pub fn unconnected(
        name: &str,
        domain: u16,
        enclave_dir: Option<&std::path::Path>,
    ) -> NodeClient {
        let lo = Some(vec![IpAddr::V4(Ipv4Addr::LOCALHOST)]);
        let mut ros = RosNode::secured(name, "/", domain, lo, enclave_dir).unwrap();
        NodeClient {
            surfaces: ros.publisher(topics::SURFACE, qos::shapes()).unwrap(),
            pockets: ros.publisher(topics::POCKET, qos::shapes()).unwrap(),
            jobs: ros.publisher(topics::JOB, qos::job()).unwrap(),
            cancel: ros.publisher(topics::CANCEL, qos::job()).unwrap(),
            status: ros
                .subscription(topics::JOB_STATUS, qos::status_reader())
                .unwrap(),
            ros,
        }
    }
}

/// The next status of job `id` on `statuses` (other jobs' are skipped),
/// waiting until `deadline`; panics naming the job when none comes.
pub async fn next_status_of<S, I, E>(
    statuses: &mut S,
    id: &str,
    deadline: std::time::Instant,
) -> msgs::JobStatus
where
    S: futures::Stream<Item = Result<(msgs::JobStatus, I), E>> + Unpin,
    E: std::fmt::Debug,
{
    use futures::StreamExt;
    loop {
        let left = deadline.saturating_duration_since(std::time::Instant::now());
        let (st, _) = tokio::time::timeout(left, statuses.next())
            .await
            .unwrap_or_else(|_| panic!("no final status of {id}"))
            .unwrap()
            .unwrap();
        if st.job_id == id {
            return st;
        }
    }
}
