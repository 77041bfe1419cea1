//! What the node publishes: the output publishers shared with the workers,
//! the strictly increasing header stamps, job statuses (recorded, and logged)
//! and the optional recorder, iceoryx2 thread, executors and NC programs.

use crate::config::{IpcSettings, NodeConfig};
use crate::dds::RosNode;
use crate::execute::{self, Cancels, Execution, Report};
use crate::journal::Journal;
use crate::plan_action::GoalLink;
use crate::qos;
use crate::recorder::Recorder;
use ros2_client::Publisher;
use std::collections::BTreeMap;
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
    /// The job journal, when the node keeps one.
    pub(super) journal: Option<Arc<Journal>>,
    /// The latest state and progress of each job that has not ended: what a
    /// refused second job under its id is told.
    latest: Mutex<BTreeMap<String, (u8, f32)>>,
    /// PlanToolpath goals sent again, by goal id, for a job accepted before
    /// the node restarted: they end with that job (by journal entry).
    reasked: Mutex<BTreeMap<u64, Vec<Arc<GoalLink>>>>,
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    match m.lock() {
        Ok(g) => g,
        Err(p) => p.into_inner(),
    }
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
        message: String,
        eta_s: f32,
    ) {
        let m = self.compose(job_id, state, progress, message, eta_s);
        self.send_status(m);
    }

    /// The final status of a job: written to the job journal (entry `seq`)
    /// before it goes out, so that a node restarted after a crash neither
    /// plans the job again nor leaves it without its final status.
    pub(super) fn finish(
        &self,
        job_id: &str,
        seq: Option<u64>,
        state: u8,
        progress: f32,
        message: String,
    ) {
        let m = self.compose(job_id, state, progress, message, ETA_UNKNOWN);
        let journaled = self.journal.as_ref().zip(seq);
        if let Some((j, seq)) = journaled {
            if let Err(e) = j.finish(seq, &m) {
                log::error!("job {job_id}: its final status is not in the journal: {e}");
            }
        }
        let (state, reason) = (m.state, m.message.clone());
        self.send_status(m);
        if let Some((j, seq)) = journaled {
            if let Err(e) = j.sent(seq) {
                log::error!("job {job_id}: {e}");
            }
            for link in lock(&self.reasked).remove(&seq).unwrap_or_default() {
                link.finish(state, reason.clone());
            }
        }
    }

    /// Publishes again, as it was, a final status the journal holds (entry
    /// `seq`) without a record that it went out.
    pub(super) fn resend(&self, seq: u64, m: msgs::JobStatus) {
        let id = m.job_id.clone();
        self.send_status(m);
        if let Some(j) = &self.journal {
            if let Err(e) = j.sent(seq) {
                log::error!("job {id}: {e}");
            }
        }
    }

    /// Answers a second job under the id of a job that is queued or
    /// running: a status of the first job (its latest state and progress,
    /// never a final one) whose message says the second was refused.
    pub(super) fn refuse_duplicate(&self, job_id: &str, why: String) {
        let (state, progress) = lock(&self.latest)
            .get(job_id)
            .copied()
            .unwrap_or((msgs::JobStatus::ACCEPTED, 0.0));
        self.status(job_id, state, progress, why);
    }

    /// Ends `link` with the job of journal entry `seq` (a goal sent again
    /// after a restart, by the goal id of a job accepted before it).
    pub(super) fn end_with(&self, seq: u64, link: &Arc<GoalLink>) {
        lock(&self.reasked)
            .entry(seq)
            .or_default()
            .push(Arc::clone(link));
        // The job may have ended meanwhile: its final is in the journal then.
        let ended = self
            .journal
            .as_ref()
            .and_then(|j| j.final_of(seq).ok().flatten());
        if let Some(m) = ended {
            link.finish(m.state, m.message);
        }
    }

    /// A status message; a final one carries the write errors of the
    /// recording that hit its job.
    fn compose(
        &self,
        job_id: &str,
        state: u8,
        progress: f32,
        mut message: String,
        eta_s: f32,
    ) -> msgs::JobStatus {
        if let (true, Some(r)) = (state >= msgs::JobStatus::SUCCEEDED, &self.recorder) {
            if let Some(failed) = r.new_failures(RECORDING_SYNC_TIMEOUT) {
                message = if message.is_empty() {
                    failed
                } else {
                    format!("{message}; {failed}")
                };
            }
        }
        msgs::JobStatus {
            header: self.header(),
            job_id: job_id.to_string(),
            state,
            progress,
            message,
            eta_s,
        }
    }

    /// Logs a status, writes it into the bag (handed to the operating
    /// system, so a client that saw it finds it in the bag of a node killed
    /// right after) and publishes it.
    fn send_status(&self, m: msgs::JobStatus) {
        let (job_id, state) = (&m.job_id, m.state);
        match state {
            msgs::JobStatus::FAILED | msgs::JobStatus::REJECTED => {
                log::warn!(
                    "job {job_id}: {}: {}",
                    msgs::JobStatus::state_name(state),
                    m.message
                )
            }
            _ => log::info!(
                "job {job_id}: {} {:.2} {}",
                msgs::JobStatus::state_name(state),
                m.progress,
                m.message
            ),
        }
        let is_final = m.is_final();
        {
            let mut latest = lock(&self.latest);
            if is_final {
                latest.remove(job_id);
            } else {
                latest.insert(job_id.clone(), (state, m.progress));
            }
        }
        if let Some(r) = &self.recorder {
            r.record_written(topics::JOB_STATUS, &m, RECORDING_WRITE_TIMEOUT);
        }
        let guard = lock(&self.status);
        if let Err(e) = guard.publish(m) {
            log::error!("cannot publish on {}: {e:?}", topics::JOB_STATUS);
        }
        drop(guard);
        if let (true, Some(r)) = (is_final, &self.recorder) {
            r.job_done();
        }
    }
}

/// How long a status waits for the recorder to write it before it is
/// published anyway (a disk that hangs must not stop the node).
const RECORDING_WRITE_TIMEOUT: Duration = Duration::from_secs(10);

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
    journal: Option<Arc<Journal>>,
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
        journal,
        latest: Mutex::default(),
        reasked: Mutex::default(),
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
