//! The job journal: every accepted job, with the shape it is bound to, is
//! written durably before its ACCEPTED status is published, and its final
//! status before that is published; on restart the node reads back the jobs
//! without a final status (to plan them again or end them) and the finals
//! that may not have gone out (to publish them, byte for byte, again).
//!
//! The store is redb: an embedded, pure-Rust B-tree file with ACID write
//! transactions; a commit with `Durability::Immediate` is on disk when it
//! returns, and a file cut by a crash opens at its last commit. The "sent"
//! mark of a final status is committed without fsync (`Durability::None`):
//! it becomes durable with the next durable commit, so after a crash only
//! the finals of the last jobs before it are published twice, never none.
//!
//! Bounded: finished entries beyond `keep_finished` are removed oldest
//! first, and a shape is kept only while an unfinished job refers to it.

use redb::{Database, ReadableDatabase, ReadableTable, ReadableTableMetadata, TableDefinition};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, VecDeque};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use toolpath_kernel::error::{Error, Result};
use toolpath_messages as msgs;
use toolpath_recording::{from_cdr, to_cdr};

/// Jobs by acceptance order (the journal's sequence number).
const JOBS: TableDefinition<u64, &[u8]> = TableDefinition::new("jobs_v1");
/// Shapes bound to unfinished jobs, by key.
const SHAPES: TableDefinition<u64, &[u8]> = TableDefinition::new("shapes_v1");

/// Where a journaled job came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Origin {
    /// Topic `job`.
    Topic,
    /// A PlanToolpath goal, by goal id.
    Goal([u8; 16]),
    /// A PlanToolpath service request.
    Service,
}

/// A shape as received, in the workpiece frame: what the journal stores
/// for a job bound to it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum ShapeMsg {
    Surface(msgs::Surface),
    Pocket(msgs::Pocket),
}

/// A shape the node holds, with its key in the journal once stored (one
/// copy for every job bound to it).
#[derive(Debug)]
pub struct JournalShape {
    pub msg: ShapeMsg,
    key: Mutex<Option<u64>>,
}

impl JournalShape {
    pub fn new(msg: ShapeMsg) -> Self {
        JournalShape {
            msg,
            key: Mutex::new(None),
        }
    }

    /// A shape read back from the journal, where it is stored under `key`.
    pub fn stored(msg: ShapeMsg, key: u64) -> Self {
        JournalShape {
            msg,
            key: Mutex::new(Some(key)),
        }
    }
}

/// One journal entry (CDR-encoded).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
struct Record {
    /// 0 topic, 1 goal, 2 service.
    origin: u8,
    goal_id: msgs::Uuid,
    job: msgs::Job,
    /// The shape's key in [`SHAPES`], 0 while none is bound.
    shape: u64,
    /// The final status once written (at most one).
    final_status: Vec<msgs::JobStatus>,
    /// Whether the final status was published.
    sent: bool,
}

impl Record {
    fn origin(&self) -> Origin {
        match self.origin {
            1 => Origin::Goal(self.goal_id.uuid),
            2 => Origin::Service,
            _ => Origin::Topic,
        }
    }
}

/// A job the journal holds without a final status.
#[derive(Clone, Debug, PartialEq)]
pub struct Unfinished {
    pub seq: u64,
    pub origin: Origin,
    pub job: msgs::Job,
    /// The shape it was bound to, `None` when it was waiting for one.
    pub shape: Option<(u64, ShapeMsg)>,
}

/// What the journal held when it was opened.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Recovery {
    /// Jobs without a final status, in acceptance order.
    pub unfinished: Vec<Unfinished>,
    /// Final statuses whose publication is not on record, in acceptance
    /// order, with their entries.
    pub unsent: Vec<(u64, msgs::JobStatus)>,
}

/// The journal's view of a PlanToolpath goal id.
#[derive(Clone, Debug, PartialEq)]
pub enum GoalEntry {
    /// Its job has no final status yet.
    Unfinished(u64),
    /// Its job's final status.
    Finished(msgs::JobStatus),
}

/// In-memory index of the file's contents.
#[derive(Default)]
struct Index {
    next_seq: u64,
    next_shape: u64,
    /// Finished entries, oldest first (the ones pruned first).
    finished: VecDeque<u64>,
    /// The shape of each unfinished entry that has one.
    shape_of: BTreeMap<u64, u64>,
    /// Unfinished entries per shape key.
    shape_refs: BTreeMap<u64, usize>,
    /// Goal ids of the entries that came from goals.
    goals: BTreeMap<[u8; 16], u64>,
}

impl Index {
    fn bind(&mut self, seq: u64, key: u64) {
        self.shape_of.insert(seq, key);
        *self.shape_refs.entry(key).or_default() += 1;
    }
    /// Drops `seq`'s reference to its shape; the key when none is left.
    fn unbind(&mut self, seq: u64) -> Option<u64> {
        let key = self.shape_of.remove(&seq)?;
        let left = self.shape_refs.get_mut(&key).map(|n| {
            *n -= 1;
            *n
        });
        (left == Some(0)).then(|| {
            self.shape_refs.remove(&key);
            key
        })
    }
}

/// The journal of one node (one file, which redb locks: two nodes cannot
/// share it).
pub struct Journal {
    db: Database,
    path: PathBuf,
    keep_finished: usize,
    index: Mutex<Index>,
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    match m.lock() {
        Ok(g) => g,
        Err(p) => p.into_inner(),
    }
}

fn encode_shape(shape: &ShapeMsg) -> Result<Vec<u8>> {
    match shape {
        ShapeMsg::Surface(s) => to_cdr(s).map(|b| [&[0u8][..], &b].concat()),
        ShapeMsg::Pocket(p) => to_cdr(p).map(|b| [&[1u8][..], &b].concat()),
    }
}

fn decode_shape(bytes: &[u8]) -> Result<ShapeMsg> {
    match bytes.split_first() {
        Some((0, rest)) => from_cdr(rest).map(ShapeMsg::Surface),
        Some((1, rest)) => from_cdr(rest).map(ShapeMsg::Pocket),
        _ => Err(Error::invalid("", "unknown shape kind")),
    }
}

impl Journal {
    /// Opens (or creates) the journal at `path` and reads what it holds; an
    /// entry that cannot be decoded is an error naming it (the file is not
    /// this program's, or is damaged beyond redb's own repair).
    pub fn open(path: &Path, keep_finished: usize) -> Result<(Self, Recovery)> {
        let shown = path.display().to_string();
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| {
                Error::invalid(
                    "journal.path",
                    format!("cannot create the directory of {shown}: {e}"),
                )
            })?;
        }
        let db = Database::create(path).map_err(|e| match e {
            redb::DatabaseError::DatabaseAlreadyOpen => Error::invalid(
                "journal.path",
                format!("{shown} is in use by another node: give each node its own journal"),
            ),
            other => Error::io(&shown, format!("cannot open the job journal: {other}")),
        })?;
        let journal = Journal {
            db,
            path: path.to_path_buf(),
            keep_finished: keep_finished.max(1),
            index: Mutex::new(Index::default()),
        };
        let recovery = journal.recover()?;
        Ok((journal, recovery))
    }

    /// The journal's file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    fn io(&self, e: impl std::fmt::Display) -> Error {
        Error::io(self.path.display().to_string(), format!("job journal: {e}"))
    }

    fn decode(&self, seq: u64, bytes: &[u8]) -> Result<Record> {
        from_cdr(bytes).map_err(|e| self.io(format!("entry {seq} cannot be read: {e}")))
    }

    /// Reads the file into the index; removes the shapes no unfinished job
    /// refers to and the finished entries beyond the bound.
    fn recover(&self) -> Result<Recovery> {
        let mut recovery = Recovery::default();
        let mut ix = Index::default();
        let mut shapes = BTreeMap::new();
        let txn = self.db.begin_read().map_err(|e| self.io(e))?;
        let records: Vec<(u64, Record)> = match txn.open_table(JOBS) {
            Ok(table) => {
                let mut out = Vec::new();
                for row in table.iter().map_err(|e| self.io(e))? {
                    let (k, v) = row.map_err(|e| self.io(e))?;
                    out.push((k.value(), self.decode(k.value(), v.value())?));
                }
                out
            }
            Err(redb::TableError::TableDoesNotExist(_)) => Vec::new(),
            Err(e) => return Err(self.io(e)),
        };
        if let Ok(table) = txn.open_table(SHAPES) {
            for row in table.iter().map_err(|e| self.io(e))? {
                let (k, v) = row.map_err(|e| self.io(e))?;
                let shape = decode_shape(v.value())
                    .map_err(|e| self.io(format!("shape {} cannot be read: {e}", k.value())))?;
                shapes.insert(k.value(), shape);
            }
        }
        drop(txn);
        for (seq, r) in records {
            ix.next_seq = ix.next_seq.max(seq + 1);
            if let Origin::Goal(id) = r.origin() {
                ix.goals.insert(id, seq);
            }
            match r.final_status.first() {
                Some(status) => {
                    ix.finished.push_back(seq);
                    if !r.sent {
                        recovery.unsent.push((seq, status.clone()));
                    }
                }
                None => {
                    let shape = shapes.get(&r.shape).map(|s| (r.shape, s.clone()));
                    if shape.is_some() {
                        ix.bind(seq, r.shape);
                    }
                    recovery.unfinished.push(Unfinished {
                        seq,
                        origin: r.origin(),
                        job: r.job,
                        shape,
                    });
                }
            }
        }
        ix.next_shape = shapes.keys().next_back().map_or(1, |k| k + 1);
        let orphans: Vec<u64> = shapes
            .keys()
            .filter(|k| !ix.shape_refs.contains_key(k))
            .copied()
            .collect();
        let mut index = lock(&self.index);
        *index = ix;
        self.write(redb::Durability::Immediate, |_, shapes| {
            for k in &orphans {
                shapes.remove(k)?;
            }
            Ok(())
        })?;
        self.prune(&mut index)?;
        Ok(recovery)
    }

    /// Runs `f` on the two tables in one write transaction, committed with
    /// `durability`.
    fn write(
        &self,
        durability: redb::Durability,
        f: impl FnOnce(
            &mut redb::Table<u64, &[u8]>,
            &mut redb::Table<u64, &[u8]>,
        ) -> std::result::Result<(), redb::StorageError>,
    ) -> Result<()> {
        let mut txn = self.db.begin_write().map_err(|e| self.io(e))?;
        txn.set_durability(durability).map_err(|e| self.io(e))?;
        {
            let mut jobs = txn.open_table(JOBS).map_err(|e| self.io(e))?;
            let mut shapes = txn.open_table(SHAPES).map_err(|e| self.io(e))?;
            f(&mut jobs, &mut shapes).map_err(|e| self.io(e))?;
        }
        txn.commit().map_err(|e| self.io(e))
    }

    fn read(&self, seq: u64) -> Result<Option<Record>> {
        let txn = self.db.begin_read().map_err(|e| self.io(e))?;
        let table = match txn.open_table(JOBS) {
            Ok(t) => t,
            Err(redb::TableError::TableDoesNotExist(_)) => return Ok(None),
            Err(e) => return Err(self.io(e)),
        };
        let Some(v) = table.get(seq).map_err(|e| self.io(e))? else {
            return Ok(None);
        };
        self.decode(seq, v.value()).map(Some)
    }

    /// The shape's key, storing it when the journal does not hold it yet;
    /// the bytes to store with the new key.
    fn shape_key(&self, ix: &mut Index, shape: &JournalShape) -> Result<(u64, Option<Vec<u8>>)> {
        let mut cached = lock(&shape.key);
        if let Some(k) = *cached {
            if ix.shape_refs.contains_key(&k) {
                return Ok((k, None));
            }
        }
        let key = ix.next_shape;
        ix.next_shape += 1;
        *cached = Some(key);
        Ok((key, Some(encode_shape(&shape.msg)?)))
    }

    /// Writes an accepted job (and the shape it is bound to, if any)
    /// durably; its sequence number.
    pub fn accept(
        &self,
        origin: Origin,
        job: &msgs::Job,
        shape: Option<&JournalShape>,
    ) -> Result<u64> {
        let mut ix = lock(&self.index);
        let seq = ix.next_seq;
        let (key, bytes) = match shape {
            Some(s) => {
                let (k, b) = self.shape_key(&mut ix, s)?;
                (k, b)
            }
            None => (0, None),
        };
        let (code, goal_id) = match origin {
            Origin::Topic => (0, [0; 16]),
            Origin::Goal(id) => (1, id),
            Origin::Service => (2, [0; 16]),
        };
        let record = Record {
            origin: code,
            goal_id: msgs::Uuid { uuid: goal_id },
            job: job.clone(),
            shape: key,
            final_status: Vec::new(),
            sent: false,
        };
        let data = to_cdr(&record)?;
        self.write(redb::Durability::Immediate, |jobs, shapes| {
            if let Some(b) = &bytes {
                shapes.insert(key, b.as_slice())?;
            }
            jobs.insert(seq, data.as_slice())?;
            Ok(())
        })?;
        ix.next_seq += 1;
        if shape.is_some() {
            ix.bind(seq, key);
        }
        if let Origin::Goal(id) = origin {
            ix.goals.insert(id, seq);
        }
        Ok(seq)
    }

    /// Binds the unfinished job `seq` to the shape that arrived for it,
    /// durably.
    pub fn bind(&self, seq: u64, shape: &JournalShape) -> Result<()> {
        let mut ix = lock(&self.index);
        if ix.shape_of.contains_key(&seq) {
            return Ok(());
        }
        let Some(mut record) = self.read(seq)? else {
            return Ok(());
        };
        let (key, bytes) = self.shape_key(&mut ix, shape)?;
        record.shape = key;
        let data = to_cdr(&record)?;
        self.write(redb::Durability::Immediate, |jobs, shapes| {
            if let Some(b) = &bytes {
                shapes.insert(key, b.as_slice())?;
            }
            jobs.insert(seq, data.as_slice())?;
            Ok(())
        })?;
        ix.bind(seq, key);
        Ok(())
    }

    /// Writes the final status of job `seq` durably (before it is
    /// published), and prunes.
    pub fn finish(&self, seq: u64, status: &msgs::JobStatus) -> Result<()> {
        let mut ix = lock(&self.index);
        let Some(mut record) = self.read(seq)? else {
            return Ok(());
        };
        if !record.final_status.is_empty() {
            return Ok(());
        }
        record.final_status = vec![status.clone()];
        let data = to_cdr(&record)?;
        let orphan = ix.unbind(seq);
        self.write(redb::Durability::Immediate, |jobs, shapes| {
            jobs.insert(seq, data.as_slice())?;
            if let Some(k) = orphan {
                shapes.remove(k)?;
            }
            Ok(())
        })?;
        ix.finished.push_back(seq);
        self.prune(&mut ix)
    }

    /// Notes that job `seq`'s final status was published; durable with the
    /// next durable commit.
    pub fn sent(&self, seq: u64) -> Result<()> {
        let _ix = lock(&self.index);
        let Some(mut record) = self.read(seq)? else {
            return Ok(());
        };
        if record.sent {
            return Ok(());
        }
        record.sent = true;
        let data = to_cdr(&record)?;
        self.write(redb::Durability::None, |jobs, _| {
            jobs.insert(seq, data.as_slice())?;
            Ok(())
        })
    }

    /// The final status of entry `seq`, once written.
    pub fn final_of(&self, seq: u64) -> Result<Option<msgs::JobStatus>> {
        Ok(self
            .read(seq)?
            .and_then(|r| r.final_status.into_iter().next()))
    }

    /// What the journal knows of the job of PlanToolpath goal `goal_id`.
    pub fn goal(&self, goal_id: &[u8; 16]) -> Result<Option<GoalEntry>> {
        let seq = match lock(&self.index).goals.get(goal_id) {
            Some(&s) => s,
            None => return Ok(None),
        };
        Ok(self
            .read(seq)?
            .map(|r| match r.final_status.into_iter().next() {
                Some(status) => GoalEntry::Finished(status),
                None => GoalEntry::Unfinished(seq),
            }))
    }

    /// Removes the oldest finished entries beyond the bound.
    fn prune(&self, ix: &mut Index) -> Result<()> {
        if ix.finished.len() <= self.keep_finished {
            return Ok(());
        }
        let excess = ix.finished.len() - self.keep_finished;
        let old: Vec<u64> = ix.finished.drain(..excess).collect();
        self.write(redb::Durability::None, |jobs, _| {
            for seq in &old {
                jobs.remove(seq)?;
            }
            Ok(())
        })?;
        ix.goals.retain(|_, s| !old.contains(s));
        Ok(())
    }

    /// Entries in the file (finished and not).
    #[cfg(test)]
    pub fn entries(&self) -> Result<usize> {
        let txn = self.db.begin_read().map_err(|e| self.io(e))?;
        match txn.open_table(JOBS) {
            Ok(t) => Ok(t.len().map_err(|e| self.io(e))? as usize),
            Err(redb::TableError::TableDoesNotExist(_)) => Ok(0),
            Err(e) => Err(self.io(e)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn job(id: &str, surface: &str) -> msgs::Job {
        msgs::Job {
            job_id: id.into(),
            surface_id: surface.into(),
            strategy: "iso_parametric".into(),
            scallop: 0.05,
            ..Default::default()
        }
    }

    fn surface(id: &str, z: f64) -> JournalShape {
        JournalShape::new(ShapeMsg::Surface(msgs::Surface {
            surface_id: id.into(),
            degree_u: 1,
            degree_v: 1,
            count_u: 2,
            count_v: 2,
            knots_u: vec![0.0, 0.0, 1.0, 1.0],
            knots_v: vec![0.0, 0.0, 1.0, 1.0],
            control_points: (0..4)
                .map(|k| msgs::Point {
                    x: f64::from(k % 2),
                    y: f64::from(k / 2),
                    z,
                })
                .collect(),
            ..Default::default()
        }))
    }

    fn status(id: &str, state: u8, sec: i32) -> msgs::JobStatus {
        msgs::JobStatus {
            header: msgs::Header {
                stamp: msgs::Time { sec, nanosec: 7 },
                frame_id: "workpiece".into(),
            },
            job_id: id.into(),
            state,
            progress: 1.0,
            message: format!("{id} done"),
            eta_s: -1.0,
        }
    }

    #[test]
    fn a_reopened_journal_gives_the_unfinished_jobs_in_order_with_their_shapes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sub/journal.redb");
        let (s1, s2) = (surface("s", 1.0), surface("s", 2.0));
        {
            let (j, rec) = Journal::open(&path, 10).unwrap();
            assert_eq!(rec, Recovery::default());
            let a = j.accept(Origin::Topic, &job("a", "s"), Some(&s1)).unwrap();
            let b = j
                .accept(Origin::Goal([9; 16]), &job("b", "s"), Some(&s1))
                .unwrap();
            let c = j.accept(Origin::Service, &job("c", "t"), None).unwrap();
            let d = j.accept(Origin::Topic, &job("d", "s"), Some(&s2)).unwrap();
            assert_eq!((a, b, c, d), (0, 1, 2, 3));
            j.finish(a, &status("a", msgs::JobStatus::SUCCEEDED, 5))
                .unwrap();
            j.sent(a).unwrap();
            j.finish(b, &status("b", msgs::JobStatus::FAILED, 6))
                .unwrap();
            // b's final was written, never marked sent: published again.
            j.bind(c, &s2).unwrap();
        }
        let (j, rec) = Journal::open(&path, 10).unwrap();
        let ids: Vec<&str> = rec
            .unfinished
            .iter()
            .map(|u| u.job.job_id.as_str())
            .collect();
        assert_eq!(ids, ["c", "d"]);
        assert_eq!(rec.unfinished[0].origin, Origin::Service);
        assert_eq!(rec.unfinished[0].job, job("c", "t"));
        // Both bound to the second "s" (one stored copy), not the first.
        for u in &rec.unfinished {
            assert_eq!(u.shape.as_ref().map(|(_, m)| m), Some(&s2.msg));
        }
        assert_eq!(
            rec.unfinished[0].shape.as_ref().unwrap().0,
            rec.unfinished[1].shape.as_ref().unwrap().0
        );
        assert_eq!(
            rec.unsent,
            vec![(1, status("b", msgs::JobStatus::FAILED, 6))]
        );
        assert_eq!(
            j.goal(&[9; 16]).unwrap(),
            Some(GoalEntry::Finished(status("b", msgs::JobStatus::FAILED, 6)))
        );
        assert_eq!(j.goal(&[8; 16]).unwrap(), None);
        // New entries continue the sequence.
        assert_eq!(j.accept(Origin::Topic, &job("e", "s"), None).unwrap(), 4);
    }

    #[test]
    fn finished_entries_beyond_the_bound_and_unreferenced_shapes_are_removed() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("journal.redb");
        let (j, _) = Journal::open(&path, 3).unwrap();
        let shape = surface("s", 1.0);
        for k in 0..20 {
            let id = format!("j{k}");
            let seq = j
                .accept(Origin::Topic, &job(&id, "s"), Some(&shape))
                .unwrap();
            j.finish(seq, &status(&id, msgs::JobStatus::SUCCEEDED, k))
                .unwrap();
            j.sent(seq).unwrap();
        }
        let kept = j
            .accept(Origin::Topic, &job("open", "s"), Some(&shape))
            .unwrap();
        // Three finished entries and the unfinished one.
        assert_eq!(j.entries().unwrap(), 4);
        drop(j);
        let (j, rec) = Journal::open(&path, 3).unwrap();
        assert_eq!(rec.unsent, vec![]);
        assert_eq!(rec.unfinished.len(), 1);
        assert_eq!(rec.unfinished[0].seq, kept);
        assert_eq!(
            rec.unfinished[0].shape.as_ref().map(|(_, m)| m),
            Some(&shape.msg)
        );
        j.finish(kept, &status("open", msgs::JobStatus::SUCCEEDED, 99))
            .unwrap();
        drop(j);
        let (j, rec) = Journal::open(&path, 3).unwrap();
        assert_eq!(rec.unfinished, vec![]);
        assert_eq!(j.entries().unwrap(), 3);
        let txn = j.db.begin_read().unwrap();
        assert_eq!(txn.open_table(SHAPES).unwrap().len().unwrap(), 0);
    }

    #[test]
    fn a_second_node_on_the_same_journal_is_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("journal.redb");
        let _first = Journal::open(&path, 10).unwrap();
        let e = Journal::open(&path, 10).err().unwrap().to_string();
        assert!(
            e.contains("journal.path") && e.contains("in use by another node"),
            "{e}"
        );
    }

    #[test]
    fn a_file_that_is_not_a_journal_is_an_error_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("journal.redb");
        std::fs::write(&path, b"not a database at all, just some text").unwrap();
        let e = Journal::open(&path, 10).err().unwrap().to_string();
        assert!(e.contains(&path.display().to_string()), "{e}");
    }
}
