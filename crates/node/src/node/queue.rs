//! The node's job queue: the shapes it knows by id, the jobs queued or being
//! planned (one job_id, one plan), and how a worker picks the next job (the
//! first whose shape has arrived, been rejected, or whose wait timed out).

use crate::joint_states::JointStates;
use crate::journal::JournalShape;
use crate::parameters::LiveConfig;
use crate::plan_action::GoalLink;
use std::collections::{BTreeMap, VecDeque};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Instant;
use toolpath_formats::Shape;
use toolpath_messages as msgs;

/// What the node knows about a shape id.
#[derive(Clone)]
pub(super) enum ShapeEntry {
    Ready(Arc<ReadyShape>),
    Rejected(String),
}

/// A shape ready to plan on, with the message the job journal stores for
/// the jobs bound to it (when the node keeps a journal).
pub(super) struct ReadyShape {
    pub(super) shape: Shape,
    pub(super) journal: Option<JournalShape>,
}

pub(super) struct Pending {
    pub(super) msg: msgs::Job,
    pub(super) received: Instant,
    pub(super) deadline: Instant,
    /// The shape this job plans on: the one known when the job was accepted,
    /// else the first to arrive after; a later re-publish of the same id does
    /// not change it.
    pub(super) shape: Option<ShapeEntry>,
    /// The PlanToolpath goal (or service request) the job serves, if any.
    pub(super) goal: Option<Arc<GoalLink>>,
    /// The job's entry in the job journal, when the node keeps one.
    pub(super) seq: Option<u64>,
    /// Accepted before the node restarted, and planned again.
    pub(super) restarted: bool,
}

/// Shapes the node keeps by id. Beyond this the least recently received
/// shape is dropped; a queued job keeps the shape it was bound to, so only a
/// job sent later for an evicted id waits for it to be published again.
pub const MAX_SHAPES: usize = 100;

#[derive(Default)]
pub(super) struct State {
    /// Shapes by id, with the order they were received in (for eviction).
    pub(super) shapes: BTreeMap<String, (u64, ShapeEntry)>,
    pub(super) received_shapes: u64,
    pub(super) queue: VecDeque<Pending>,
    /// The messages of the jobs queued or being planned, by job_id.
    pub(super) active: BTreeMap<String, msgs::Job>,
    pub(super) shutdown: bool,
    /// Planning threads running, and how many `node.workers` asks for:
    /// surplus threads leave when they next look for work.
    pub(super) running_workers: usize,
    pub(super) wanted_workers: usize,
}

/// What to do with a job message whose job_id may already be in use.
#[derive(Debug, PartialEq)]
pub(super) enum Admission {
    New,
    /// The same job sent again while queued or running: its statuses answer it.
    Resent,
    /// Another job under a job_id that is queued or running: refused.
    Conflict(String),
}

impl State {
    pub(super) fn admit(&self, msg: &msgs::Job) -> Admission {
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
                "job_id \"{}\" is already queued or running with other parameters: this second job is \
                 refused and not planned (one job_id, one plan: use a new job_id); the job under this id goes on",
                msg.job_id
            ))
        }
    }

    /// Stores a received shape, binds it to the queued jobs waiting for it,
    /// and evicts the least recently received shapes beyond [`MAX_SHAPES`];
    /// the journal entries of the jobs it was bound to.
    pub(super) fn insert_shape(&mut self, id: String, entry: ShapeEntry) -> Vec<u64> {
        let mut bound = Vec::new();
        for p in self.queue.iter_mut() {
            if p.shape.is_none() && p.msg.surface_id == id {
                p.shape = Some(entry.clone());
                bound.extend(p.seq);
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
        bound
    }
}

pub(super) struct Shared {
    pub(super) state: Mutex<State>,
    pub(super) wake: Condvar,
    /// The latest `/joint_states`: where each trajectory starts.
    pub(super) joints: JointStates,
    /// The settings each job is planned with (parameters change them).
    pub(super) live: Arc<LiveConfig>,
    /// Busy workers and planning times, for `/diagnostics`.
    pub(super) activity: crate::diagnostics::Activity,
}

impl Shared {
    pub(super) fn lock(&self) -> std::sync::MutexGuard<'_, State> {
        match self.state.lock() {
            Ok(g) => g,
            Err(p) => p.into_inner(),
        }
    }
}

/// What a worker takes from the queue.
pub(super) enum Work {
    Plan(Pending, Arc<ReadyShape>),
    Reject(Pending, String),
    TimedOut(Pending),
}

/// Blocks until a job can be handled: the first queued job whose shape has
/// arrived (or been rejected), or whose wait has timed out.
pub(super) fn next_work(shared: &Shared) -> Option<Work> {
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

#[cfg(test)]
mod tests {
    use super::*;

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
            seq: None,
            restarted: false,
        }
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
