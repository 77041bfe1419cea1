//! The node's health on `/diagnostics` (diagnostic_msgs/DiagnosticArray)
//! once a second, laid out as ROS's `diagnostic_updater` publishes it: one
//! status named `<node name>: planner` whose values are the queue, the
//! workers, the last planning time, the recorder and the peers discovered on
//! each of the node's topics (discovered, not matched: a peer with an
//! incompatible QoS is counted too). `rqt_robot_monitor` and the diagnostic
//! aggregator read it as any other node's.

use super::recorder::Recorder;
use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::ros2::QosProfile;
use ros2_client::{MessageTypeName, Name, Node, Publisher};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::time::Duration;
use toolpath_kernel::error::{Error, Result};
use toolpath_messages::diagnostics::{DiagnosticArray, DiagnosticStatus, KeyValue};
use toolpath_messages::{Header, RosMessage, Time};

/// The topic, absolute as diagnostic_updater's.
pub const TOPIC: &str = "/diagnostics";

/// How often the status is published.
pub const PERIOD: Duration = Duration::from_secs(1);

/// What the workers are doing, updated by them.
#[derive(Default)]
pub struct Activity {
    busy: AtomicUsize,
    planned: AtomicU64,
    /// Wall time of the last planned job, ns; 0 = none yet.
    last_planning_ns: AtomicU64,
}

/// A worker counts as busy while this lives.
pub struct Busy<'a>(&'a Activity);

impl Drop for Busy<'_> {
    fn drop(&mut self) {
        self.0.busy.fetch_sub(1, Ordering::Relaxed);
    }
}

impl Activity {
    /// Marks a worker busy until the guard drops.
    pub fn working(&self) -> Busy<'_> {
        self.busy.fetch_add(1, Ordering::Relaxed);
        Busy(self)
    }

    /// A job was planned (whatever its outcome) in `took`.
    pub fn planned(&self, took: Duration) {
        self.planned.fetch_add(1, Ordering::Relaxed);
        let ns = u64::try_from(took.as_nanos()).unwrap_or(u64::MAX).max(1);
        self.last_planning_ns.store(ns, Ordering::Relaxed);
    }
}

/// The recorder as diagnostics report it.
#[derive(Clone, Debug, PartialEq)]
pub enum RecorderState {
    Off,
    Recording,
    Paused,
    /// Writes failed: how many, and the last reason.
    Failing(u64, String),
}

impl RecorderState {
    pub fn of(recorder: Option<&Recorder>) -> Self {
        let Some(r) = recorder else {
            return Self::Off;
        };
        let f = r.failures();
        if f.errors > 0 || f.broken {
            Self::Failing(f.errors + f.dropped, f.last.unwrap_or_default())
        } else if r.paused() {
            Self::Paused
        } else {
            Self::Recording
        }
    }
}

/// The node's state at one moment.
#[derive(Clone, Debug)]
pub struct Snapshot {
    pub queued: usize,
    pub workers: usize,
    pub activity_busy: usize,
    pub planned: u64,
    pub last_planning: Option<Duration>,
    pub recorder: RecorderState,
    /// (fully qualified topic, "publishers" or "subscribers", how many other
    /// endpoints discovery knows on it).
    pub peers: Vec<(String, &'static str, usize)>,
}

impl Snapshot {
    /// The workers' part of a snapshot.
    pub fn activity(a: &Activity) -> (usize, u64, Option<Duration>) {
        let ns = a.last_planning_ns.load(Ordering::Relaxed);
        (
            a.busy.load(Ordering::Relaxed),
            a.planned.load(Ordering::Relaxed),
            (ns > 0).then(|| Duration::from_nanos(ns)),
        )
    }
}

/// The status of a node called `name` (`/ns/name` is `fully_qualified`):
/// OK, or WARN while the recorder fails to write.
pub fn status(name: &str, fully_qualified: &str, s: &Snapshot) -> DiagnosticStatus {
    let kv = |key: &str, value: String| KeyValue {
        key: key.to_string(),
        value,
    };
    let mut message = if s.activity_busy == 0 && s.queued == 0 {
        "idle".to_string()
    } else {
        format!(
            "planning on {} of {} workers, {} queued",
            s.activity_busy, s.workers, s.queued
        )
    };
    let recorder = match &s.recorder {
        RecorderState::Off => "off".to_string(),
        RecorderState::Recording => "recording".to_string(),
        RecorderState::Paused => "paused".to_string(),
        RecorderState::Failing(n, why) => format!("failing: {n} writes lost, last: {why}"),
    };
    let level = if let RecorderState::Failing(..) = s.recorder {
        message += &format!("; recorder {recorder}");
        DiagnosticStatus::WARN
    } else {
        DiagnosticStatus::OK
    };
    let mut values = vec![
        kv("queued jobs", s.queued.to_string()),
        kv("busy workers", s.activity_busy.to_string()),
        kv("workers", s.workers.to_string()),
        kv("jobs planned", s.planned.to_string()),
        kv(
            "last planning time s",
            s.last_planning
                .map_or_else(|| "none".to_string(), |d| format!("{:.3}", d.as_secs_f64())),
        ),
        kv("recorder", recorder),
    ];
    for (topic, kind, n) in &s.peers {
        values.push(kv(&format!("discovered {kind} {topic}"), n.to_string()));
    }
    DiagnosticStatus {
        level,
        name: format!("{name}: planner"),
        message,
        hardware_id: fully_qualified.to_string(),
        values,
    }
}

/// diagnostic_updater's publisher QoS: reliable, volatile, keep last 1
/// (a reader with ROS's default QoS matches it).
pub fn qos() -> QosProfile {
    QosProfile::subscription_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_millis(100)))
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 1 })
}

/// The `/diagnostics` publisher of `node`.
pub fn publisher(node: &mut Node) -> Result<Publisher<DiagnosticArray>> {
    let name =
        Name::new("/", "diagnostics").map_err(|e| Error::dds(format!("topic {TOPIC}: {e:?}")))?;
    let topic = node
        .create_topic(
            &name,
            MessageTypeName::new(DiagnosticArray::PACKAGE, DiagnosticArray::NAME),
            &qos(),
        )
        .map_err(|e| Error::dds(format!("cannot create topic {TOPIC}: {e:?}")))?;
    node.create_publisher(&topic, Some(qos()))
        .map_err(|e| Error::dds(format!("cannot publish on {TOPIC}: {e:?}")))
}

/// Publishes `status(snapshot())` every [`PERIOD`], forever.
pub async fn publish(
    publisher: Publisher<DiagnosticArray>,
    name: String,
    fully_qualified: String,
    snapshot: impl Fn() -> Snapshot,
) {
    let mut tick = tokio::time::interval(PERIOD);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        tick.tick().await;
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap_or_default();
        let msg = DiagnosticArray {
            header: Header {
                stamp: Time {
                    sec: i32::try_from(now.as_secs()).unwrap_or(i32::MAX),
                    nanosec: now.subsec_nanos(),
                },
                frame_id: String::new(),
            },
            status: vec![status(&name, &fully_qualified, &snapshot())],
        };
        if let Err(e) = publisher.async_publish(msg).await {
            log::warn!("cannot publish {TOPIC}: {e:?}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn snapshot() -> Snapshot {
        Snapshot {
            queued: 3,
            workers: 2,
            activity_busy: 2,
            planned: 7,
            last_planning: Some(Duration::from_millis(1234)),
            recorder: RecorderState::Recording,
            peers: vec![("/cell_b/job".into(), "publishers", 1)],
        }
    }

    #[test]
    fn a_busy_node_reports_its_queue_workers_and_peers() {
        let s = status("tp", "/cell_b/tp", &snapshot());
        assert_eq!(s.level, DiagnosticStatus::OK);
        assert_eq!(s.name, "tp: planner");
        assert_eq!(s.hardware_id, "/cell_b/tp");
        assert_eq!(s.message, "planning on 2 of 2 workers, 3 queued");
        let v: Vec<(&str, &str)> = s
            .values
            .iter()
            .map(|k| (k.key.as_str(), k.value.as_str()))
            .collect();
        assert_eq!(
            v,
            [
                ("queued jobs", "3"),
                ("busy workers", "2"),
                ("workers", "2"),
                ("jobs planned", "7"),
                ("last planning time s", "1.234"),
                ("recorder", "recording"),
                ("discovered publishers /cell_b/job", "1"),
            ]
        );
    }

    #[test]
    fn an_idle_node_is_ok_and_a_failing_recorder_warns() {
        let idle = Snapshot {
            queued: 0,
            activity_busy: 0,
            last_planning: None,
            recorder: RecorderState::Off,
            peers: vec![],
            ..snapshot()
        };
        let s = status("tp", "/tp", &idle);
        assert_eq!(
            (s.level, s.message.as_str()),
            (DiagnosticStatus::OK, "idle")
        );
        assert_eq!(s.values[4].value, "none");
        assert_eq!(s.values[5].value, "off");
        let failing = Snapshot {
            recorder: RecorderState::Failing(2, "disk full".into()),
            ..idle
        };
        let s = status("tp", "/tp", &failing);
        assert_eq!(s.level, DiagnosticStatus::WARN);
        assert_eq!(
            s.message,
            "idle; recorder failing: 2 writes lost, last: disk full"
        );
    }

    #[test]
    fn workers_are_busy_while_the_guard_lives() {
        let a = Activity::default();
        assert_eq!(Snapshot::activity(&a), (0, 0, None));
        {
            let _one = a.working();
            let _two = a.working();
            assert_eq!(Snapshot::activity(&a).0, 2);
            a.planned(Duration::from_millis(5));
        }
        assert_eq!(
            Snapshot::activity(&a),
            (0, 1, Some(Duration::from_millis(5)))
        );
    }
}
