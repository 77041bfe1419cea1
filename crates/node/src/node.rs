//! The `toolpath_planner` node: subscribes to surfaces, pockets and jobs,
//! plans each job on a worker thread through [`toolpath_pipeline::run`] and
//! publishes the toolpath, tool poses, joint trajectory, markers and status.
//!
//! Threads: the tokio runtime receives messages and never plans; `workers`
//! planning threads take jobs from one queue. A job whose surface has not
//! arrived yet stays queued (other jobs overtake it) until the surface
//! arrives or `surface_timeout_s` passes. Every job gets exactly one final
//! status; a panic inside a planner becomes FAILED, never a dead node.

use super::config::{IpcSettings, NodeConfig};
use super::execute::{self, Cancels, Execution, Report};
use super::joint_states::JointStates;
use super::parameters::{self, LiveConfig, Resolved};
use super::plan_action::GoalLink;
use super::recorder::Recorder;
use super::ros_args::Remaps;
use super::shape_readers::ShapeReaders;
use futures::StreamExt;
use ros2_client::ros2::QosProfile;
use ros2_client::{
    qos::{Durability, History, WhenFull},
    Context, MessageTypeName, Name, Node, NodeName, NodeOptions, Publisher, Subscription,
};
use std::collections::{BTreeMap, VecDeque};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};
use toolpath_formats::job::DEFAULT_FEED_RATE;
use toolpath_formats::{Machine, PlanResult, Shape};
use toolpath_ipc::ToolpathPublisher;
use toolpath_kernel::error::{Error, Result};
use toolpath_machines::Machines;
use toolpath_messages::frames::Frames;
use toolpath_messages::{self as msgs, convert, final_state, topics, JobOutputs, RosMessage};
use toolpath_pipeline::{self as pipeline, RunOptions};
use toolpath_planners::Progress;

mod goals;

/// Start of the per-job timing line the node logs at debug level.
pub const TIMING_TAG: &str = "timing:";

/// QoS of the topics (all reliable).
pub mod qos {
    use super::*;
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
}

/// Absolute ROS name of a relative topic in `namespace`.
pub fn topic_name(namespace: &str, relative: &str) -> Result<Name> {
    let full = topics::absolute(namespace, relative);
    Name::parse(&full).map_err(|e| {
        Error::invalid(
            "node.namespace",
            format!("topic name \"{full}\" is not valid: {e}"),
        )
    })
}

fn ros_err(what: &str, e: impl std::fmt::Debug) -> Error {
    Error::planning(format!("ROS 2: {what}: {e:?}"))
}

/// The IP addresses of this host's network interfaces.
fn host_addresses() -> Result<Vec<std::net::IpAddr>> {
    let addrs = nix::ifaddrs::getifaddrs()
        .map_err(|e| Error::planning(format!("cannot list the network interfaces: {e}")))?;
    Ok(addrs
        .filter_map(|a| {
            let a = a.address?;
            if let Some(v4) = a.as_sockaddr_in() {
                Some(std::net::IpAddr::V4(v4.ip()))
            } else {
                a.as_sockaddr_in6().map(|v6| std::net::IpAddr::V6(v6.ip()))
            }
        })
        .collect())
}

/// Every configured interface address must belong to this host: DDS would
/// otherwise advertise an address nobody can reach it on (or none at all)
/// and the node would look ready while deaf.
pub fn check_on_this_host(ips: &[std::net::IpAddr]) -> Result<()> {
    let host = host_addresses()?;
    for (k, ip) in ips.iter().enumerate() {
        if !host.contains(ip) {
            let mut have: Vec<String> = host.iter().map(|a| a.to_string()).collect();
            have.sort();
            have.dedup();
            return Err(Error::invalid(
                format!("node.interfaces[{k}]"),
                format!(
                    "{ip} is not an address of this host (its addresses: {})",
                    have.join(", ")
                ),
            ));
        }
    }
    Ok(())
}

/// A ROS 2 context + node on the configured domain and interfaces, with the
/// spinner running (without it matching never completes).
pub struct RosNode {
    pub node: Node,
    pub namespace: String,
    /// Topic remapping rules (`--ros-args -r from:=to`).
    remaps: Remaps,
    /// The request/reply mapping of the services and actions it creates.
    pub service_mapping: ros2_client::ServiceMapping,
    _context: Context,
}

impl RosNode {
    pub fn new(
        name: &str,
        namespace: &str,
        domain_id: u16,
        interfaces: Option<Vec<std::net::IpAddr>>,
    ) -> Result<Self> {
        Self::secured(name, namespace, domain_id, interfaces, None)
    }

    /// [`RosNode::new`] with DDS Security from an SROS2 enclave directory
    /// (`None`: unsecured); see [`super::security`].
    pub fn secured(
        name: &str,
        namespace: &str,
        domain_id: u16,
        interfaces: Option<Vec<std::net::IpAddr>>,
        enclave_dir: Option<&std::path::Path>,
    ) -> Result<Self> {
        let options = NodeOptions::new().enable_rosout(false);
        Self::with_options(
            name,
            namespace,
            domain_id,
            interfaces,
            options,
            &[],
            enclave_dir,
        )
    }

    /// A node with `options` (parameters, rosout), topic `remaps` and DDS
    /// Security from `enclave_dir` when given.
    pub fn with_options(
        name: &str,
        namespace: &str,
        domain_id: u16,
        interfaces: Option<Vec<std::net::IpAddr>>,
        options: NodeOptions,
        remaps: &[(String, String)],
        enclave_dir: Option<&std::path::Path>,
    ) -> Result<Self> {
        let mut builder = rustdds::DomainParticipantBuilder::new(domain_id);
        if let Some(ips) = interfaces {
            check_on_this_host(&ips)?;
            builder = builder.with_only_networks(ips);
        }
        if let Some(dir) = enclave_dir {
            builder = super::security::secure(builder, dir)?;
        }
        let dp = builder.build().map_err(|e| match enclave_dir {
            Some(dir) => Error::invalid(
                dir.display().to_string(),
                format!("DDS Security refused the enclave's files: {e}"),
            ),
            None => ros_err("cannot create the DDS participant", e),
        })?;
        let context = Context::from_domain_participant(dp)
            .map_err(|e| ros_err("cannot create the context", e))?;
        let node_name = NodeName::new(namespace, name)
            .map_err(|e| Error::invalid("node.name", format!("\"{namespace}\" \"{name}\": {e}")))?;
        let mut node = context
            .new_node(node_name, options)
            .map_err(|e| ros_err("cannot create the node", e))?;
        let spinner = node
            .spinner()
            .map_err(|e| ros_err("cannot start the spinner", e))?;
        tokio::spawn(async move {
            if let Err(e) = spinner.spin().await {
                log::error!("ROS 2 spinner stopped: {e:?}");
            }
        });
        Ok(Self {
            node,
            namespace: namespace.to_string(),
            remaps: Remaps::new(remaps, namespace, name),
            service_mapping: ros2_client::ServiceMapping::Enhanced,
            _context: context,
        })
    }

    /// The fully qualified name of the node's topic `relative`, after remapping.
    pub fn resolved(&self, relative: &str) -> String {
        self.remaps
            .apply(&topics::absolute(&self.namespace, relative))
    }

    fn topic<M: RosMessage>(&mut self, relative: &str, qos: &QosProfile) -> Result<rustdds::Topic> {
        let name = topic_name(&self.namespace, relative)?;
        let name = match self.remaps.apply(&name.to_string()) {
            same if same == name.to_string() => name,
            remapped => Name::parse(&remapped).map_err(|e| {
                Error::invalid(
                    "--ros-args -r",
                    format!("topic {relative} remapped to \"{remapped}\", which is not a valid name: {e}"),
                )
            })?,
        };
        self.node
            .create_topic(&name, MessageTypeName::new(M::PACKAGE, M::NAME), qos)
            .map_err(|e| ros_err(&format!("cannot create topic {relative}"), e))
    }

    pub fn publisher<M: RosMessage>(
        &mut self,
        relative: &str,
        qos: QosProfile,
    ) -> Result<Publisher<M>> {
        let topic = self.topic::<M>(relative, &qos)?;
        self.node
            .create_publisher(&topic, Some(qos))
            .map_err(|e| ros_err(&format!("cannot publish on {relative}"), e))
    }

    pub fn subscription<M: RosMessage>(
        &mut self,
        relative: &str,
        qos: QosProfile,
    ) -> Result<Subscription<M>> {
        let topic = self.topic::<M>(relative, &qos)?;
        self.node
            .create_subscription(&topic, Some(qos))
            .map_err(|e| ros_err(&format!("cannot subscribe to {relative}"), e))
    }
}

/// The node's publishers, shared with the workers.
struct Outputs {
    status: Mutex<Publisher<msgs::JobStatus>>,
    toolpath: Mutex<Publisher<msgs::Toolpath>>,
    poses: Mutex<Publisher<msgs::PoseArray>>,
    segments: Mutex<Publisher<msgs::ToolPoseSegments>>,
    mill5: Mutex<Publisher<msgs::JointTrajectory>>,
    belt6: Mutex<Publisher<msgs::JointTrajectory>>,
    markers: Mutex<Publisher<msgs::MarkerArray>>,
    frame_id: String,
    recorder: Option<Arc<Recorder>>,
    /// The last header stamp given out, ns since the epoch.
    last_stamp_ns: AtomicU64,
    /// To the iceoryx2 publisher thread (its publisher is not `Send`).
    ipc: Option<std::sync::mpsc::Sender<PlanResult>>,
    /// Executors of both machines (a job may execute on a machine whose
    /// `controller.execute` is off).
    executors: Vec<(Machine, ExecutorQueue)>,
    /// Cancel requests of executions.
    cancels: Arc<Cancels>,
    /// NC programs of mill5 results: the cell's mill5, the format, the directory.
    programs: Option<(
        toolpath_post::PostMachine,
        toolpath_post::Format,
        std::path::PathBuf,
    )>,
}

/// The queue of a machine's executor task.
type ExecutorQueue = tokio::sync::mpsc::UnboundedSender<(Execution, Arc<Report<'static>>)>;

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
        .map_err(|e| Error::planning(format!("cannot start the iceoryx2 thread: {e}")))?;
    ready_rx
        .recv()
        .map_err(|_| Error::planning("the iceoryx2 thread stopped"))?
        .map_err(|e| e.within("ipc"))?;
    Ok((tx, handle))
}

impl Outputs {
    /// Publishes `m` on `topic` (and records it when the run is recorded).
    fn publish<M: RosMessage>(&self, p: &Mutex<Publisher<M>>, topic: &str, m: M) {
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
    fn header(&self) -> msgs::Header {
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
    fn status(&self, job_id: &str, state: u8, progress: f32, message: String) {
        self.status_eta(job_id, state, progress, message, ETA_UNKNOWN)
    }

    /// A status with the estimated seconds left (`eta_s`, [`ETA_UNKNOWN`]
    /// when there is no estimate).
    fn status_eta(&self, job_id: &str, state: u8, progress: f32, mut message: String, eta_s: f32) {
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
const ETA_UNKNOWN: f32 = -1.0;

/// Seconds left if the rest goes at the pace so far: `elapsed` x (1 - f) / f,
/// once there is progress to go by ([`ETA_UNKNOWN`] before 1 %).
fn eta_s(elapsed: Duration, fraction: f32) -> f32 {
    if fraction < 0.01 {
        return ETA_UNKNOWN;
    }
    (elapsed.as_secs_f64() * f64::from(1.0 - fraction) / f64::from(fraction)) as f32
}

/// How long a job's final status waits for the recorder to write the job's
/// messages, so that a write error is reported in that status.
const RECORDING_SYNC_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(2);

/// What the node knows about a shape id.
#[derive(Clone)]
enum ShapeEntry {
    Ready(Arc<Shape>),
    Rejected(String),
}

struct Pending {
    msg: msgs::Job,
    received: Instant,
    deadline: Instant,
    /// The shape this job plans on: the one known when the job was accepted,
    /// else the first to arrive after; a later re-publish of the same id does
    /// not change it.
    shape: Option<ShapeEntry>,
    /// The PlanToolpath goal (or service request) the job serves, if any.
    goal: Option<Arc<GoalLink>>,
}

/// Shapes the node keeps by id. Beyond this the least recently received
/// shape is dropped; a queued job keeps the shape it was bound to, so only a
/// job sent later for an evicted id waits for it to be published again.
pub const MAX_SHAPES: usize = 100;

#[derive(Default)]
struct State {
    /// Shapes by id, with the order they were received in (for eviction).
    shapes: BTreeMap<String, (u64, ShapeEntry)>,
    received_shapes: u64,
    queue: VecDeque<Pending>,
    /// The messages of the jobs queued or being planned, by job_id.
    active: BTreeMap<String, msgs::Job>,
    shutdown: bool,
    /// Planning threads running, and how many `node.workers` asks for:
    /// surplus threads leave when they next look for work.
    running_workers: usize,
    wanted_workers: usize,
}

/// What to do with a job message whose job_id may already be in use.
#[derive(Debug, PartialEq)]
enum Admission {
    New,
    /// The same job sent again while queued or running: its statuses answer it.
    Resent,
    /// Another job under a job_id that is queued or running: refused.
    Conflict(String),
}

impl State {
    fn admit(&self, msg: &msgs::Job) -> Admission {
        let Some(active) = self.active.get(&msg.job_id) else {
            return Admission::New;
        };
        // The header (stamp) differs between sends of the same job.
        let same = msgs::Job {
            header: active.header.clone(),
            ..msg.clone()
        } == *active;
        if same {
            Admission::Resent
        } else {
            Admission::Conflict(format!(
                "job_id \"{}\" is already queued or running with other parameters: one job_id, one plan (use a new job_id)",
                msg.job_id
            ))
        }
    }

    /// Stores a received shape, binds it to the queued jobs waiting for it,
    /// and evicts the least recently received shapes beyond [`MAX_SHAPES`].
    fn insert_shape(&mut self, id: String, entry: ShapeEntry) {
        for p in self.queue.iter_mut() {
            if p.shape.is_none() && p.msg.surface_id == id {
                p.shape = Some(entry.clone());
            }
        }
        self.received_shapes += 1;
        self.shapes.insert(id, (self.received_shapes, entry));
        while self.shapes.len() > MAX_SHAPES {
            let oldest = self
                .shapes
                .iter()
                .min_by_key(|(_, (order, _))| *order)
                .map(|(id, _)| id.clone());
            match oldest {
                Some(id) => {
                    self.shapes.remove(&id);
                }
                None => break,
            }
        }
    }
}

struct Shared {
    state: Mutex<State>,
    wake: Condvar,
    /// The latest `/joint_states`: where each trajectory starts.
    joints: JointStates,
    /// The settings each job is planned with (parameters change them).
    live: Arc<LiveConfig>,
    /// Busy workers and planning times, for `/diagnostics`.
    activity: super::diagnostics::Activity,
}

impl Shared {
    fn lock(&self) -> std::sync::MutexGuard<'_, State> {
        match self.state.lock() {
            Ok(g) => g,
            Err(p) => p.into_inner(),
        }
    }
}

/// What a worker takes from the queue.
enum Work {
    Plan(Pending, Arc<Shape>),
    Reject(Pending, String),
    TimedOut(Pending),
}

/// Blocks until a job can be handled: the first queued job whose shape has
/// arrived (or been rejected), or whose wait has timed out.
fn next_work(shared: &Shared) -> Option<Work> {
    let mut st = shared.lock();
    loop {
        if st.shutdown {
            return None;
        }
        if st.running_workers > st.wanted_workers {
            st.running_workers -= 1;
            return None;
        }
        let now = Instant::now();
        let mut pick = None;
        let mut earliest: Option<Instant> = None;
        for (k, p) in st.queue.iter().enumerate() {
            match &p.shape {
                Some(_) => {
                    pick = Some(k);
                    break;
                }
                None if p.deadline <= now => {
                    pick = Some(k);
                    break;
                }
                None => {
                    earliest = Some(earliest.map_or(p.deadline, |e: Instant| e.min(p.deadline)))
                }
            }
        }
        if let Some(k) = pick {
            let p = st.queue.remove(k)?;
            return Some(match p.shape.clone() {
                Some(ShapeEntry::Ready(s)) => Work::Plan(p, s),
                Some(ShapeEntry::Rejected(why)) => Work::Reject(p, why),
                None => Work::TimedOut(p),
            });
        }
        st = match earliest {
            Some(t) => match shared
                .wake
                .wait_timeout(st, t.saturating_duration_since(now))
            {
                Ok((g, _)) => g,
                Err(p) => p.into_inner().0,
            },
            None => match shared.wake.wait(st) {
                Ok(g) => g,
                Err(p) => p.into_inner(),
            },
        };
    }
}

/// RUNNING statuses (and goal feedback) from planner progress, at most
/// every 100 ms or 10 %; its check stops a job canceled on the `cancel`
/// topic or whose goal was canceled.
struct StatusProgress<'a> {
    outputs: &'a Outputs,
    job_id: &'a str,
    last: Mutex<(Instant, f32)>,
    goal: Option<&'a GoalLink>,
    /// When planning started: the pace for the estimated time left.
    started: Instant,
}

impl Progress for StatusProgress<'_> {
    fn set(&self, fraction: f32) {
        let f = if fraction.is_finite() {
            fraction.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let mut last = match self.last.lock() {
            Ok(g) => g,
            Err(p) => p.into_inner(),
        };
        if f > last.1
            && (f - last.1 >= 0.1 || last.0.elapsed() >= Duration::from_millis(100))
            && f < 1.0
        {
            *last = (Instant::now(), f);
            let eta = eta_s(self.started.elapsed(), f);
            self.outputs
                .status_eta(self.job_id, msgs::JobStatus::RUNNING, f, String::new(), eta);
            if let Some(g) = self.goal {
                g.feedback("planning", f, eta);
            }
        }
    }

    fn check(&self) -> Result<()> {
        if self.outputs.cancels.requested(self.job_id) {
            return Err(Error::canceled("canceled on topic cancel while planning"));
        }
        self.goal.map_or(Ok(()), GoalLink::check)
    }
}

/// Where `machine` is according to `/joint_states` (`None`: never reported,
/// start from its home pose).
fn start_pose(
    joints: &JointStates,
    machine: Machine,
    machines: &Machines,
) -> Result<Option<Vec<f64>>> {
    let axes = machines.axes(machine);
    let (names, limits, controller) = (axes.joint_names, axes.limits, axes.controller);
    joints.start_pose(
        machine.name(),
        &names,
        &limits,
        Duration::from_secs_f64(controller.joint_states_max_age_s),
        Instant::now(),
    )
}

/// Plans one job and publishes its outputs; returns the success summary.
fn plan_and_publish(
    p: &Pending,
    shape: &Shape,
    outputs: &Arc<Outputs>,
    machines: &Machines,
    joints: &JointStates,
    options: RunOptions,
) -> Result<String> {
    let job = convert::job_from_msg(&p.msg, shape)?;
    outputs.status(&job.job_id, msgs::JobStatus::RUNNING, 0.0, String::new());
    let progress = StatusProgress {
        outputs,
        job_id: &job.job_id,
        last: Mutex::new((Instant::now(), 0.0)),
        goal: p.goal.as_deref(),
        started: Instant::now(),
    };
    if let Some(g) = &p.goal {
        g.feedback("planning", 0.0, ETA_UNKNOWN);
    }
    progress.check()?;
    let planning_started = Instant::now();
    let result = pipeline::run(&job, &progress, options)?;
    // A cancel during planning ends the job here at the latest: nothing is
    // published.
    progress.check()?;
    pipeline::refuse_gouge(&job, &result)?;
    let planning = planning_started.elapsed();
    let start = start_pose(joints, job.machine, machines)?;
    let trajectory = toolpath_machines::trajectory_from(&job, &result, machines, start.as_deref())?;
    let out = msgs::job_outputs(
        &job,
        &p.msg.surface_id,
        &result,
        &trajectory,
        &outputs.header(),
    );
    let mut summary = format!(
        "{}, planned in {:.1} ms",
        out.summary(),
        result.stats.compute_ms
    );
    // A plan the simulator finds above the scallop height (or an MPEC plan
    // below its band) still succeeds, but its final status says so.
    if result.within_scallop == Some(false) {
        let why: Vec<&str> = result
            .warnings
            .iter()
            .filter(|w| {
                w.starts_with(toolpath_pipeline::ABOVE_LIMIT)
                    || w.starts_with(toolpath_pipeline::BELOW_BAND)
            })
            .map(String::as_str)
            .collect();
        summary.push_str(&format!("; WARNING: {}", why.join("; ")));
    }
    let trajectory_topic = out.trajectory_topic();
    let executes = job
        .execute
        .unwrap_or_else(|| machines.executes_by_default(job.machine));
    let executor = outputs
        .executors
        .iter()
        .find(|(m, _)| *m == job.machine && executes)
        .map(|(_, q)| q);
    let chunks = executor.map(|_| convert::trajectory_chunks(&trajectory, &out.trajectory));
    let JobOutputs {
        toolpath,
        poses,
        segments,
        machine,
        trajectory,
        markers,
    } = out;
    if let Some(g) = &p.goal {
        g.keep_toolpath(&toolpath);
    }
    outputs.publish(&outputs.toolpath, topics::TOOLPATH, toolpath);
    // `toolpath bench-node` reads this line (target: debug, this module).
    log::debug!(
        "{TIMING_TAG} job={} received_to_toolpath_published_ms={:.3} planning_ms={:.3}",
        job.job_id,
        p.received.elapsed().as_secs_f64() * 1e3,
        planning.as_secs_f64() * 1e3
    );
    outputs.publish(&outputs.poses, topics::TOOL_POSES, poses);
    outputs.publish(&outputs.segments, topics::TOOL_POSE_SEGMENTS, segments);
    let publisher = match machine {
        Machine::Mill5 => &outputs.mill5,
        Machine::Belt6 => &outputs.belt6,
    };
    outputs.publish(publisher, trajectory_topic, trajectory);
    outputs.publish(&outputs.markers, topics::MARKERS, markers);
    if let (Some((post_machine, format, dir)), Machine::Mill5) = (&outputs.programs, job.machine) {
        // Best effort, like the recording: the job has succeeded either way.
        if let Err(e) = toolpath_post::write_program_file(dir, &job, &result, post_machine, *format)
        {
            log::warn!("no NC program of job {}: {e}", job.job_id);
        }
    }
    if let Some(tx) = &outputs.ipc {
        let _ = tx.send(result);
    }
    match (executor, chunks) {
        (Some(queue), Some(chunks)) => {
            let executed = execute_job(queue, outputs, &job.job_id, chunks, p.goal.clone())?;
            Ok(format!("{summary}; {executed}"))
        }
        _ => Ok(summary),
    }
}

/// Hands a job's passes to its machine's executor and waits for the outcome,
/// reporting its progress as RUNNING statuses.
fn execute_job(
    queue: &ExecutorQueue,
    outputs: &Arc<Outputs>,
    job_id: &str,
    chunks: Vec<msgs::JointTrajectory>,
    goal: Option<Arc<GoalLink>>,
) -> Result<String> {
    let (reply, outcome) = std::sync::mpsc::channel();
    let (o, id) = (Arc::clone(outputs), job_id.to_string());
    if let Some(g) = &goal {
        g.set_executing();
    }
    let report: Arc<Report<'static>> = Arc::new(move |f: f32, text: String| {
        if let Some(g) = &goal {
            g.feedback(&text, f, ETA_UNKNOWN);
        }
        o.status(&id, msgs::JobStatus::RUNNING, f, text)
    });
    let e = Execution {
        job_id: job_id.to_string(),
        chunks,
        reply,
    };
    queue
        .send((e, report))
        .map_err(|_| Error::planning("the executor has stopped"))?;
    outcome
        .recv()
        .map_err(|_| Error::planning("the executor has stopped"))?
}

fn worker(shared: Arc<Shared>, outputs: Arc<Outputs>) {
    while let Some(work) = next_work(&shared) {
        let _busy = shared.activity.working();
        let config = shared.live.get();
        let (machines, timeout_s) = (config.machines(), config.node.surface_timeout_s);
        let options = RunOptions {
            skip_verify: !config.node.verify,
            no_timing: false,
            time_limit: config.node.time_limit(),
            budget: config.node.budget,
        };
        let goal = match &work {
            Work::Reject(p, _) | Work::TimedOut(p) | Work::Plan(p, _) => p.goal.clone(),
        };
        let (job_id, state, progress, message) = match work {
            Work::Reject(p, why) => (p.msg.job_id, msgs::JobStatus::REJECTED, 0.0, why),
            Work::TimedOut(p) => {
                let why = format!(
                    "surface \"{}\" has not arrived within {timeout_s} s: publish it on topic surface (or pocket)",
                    p.msg.surface_id
                );
                (p.msg.job_id, msgs::JobStatus::FAILED, 0.0, why)
            }
            Work::Plan(p, shape) => {
                let started = Instant::now();
                let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    plan_and_publish(&p, &shape, &outputs, &machines, &shared.joints, options)
                }));
                shared.activity.planned(started.elapsed());
                let (state, progress, message) = match run {
                    Ok(Ok(summary)) => (msgs::JobStatus::SUCCEEDED, 1.0, summary),
                    Ok(Err(e)) => (final_state(&e), 0.0, e.to_string()),
                    Err(panic) => {
                        let what = panic
                            .downcast_ref::<String>()
                            .cloned()
                            .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                            .unwrap_or_default();
                        let why = format!("internal error while planning (please report): {what}");
                        (msgs::JobStatus::FAILED, 0.0, why)
                    }
                };
                (p.msg.job_id, state, progress, message)
            }
        };
        outputs.status(&job_id, state, progress, message.clone());
        // A later job under this id starts uncanceled.
        outputs.cancels.forget(&job_id);
        let idle = {
            let mut st = shared.lock();
            st.active.remove(&job_id);
            st.queue.is_empty()
        };
        if let Some(g) = goal {
            g.finish(state, message);
        }
        if idle {
            release_free_memory();
        }
    }
}

/// Large blocks (toolpaths, messages, simulator grids) are mapped on their
/// own and unmapped when freed. glibc otherwise raises its mmap threshold to
/// the largest block freed so far (up to 32 MiB), after which such blocks come
/// from the arenas and stay in the resident set when freed.
fn large_blocks_back_to_the_system() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only sets an allocator parameter; called before the
    // workers start.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 256 * 1024);
    }
}

/// Hands the allocator's free memory back to the system. glibc keeps what
/// a job freed in its per-thread arenas, so without this the resident set
/// of a node serving a long job stream creeps up (docs/results.md, "Node
/// memory"); trimming once the queue is empty costs nothing during a burst.
fn release_free_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only walks and shrinks the allocator's own free
    // lists; it takes no pointers from us and is thread-safe in glibc.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// The checks of a job message that need no shape: its fields, and its feed
/// rate on its machine.
fn check_job(msg: &msgs::Job, machines: &Machines) -> Result<()> {
    let file = convert::prevalidate_job(msg)?;
    let machine = file.machine.unwrap_or(file.strategy.default_machine());
    toolpath_machines::check_feed_rate(
        machine,
        file.feed_rate.unwrap_or(DEFAULT_FEED_RATE),
        machines,
    )?;
    if file.execute == Some(true) && !machines.executes_by_default(machine) {
        machines.check_job_may_execute(machine)?;
    }
    Ok(())
}

/// Handles a received job message: REJECTED at once when the message itself is
/// bad, else ACCEPTED and queued.
fn receive_job(
    shared: &Shared,
    outputs: &Outputs,
    (machines, frames): (&Machines, &Frames),
    msg: msgs::Job,
    timeout: Duration,
) {
    let msg = match frames.job_in_workpiece(&msg) {
        Ok(moved) => moved.unwrap_or(msg),
        Err(e) => {
            outputs.status(&msg.job_id, final_state(&e), 0.0, e.to_string());
            return;
        }
    };
    if let Err(e) = check_job(&msg, machines) {
        outputs.status(&msg.job_id, final_state(&e), 0.0, e.to_string());
        return;
    }
    let mut st = shared.lock();
    match st.admit(&msg) {
        Admission::New => {}
        Admission::Resent => {
            log::info!("job {}: sent again while queued or running", msg.job_id);
            return;
        }
        Admission::Conflict(why) => {
            drop(st);
            outputs.status(&msg.job_id, msgs::JobStatus::REJECTED, 0.0, why);
            return;
        }
    }
    st.active.insert(msg.job_id.clone(), msg.clone());
    drop(st);
    // A cancel sent before this job (for an earlier one of its id) is not its own.
    outputs.cancels.forget(&msg.job_id);
    // ACCEPTED before the job is queued, so a worker's statuses follow it;
    // published without the lock (a reliable publish may wait).
    outputs.status(&msg.job_id, msgs::JobStatus::ACCEPTED, 0.0, String::new());
    let mut st = shared.lock();
    let shape = st.shapes.get(&msg.surface_id).map(|(_, e)| e.clone());
    let now = Instant::now();
    st.queue.push_back(Pending {
        msg,
        received: now,
        deadline: now + timeout,
        shape,
        goal: None,
    });
    drop(st);
    shared.wake.notify_all();
}

fn receive_shape(shared: &Shared, id: String, shape: Result<Shape>) {
    let entry = match shape {
        Ok(s) => {
            log::info!("received {id}");
            ShapeEntry::Ready(Arc::new(s))
        }
        Err(e) => {
            log::warn!("rejected {id}: {e}");
            ShapeEntry::Rejected(e.to_string())
        }
    };
    shared.lock().insert_shape(id, entry);
    shared.wake.notify_all();
}

/// The node's readers of its inputs.
struct Inputs {
    /// This node's fully qualified name, which `Job.node` may name.
    name: String,
    /// The frames inputs may be given in.
    frames: Frames,
    surfaces: ShapeReaders<msgs::Surface>,
    pockets: ShapeReaders<msgs::Pocket>,
    jobs: Subscription<msgs::Job>,
    joint_states: Subscription<msgs::JointState>,
    cancels: Subscription<msgs::follow_joint_trajectory::StringMsg>,
}

/// Creates the output publishers and the optional recorder, iceoryx2 thread
/// and NC program directory; returns the iceoryx2 thread to join at the end.
fn start_outputs(
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

/// The planning threads on the shared queue, as many as `node.workers`
/// asks for: set at run time, the pool grows at once and shrinks as
/// surplus workers finish their current job.
struct Workers {
    shared: Arc<Shared>,
    outputs: Arc<Outputs>,
    handles: Mutex<Vec<std::thread::JoinHandle<()>>>,
}

impl Workers {
    /// Starts `count` workers, and resizes the pool whenever a parameter
    /// set changes `node.workers`.
    fn start(count: usize, shared: &Arc<Shared>, outputs: &Arc<Outputs>) -> Result<Arc<Self>> {
        let pool = Arc::new(Self {
            shared: Arc::clone(shared),
            outputs: Arc::clone(outputs),
            handles: Mutex::new(Vec::new()),
        });
        pool.resize(count)?;
        let weak = Arc::downgrade(&pool);
        shared.live.on_replace(Box::new(move |c: &NodeConfig| {
            if let Some(pool) = weak.upgrade() {
                if let Err(e) = pool.resize(c.node.worker_count()) {
                    log::error!("{e}");
                }
            }
        }));
        Ok(pool)
    }

    fn resize(&self, count: usize) -> Result<()> {
        let mut handles = self.handles.lock().unwrap_or_else(|p| p.into_inner());
        let mut st = self.shared.lock();
        if st.shutdown {
            return Ok(());
        }
        st.wanted_workers = count;
        while st.running_workers < count {
            let (s, o) = (Arc::clone(&self.shared), Arc::clone(&self.outputs));
            let h = std::thread::Builder::new()
                .name(format!("planner-{}", handles.len()))
                .spawn(move || worker(s, o))
                .map_err(|e| Error::planning(format!("cannot start a planning thread: {e}")))?;
            handles.push(h);
            st.running_workers += 1;
        }
        drop(st);
        // Idle surplus workers wake up to leave.
        self.shared.wake.notify_all();
        Ok(())
    }

    /// Stops every worker after its current job and waits for them.
    fn stop(self: Arc<Self>) {
        self.shared.lock().shutdown = true;
        self.shared.wake.notify_all();
        let handles = {
            let mut g = self.handles.lock().unwrap_or_else(|p| p.into_inner());
            std::mem::take(&mut *g)
        };
        for h in handles {
            let _ = h.join();
        }
    }
}

/// Prints the one "ready ..." line on stdout and flushes it.
fn announce_ready(
    ros: &RosNode,
    config: &NodeConfig,
    domain: u16,
    outputs: &Outputs,
    enclave_dir: Option<&std::path::Path>,
) {
    let mut extra = outputs
        .recorder
        .as_ref()
        .map(|r| format!(", recording to {}", r.directory().display()))
        .unwrap_or_default();
    if let Some(dir) = enclave_dir {
        extra += &format!(", DDS Security enclave {}", dir.display());
    }
    if config.ipc.enabled {
        extra += &format!(", iceoryx2 service {}", config.ipc.service);
    }
    println!(
        "ready: node {} on ROS domain {domain}, interfaces {}{extra}",
        ros.node.fully_qualified_name(),
        config.node.interfaces.join(",")
    );
    use std::io::Write;
    let _ = std::io::stdout().flush();
}

/// The `/diagnostics` publishing loop of the node (see `diagnostics`): the
/// queue, the workers, the recorder and the peers discovered on each topic.
fn diagnostics<'a>(
    ros: &'a RosNode,
    publisher: Publisher<toolpath_messages::diagnostics::DiagnosticArray>,
    config: &NodeConfig,
    shared: &'a Shared,
    outputs: &'a Outputs,
) -> impl std::future::Future<Output = ()> + 'a {
    use super::diagnostics::{self as diag, RecorderState, Snapshot};
    let inputs = [
        topics::SURFACE,
        topics::POCKET,
        topics::JOB,
        topics::JOINT_STATES,
        topics::CANCEL,
    ];
    let outputs_topics = [
        topics::JOB_STATUS,
        topics::TOOLPATH,
        topics::TOOL_POSES,
        topics::MILL5_TRAJECTORY,
        topics::BELT6_TRAJECTORY,
        topics::MARKERS,
    ];
    let snapshot = move || {
        let (queued, workers) = {
            let st = shared.lock();
            (st.queue.len(), st.running_workers)
        };
        let (activity_busy, planned, last_planning) = Snapshot::activity(&shared.activity);
        let mut peers = Vec::new();
        for t in inputs {
            let fq = ros.resolved(t);
            let n = ros.node.publisher_count(&fq);
            peers.push((fq, "publishers", n));
        }
        for t in outputs_topics {
            let fq = ros.resolved(t);
            let n = ros.node.subscription_count(&fq);
            peers.push((fq, "subscribers", n));
        }
        Snapshot {
            queued,
            workers,
            activity_busy,
            planned,
            last_planning,
            recorder: RecorderState::of(outputs.recorder.as_deref()),
            peers,
        }
    };
    let name = config.node.name.clone();
    let fully_qualified = ros.node.fully_qualified_name();
    diag::publish(publisher, name, fully_qualified, snapshot)
}

/// Whether a job is for the node named `name` (fully qualified): it names
/// no node, or this one. Jobs for other nodes are neither planned nor recorded.
fn addressed_to(job: &msgs::Job, name: &str) -> bool {
    job.node.is_empty() || job.node == name
}

/// Receives shapes and jobs (recording each as it arrives) until SIGINT or
/// SIGTERM. Never plans: jobs go to the workers' queue.
async fn receive_until_signal(inputs: Inputs, shared: &Shared, outputs: &Outputs) -> Result<()> {
    let recorder = outputs.recorder.as_deref();
    let mut surface_stream = Box::pin(inputs.surfaces.async_stream());
    let mut pocket_stream = Box::pin(inputs.pockets.async_stream());
    let mut job_stream = Box::pin(inputs.jobs.async_stream());
    let mut joint_stream = Box::pin(inputs.joint_states.async_stream());
    let mut cancel_stream = Box::pin(inputs.cancels.async_stream());
    let mut sigterm = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())
        .map_err(|e| Error::planning(format!("cannot watch SIGTERM: {e}")))?;
    loop {
        tokio::select! {
            Some(r) = job_stream.next() => match r {
                Ok((msg, _)) if !addressed_to(&msg, &inputs.name) => {
                    log::debug!("job {} is for node {}, not {}: ignored", msg.job_id, msg.node, inputs.name);
                }
                Ok((msg, _)) => {
                    if let Some(rec) = recorder {
                        rec.record(topics::JOB, &msg);
                    }
                    let config = shared.live.get();
                    let timeout = Duration::from_secs_f64(config.node.surface_timeout_s);
                    let machines = config.machines();
                    receive_job(shared, outputs, (&machines, &inputs.frames), msg, timeout)
                }
                Err(e) => log::error!("undecodable message on topic job: {e:?}"),
            },
            Some(r) = surface_stream.next() => match r {
                Ok((msg, _)) => {
                    if let Some(rec) = recorder {
                        rec.record(topics::SURFACE, &msg);
                    }
                    let id = msg.surface_id.clone();
                    let shape = inputs
                        .frames
                        .surface_in_workpiece(msg)
                        .and_then(|m| convert::surface_from_msg(&m))
                        .map(Shape::Surface);
                    receive_shape(shared, id, shape);
                }
                Err(e) => log::error!("undecodable message on topic surface: {e:?}"),
            },
            Some(r) = pocket_stream.next() => match r {
                Ok((msg, _)) => {
                    if let Some(rec) = recorder {
                        rec.record(topics::POCKET, &msg);
                    }
                    let shape = inputs
                        .frames
                        .check_pocket(&msg)
                        .and_then(|()| convert::pocket_from_msg(&msg))
                        .map(Shape::Pocket);
                    receive_shape(shared, msg.pocket_id, shape);
                }
                Err(e) => log::error!("undecodable message on topic pocket: {e:?}"),
            },
            Some(r) = joint_stream.next() => match r {
                // Not recorded: a bag replays from the home pose.
                Ok((msg, _)) => {
                    if let Err(e) = shared.joints.update(&msg, Instant::now()) {
                        log::warn!("ignored a joint state: {e}");
                    }
                }
                Err(e) => log::error!("undecodable message on topic joint_states: {e:?}"),
            },
            Some(r) = cancel_stream.next() => match r {
                Ok((msg, _)) => {
                    log::info!("cancel of job {} requested", msg.data);
                    outputs.cancels.cancel(&msg.data);
                }
                Err(e) => log::error!("undecodable message on topic cancel: {e:?}"),
            },
            _ = tokio::signal::ctrl_c() => return Ok(()),
            _ = sigterm.recv() => return Ok(()),
        }
    }
}

/// Stops the workers after their current job, then the iceoryx2 thread, then
/// closes the recording; an error when the recording lost messages or could
/// not be finished (the process exits non-zero).
fn shut_down(
    workers: Arc<Workers>,
    outputs: Arc<Outputs>,
    ipc_thread: Option<std::thread::JoinHandle<()>>,
) -> Result<()> {
    // The pool's own reference to the outputs goes with it.
    workers.stop();
    let recorder = outputs.recorder.clone();
    // The workers are gone: dropping the outputs closes the iceoryx2 channel,
    // and its thread removes the publisher's shared memory as it ends.
    drop(outputs);
    if let Some(h) = ipc_thread {
        let _ = h.join();
    }
    let Some(r) = &recorder else {
        return Ok(());
    };
    let finished = match r.finish() {
        Some(Ok(b)) => {
            log::info!(
                "recorded {}: {} messages, {} chunks, {} bytes ({} uncompressed)",
                b.directory.display(),
                b.messages,
                b.chunks,
                b.file_bytes,
                b.uncompressed_bytes
            );
            None
        }
        Some(Err(e)) => Some(e.to_string()),
        None => None,
    };
    let failures = r.failures();
    if failures.errors == 0 && finished.is_none() {
        return Ok(());
    }
    let mut why = format!("recording failed: {} write error(s)", failures.errors);
    if let Some(first) = failures.first {
        why += &format!(", the first: {first}");
    }
    if let Some(finished) = finished {
        why += &format!("; the bag could not be finished: {finished}");
    }
    Err(Error::io(r.directory().display().to_string(), why))
}

/// Runs the node until SIGINT/SIGTERM. Prints one line "ready ..." on stdout
/// once every topic exists (tests and the demo wait for it).
/// `enclave_dir`: the SROS2 enclave to secure the participant with
/// ([`super::security::Request::enclave_dir`]), `None` for none.
pub async fn run(resolved: Resolved, enclave_dir: Option<std::path::PathBuf>) -> Result<()> {
    let config = &resolved.config;
    config.validate()?;
    large_blocks_back_to_the_system();
    let domain = config.domain_id()?;
    let settings = &config.node;
    let live = LiveConfig::new(config.clone());
    let options =
        parameters::node_options(config, &resolved.builtin, &live)?.enable_rosout(resolved.rosout);
    let mut ros = RosNode::with_options(
        &settings.name,
        &settings.namespace,
        domain,
        config.interfaces()?,
        options,
        &resolved.remaps,
        enclave_dir.as_deref(),
    )?;
    ros.service_mapping = settings.service_mapping.into();
    super::logging::attach_rosout(
        ros.node.logging_handle(),
        super::logging::logger_name(&settings.namespace, &settings.name),
    );
    // A volatile shape writer matches the volatile reader of each pair only.
    for t in [topics::SURFACE, topics::POCKET] {
        super::logging::paired_durability_readers(&format!("rt{}", ros.resolved(t)));
    }
    let frames = config.frames();
    let inputs = Inputs {
        name: ros.node.fully_qualified_name(),
        frames: frames.clone(),
        surfaces: ShapeReaders {
            volatile: ros.subscription(topics::SURFACE, qos::shapes_reader())?,
            transient_local: ros.subscription(topics::SURFACE, qos::shapes_history_reader())?,
        },
        pockets: ShapeReaders {
            volatile: ros.subscription(topics::POCKET, qos::shapes_reader())?,
            transient_local: ros.subscription(topics::POCKET, qos::shapes_history_reader())?,
        },
        jobs: ros.subscription(topics::JOB, qos::job_reader())?,
        joint_states: ros.subscription(topics::JOINT_STATES, qos::joint_states())?,
        cancels: ros.subscription(topics::CANCEL, qos::job())?,
    };
    let (outputs, ipc_thread) = start_outputs(&mut ros, config)?;
    if let Some(r) = &outputs.recorder {
        live.set_recorder(Arc::clone(r));
    }
    let shared = Arc::new(Shared {
        state: Mutex::new(State::default()),
        wake: Condvar::new(),
        joints: JointStates::default(),
        live,
        activity: Default::default(),
    });
    let workers = Workers::start(config.node.worker_count(), &shared, &outputs)?;
    let queue = goals::NodeQueue {
        shared: Arc::clone(&shared),
        outputs: Arc::downgrade(&outputs),
        machines: config.machines(),
        frames: frames.clone(),
    };
    super::plan_action::serve(&mut ros, Arc::new(queue))?;
    let _tf_static = match settings.tf_static {
        true => Some(super::tf_static::publish(&mut ros.node, &frames)?),
        false => None,
    };
    let diagnostics_publisher = super::diagnostics::publisher(&mut ros.node)?;
    let diagnostics = diagnostics(&ros, diagnostics_publisher, config, &shared, &outputs);
    announce_ready(&ros, config, domain, &outputs, enclave_dir.as_deref());
    let received = tokio::select! {
        r = receive_until_signal(inputs, &shared, &outputs) => r,
        () = diagnostics => Ok(()),
    };
    // Executions are canceled at the controller; workers finish their
    // current job; the process exits after them.
    outputs.cancels.cancel_all();
    let recorded = shut_down(workers, outputs, ipc_thread);
    received.and(recorded)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::net::{IpAddr, Ipv4Addr};

    #[test]
    fn a_job_names_no_node_or_this_one() {
        let job = |node: &str| msgs::Job {
            node: node.into(),
            ..Default::default()
        };
        assert!(addressed_to(&job(""), "/cell_b/tp"));
        assert!(addressed_to(&job("/cell_b/tp"), "/cell_b/tp"));
        assert!(!addressed_to(&job("/cell_a/tp"), "/cell_b/tp"));
        assert!(!addressed_to(&job("tp"), "/cell_b/tp"));
    }

    #[test]
    fn an_interface_not_on_this_host_is_refused_by_name() {
        check_on_this_host(&[IpAddr::V4(Ipv4Addr::LOCALHOST)]).unwrap();
        // 192.0.2.0/24 is reserved for documentation (RFC 5737): never a host's address.
        let e = check_on_this_host(&[
            IpAddr::V4(Ipv4Addr::LOCALHOST),
            IpAddr::V4(Ipv4Addr::new(192, 0, 2, 7)),
        ])
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("node.interfaces[1]")
                && e.contains("192.0.2.7 is not an address of this host")
                && e.contains("127.0.0.1"),
            "{e}"
        );
    }

    fn job(id: &str, surface: &str, scallop: f64, sec: i32) -> msgs::Job {
        msgs::Job {
            header: msgs::Header {
                stamp: msgs::Time { sec, nanosec: 0 },
                frame_id: "workpiece".into(),
            },
            job_id: id.into(),
            surface_id: surface.into(),
            strategy: "iso_parametric".into(),
            scallop,
            ..Default::default()
        }
    }

    fn pending(msg: msgs::Job) -> Pending {
        let now = Instant::now();
        Pending {
            msg,
            received: now,
            deadline: now,
            shape: None,
            goal: None,
        }
    }

    #[test]
    fn the_time_left_goes_at_the_pace_so_far() {
        // A quarter done in 2 s: three quarters left at that pace, 6 s.
        assert_eq!(eta_s(Duration::from_secs(2), 0.25), 6.0);
        assert_eq!(eta_s(Duration::from_millis(1500), 1.0), 0.0);
        // Too little progress to go by.
        assert_eq!(eta_s(Duration::from_secs(5), 0.005), ETA_UNKNOWN);
        assert_eq!(eta_s(Duration::ZERO, 0.0), ETA_UNKNOWN);
    }

    #[test]
    fn one_job_id_one_plan_while_queued_or_running() {
        let mut st = State::default();
        let a = job("a", "s", 0.05, 1);
        assert_eq!(st.admit(&a), Admission::New);
        st.active.insert("a".into(), a.clone());
        // The same job sent again (another stamp) is not planned twice.
        assert_eq!(st.admit(&job("a", "s", 0.05, 2)), Admission::Resent);
        // Other parameters under the same job_id are refused with a reason.
        match st.admit(&job("a", "s", 0.1, 2)) {
            Admission::Conflict(why) => {
                assert!(why.contains("\"a\" is already queued or running"), "{why}")
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(st.admit(&job("b", "s", 0.1, 2)), Admission::New);
        st.active.remove("a");
        assert_eq!(st.admit(&job("a", "s", 0.1, 3)), Admission::New);
    }

    fn ready(id: &str) -> ShapeEntry {
        ShapeEntry::Rejected(id.to_string())
    }

    fn why(e: &Option<ShapeEntry>) -> Option<String> {
        match e {
            Some(ShapeEntry::Rejected(w)) => Some(w.clone()),
            _ => None,
        }
    }

    #[test]
    fn a_queued_job_keeps_its_shape_and_the_cache_is_bounded() {
        let mut st = State::default();
        st.queue.push_back(pending(job("waits", "s", 0.05, 1)));
        st.insert_shape("s".into(), ready("first s"));
        st.insert_shape("s".into(), ready("second s"));
        // Bound to the first "s" received; the re-publish does not change it.
        assert_eq!(why(&st.queue[0].shape), Some("first s".into()));
        for k in 0..2 * MAX_SHAPES {
            st.insert_shape(format!("x{k}"), ready("x"));
        }
        assert_eq!(st.shapes.len(), MAX_SHAPES);
        // The oldest went first: the last MAX_SHAPES received are kept.
        assert!(!st.shapes.contains_key("s"));
        assert!(!st.shapes.contains_key(&format!("x{}", MAX_SHAPES - 1)));
        assert!(st.shapes.contains_key(&format!("x{MAX_SHAPES}")));
        assert!(st.shapes.contains_key(&format!("x{}", 2 * MAX_SHAPES - 1)));
        assert_eq!(why(&st.queue[0].shape), Some("first s".into()));
    }
}
