//! Recording the node's run as a rosbag2 bag (the `recording:` config section).
//!
//! Every message the node receives (surface, pocket, job) or publishes (all
//! outputs) is handed to one writer thread as a clone; the thread serialises
//! it to CDR and writes it, so recording adds a clone, not serialisation or
//! compression, to a job's latency. After a job's final status the current
//! chunk is closed and written (once the queue is empty, so a burst of jobs
//! shares chunks): a node killed with SIGKILL leaves a .mcap whose finished
//! jobs are readable; metadata.yaml is written at the start and refreshed
//! (atomically) with each such chunk, and `toolpath bag reindex` adds the
//! summary that the standard readers need. On a normal stop (SIGINT/SIGTERM)
//! the summary and the final metadata.yaml are written.
//!
//! A write error (a full disk) is counted, stops writing into that storage
//! file, and is reported in the final status of the job it hit; with the
//! next job the recorder goes on in a new storage file (a split), so freeing
//! space lets recording resume without a restart. The node's exit code still
//! says that recording failed.

use super::config::RecordingSettings;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, Receiver, Sender, TryRecvError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use toolpath_kernel::error::{Error, Result};
use toolpath_messages::{topics, RosMessage};
use toolpath_recording::{now_ns, runs, to_cdr, BagSummary, BagWriter, WriterOptions};

type Encode = Box<dyn FnOnce() -> Result<Vec<u8>> + Send>;

enum Entry {
    Message {
        topic: String,
        time_ns: u64,
        encode: Encode,
    },
    /// A job is finished: close the chunk once nothing else is waiting.
    JobDone,
    /// Write what is queued now and answer (a job's final status waits for
    /// it, to report a write error that hit the job's messages).
    Sync(mpsc::Sender<()>),
    /// Write what is queued now into the file (the chunk handed to the
    /// operating system) and answer: a status waits for it before it is
    /// published.
    Written(mpsc::Sender<()>),
}

/// Write errors of a recording.
#[derive(Clone, Debug, Default)]
pub struct Failures {
    /// Write errors so far.
    pub errors: u64,
    /// The first and the latest of them.
    pub first: Option<String>,
    pub last: Option<String>,
    /// Messages not recorded because their storage file had failed.
    pub dropped: u64,
    /// The storage file failed and no new one is open yet.
    pub broken: bool,
    /// `errors` when a job's status last reported them.
    reported: u64,
}

/// The recorder of one node run.
pub struct Recorder {
    namespace: String,
    directory: PathBuf,
    failures: Arc<Mutex<Failures>>,
    tx: Mutex<Option<Sender<Entry>>>,
    thread: Mutex<Option<JoinHandle<Result<BagSummary>>>>,
    /// Messages are dropped while paused (the `recording.enabled` parameter).
    paused: std::sync::atomic::AtomicBool,
}

/// `YYYYMMDDTHHMMSSZ` of a Unix time in seconds (UTC, proleptic Gregorian).
pub fn utc_stamp(unix_s: u64) -> String {
    let days = (unix_s / 86_400) as i64;
    let secs = unix_s % 86_400;
    // Howard Hinnant's civil_from_days.
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}{m:02}{d:02}T{:02}{:02}{:02}Z",
        secs / 3600,
        secs / 60 % 60,
        secs % 60
    )
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    match m.lock() {
        Ok(g) => g,
        Err(p) => p.into_inner(),
    }
}

impl Recorder {
    /// Creates the bag (an error names the directory when it cannot be made)
    /// and starts the writer thread.
    pub fn start(settings: &RecordingSettings, node_name: &str, namespace: &str) -> Result<Self> {
        let name = settings.bag_name.clone().unwrap_or_else(|| {
            format!(
                "{node_name}_{}_{}",
                utc_stamp(now_ns() / 1_000_000_000),
                std::process::id()
            )
        });
        let directory = Path::new(&settings.directory).join(name);
        let options = WriterOptions {
            chunk_size: settings.chunk_size_kib.saturating_mul(1024),
            compress: settings.zstd_level > 0,
            compression_level: settings.zstd_level,
        };
        let mut writer = BagWriter::create(&directory, options).map_err(|e| match e {
            Error::Invalid { message, .. } => Error::invalid("recording.directory", message),
            other => other,
        })?;
        for spec in runs::topic_specs_in(namespace) {
            writer.add_topic(&spec)?;
        }
        // Shapes and the header record are on disk before the first job, and
        // metadata.yaml names the storage file from the start.
        writer.flush()?;
        writer.write_metadata_yaml()?;
        let (tx, rx) = mpsc::channel();
        let failures = Arc::new(Mutex::new(Failures::default()));
        let thread = std::thread::Builder::new()
            .name("recorder".into())
            .spawn({
                let failures = Arc::clone(&failures);
                move || write_loop(writer, rx, &failures)
            })
            .map_err(|e| Error::system(format!("cannot start the recorder thread: {e}")))?;
        Ok(Recorder {
            failures,
            namespace: namespace.trim_end_matches('/').to_string(),
            directory,
            tx: Mutex::new(Some(tx)),
            thread: Mutex::new(Some(thread)),
            paused: std::sync::atomic::AtomicBool::new(false),
        })
    }

    /// Pauses (or resumes) recording; the bag stays open.
    pub fn set_paused(&self, paused: bool) {
        self.paused
            .store(paused, std::sync::atomic::Ordering::Relaxed);
    }

    /// Whether recording is paused.
    pub fn paused(&self) -> bool {
        self.paused.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// The bag directory.
    pub fn directory(&self) -> &Path {
        &self.directory
    }

    fn send(&self, entry: Entry) {
        if let Some(tx) = lock(&self.tx).as_ref() {
            // A stopped writer thread has logged why; recording is best effort.
            let _ = tx.send(entry);
        }
    }

    /// Records `msg` on the node topic `relative` (as received or published now).
    pub fn record<M: RosMessage>(&self, relative: &str, msg: &M) {
        if self.paused.load(std::sync::atomic::Ordering::Relaxed) {
            return;
        }
        let msg = msg.clone();
        self.send(Entry::Message {
            topic: topics::absolute(&self.namespace, relative),
            time_ns: now_ns(),
            encode: Box::new(move || to_cdr(&msg)),
        });
    }

    /// Records `msg` and waits (up to `timeout`) until it is written to the
    /// bag's file, handed to the operating system: a message recorded so is
    /// in the bag of a node killed right after, once `toolpath bag reindex`
    /// has read its completed chunks. Nothing to wait for while paused or
    /// while the storage file has failed (the message is not recorded then).
    pub fn record_written<M: RosMessage>(
        &self,
        relative: &str,
        msg: &M,
        timeout: std::time::Duration,
    ) {
        if self.paused() {
            return;
        }
        self.record(relative, msg);
        let (tx, rx) = mpsc::channel();
        self.send(Entry::Written(tx));
        if rx.recv_timeout(timeout).is_err() {
            log::warn!(
                "recording: {relative} not written within {:.0} s; published anyway",
                timeout.as_secs_f64()
            );
        }
    }

    /// A job got its final status: its messages form a unit on disk.
    pub fn job_done(&self) {
        self.send(Entry::JobDone);
    }

    /// The write errors so far.
    pub fn failures(&self) -> Failures {
        lock(&self.failures).clone()
    }

    /// Waits (up to `timeout`) until what is queued is written, then returns
    /// the write errors since the last call, as a sentence for a job status.
    pub fn new_failures(&self, timeout: std::time::Duration) -> Option<String> {
        let (tx, rx) = mpsc::channel();
        self.send(Entry::Sync(tx));
        // A writer that does not answer in time reports with a later job.
        let _ = rx.recv_timeout(timeout);
        let mut f = lock(&self.failures);
        if f.errors == f.reported {
            return None;
        }
        let new = f.errors - f.reported;
        f.reported = f.errors;
        Some(format!(
            "recording failed: {new} write error(s), the last: {}; this job's messages may be \
             missing from the bag (recording goes on in a new file with the next job)",
            f.last.as_deref().unwrap_or("unknown")
        ))
    }

    /// Writes what is queued, the summary and metadata.yaml. Idempotent.
    pub fn finish(&self) -> Option<Result<BagSummary>> {
        drop(lock(&self.tx).take());
        let handle = lock(&self.thread).take()?;
        Some(handle.join().unwrap_or_else(|_| {
            Err(Error::shutdown(
                "the recorder thread panicked (please report)",
            ))
        }))
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        let _ = self.finish();
    }
}

/// Counts a write error and logs it.
fn failed(failures: &Mutex<Failures>, what: String) {
    log::error!("{what}");
    let mut f = lock(failures);
    f.errors += 1;
    f.first.get_or_insert_with(|| what.clone());
    f.last = Some(what);
    f.broken = true;
}

/// The writer thread: writes entries in order. After a write error it drops
/// the rest of the job's messages; the first message after the job's end
/// tries a new storage file.
fn write_loop(
    mut writer: BagWriter,
    rx: Receiver<Entry>,
    failures: &Mutex<Failures>,
) -> Result<BagSummary> {
    let mut flush_due = false;
    let mut retry_due = false;
    loop {
        let entry = if flush_due {
            match rx.try_recv() {
                Ok(e) => Some(e),
                Err(TryRecvError::Empty) => {
                    flush(&mut writer, failures);
                    flush_due = false;
                    continue;
                }
                Err(TryRecvError::Disconnected) => None,
            }
        } else {
            rx.recv().ok()
        };
        match entry {
            None => break,
            Some(Entry::JobDone) => {
                retry_due = lock(failures).broken;
                flush_due = true;
            }
            Some(Entry::Sync(done)) => {
                flush(&mut writer, failures);
                let _ = done.send(());
            }
            Some(Entry::Written(done)) => {
                if !lock(failures).broken {
                    if let Err(e) = writer.flush() {
                        failed(failures, format!("recording: {e}"));
                    }
                }
                let _ = done.send(());
            }
            Some(Entry::Message {
                topic,
                time_ns,
                encode,
            }) => {
                if lock(failures).broken && std::mem::take(&mut retry_due) {
                    resume(&mut writer, failures);
                }
                if lock(failures).broken {
                    lock(failures).dropped += 1;
                    continue;
                }
                let written = encode().and_then(|data| writer.write_raw(&topic, time_ns, &data));
                if let Err(e) = written {
                    failed(failures, format!("recording {topic}: {e}"));
                }
            }
        }
    }
    writer.finish()
}

/// Writes the current chunk and metadata.yaml (unless the file has failed).
fn flush(writer: &mut BagWriter, failures: &Mutex<Failures>) {
    if lock(failures).broken {
        return;
    }
    if let Err(e) = writer.flush().and_then(|()| writer.write_metadata_yaml()) {
        failed(failures, format!("recording: {e}"));
    }
}

/// Goes on in a new storage file after a write error.
fn resume(writer: &mut BagWriter, failures: &Mutex<Failures>) {
    match writer.split().and_then(|()| writer.write_metadata_yaml()) {
        Ok(()) => {
            let mut f = lock(failures);
            f.broken = false;
            log::warn!(
                "recording goes on in {} ({} message(s) were not recorded)",
                writer.current_file(),
                f.dropped
            );
        }
        Err(e) => log::error!("recording: cannot go on in a new file yet: {e}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_stamps_of_known_dates() {
        assert_eq!(utc_stamp(0), "19700101T000000Z");
        // 2000-02-29 12:34:56 UTC (leap day).
        assert_eq!(utc_stamp(951_827_696), "20000229T123456Z");
        // 2026-11-22 09:21:01 UTC.
        assert_eq!(utc_stamp(1_795_339_261), "20261122T092101Z");
    }
}
