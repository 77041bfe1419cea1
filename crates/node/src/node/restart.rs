//! A node that starts on a job journal with entries left by its previous
//! run (docs/node.md, "Job journal and restarts"): the final statuses it
//! may not have published go out again as they were, and the jobs it had
//! not finished are planned again in their order (or ended FAILED, as
//! `journal.on_restart` says), under their job_id.

use super::outputs::Outputs;
use super::queue::{Pending, ReadyShape, ShapeEntry, Shared};
use super::receive::check_job;
use crate::config::{JournalSettings, OnRestart};
use crate::journal::{Journal, JournalShape, Recovery, ShapeMsg, Unfinished};
use std::sync::Arc;
use std::time::{Duration, Instant};
use toolpath_formats::Shape;
use toolpath_kernel::error::Result;
use toolpath_machines::Machines;
use toolpath_messages::{self as msgs, convert, final_state};

/// The message of the ACCEPTED status a job planned again gets.
pub(super) const RESTARTED: &str =
    "the node restarted before this job finished (accepted before the restart): planned again";

/// The reason of a job a restart ends (`journal.on_restart: fail`).
pub(super) const RESTARTED_FAILED: &str = "node restarted before finishing";

/// Opens the journal of `settings`, if the node keeps one.
pub(super) fn open(settings: &JournalSettings) -> Result<Option<(Arc<Journal>, Recovery)>> {
    let Some(path) = &settings.path else {
        return Ok(None);
    };
    let (journal, recovery) = Journal::open(std::path::Path::new(path), settings.keep_finished)?;
    if !recovery.unfinished.is_empty() || !recovery.unsent.is_empty() {
        log::warn!(
            "job journal {path}: {} job(s) the previous run had not finished, {} final status(es) it may not have published",
            recovery.unfinished.len(),
            recovery.unsent.len()
        );
    }
    Ok(Some((Arc::new(journal), recovery)))
}

/// The shape a journaled job was bound to, ready to plan on again.
fn ready(key: u64, msg: ShapeMsg) -> ShapeEntry {
    let shape = match &msg {
        ShapeMsg::Surface(s) => convert::surface_from_msg(s).map(Shape::Surface),
        ShapeMsg::Pocket(p) => convert::pocket_from_msg(p).map(Shape::Pocket),
    };
    match shape {
        Ok(shape) => ShapeEntry::Ready(Arc::new(ReadyShape {
            shape,
            journal: Some(JournalShape::stored(msg, key)),
        })),
        Err(e) => ShapeEntry::Rejected(e.to_string()),
    }
}

/// Publishes the finals of `recovery` that may not have gone out, then
/// plans again (or ends) its unfinished jobs in their order. A job waiting
/// for its shape when the node stopped waits again, `timeout` from now.
pub(super) fn resume(
    recovery: Recovery,
    on_restart: OnRestart,
    (shared, outputs): (&Shared, &Outputs),
    machines: &Machines,
    timeout: Duration,
) {
    for (seq, status) in recovery.unsent {
        outputs.resend(seq, status);
    }
    for u in recovery.unfinished {
        let Unfinished {
            seq, job, shape, ..
        } = u;
        let id = job.job_id.clone();
        if on_restart == OnRestart::Fail {
            let why = RESTARTED_FAILED.to_string();
            outputs.finish(&id, Some(seq), msgs::JobStatus::FAILED, 0.0, why);
            continue;
        }
        // The cell's machines may have changed since the job was accepted.
        if let Err(e) = check_job(&job, machines) {
            outputs.finish(&id, Some(seq), final_state(&e), 0.0, e.to_string());
            continue;
        }
        shared.lock().active.insert(id.clone(), job.clone());
        outputs.status(&id, msgs::JobStatus::ACCEPTED, 0.0, RESTARTED.into());
        let now = Instant::now();
        shared.lock().queue.push_back(Pending {
            msg: job,
            received: now,
            deadline: now + timeout,
            shape: shape.map(|(key, msg)| ready(key, msg)),
            goal: None,
            seq: Some(seq),
            restarted: true,
        });
        shared.wake.notify_all();
    }
}
