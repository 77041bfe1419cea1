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

use super::config::RecordingSettings;
use crate::error::{Error, Result};
use crate::messages::{topics, RosMessage};
use crate::recording::{now_ns, runs, to_cdr, BagSummary, BagWriter, WriterOptions};
use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, Receiver, Sender, TryRecvError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

type Encode = Box<dyn FnOnce() -> Result<Vec<u8>> + Send>;

enum Entry {
    Message {
        topic: String,
        time_ns: u64,
        encode: Encode,
    },
    /// A job is finished: close the chunk once nothing else is waiting.
    JobDone,
}

/// The recorder of one node run.
pub struct Recorder {
    namespace: String,
    directory: PathBuf,
    /// Write errors so far and the first of them.
    failures: Arc<Mutex<(u64, Option<String>)>>,
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
        let failures = Arc::new(Mutex::new((0, None)));
        let thread = std::thread::Builder::new()
            .name("recorder".into())
            .spawn({
                let failures = Arc::clone(&failures);
                move || write_loop(writer, rx, &failures)
            })
            .map_err(|e| Error::planning(format!("cannot start the recorder thread: {e}")))?;
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

    /// A job got its final status: its messages form a unit on disk.
    pub fn job_done(&self) {
        self.send(Entry::JobDone);
    }

    /// The number of write errors so far and the first of them.
    pub fn failures(&self) -> (u64, Option<String>) {
        lock(&self.failures).clone()
    }

    /// Writes what is queued, the summary and metadata.yaml. Idempotent.
    pub fn finish(&self) -> Option<Result<BagSummary>> {
        drop(lock(&self.tx).take());
        let handle = lock(&self.thread).take()?;
        Some(handle.join().unwrap_or_else(|_| {
            Err(Error::planning(
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
fn failed(failures: &Mutex<(u64, Option<String>)>, what: String) {
    log::error!("{what}");
    let mut f = lock(failures);
    f.0 += 1;
    f.1.get_or_insert(what);
}

fn write_loop(
    mut writer: BagWriter,
    rx: Receiver<Entry>,
    failures: &Mutex<(u64, Option<String>)>,
) -> Result<BagSummary> {
    let mut flush_due = false;
    loop {
        let entry = if flush_due {
            match rx.try_recv() {
                Ok(e) => Some(e),
                Err(TryRecvError::Empty) => {
                    if let Err(e) = writer.flush().and_then(|()| writer.write_metadata_yaml()) {
                        failed(failures, format!("recording: {e}"));
                    }
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
            Some(Entry::JobDone) => flush_due = true,
            Some(Entry::Message {
                topic,
                time_ns,
                encode,
            }) => {
                let written = encode().and_then(|data| writer.write_raw(&topic, time_ns, &data));
                if let Err(e) = written {
                    failed(failures, format!("recording {topic}: {e}"));
                }
            }
        }
    }
    writer.finish()
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
