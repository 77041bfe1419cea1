//! The node's receive loop (tokio): shapes, jobs, joint states and cancels
//! as they arrive, each recorded; a job is checked and REJECTED at once, or
//! ACCEPTED and queued for the workers. It never plans.

use super::outputs::Outputs;
use super::queue::{Admission, Pending, ReadyShape, ShapeEntry, Shared};
use crate::dds::RosNode;
use crate::journal::{JournalShape, Origin, ShapeMsg};
use crate::qos;
use crate::shape_readers::ShapeReaders;
use futures::StreamExt;
use ros2_client::Subscription;
use std::sync::Arc;
use std::time::{Duration, Instant};
use toolpath_formats::job::DEFAULT_FEED_RATE;
use toolpath_formats::Shape;
use toolpath_kernel::error::{Error, Result};
use toolpath_machines::Machines;
use toolpath_messages::frames::Frames;
use toolpath_messages::{self as msgs, convert, final_state, topics};

/// The node's readers of its inputs.
pub(super) struct Inputs {
    /// This node's fully qualified name, which `Job.node` may name.
    pub(super) name: String,
    /// The frames inputs may be given in.
    pub(super) frames: Frames,
    pub(super) surfaces: ShapeReaders<msgs::Surface>,
    pub(super) pockets: ShapeReaders<msgs::Pocket>,
    pub(super) jobs: Subscription<msgs::Job>,
    pub(super) joint_states: Subscription<msgs::JointState>,
    pub(super) cancels: Subscription<msgs::follow_joint_trajectory::StringMsg>,
}

impl Inputs {
    /// The node's readers on `ros`.
    pub(super) fn subscribe(ros: &mut RosNode, frames: &Frames) -> Result<Self> {
        Ok(Inputs {
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
        })
    }
}

/// The checks of a job message that need no shape: its fields, and its feed
/// rate on its machine.
pub(super) fn check_job(msg: &msgs::Job, machines: &Machines) -> Result<()> {
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
    let checked = frames
        .job_in_workpiece(&msg)
        .map(|moved| moved.unwrap_or_else(|| msg.clone()))
        .and_then(|m| check_job(&m, machines).map(|()| m));
    let msg = match checked {
        Ok(m) => m,
        Err(e) => return refuse(shared, outputs, &msg.job_id, &e),
    };
    let mut st = shared.lock();
    match st.admit(&msg) {
        Admission::New => {}
        Admission::Resent => {
            log::info!("job {}: sent again while queued or running", msg.job_id);
            return;
        }
        Admission::Conflict(why) => {
            drop(st);
            outputs.refuse_duplicate(&msg.job_id, why);
            return;
        }
    }
    st.active.insert(msg.job_id.clone(), msg.clone());
    let shape = st.shapes.get(&msg.surface_id).map(|(_, e)| e.clone());
    drop(st);
    // A cancel sent before this job (for an earlier one of its id) is not its own.
    outputs.cancels.forget(&msg.job_id);
    let Some(seq) = journal_accept(outputs, Origin::Topic, &msg, shape.as_ref()) else {
        shared.lock().active.remove(&msg.job_id);
        return;
    };
    // ACCEPTED before the job is queued, so a worker's statuses follow it;
    // published without the lock (a reliable publish may wait).
    outputs.status(&msg.job_id, msgs::JobStatus::ACCEPTED, 0.0, String::new());
    let now = Instant::now();
    let mut st = shared.lock();
    // A shape that arrived since is bound now, as if it had come later.
    let late = shape
        .is_none()
        .then(|| st.shapes.get(&msg.surface_id).map(|(_, e)| e.clone()))
        .flatten();
    st.queue.push_back(Pending {
        msg,
        received: now,
        deadline: now + timeout,
        shape: shape.or(late.clone()),
        goal: None,
        seq,
        restarted: false,
    });
    drop(st);
    shared.wake.notify_all();
    if let (Some(ShapeEntry::Ready(s)), Some(seq)) = (late, seq) {
        journal_bind(outputs, &[seq], &s);
    }
}

/// Answers a job refused before it was accepted: REJECTED (or FAILED) with
/// the reason, unless a job under its id is queued or running, whose own
/// final status that would look like; that job's id gets a non-final status
/// saying the second job was refused.
pub(super) fn refuse(shared: &Shared, outputs: &Outputs, job_id: &str, e: &Error) {
    if shared.lock().active.contains_key(job_id) {
        outputs.refuse_duplicate(
            job_id,
            format!("a second job under job_id \"{job_id}\" is refused ({e}); the job under this id goes on"),
        );
    } else {
        outputs.status(job_id, final_state(e), 0.0, e.to_string());
    }
}

/// Writes an accepted job into the journal (when the node keeps one) before
/// its ACCEPTED status goes out: `Some(entry)`, `Some(None)` without a
/// journal, `None` when the journal could not take it (the job then ends
/// FAILED: it cannot be promised).
pub(super) fn journal_accept(
    outputs: &Outputs,
    origin: Origin,
    msg: &msgs::Job,
    shape: Option<&ShapeEntry>,
) -> Option<Option<u64>> {
    let Some(journal) = &outputs.journal else {
        return Some(None);
    };
    let stored = match shape {
        Some(ShapeEntry::Ready(s)) => s.journal.as_ref(),
        _ => None,
    };
    match journal.accept(origin, msg, stored) {
        Ok(seq) => Some(Some(seq)),
        Err(e) => {
            let why = format!("not accepted: the job journal cannot take it: {e}");
            outputs.status(&msg.job_id, msgs::JobStatus::FAILED, 0.0, why);
            None
        }
    }
}

/// Binds journal entries `seqs` to the shape that arrived for them.
fn journal_bind(outputs: &Outputs, seqs: &[u64], shape: &ReadyShape) {
    let (Some(journal), Some(stored)) = (&outputs.journal, &shape.journal) else {
        return;
    };
    for &seq in seqs {
        if let Err(e) = journal.bind(seq, stored) {
            log::error!("journal entry {seq}: the shape it waited for is not recorded: {e}");
        }
    }
}

fn receive_shape(shared: &Shared, outputs: &Outputs, id: String, shape: Result<(Shape, ShapeMsg)>) {
    let entry = match shape {
        Ok((s, msg)) => {
            log::info!("received {id}");
            ShapeEntry::Ready(Arc::new(ReadyShape {
                shape: s,
                journal: outputs.journal.as_ref().map(|_| JournalShape::new(msg)),
            }))
        }
        Err(e) => {
            log::warn!("rejected {id}: {e}");
            ShapeEntry::Rejected(e.to_string())
        }
    };
    let bound = shared.lock().insert_shape(id, entry.clone());
    shared.wake.notify_all();
    if let ShapeEntry::Ready(s) = &entry {
        journal_bind(outputs, &bound, s);
    }
}

/// Whether a job is for the node named `name` (fully qualified): it names
/// no node, or this one. Jobs for other nodes are neither planned nor recorded.
fn addressed_to(job: &msgs::Job, name: &str) -> bool {
    job.node.is_empty() || job.node == name
}

/// Receives shapes and jobs (recording each as it arrives) until SIGINT or
/// SIGTERM. Never plans: jobs go to the workers' queue.
pub(super) async fn receive_until_signal(
    inputs: Inputs,
    shared: &Shared,
    outputs: &Outputs,
) -> Result<()> {
    let recorder = outputs.recorder.as_deref();
    let mut surface_stream = Box::pin(inputs.surfaces.async_stream());
    let mut pocket_stream = Box::pin(inputs.pockets.async_stream());
    let mut job_stream = Box::pin(inputs.jobs.async_stream());
    let mut joint_stream = Box::pin(inputs.joint_states.async_stream());
    let mut cancel_stream = Box::pin(inputs.cancels.async_stream());
    let mut sigterm = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())
        .map_err(|e| Error::system(format!("cannot watch SIGTERM: {e}")))?;
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
                        .and_then(|m| {
                            convert::surface_from_msg(&m).map(|s| (Shape::Surface(s), ShapeMsg::Surface(m)))
                        });
                    receive_shape(shared, outputs, id, shape);
                }
                Err(e) => log::error!("undecodable message on topic surface: {e:?}"),
            },
            Some(r) = pocket_stream.next() => match r {
                Ok((msg, _)) => {
                    if let Some(rec) = recorder {
                        rec.record(topics::POCKET, &msg);
                    }
                    let id = msg.pocket_id.clone();
                    let shape = inputs
                        .frames
                        .check_pocket(&msg)
                        .and_then(|()| convert::pocket_from_msg(&msg))
                        .map(|p| (Shape::Pocket(p), ShapeMsg::Pocket(msg)));
                    receive_shape(shared, outputs, id, shape);
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
