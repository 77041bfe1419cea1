//! The bag reader: a bag directory (metadata.yaml, or the .mcap files in it)
//! or a bare .mcap; a truncated file gives the messages of its completed
//! chunks and says where it stopped.

use super::metadata::BagMetadata;
use super::{from_cdr, normalize_definition, TopicSpec};
use serde::de::DeserializeOwned;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use toolpath_kernel::error::{Error, Result};

/// A topic as recorded.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordedTopic {
    pub topic: String,
    pub type_name: String,
    pub schema_encoding: String,
    pub definition: String,
    pub message_encoding: String,
    pub offered_qos_profiles: String,
    pub message_count: u64,
}

/// One recorded message (CDR payload with its encapsulation header).
#[derive(Clone, Debug, PartialEq)]
pub struct RecordedMessage {
    pub topic: String,
    pub log_time: u64,
    pub sequence: u32,
    pub data: Vec<u8>,
}

/// A bag read into memory, messages in file order.
#[derive(Clone, Debug)]
pub struct Bag {
    /// The .mcap file(s) read.
    pub files: Vec<PathBuf>,
    pub metadata: Option<BagMetadata>,
    pub topics: BTreeMap<String, RecordedTopic>,
    pub messages: Vec<RecordedMessage>,
    /// Why reading stopped early (truncated or damaged file), if it did.
    pub truncated: Option<String>,
}

const MAGIC: &[u8] = b"\x89MCAP0\r\n";

/// Opens a bag directory or a .mcap file.
pub fn read_bag(path: &Path) -> Result<Bag> {
    let shown = path.display().to_string();
    if !path.exists() {
        return Err(Error::io(
            &shown,
            "no such bag (expected a bag directory or a .mcap file)",
        ));
    }
    let (files, metadata) = if path.is_dir() {
        let meta_path = path.join("metadata.yaml");
        if meta_path.exists() {
            let m = BagMetadata::read(&meta_path)?;
            let files: Vec<PathBuf> = m.relative_file_paths.iter().map(|f| path.join(f)).collect();
            if files.is_empty() {
                return Err(Error::invalid(
                    format!(
                        "{}: rosbag2_bagfile_information.relative_file_paths",
                        meta_path.display()
                    ),
                    "lists no storage file",
                ));
            }
            (files, Some(m))
        } else {
            // A bag whose writer was killed has no metadata.yaml yet: read its files.
            let mut files: Vec<PathBuf> = std::fs::read_dir(path)
                .map_err(|e| Error::io(&shown, e))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "mcap"))
                .collect();
            files.sort();
            if files.is_empty() {
                return Err(Error::invalid(
                    shown,
                    "not a bag: the directory has neither metadata.yaml nor a .mcap file",
                ));
            }
            (files, None)
        }
    } else {
        (vec![path.to_path_buf()], None)
    };
    let mut bag = Bag {
        files: files.clone(),
        metadata,
        topics: BTreeMap::new(),
        messages: Vec::new(),
        truncated: None,
    };
    // A damaged file does not hide the files after it: a recorder that hit
    // a write error goes on in a new file (a split).
    let mut notes = Vec::new();
    for file in &files {
        read_mcap(file, &mut bag)?;
        notes.extend(bag.truncated.take());
    }
    bag.truncated = (!notes.is_empty()).then(|| notes.join("; "));
    Ok(bag)
}

/// Largest bag file read, bytes: the whole file is held in memory.
pub const MAX_BAG_BYTES: u64 = 4 << 30;

/// Largest uncompressed chunk accepted, bytes.
pub const MAX_CHUNK_BYTES: u64 = 1 << 30;

/// MCAP record opcode of a chunk.
const CHUNK_OPCODE: u8 = 0x06;

/// The first chunk the mcap reader must not see, with why: the reader
/// reserves the sizes a chunk and the records in it claim before reading
/// them, so a damaged size field would abort the process. Walks the
/// top-level records (opcode, u64 length) as the reader does. Damaged: a
/// chunk claiming more than [`MAX_CHUNK_BYTES`] uncompressed (a writer that
/// hit a full disk leaves its placeholder, all ones), a record in a chunk
/// reaching past the chunk's claimed size, a whole chunk that does not
/// decompress to that size. A chunk cut short by the end of the file is
/// checked as far as it goes.
fn first_damaged_chunk(bytes: &[u8]) -> Option<(usize, String)> {
    let mut at = MAGIC.len();
    while let (Some(&opcode), Some(len)) = (bytes.get(at), le_u64(bytes, at + 1)) {
        let body = at + 9;
        let end = usize::try_from(len).ok().and_then(|l| body.checked_add(l));
        if opcode == CHUNK_OPCODE {
            let whole = end.and_then(|e| bytes.get(body..e));
            let chunk = whole.unwrap_or_else(|| bytes.get(body..).unwrap_or(&[]));
            if let Err(why) = check_chunk(chunk, whole.is_some()) {
                return Some((at, why));
            }
        }
        match end {
            Some(e) if e <= bytes.len() => at = e,
            _ => return None,
        }
    }
    None
}

fn le_u64(bytes: &[u8], at: usize) -> Option<u64> {
    Some(u64::from_le_bytes(bytes.get(at..at + 8)?.try_into().ok()?))
}

fn le_u32(bytes: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(bytes.get(at..at + 4)?.try_into().ok()?))
}

/// One chunk's body (`whole`: not cut by the end of the file): start and
/// end time, uncompressed size and CRC, the compression name, the
/// (compressed) records.
fn check_chunk(chunk: &[u8], whole: bool) -> std::result::Result<(), String> {
    // A header cut by the end of the file leaves nothing for the reader to reserve.
    let cut_short = |what: &str| {
        if whole {
            Err(format!("its {what} cut short"))
        } else {
            Ok(())
        }
    };
    let Some(size) = le_u64(chunk, 16) else {
        return cut_short("header is");
    };
    if size > MAX_CHUNK_BYTES {
        return Err(format!(
            "it claims {size} bytes uncompressed (more than {MAX_CHUNK_BYTES})"
        ));
    }
    let Some(name_len) = le_u32(chunk, 28).map(|n| n as usize) else {
        return cut_short("compression name is");
    };
    let Some(name) = chunk.get(32..32 + name_len) else {
        return cut_short("compression name is");
    };
    let records_at = 32 + name_len;
    let Some(records_len) = le_u64(chunk, records_at) else {
        return cut_short("records are");
    };
    let from = records_at + 8;
    let records = match usize::try_from(records_len)
        .ok()
        .and_then(|l| from.checked_add(l))
    {
        Some(to) if to <= chunk.len() => &chunk[from..to],
        _ if whole => return Err("its records run past its end".into()),
        _ => &chunk[from.min(chunk.len())..],
    };
    // Read at most one byte more than claimed: enough to tell it is longer.
    let limit = size + 1;
    let mut plain = Vec::new();
    let decoded = match name {
        b"" => {
            plain.extend_from_slice(&records[..records.len().min(limit as usize)]);
            Ok(())
        }
        b"zstd" => zstd::stream::read::Decoder::new(records)
            .and_then(|d| {
                std::io::Read::read_to_end(&mut std::io::Read::take(d, limit), &mut plain)
            })
            .map(|_| ())
            .map_err(|e| format!("zstd: {e}")),
        b"lz4" => lz4::Decoder::new(records)
            .and_then(|d| {
                std::io::Read::read_to_end(&mut std::io::Read::take(d, limit), &mut plain)
            })
            .map(|_| ())
            .map_err(|e| format!("lz4: {e}")),
        // Unknown compression: the reader refuses it by name.
        _ => return Ok(()),
    };
    if whole {
        decoded?;
        if plain.len() as u64 != size {
            return Err(format!(
                "it holds {} bytes uncompressed, not the {size} it claims",
                plain.len()
            ));
        }
    }
    let mut at = 0usize;
    while let Some(len) = le_u64(&plain, at + 1) {
        at = usize::try_from(len)
            .ok()
            .and_then(|l| (at + 9).checked_add(l))
            .filter(|&end| end as u64 <= size)
            .ok_or_else(|| {
                format!("the record at offset {at} claims {len} bytes, past the chunk's end")
            })?;
    }
    if whole && at != plain.len() {
        return Err(format!("a record header at offset {at} is cut short"));
    }
    Ok(())
}

/// Schemas and channels of an MCAP file by id, as its records arrive (the
/// summary section repeats them).
#[derive(Default)]
struct Records {
    schemas: BTreeMap<u16, (String, String, String)>,
    channels: BTreeMap<u16, String>,
}

impl Records {
    /// Takes one record of `shown` into `bag`: a schema, a channel (a topic
    /// of the bag) or a message.
    fn take(&mut self, record: mcap::records::Record, bag: &mut Bag, shown: &str) -> Result<()> {
        match record {
            mcap::records::Record::Schema { header, data } => {
                let text = String::from_utf8(data.into_owned()).map_err(|_| {
                    Error::invalid(
                        format!("{shown}: schema {}", header.name),
                        "the definition is not UTF-8 text",
                    )
                })?;
                self.schemas
                    .insert(header.id, (header.name, header.encoding, text));
            }
            mcap::records::Record::Channel(c) => {
                let (type_name, schema_encoding, definition) =
                    self.schemas.get(&c.schema_id).cloned().ok_or_else(|| {
                        Error::invalid(
                            format!("{shown}: {}", c.topic),
                            format!("channel refers to unknown schema {}", c.schema_id),
                        )
                    })?;
                let qos = c
                    .metadata
                    .get("offered_qos_profiles")
                    .cloned()
                    .unwrap_or_default();
                self.channels.insert(c.id, c.topic.clone());
                bag.topics.entry(c.topic.clone()).or_insert(RecordedTopic {
                    topic: c.topic,
                    type_name,
                    schema_encoding,
                    definition,
                    message_encoding: c.message_encoding,
                    offered_qos_profiles: qos,
                    message_count: 0,
                });
            }
            mcap::records::Record::Message { header, data } => {
                let topic = self
                    .channels
                    .get(&header.channel_id)
                    .cloned()
                    .ok_or_else(|| {
                        Error::invalid(
                            shown,
                            format!(
                                "message {} on unknown channel {}",
                                header.sequence, header.channel_id
                            ),
                        )
                    })?;
                if let Some(t) = bag.topics.get_mut(&topic) {
                    t.message_count += 1;
                }
                bag.messages.push(RecordedMessage {
                    topic,
                    log_time: header.log_time,
                    sequence: header.sequence,
                    data: data.into_owned(),
                });
            }
            _ => {}
        }
        Ok(())
    }
}

fn read_mcap(path: &Path, bag: &mut Bag) -> Result<()> {
    let shown = path.display().to_string();
    let bytes = toolpath_formats::read_file_limited(path, MAX_BAG_BYTES)?;
    if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
        return Err(Error::invalid(
            shown,
            "not an MCAP file (no MCAP magic at the start)",
        ));
    }
    // The reader gets the file up to its first damaged chunk, as if it were
    // cut there, and recovers what comes before.
    let damaged = first_damaged_chunk(&bytes);
    let usable = damaged.as_ref().map_or(&bytes[..], |(at, _)| &bytes[..*at]);
    let complete = damaged.is_none() && bytes.len() >= 2 * MAGIC.len() && bytes.ends_with(MAGIC);
    let reader = mcap::read::ChunkFlattener::new_with_options(
        usable,
        mcap::read::Options::IgnoreEndMagic.into(),
    )
    .map_err(|e| Error::invalid(&shown, format!("cannot read MCAP: {e}")))?;
    let mut records = Records::default();
    let before = bag.messages.len();
    for record in reader {
        let record = match record {
            Ok(r) => r,
            Err(e) => {
                let read = bag.messages.len() - before;
                let why = if complete {
                    format!("{shown} is damaged ({e}) after {read} messages")
                } else {
                    format!("{shown} is truncated ({e}); {read} messages of its completed chunks recovered")
                };
                if read == 0 && bag.topics.is_empty() {
                    return Err(Error::invalid(
                        shown,
                        format!("no complete chunk could be read: {e}"),
                    ));
                }
                bag.truncated = Some(why);
                break;
            }
        };
        records.take(record, bag, &shown)?;
    }
    if let Some((at, why)) = damaged {
        let read = bag.messages.len() - before;
        if read == 0 && bag.topics.is_empty() {
            return Err(Error::invalid(
                shown,
                format!("the chunk at byte {at} is damaged ({why}) and nothing precedes it"),
            ));
        }
        bag.truncated = Some(format!(
            "{shown} is damaged from the chunk at byte {at} ({why}); {read} messages before it recovered"
        ));
    } else if !complete && bag.truncated.is_none() {
        let read = bag.messages.len() - before;
        bag.truncated = Some(format!(
            "{shown} is truncated (no footer); {read} messages of its completed chunks recovered"
        ));
    }
    Ok(())
}

impl Bag {
    /// Messages on `topic`, in order.
    pub fn messages_on<'a>(
        &'a self,
        topic: &'a str,
    ) -> impl Iterator<Item = &'a RecordedMessage> + 'a {
        self.messages.iter().filter(move |m| m.topic == topic)
    }

    /// Checks that `topic`, if recorded, has the expected type, encodings and
    /// definition (comments and spacing aside).
    pub fn check_topic(&self, spec: &TopicSpec) -> Result<()> {
        let Some(t) = self.topics.get(&spec.topic) else {
            return Ok(());
        };
        if t.type_name != spec.type_name {
            return Err(Error::invalid(
                spec.topic.clone(),
                format!(
                    "recorded with type {}, expected {}",
                    t.type_name, spec.type_name
                ),
            ));
        }
        if t.schema_encoding != "ros2msg" {
            return Err(Error::invalid(
                spec.topic.clone(),
                format!(
                    "schema encoding \"{}\", expected ros2msg",
                    t.schema_encoding
                ),
            ));
        }
        if t.message_encoding != "cdr" {
            return Err(Error::invalid(
                spec.topic.clone(),
                format!("message encoding \"{}\", expected cdr", t.message_encoding),
            ));
        }
        let (a, b) = (
            normalize_definition(&t.definition),
            normalize_definition(&spec.definition),
        );
        if a != b {
            let line = a
                .lines()
                .zip(b.lines())
                .position(|(x, y)| x != y)
                .unwrap_or(a.lines().count().min(b.lines().count()));
            return Err(Error::invalid(
                spec.topic.clone(),
                format!(
                    "the recorded schema of {} differs from this build's definition (first difference at field line {}: recorded \"{}\", expected \"{}\")",
                    t.type_name,
                    line + 1,
                    a.lines().nth(line).unwrap_or("<end>"),
                    b.lines().nth(line).unwrap_or("<end>")
                ),
            ));
        }
        Ok(())
    }

    /// Checks every recorded topic against `known`: unknown topics or types
    /// and mismatching schemas are errors.
    pub fn check_types(&self, known: &[TopicSpec]) -> Result<()> {
        for t in self.topics.values() {
            match known.iter().find(|k| k.topic == t.topic) {
                Some(spec) => self.check_topic(spec)?,
                None => {
                    return Err(Error::invalid(
                        t.topic.clone(),
                        format!(
                            "unknown topic of type {} (this build knows {})",
                            t.type_name,
                            known
                                .iter()
                                .map(|k| k.topic.as_str())
                                .collect::<Vec<_>>()
                                .join(", ")
                        ),
                    ))
                }
            }
        }
        Ok(())
    }

    /// Decodes message `index` of the bag as `T` (after checking its topic against `spec`).
    pub fn decode<T: DeserializeOwned>(&self, index: usize, spec: &TopicSpec) -> Result<T> {
        let m = self
            .messages
            .get(index)
            .ok_or_else(|| Error::invalid("", format!("no message {index} in the bag")))?;
        if m.topic != spec.topic {
            return Err(Error::invalid(
                m.topic.clone(),
                format!("message {index} is on {}, not {}", m.topic, spec.topic),
            ));
        }
        self.check_topic(spec)?;
        from_cdr(&m.data).map_err(|e| {
            e.within(&format!(
                "{}[message {index}, sequence {}]",
                m.topic, m.sequence
            ))
        })
    }
}
