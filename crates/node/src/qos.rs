//! QoS of the node's topics (all reliable but `joint_states`), shared by the
//! node and its clients (docs/node.md, "QoS of every endpoint").

use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::ros2::QosProfile;
use std::time::Duration;

fn reliable(durability: Durability, history: History) -> QosProfile {
    QosProfile::subscription_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_secs(5)))
        .durability(durability)
        .history(history)
}
/// `surface`, `pocket`: transient-local, depth 100 (late-joining node still gets them).
pub fn shapes() -> QosProfile {
    reliable(Durability::TransientLocal, History::KeepLast { depth: 100 })
}
/// `job`: volatile, depth 100.
pub fn job() -> QosProfile {
    reliable(Durability::Volatile, History::KeepLast { depth: 100 })
}
/// Samples the node's `job` reader holds before the node has taken them.
///
/// The depth is what bounds the reader's cache in RustDDS 0.15: a KEEP_ALL
/// reader without RESOURCE_LIMITS (which ros2-client's `QosProfile` cannot
/// carry) is capped at 64 samples, and the cache evicts the oldest samples
/// over the cap whether or not the reader has taken them, after the RTPS
/// reader has acknowledged them, so the writer never repairs them. A burst
/// arrives as a few 64 KB datagrams of ~350 coalesced jobs, each inserted
/// under one lock, so the node cannot take in between: with KEEP_ALL a
/// burst of more than ~128 jobs loses jobs (docs/architecture.md, "Job
/// bursts: the RustDDS reader cache"). Jobs are a few hundred bytes, so
/// 10 000 cost a few MB.
pub const JOB_READER_DEPTH: usize = 10_000;
/// The node's reader of `job`: [`job`] with [`JOB_READER_DEPTH`]. History
/// is not part of QoS matching, so publishers still see the documented
/// profile.
pub fn job_reader() -> QosProfile {
    job().history(History::KeepLast {
        depth: JOB_READER_DEPTH,
    })
}
/// The node's readers of `surface` and `pocket`: keep-last 100 (not
/// KEEP_ALL, which RustDDS caps at 64, see [`JOB_READER_DEPTH`]); a
/// transient-local writer of depth 100 offers no more to a late joiner,
/// and read samples stay in the cache up to the depth, which for large
/// surfaces is memory. This one is volatile: it matches ROS's default
/// publisher (reliable, volatile, keep-last 10) and transient-local ones.
pub fn shapes_reader() -> QosProfile {
    reliable(Durability::Volatile, History::KeepLast { depth: 100 })
}
/// The second reader of `surface` and `pocket`: transient-local, so a
/// transient-local publisher that published before the node started
/// hands it its history (see `shape_readers`).
pub fn shapes_history_reader() -> QosProfile {
    shapes()
}
/// A client's reader of `job_status` that must see every status of a
/// burst (about four per job) even when it reads late: deep like
/// [`JOB_READER_DEPTH`].
pub fn status_reader() -> QosProfile {
    status().history(History::KeepLast {
        depth: JOB_READER_DEPTH,
    })
}
/// `job_status`: transient-local, depth 1000 (a burst's statuses are not overwritten).
pub fn status() -> QosProfile {
    reliable(
        Durability::TransientLocal,
        History::KeepLast { depth: 1000 },
    )
}
/// The node's reader of `joint_states`: best effort (matches reliable and
/// best-effort broadcasters), volatile, depth 10; only the latest counts.
pub fn joint_states() -> QosProfile {
    QosProfile::subscription_default()
        .reliability(ros2_client::qos::Reliability::BestEffort)
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
}
/// Results (toolpath, tool_poses, tool_pose_segments, trajectories,
/// markers): transient-local, depth 10.
pub fn results() -> QosProfile {
    reliable(Durability::TransientLocal, History::KeepLast { depth: 10 })
}
