//! The `toolpath_planner` node: subscribes to surfaces, pockets and jobs,
//! plans each job on a worker thread through [`toolpath_pipeline::run`] and
//! publishes the toolpath, tool poses, joint trajectory, markers and status.
//!
//! Threads: the tokio runtime receives messages and never plans; `workers`
//! planning threads take jobs from one queue. A job whose surface has not
//! arrived yet stays queued (other jobs overtake it) until the surface
//! arrives or `surface_timeout_s` passes. Every job gets exactly one final
//! status; a panic inside a planner becomes FAILED, never a dead node.
//!
//! The parts: [`outputs`] (publishers, stamps, statuses), [`queue`] (shapes
//! and jobs by id), [`receive`] (the receive loop), [`worker`] (planning
//! threads), [`goals`] (the queue as the PlanToolpath action sees it).

use crate::joint_states::JointStates;
use crate::parameters::{self, LiveConfig, Resolved};
use crate::NodeConfig;
use outputs::{start_outputs, Outputs};
use queue::{Shared, State};
use receive::{receive_until_signal, Inputs};
use ros2_client::Publisher;
use std::sync::{Arc, Condvar, Mutex};
use toolpath_kernel::error::{Error, Result};
use toolpath_messages::topics;
use worker::{large_blocks_back_to_the_system, Workers};

mod goals;
mod outputs;
mod queue;
mod receive;
mod restart;
mod worker;

/// The DDS helpers the node's clients use, under the names they had here.
pub use crate::dds::{topic_name, RosNode};
pub use crate::qos;

/// Start of the per-job timing line the node logs at debug level.
pub const TIMING_TAG: &str = "timing:";

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
    if let Some(j) = &outputs.journal {
        extra += &format!(", job journal {}", j.path().display());
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
    use crate::diagnostics::{self as diag, RecorderState, Snapshot};
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
/// ([`crate::security::Request::enclave_dir`]), `None` for none.
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
    crate::logging::attach_rosout(
        ros.node.logging_handle(),
        crate::logging::logger_name(&settings.namespace, &settings.name),
    );
    // A volatile shape writer matches the volatile reader of each pair only.
    for t in [topics::SURFACE, topics::POCKET] {
        crate::logging::paired_durability_readers(&format!("rt{}", ros.resolved(t)));
    }
    let frames = config.frames();
    let inputs = Inputs::subscribe(&mut ros, &frames)?;
    let journal = restart::open(&config.journal)?;
    let (outputs, ipc_thread) = start_outputs(
        &mut ros,
        config,
        journal.as_ref().map(|(j, _)| Arc::clone(j)),
    )?;
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
    if let Some((_, recovery)) = journal {
        let timeout = std::time::Duration::from_secs_f64(settings.surface_timeout_s);
        let on_restart = config.journal.on_restart;
        let machines = config.machines();
        restart::resume(
            recovery,
            on_restart,
            (&shared, &outputs),
            &machines,
            timeout,
        );
    }
    let queue = goals::NodeQueue {
        shared: Arc::clone(&shared),
        outputs: Arc::downgrade(&outputs),
        machines: config.machines(),
        frames: frames.clone(),
    };
    crate::plan_action::serve(&mut ros, Arc::new(queue))?;
    let _tf_static = match settings.tf_static {
        true => Some(crate::tf_static::publish(&mut ros.node, &frames)?),
        false => None,
    };
    let diagnostics_publisher = crate::diagnostics::publisher(&mut ros.node)?;
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
