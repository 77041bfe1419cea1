//! What the node publishes: the output publishers shared with the workers,
//! the strictly increasing header stamps, job statuses (recorded, and logged)
//! and the optional recorder, iceoryx2 thread, executors and NC programs.

use crate::config::{IpcSettings, NodeConfig};
use crate::dds::RosNode;
use crate::execute::{self, Cancels, Execution, Report};
use crate::qos;
use crate::recorder::Recorder;
use ros2_client::Publisher;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use toolpath_formats::{Machine, PlanResult};
use toolpath_ipc::ToolpathPublisher;
use toolpath_kernel::error::{Error, Result};
use toolpath_messages::{self as msgs, topics, RosMessage};

/// The node's publishers, shared with the workers.
pub(super) struct Outputs {
    pub(super) status: Mutex<Publisher<msgs::JobStatus>>,
    pub(super) toolpath: Mutex<Publisher<msgs::Toolpath>>,
    pub(super) poses: Mutex<Publisher<msgs::PoseArray>>,
    pub(super) segments: Mutex<Publisher<msgs::ToolPoseSegments>>,
    pub(super) mill5: Mutex<Publisher<msgs::JointTrajectory>>,
    pub(super) belt6: Mutex<Publisher<msgs::JointTrajectory>>,
    pub(super) markers: Mutex<Publisher<msgs::MarkerArray>>,
    pub(super) frame_id: String,
    pub(super) recorder: Option<Arc<Recorder>>,
    /// The last header stamp given out, ns since the epoch.
    pub(super) last_stamp_ns: AtomicU64,
    /// To the iceoryx2 publisher thread (its publisher is not `Send`).
    pub(super) ipc: Option<std::sync::mpsc::Sender<PlanResult>>,
    /// Executors of both machines (a job may execute on a machine whose
    /// `controller.execute` is off).
    pub(super) executors: Vec<(Machine, ExecutorQueue)>,
    /// Cancel requests of executions.
    pub(super) cancels: Arc<Cancels>,
    /// NC programs of mill5 results: the cell's mill5, the format, the directory.
    pub(super) programs: Option<(
        toolpath_post::PostMachine,
        toolpath_post::Format,
        std::path::PathBuf,
    )>,
}

/// The queue of a machine's executor task.
pub(super) type ExecutorQueue =
    tokio::sync::mpsc::UnboundedSender<(Execution, Arc<Report<'static>>)>;

/// Starts the thread that owns the iceoryx2 publisher and sends it every
/// result; fails (naming the service) when the publisher cannot be made.
fn start_ipc(
    settings: &IpcSettings,
) -> Result<(
    std::sync::mpsc::Sender<PlanResult>,
    std::thread::JoinHandle<()>,
)> {
    let (tx, rx) = std::sync::mpsc::channel::<PlanResult>();
    let (ready_tx, ready_rx) = std::sync::mpsc::channel::<Result<()>>();
    let (service, prefix) = (settings.service.clone(), settings.prefix.clone());
    let handle = std::thread::Builder::new()
        .name("ipc".into())
        .spawn(move || {
            let mut publisher = match ToolpathPublisher::with_prefix(&service, prefix.as_deref()) {
                Ok(p) => {
                    let _ = ready_tx.send(Ok(()));
                    p
                }
                Err(e) => {
                    let _ = ready_tx.send(Err(e));
                    return;
                }
            };
            for result in rx {
                if let Err(e) = publisher.publish(&result) {
                    log::error!("iceoryx2 {service}: job {}: {e}", result.job_id);
                }
            }
        })
        .map_err(|e| Error::system(format!("cannot start the iceoryx2 thread: {e}")))?;
    ready_rx
        .recv()
        .map_err(|_| Error::shutdown("the iceoryx2 thread stopped"))?
        .map_err(|e| e.within("ipc"))?;
    Ok((tx, handle))
}

impl Outputs {
    /// Publishes `m` on `topic` (and records it when the run is recorded).
    pub(super) fn publish<M: RosMessage>(&self, p: &Mutex<Publisher<M>>, topic: &str, m: M) {
        if let Some(r) = &self.recorder {
            r.record(topic, &m);
        }
        let guard = match p.lock() {
            Ok(g) => g,
            Err(poisoned) => poisoned.into_inner(),
        };
        if let Err(e) = guard.publish(m) {
            log::error!("cannot publish on {topic}: {e:?}");
        }
    }

    /// A header stamped now, strictly later than every earlier stamp of this
    /// node: the outputs of one job share a stamp that no other job's outputs
    /// carry, so clients can match them to their Toolpath by stamp.
    pub(super) fn header(&self) -> msgs::Header {
        let now = msgs::Time::now();
        let now_ns = u64::try_from(now.sec).unwrap_or(0) * 1_000_000_000 + u64::from(now.nanosec);
        let mut prev = self.last_stamp_ns.load(Ordering::Relaxed);
        let ns = loop {
            let next = now_ns.max(prev + 1);
            match self.last_stamp_ns.compare_exchange_weak(
                prev,
                next,
                Ordering::Relaxed,
                Ordering::Relaxed,
            ) {
                Ok(_) => break next,
                Err(p) => prev = p,
            }
        };
        msgs::Header {
            stamp: msgs::Time {
                sec: i32::try_from(ns / 1_000_000_000).unwrap_or(i32::MAX),
                nanosec: (ns % 1_000_000_000) as u32,
            },
            frame_id: self.frame_id.clone(),
        }
    }
    pub(super) fn status(&self, job_id: &str, state: u8, progress: f32, message: String) {
        self.status_eta(job_id, state, progress, message, ETA_UNKNOWN)
    }

    /// A status with the estimated seconds left (`eta_s`, [`ETA_UNKNOWN`]
    /// when there is no estimate).
    pub(super) fn status_eta(
        &self,
        job_id: &str,
        state: u8,
        progress: f32,
        mut message: String,
        eta_s: f32,
    ) {
        if let (true, Some(r)) = (state >= msgs::JobStatus::SUCCEEDED, &self.recorder) {
            if let Some(failed) = r.new_failures(RECORDING_SYNC_TIMEOUT) {
                message = if message.is_empty() {
                    failed
                } else {
                    format!("{message}; {failed}")
                };
            }
        }
        match state {
            msgs::JobStatus::FAILED | msgs::JobStatus::REJECTED => {
                log::warn!(
                    "job {job_id}: {}: {message}",
                    msgs::JobStatus::state_name(state)
                )
            }
            _ => log::info!(
                "job {job_id}: {} {progress:.2} {message}",
                msgs::JobStatus::state_name(state)
            ),
        }
        let m = msgs::JobStatus {
            header: self.header(),
            job_id: job_id.to_string(),
            state,
            progress,
            message,
            eta_s,
        };
        let is_final = m.is_final();
        self.publish(&self.status, topics::JOB_STATUS, m);
        if let (true, Some(r)) = (is_final, &self.recorder) {
            r.job_done();
        }
    }
}

/// `eta_s` of a status or feedback that carries no estimate.
pub(super) const ETA_UNKNOWN: f32 = -1.0;

/// Seconds left if the rest goes at the pace so far: `elapsed` x (1 - f) / f,
/// once there is progress to go by ([`ETA_UNKNOWN`] before 1 %).
pub(super) fn eta_s(elapsed: Duration, fraction: f32) -> f32 {
    if fraction < 0.01 {
        return ETA_UNKNOWN;
    }
    (elapsed.as_secs_f64() * f64::from(1.0 - fraction) / f64::from(fraction)) as f32
}

/// How long a job's final status waits for the recorder to write the job's
/// messages, so that a write error is reported in that status.
const RECORDING_SYNC_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(2);

/// Creates the output publishers and the optional recorder, iceoryx2 thread
/// and NC program directory; returns the iceoryx2 thread to join at the end.
pub(super) fn start_outputs(
    ros: &mut RosNode,
    config: &NodeConfig,
) -> Result<(Arc<Outputs>, Option<std::thread::JoinHandle<()>>)> {
    let settings = &config.node;
    let recorder = if config.recording.enabled {
        Some(Arc::new(Recorder::start(
            &config.recording,
            &settings.name,
            &settings.namespace,
        )?))
    } else {
        None
    };
    let ipc = if config.ipc.enabled {
        Some(start_ipc(&config.ipc)?)
    } else {
        None
    };
    let cancels = Arc::new(Cancels::default());
    let mut executors = Vec::new();
    for (machine, controller) in [
        (Machine::Mill5, &config.mill5.controller),
        (Machine::Belt6, &config.belt6.controller),
    ] {
        let action = controller.action(machine.name());
        let client = Arc::new(execute::client(ros, &action)?);
        let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
        tokio::spawn(execute::executor(client, action, rx, Arc::clone(&cancels)));
        executors.push((machine, tx));
    }
    let outputs = Arc::new(Outputs {
        status: Mutex::new(ros.publisher(topics::JOB_STATUS, qos::status())?),
        toolpath: Mutex::new(ros.publisher(topics::TOOLPATH, qos::results())?),
        poses: Mutex::new(ros.publisher(topics::TOOL_POSES, qos::results())?),
        segments: Mutex::new(ros.publisher(topics::TOOL_POSE_SEGMENTS, qos::results())?),
        mill5: Mutex::new(ros.publisher(topics::MILL5_TRAJECTORY, qos::results())?),
        belt6: Mutex::new(ros.publisher(topics::BELT6_TRAJECTORY, qos::results())?),
        markers: Mutex::new(ros.publisher(topics::MARKERS, qos::results())?),
        frame_id: settings.frame_id.clone(),
        recorder,
        last_stamp_ns: AtomicU64::new(0),
        ipc: ipc.as_ref().map(|(tx, _)| tx.clone()),
        executors,
        cancels,
        programs: if config.post.enabled {
            Some((
                toolpath_post::PostMachine::from_mill5(&config.mill5),
                config.post.format()?,
                config.post.directory(&config.recording),
            ))
        } else {
            None
        },
    });
    Ok((outputs, ipc.map(|(_, handle)| handle)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_time_left_goes_at_the_pace_so_far() {
        // A quarter done in 2 s: three quarters left at that pace, 6 s.
        assert_eq!(eta_s(Duration::from_secs(2), 0.25), 6.0);
        assert_eq!(eta_s(Duration::from_millis(1500), 1.0), 0.0);
        // Too little progress to go by.
        assert_eq!(eta_s(Duration::from_secs(5), 0.005), ETA_UNKNOWN);
        assert_eq!(eta_s(Duration::ZERO, 0.0), ETA_UNKNOWN);
    }
}
