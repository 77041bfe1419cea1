//! The bag writer.

use super::metadata::{
    self, BagMetadata, FileInformation, Nanoseconds, StartingTime, TopicInformation, TopicMetadata,
};
use super::{to_cdr, TopicSpec};
use serde::Serialize;
use std::collections::BTreeMap;
use std::fs::File;
use std::path::{Path, PathBuf};
use toolpath_kernel::error::{Error, Result};

/// How the MCAP file is chunked and compressed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WriterOptions {
    /// Target uncompressed chunk size, bytes. A chunk is finished (and written
    /// to the file) once it grows past this.
    pub chunk_size: u64,
    /// zstd-compress chunks.
    pub compress: bool,
    /// zstd level (1 fast .. 19 small).
    pub compression_level: u32,
}

impl Default for WriterOptions {
    /// 256 KiB chunks, zstd level 3: a few chunks per large toolpath, so a
    /// killed node loses little (bag sizes in docs/results.md, "Recording").
    fn default() -> Self {
        WriterOptions {
            chunk_size: 256 * 1024,
            compress: true,
            compression_level: 3,
        }
    }
}

/// What a finished bag holds.
#[derive(Clone, Debug, PartialEq)]
pub struct BagSummary {
    pub directory: PathBuf,
    pub mcap: PathBuf,
    pub messages: u64,
    pub chunks: usize,
    /// Size of the .mcap file, bytes.
    pub file_bytes: u64,
    /// Sum of the uncompressed chunk sizes, bytes.
    pub uncompressed_bytes: u64,
}

struct Channel {
    id: u16,
    spec: TopicSpec,
    count: u64,
}

/// One storage file of the bag and what was written to it.
struct StorageFile {
    name: String,
    first_time: Option<u64>,
    last_time: u64,
    messages: u64,
}

impl StorageFile {
    fn new(name: String) -> Self {
        StorageFile {
            name,
            first_time: None,
            last_time: 0,
            messages: 0,
        }
    }

    fn count(&mut self, log_time_ns: u64) {
        self.first_time = Some(self.first_time.map_or(log_time_ns, |t| t.min(log_time_ns)));
        self.last_time = self.last_time.max(log_time_ns);
        self.messages += 1;
    }

    fn information(&self) -> FileInformation {
        let start = self.first_time.unwrap_or(0);
        FileInformation {
            path: self.name.clone(),
            starting_time: StartingTime {
                nanoseconds_since_epoch: start,
            },
            duration: Nanoseconds {
                nanoseconds: self.last_time.saturating_sub(start),
            },
            message_count: self.messages,
        }
    }
}

/// Writes one rosbag2 bag. Messages go into chunks; each finished chunk is
/// written straight to the file (no user-space buffer), so it survives the
/// process being killed. [`BagWriter::finish`] writes the summary and
/// metadata.yaml. After a write error, [`BagWriter::split`] goes on in a new
/// storage file `<name>_<k>.mcap`, as rosbag2 splits a bag.
pub struct BagWriter {
    directory: PathBuf,
    /// The bag's name: storage files are `<stem>_<k>.mcap`.
    stem: String,
    options: WriterOptions,
    /// Storage files before the current one.
    closed: Vec<StorageFile>,
    current: StorageFile,
    /// The current file's writer; `None` once finished, or while a split
    /// could not open the next file.
    writer: Option<mcap::Writer<File>>,
    channels: BTreeMap<String, Channel>,
    sequence: u32,
}

fn mcap_error(path: &Path, e: mcap::McapError) -> Error {
    Error::io(
        path.display().to_string(),
        format!("MCAP write failed: {e}"),
    )
}

/// Nanoseconds since the Unix epoch, now.
pub fn now_ns() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0)
}

impl BagWriter {
    /// Creates bag directory `directory` (it must not exist, or be empty) with
    /// `<name>_0.mcap` inside, `<name>` being the directory's name.
    pub fn create(directory: &Path, options: WriterOptions) -> Result<Self> {
        Self::create_file(directory, None, options)
    }

    /// [`BagWriter::create`] with the storage file named `file_name`
    /// (default `<name>_0.mcap`).
    pub fn create_file(
        directory: &Path,
        file_name: Option<&str>,
        options: WriterOptions,
    ) -> Result<Self> {
        let shown = directory.display().to_string();
        if directory.exists() {
            let empty = std::fs::read_dir(directory)
                .map_err(|e| Error::io(&shown, e))?
                .next()
                .is_none();
            if !empty {
                return Err(Error::invalid(
                    "output",
                    format!("{shown} already exists and is not empty: choose a new bag directory"),
                ));
            }
        } else {
            std::fs::create_dir_all(directory).map_err(|e| Error::io(&shown, e))?;
        }
        let name = directory
            .file_name()
            .and_then(|n| n.to_str())
            .filter(|n| !n.is_empty())
            .ok_or_else(|| {
                Error::invalid("output", format!("{shown} has no usable directory name"))
            })?
            .to_string();
        let file_name = file_name.map_or_else(|| format!("{name}_0.mcap"), str::to_string);
        let path = directory.join(&file_name);
        let writer = open_mcap(&path, options)?;
        Ok(BagWriter {
            directory: directory.to_path_buf(),
            stem: name,
            options,
            closed: Vec::new(),
            current: StorageFile::new(file_name),
            writer: Some(writer),
            channels: BTreeMap::new(),
            sequence: 0,
        })
    }

    fn path(&self) -> PathBuf {
        self.directory.join(&self.current.name)
    }

    fn writer(&mut self) -> Result<&mut mcap::Writer<File>> {
        let path = self.path();
        self.writer.as_mut().ok_or_else(|| {
            Error::io(
                path.display().to_string(),
                "no storage file is open (the bag is finished, or a new file could not be opened)",
            )
        })
    }

    /// Closes the current storage file as well as it still can (after a write
    /// error its last chunk may be lost) and goes on in the next one,
    /// `<name>_<k>.mcap`, with every topic added again. When the next file
    /// cannot be opened the error is returned and a later call tries again.
    pub fn split(&mut self) -> Result<()> {
        if let Some(mut old) = self.writer.take() {
            // Best effort: the summary of a file that failed may not fit.
            let _ = old.finish();
            let k = self.closed.len() + 1;
            let next = StorageFile::new(format!("{}_{k}.mcap", self.stem));
            self.closed.push(std::mem::replace(&mut self.current, next));
        }
        let path = self.path();
        let mut w = open_mcap(&path, self.options)?;
        for channel in self.channels.values_mut() {
            channel.id = add_channel(&mut w, &channel.spec).map_err(|e| mcap_error(&path, e))?;
        }
        w.flush().map_err(|e| mcap_error(&path, e))?;
        self.writer = Some(w);
        Ok(())
    }

    /// The name of the storage file being written.
    pub fn current_file(&self) -> &str {
        &self.current.name
    }

    /// Adds a topic (schema + channel). Adding the same spec twice is a no-op;
    /// the same topic with another type or definition is an error.
    pub fn add_topic(&mut self, spec: &TopicSpec) -> Result<()> {
        spec.validate().map_err(|e| e.within(&spec.topic))?;
        if let Some(c) = self.channels.get(&spec.topic) {
            if c.spec == *spec {
                return Ok(());
            }
            return Err(Error::invalid(
                spec.topic.clone(),
                format!(
                    "already recorded as {} with another definition or QoS",
                    c.spec.type_name
                ),
            ));
        }
        let path = self.path();
        let id = add_channel(self.writer()?, spec).map_err(|e| mcap_error(&path, e))?;
        self.channels.insert(
            spec.topic.clone(),
            Channel {
                id,
                spec: spec.clone(),
                count: 0,
            },
        );
        Ok(())
    }

    /// Writes a serialised message (CDR with its 4-byte header) on `topic`
    /// at `log_time_ns` (nanoseconds since the epoch).
    pub fn write_raw(&mut self, topic: &str, log_time_ns: u64, data: &[u8]) -> Result<()> {
        let Some(channel) = self.channels.get(topic) else {
            return Err(Error::invalid(topic, "topic not added to the bag"));
        };
        let header = mcap::records::MessageHeader {
            channel_id: channel.id,
            sequence: self.sequence.wrapping_add(1),
            log_time: log_time_ns,
            publish_time: log_time_ns,
        };
        let path = self.path();
        self.writer()?
            .write_to_known_channel(&header, data)
            .map_err(|e| mcap_error(&path, e))?;
        self.sequence = header.sequence;
        if let Some(channel) = self.channels.get_mut(topic) {
            channel.count += 1;
        }
        self.current.count(log_time_ns);
        Ok(())
    }

    /// Serialises `msg` to CDR and writes it.
    pub fn write<T: Serialize>(&mut self, topic: &str, log_time_ns: u64, msg: &T) -> Result<()> {
        let data = to_cdr(msg).map_err(|e| e.within(topic))?;
        self.write_raw(topic, log_time_ns, &data)
    }

    /// Finishes the current chunk and writes it to the file now (call after a
    /// unit of work, e.g. a job's outputs, so that it survives a crash).
    pub fn flush(&mut self) -> Result<()> {
        let path = self.path();
        self.writer()?.flush().map_err(|e| mcap_error(&path, e))
    }

    /// Writes metadata.yaml for what has been written so far, atomically (a
    /// temporary file renamed over it): a reader never sees half a file, and
    /// a bag whose writer is killed still has one that lists its storage file.
    pub fn write_metadata_yaml(&self) -> Result<()> {
        write_yaml_atomically(&self.directory, &self.metadata())
    }

    /// The rosbag2 metadata of what has been written so far.
    pub fn metadata(&self) -> BagMetadata {
        // A current file that could not be opened is not listed.
        let files: Vec<&StorageFile> = self
            .closed
            .iter()
            .chain((self.writer.is_some() || self.current.messages > 0).then_some(&self.current))
            .collect();
        let start = files.iter().filter_map(|f| f.first_time).min().unwrap_or(0);
        let end = files.iter().map(|f| f.last_time).max().unwrap_or(0);
        let messages: u64 = files.iter().map(|f| f.messages).sum();
        BagMetadata {
            version: metadata::VERSION,
            storage_identifier: "mcap".into(),
            duration: Nanoseconds {
                nanoseconds: end.saturating_sub(start),
            },
            starting_time: StartingTime {
                nanoseconds_since_epoch: start,
            },
            message_count: messages,
            topics_with_message_count: self
                .channels
                .values()
                .map(|c| TopicInformation {
                    topic_metadata: TopicMetadata {
                        name: c.spec.topic.clone(),
                        type_name: c.spec.type_name.clone(),
                        serialization_format: "cdr".into(),
                        offered_qos_profiles: vec![c.spec.qos.to_profile()],
                        type_description_hash: String::new(),
                    },
                    message_count: c.count,
                })
                .collect(),
            compression_format: String::new(),
            compression_mode: String::new(),
            relative_file_paths: files.iter().map(|f| f.name.clone()).collect(),
            files: files.iter().map(|f| f.information()).collect(),
            custom_data: BTreeMap::new(),
            ros_distro: "jazzy".into(),
        }
    }

    /// Writes the summary section, the `rosbag2` metadata record and metadata.yaml.
    pub fn finish(mut self) -> Result<BagSummary> {
        let meta = self.metadata();
        let path = self.path();
        let Some(mut w) = self.writer.take() else {
            // The files written so far stay readable through metadata.yaml.
            write_yaml_atomically(&self.directory, &meta)?;
            return Err(Error::io(
                path.display().to_string(),
                "the storage file could not be opened after a write error",
            ));
        };
        let mut record = BTreeMap::new();
        // The record holds the bare bagfile information, as rosbag2 does.
        record.insert(
            "serialized_metadata".to_string(),
            serde_yaml_ng::to_string(&meta).unwrap_or_default(),
        );
        record.insert("ROS_DISTRO".to_string(), "jazzy".to_string());
        w.write_metadata(&mcap::records::Metadata {
            name: "rosbag2".into(),
            metadata: record,
        })
        .map_err(|e| mcap_error(&path, e))?;
        let summary = w.finish().map_err(|e| mcap_error(&path, e))?;
        drop(w);
        write_yaml_atomically(&self.directory, &meta)?;
        let file_bytes = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
        Ok(BagSummary {
            directory: self.directory.clone(),
            mcap: path,
            messages: meta.message_count,
            chunks: summary.chunk_indexes.len(),
            file_bytes,
            uncompressed_bytes: summary
                .chunk_indexes
                .iter()
                .map(|c| c.uncompressed_size)
                .sum(),
        })
    }
}

/// Creates the storage file at `path` and its MCAP writer.
fn open_mcap(path: &Path, options: WriterOptions) -> Result<mcap::Writer<File>> {
    let file = File::create(path).map_err(|e| Error::io(path.display().to_string(), e))?;
    mcap::WriteOptions::new()
        .profile("ros2")
        .library(concat!("toolpath_planner ", env!("CARGO_PKG_VERSION")))
        .chunk_size(Some(options.chunk_size.max(1)))
        .compression(if options.compress {
            Some(mcap::Compression::Zstd)
        } else {
            None
        })
        .compression_level(options.compression_level)
        .compression_threads(0)
        .create(file)
        .map_err(|e| mcap_error(path, e))
}

/// Adds `spec`'s schema and channel (with rosbag2's channel metadata).
fn add_channel(w: &mut mcap::Writer<File>, spec: &TopicSpec) -> mcap::McapResult<u16> {
    let schema = w.add_schema(&spec.type_name, "ros2msg", spec.definition.as_bytes())?;
    let mut meta = BTreeMap::new();
    meta.insert(
        "offered_qos_profiles".to_string(),
        metadata::qos_yaml(spec.qos),
    );
    meta.insert("topic_type_hash".to_string(), String::new());
    w.add_channel(schema, &spec.topic, "cdr", &meta)
}

/// Writes `directory/metadata.yaml` through a temporary file and a rename.
fn write_yaml_atomically(directory: &Path, meta: &BagMetadata) -> Result<()> {
    let yaml_path = directory.join("metadata.yaml");
    let tmp = directory.join(".metadata.yaml.tmp");
    std::fs::write(&tmp, meta.to_yaml()).map_err(|e| Error::io(tmp.display().to_string(), e))?;
    std::fs::rename(&tmp, &yaml_path).map_err(|e| Error::io(yaml_path.display().to_string(), e))
}
