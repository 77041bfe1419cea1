//! Waiting for a DDS match survives a discovery burst. ros2-client hands
//! each waiting future a bounded channel of node events and drops events
//! when it is full; the future used to re-check its match only on an event
//! of its own kind, so a burst of other events before its match left it
//! waiting forever (a node test's action was "not discovered" under load).
//! Here a writer's wait is created, then, before it is first polled, a peer
//! matches more readers of ours than the channel holds and only then a
//! reader of the writer: the wait must still resolve. Loopback only, a
//! random domain.

#[path = "common/node_process.rs"]
mod node_process;

use std::net::{IpAddr, Ipv4Addr};
use std::time::Duration;
use toolpath_planner::messages as msgs;
use toolpath_planner::ros::node::{qos, RosNode};

/// More matches than the event channel of a wait holds (64).
const BURST: usize = 80;

#[test]
fn a_wait_for_a_reader_resolves_after_a_burst_of_other_matches() {
    let d = node_process::fresh_domain(0);
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let lo = Some(vec![IpAddr::V4(Ipv4Addr::LOCALHOST)]);
        let mut ours = RosNode::new("waiting", "/", d, lo.clone()).unwrap();
        let mut peer = RosNode::new("peer", "/", d, lo).unwrap();
        // Discovery between the two participants first: its matches of
        // built-in endpoints would wake the wait on their own.
        let warm_writer = ours
            .publisher::<msgs::JobStatus>("warm_up", qos::results())
            .unwrap();
        let _warm_reader = peer
            .subscription::<msgs::JobStatus>("warm_up", qos::results())
            .unwrap();
        let deadline = tokio::time::Instant::now() + Duration::from_secs(60);
        while warm_writer.get_subscription_count(&ours.node) == 0 {
            assert!(
                tokio::time::Instant::now() < deadline,
                "the peer was not discovered within 60 s"
            );
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        tokio::time::sleep(Duration::from_secs(1)).await;

        let writer = ours
            .publisher::<msgs::JobStatus>("wait_target", qos::results())
            .unwrap();
        let readers: Vec<_> = (0..BURST)
            .map(|i| {
                ours.subscription::<msgs::JobStatus>(&format!("burst_{i}"), qos::results())
                    .unwrap()
            })
            .collect();
        // Created now, first polled only after every match below.
        let wait = writer.wait_for_subscription(&ours.node);
        // A second receiver of the same capacity shows the burst overflowed it.
        let probe = ours.node.status_receiver().unwrap();

        let peer_writers: Vec<_> = (0..BURST)
            .map(|i| {
                peer.publisher::<msgs::JobStatus>(&format!("burst_{i}"), qos::results())
                    .unwrap()
            })
            .collect();
        let all_matched = |ours: &RosNode| {
            readers
                .iter()
                .all(|r| r.get_publisher_count(&ours.node) > 0)
        };
        while !all_matched(&ours) {
            assert!(
                tokio::time::Instant::now() < deadline,
                "the peer's {BURST} writers were not matched within 60 s"
            );
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        let _peer_reader = peer
            .subscription::<msgs::JobStatus>("wait_target", qos::results())
            .unwrap();
        while writer.get_subscription_count(&ours.node) == 0 {
            assert!(
                tokio::time::Instant::now() < deadline,
                "the peer's reader was not matched within 60 s"
            );
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        assert!(
            probe.is_full(),
            "the burst did not fill the event channel ({} events)",
            probe.len()
        );
        // The match is in the node's map; the wait must see it.
        tokio::time::timeout(Duration::from_secs(10), wait)
            .await
            .expect("the wait missed a match made during a burst of other matches");
        drop(peer_writers);
    });
}
