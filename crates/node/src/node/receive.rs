//! The node's receive loop (tokio): shapes, jobs, joint states and cancels
//! as they arrive, each recorded; a job is checked and REJECTED at once, or
//! ACCEPTED and queued for the workers. It never plans.

use super::outputs::Outputs;
use super::queue::{Admission, Pending, ShapeEntry, Shared};
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
