//! The node's queue as the PlanToolpath action and service see it: a goal's
//! job goes through the checks and the queue of a job from topic `job`,
//! bound to its shape (inline, or one received) when it is accepted.

use super::outputs::Outputs;
use super::queue::{Admission, Pending, ReadyShape, ShapeEntry, Shared};
use super::receive::{check_job, journal_accept, refuse};
use crate::journal::{GoalEntry, JournalShape, Origin, ShapeMsg};
use crate::plan_action::{GoalLink, GoalQueue};
use std::sync::{Arc, Weak};
use std::time::Instant;
use toolpath_formats::Shape;
use toolpath_kernel::error::{Error, Result};
use toolpath_machines::Machines;
use toolpath_messages::frames::Frames;
use toolpath_messages::plan_toolpath::{FeedbackMessage, Goal};
use toolpath_messages::{self as msgs, convert, topics};

pub(super) struct NodeQueue {
    pub shared: Arc<Shared>,
    /// Weak: the action's tasks live as long as the runtime, and the node's
    /// shutdown drops the outputs to close the iceoryx2 channel.
    pub outputs: Weak<Outputs>,
    pub machines: Machines,
    /// The frames a goal's job and shapes may be given in.
    pub frames: Frames,
}

impl NodeQueue {
    /// A goal sent again by the goal id of a job the journal holds (the
    /// node restarted since the goal was first sent): it ends with that job,
    /// at once when the job has ended. `Ok(true)` when so answered.
    fn answered_from_journal(&self, outputs: &Outputs, link: &Arc<GoalLink>) -> Result<bool> {
        let (Some(journal), Some(goal_id)) = (&outputs.journal, link.goal_id) else {
            return Ok(false);
        };
        match journal.goal(&goal_id)? {
            None => Ok(false),
            Some(GoalEntry::Finished(m)) => {
                log::info!(
                    "PlanToolpath goal of job {} sent again: it has ended",
                    m.job_id
                );
                link.finish(m.state, m.message);
                Ok(true)
            }
            Some(GoalEntry::Unfinished(seq)) => {
                log::info!(
                    "PlanToolpath goal of job {} sent again: it ends with that job",
                    link.job_id
                );
                outputs.end_with(seq, link);
                Ok(true)
            }
        }
    }

    fn outputs(&self) -> Result<Arc<Outputs>> {
        self.outputs
            .upgrade()
            .ok_or_else(|| Error::shutdown("the node is shutting down"))
    }

    /// The shape a goal's job plans on: the one inline, else one received.
    fn shape_of(&self, goal: &Goal, journal: bool) -> Result<Arc<ReadyShape>> {
        let id = &goal.job.surface_id;
        if goal.surface.len() + goal.pocket.len() > 1 {
            return Err(Error::invalid(
                "surface",
                "give at most one shape inline: one surface or one pocket",
            ));
        }
        let inline = match (goal.surface.first(), goal.pocket.first()) {
            (Some(s), _) if s.surface_id != *id => Some(Err(Error::invalid(
                "surface[0].surface_id",
                format!("\"{}\" differs from job.surface_id \"{id}\"", s.surface_id),
            ))),
            (Some(s), _) => Some(
                convert::surface_from_msg(s)
                    .map(|x| (Shape::Surface(x), ShapeMsg::Surface(s.clone()))),
            ),
            (_, Some(p)) if p.pocket_id != *id => Some(Err(Error::invalid(
                "pocket[0].pocket_id",
                format!("\"{}\" differs from job.surface_id \"{id}\"", p.pocket_id),
            ))),
            (_, Some(p)) => Some(
                convert::pocket_from_msg(p)
                    .map(|x| (Shape::Pocket(x), ShapeMsg::Pocket(p.clone()))),
            ),
            _ => None,
        };
        if let Some(shape) = inline {
            return shape.map(|(shape, msg)| {
                Arc::new(ReadyShape {
                    shape,
                    journal: journal.then(|| JournalShape::new(msg)),
                })
            });
        }
        let known = self.shared.lock().shapes.get(id).map(|(_, e)| e.clone());
        match known {
            Some(ShapeEntry::Ready(s)) => Ok(s),
            Some(ShapeEntry::Rejected(why)) => Err(Error::invalid(
                "job.surface_id",
                format!("\"{id}\" names a shape the node rejected: {why}"),
            )),
            None => Err(Error::invalid(
                "job.surface_id",
                format!(
                    "no surface or pocket \"{id}\" has been received: publish it on topic {} or {}, or send it inline in the goal",
                    topics::SURFACE,
                    topics::POCKET
                ),
            )),
        }
    }

    /// The goal with its job and inline shapes in the workpiece frame.
    fn in_workpiece(&self, mut goal: Goal) -> Result<Goal> {
        if let Some(job) = self.frames.job_in_workpiece(&goal.job)? {
            goal.job = job;
        }
        goal.surface = std::mem::take(&mut goal.surface)
            .into_iter()
            .map(|s| self.frames.surface_in_workpiece(s))
            .collect::<Result<_>>()?;
        for p in &goal.pocket {
            self.frames.check_pocket(p)?;
        }
        Ok(goal)
    }

    /// Checks the goal; its shape when the job may be queued.
    fn admit(&self, goal: &Goal, journal: bool) -> Result<Arc<ReadyShape>> {
        check_job(&goal.job, &self.machines)?;
        let shape = self.shape_of(goal, journal)?;
        convert::job_from_msg(&goal.job, &shape.shape)?;
        let mut st = self.shared.lock();
        match st.admit(&goal.job) {
            Admission::New => {}
            Admission::Resent | Admission::Conflict(_) => {
                return Err(Error::invalid(
                    "job.job_id",
                    format!(
                    "\"{}\" is already queued or running: one job_id, one plan (use a new job_id)",
                    goal.job.job_id
                ),
                ))
            }
        }
        st.active.insert(goal.job.job_id.clone(), goal.job.clone());
        Ok(shape)
    }
}

impl GoalQueue for NodeQueue {
    fn submit(&self, goal: Goal, link: &Arc<GoalLink>) -> Result<()> {
        let job_id = goal.job.job_id.clone();
        let outputs = self.outputs()?;
        if let Some(rec) = &outputs.recorder {
            rec.record(topics::JOB, &goal.job);
            for s in &goal.surface {
                rec.record(topics::SURFACE, s);
            }
            for p in &goal.pocket {
                rec.record(topics::POCKET, p);
            }
        }
        if self.answered_from_journal(&outputs, link)? {
            return Ok(());
        }
        let journal = outputs.journal.is_some();
        let admitted = self
            .in_workpiece(goal)
            .and_then(|goal| self.admit(&goal, journal).map(|shape| (goal, shape)));
        let (goal, shape) = match admitted {
            Ok(s) => s,
            Err(e) => {
                refuse(&self.shared, &outputs, &job_id, &e);
                return Err(e);
            }
        };
        let origin = link.goal_id.map_or(Origin::Service, Origin::Goal);
        let shape = ShapeEntry::Ready(shape);
        let Some(seq) = journal_accept(&outputs, origin, &goal.job, Some(&shape)) else {
            self.shared.lock().active.remove(&job_id);
            return Err(Error::shutdown(
                "not accepted: the job journal cannot take it",
            ));
        };
        // ACCEPTED before the job is queued, so a worker's statuses follow it.
        outputs.status(&job_id, msgs::JobStatus::ACCEPTED, 0.0, String::new());
        let now = Instant::now();
        self.shared.lock().queue.push_back(Pending {
            msg: goal.job,
            received: now,
            deadline: now,
            shape: Some(shape),
            goal: Some(Arc::clone(link)),
            seq,
            restarted: false,
        });
        self.shared.wake.notify_all();
        Ok(())
    }

    fn cancel(&self, link: &Arc<GoalLink>) {
        link.cancel();
        let mut st = self.shared.lock();
        let queued = st
            .queue
            .iter()
            .position(|p| p.goal.as_ref().is_some_and(|g| Arc::ptr_eq(g, link)));
        if let Some(p) = queued.and_then(|k| st.queue.remove(k)) {
            st.active.remove(&p.msg.job_id);
            drop(st);
            let why = Error::canceled(format!(
                "job {}: its PlanToolpath goal was canceled by the client while queued: not planned",
                link.job_id
            ))
            .to_string();
            if let Ok(outputs) = self.outputs() {
                outputs.finish(
                    &link.job_id,
                    p.seq,
                    msgs::JobStatus::CANCELED,
                    0.0,
                    why.clone(),
                );
            }
            link.finish(msgs::JobStatus::CANCELED, why);
            return;
        }
        drop(st);
        // Planning stops at its next progress check; an execution is
        // canceled at the controller.
        if let (true, Ok(outputs)) = (link.is_executing(), self.outputs()) {
            outputs.cancels.cancel(&link.job_id);
        }
    }

    fn feedback_published(&self, msg: &FeedbackMessage) {
        if let Some(rec) = self.outputs.upgrade().and_then(|o| o.recorder.clone()) {
            rec.record(topics::PLAN_TOOLPATH_FEEDBACK, msg);
        }
    }

    fn status_published(&self, msg: &msgs::GoalStatusArray) {
        if let Some(rec) = self.outputs.upgrade().and_then(|o| o.recorder.clone()) {
            rec.record(topics::PLAN_TOOLPATH_STATUS, msg);
        }
    }
}
