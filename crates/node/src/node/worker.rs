//! The planning workers: each takes the next job from the queue, plans it
//! whole through [`toolpath_pipeline::run`] (progress as RUNNING statuses,
//! cancels at each progress check), publishes its outputs, hands it to the
//! machine's executor when it executes, and publishes its one final status;
//! a panic inside a planner becomes FAILED. [`Workers`] is the pool, resized
//! by the `node.workers` parameter.

use super::outputs::{eta_s, ExecutorQueue, Outputs, ETA_UNKNOWN};
use super::queue::{next_work, Pending, Shared, Work};
use super::TIMING_TAG;
use crate::config::NodeConfig;
use crate::execute::{Execution, Report};
use crate::joint_states::JointStates;
use crate::plan_action::GoalLink;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use toolpath_formats::{Machine, PlanResult, Shape};
use toolpath_kernel::error::{Error, Result};
use toolpath_machines::Machines;
use toolpath_messages::{self as msgs, convert, final_state, topics, JobOutputs};
use toolpath_pipeline::{self as pipeline, RunOptions};
use toolpath_planners::Progress;

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
    let summary = success_summary(&out, &result);
    let executes = job
        .execute
        .unwrap_or_else(|| machines.executes_by_default(job.machine));
    let executor = outputs
        .executors
        .iter()
        .find(|(m, _)| *m == job.machine && executes)
        .map(|(_, q)| q);
    let chunks = executor.map(|_| convert::trajectory_chunks(&trajectory, &out.trajectory));
    publish_outputs(outputs, p, &job, out, planning);
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

/// The message of a job's SUCCEEDED status. A plan the simulator finds
/// above the scallop height (or an MPEC plan below its band) still
/// succeeds, but its final status says so.
fn success_summary(out: &JobOutputs, result: &PlanResult) -> String {
    let mut summary = format!(
        "{}, planned in {:.1} ms",
        out.summary(),
        result.stats.compute_ms
    );
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
    summary
}

/// Publishes (and records) a job's output messages, the toolpath first.
fn publish_outputs(
    outputs: &Outputs,
    p: &Pending,
    job: &toolpath_formats::Job,
    out: JobOutputs,
    planning: Duration,
) {
    let trajectory_topic = out.trajectory_topic();
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
        .map_err(|_| Error::shutdown("the executor has stopped"))?;
    outcome
        .recv()
        .map_err(|_| Error::shutdown("the executor has stopped"))?
}

pub(super) fn worker(shared: Arc<Shared>, outputs: Arc<Outputs>) {
    while let Some(work) = next_work(&shared) {
        let _busy = shared.activity.working();
        let (goal, seq, restarted) = match &work {
            Work::Reject(p, _) | Work::TimedOut(p) | Work::Plan(p, _) => {
                (p.goal.clone(), p.seq, p.restarted)
            }
        };
        let (job_id, state, progress, mut message) = handle(work, &shared, &outputs);
        if restarted {
            message.push_str(&format!("; {RESTARTED_FINAL}"));
        }
        outputs.finish(&job_id, seq, state, progress, message.clone());
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

/// What the final status of a job planned again after a restart adds.
pub(super) const RESTARTED_FINAL: &str = "planned again after the node restarted";

/// Handles one piece of work: the job's id and final state, progress and
/// message.
fn handle(work: Work, shared: &Shared, outputs: &Arc<Outputs>) -> (String, u8, f32, String) {
    let config = shared.live.get();
    let (machines, timeout_s) = (config.machines(), config.node.surface_timeout_s);
    let options = RunOptions {
        skip_verify: !config.node.verify,
        no_timing: false,
        time_limit: config.node.time_limit(),
        budget: config.node.budget,
    };
    match work {
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
                plan_and_publish(
                    &p,
                    &shape.shape,
                    outputs,
                    &machines,
                    &shared.joints,
                    options,
                )
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
    }
}

/// Large blocks (toolpaths, messages, simulator grids) are mapped on their
/// own and unmapped when freed. glibc otherwise raises its mmap threshold to
/// the largest block freed so far (up to 32 MiB), after which such blocks come
/// from the arenas and stay in the resident set when freed.
pub(super) fn large_blocks_back_to_the_system() {
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

/// The planning threads on the shared queue, as many as `node.workers`
/// asks for: set at run time, the pool grows at once and shrinks as
/// surplus workers finish their current job.
pub(super) struct Workers {
    shared: Arc<Shared>,
    outputs: Arc<Outputs>,
    handles: Mutex<Vec<std::thread::JoinHandle<()>>>,
}

impl Workers {
    /// Starts `count` workers, and resizes the pool whenever a parameter
    /// set changes `node.workers`.
    pub(super) fn start(
        count: usize,
        shared: &Arc<Shared>,
        outputs: &Arc<Outputs>,
    ) -> Result<Arc<Self>> {
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
                .map_err(|e| Error::system(format!("cannot start a planning thread: {e}")))?;
            handles.push(h);
            st.running_workers += 1;
        }
        drop(st);
        // Idle surplus workers wake up to leave.
        self.shared.wake.notify_all();
        Ok(())
    }

    /// Stops every worker after its current job and waits for them.
    pub(super) fn stop(self: Arc<Self>) {
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
