//! Recording runs as rosbag2 bags (MCAP storage) and reading them back.
//!
//! A bag is a directory `NAME/` with `NAME_0.mcap` and a rosbag2
//! `metadata.yaml` (format version 9, the one `ros2 bag` in Jazzy writes).
//! The MCAP file follows rosbag2's MCAP storage plugin: profile `ros2`,
//! schemas `pkg/msg/Type` in `ros2msg` encoding with every nested definition
//! appended, messages `cdr` (4-byte encapsulation header + CDR body, the
//! serializer ros2-client uses), channel metadata `offered_qos_profiles` (the
//! YAML text rosbag2 writes) and `topic_type_hash`, and a `rosbag2` metadata
//! record. Chunks are zstd-compressed and written straight to the file as they
//! complete, so a writer killed mid-run leaves its completed chunks readable.
//!
//! This module is generic over topics: a [`TopicSpec`] names the topic, its
//! type, its full definition text and its QoS. The node's message structs and
//! their .msg texts live in [`toolpath_messages`]; [`runs`] records and replays
//! the node's jobs with them. Republishing a bag to a live node is DDS, so it
//! lives with the node (`toolpath_node::republish`).

mod metadata;
mod reader;
pub mod reindex;
pub mod runs;
mod writer;

pub use metadata::{BagMetadata, FileInformation, TopicInformation, TopicMetadata};
pub use reader::{read_bag, Bag, RecordedMessage, RecordedTopic};
pub use writer::{now_ns, BagSummary, BagWriter, WriterOptions};

use serde::de::DeserializeOwned;
use serde::Serialize;
use toolpath_kernel::error::{Error, Result};

/// CDR encapsulation header for little-endian plain CDR (what ROS 2 sends).
pub const CDR_LE_HEADER: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// The `ros2msg` separator line between a definition and a nested one.
pub const DEFINITION_SEPARATOR: &str =
    "================================================================================";

/// Reliability QoS policy.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reliability {
    Reliable,
    BestEffort,
}

/// Durability QoS policy.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Durability {
    Volatile,
    TransientLocal,
}

/// The QoS a topic was offered with (history is keep-last `depth`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Qos {
    pub reliability: Reliability,
    pub durability: Durability,
    pub depth: u32,
}

impl Qos {
    /// rclpy's default: reliable, volatile, keep-last 10.
    pub const DEFAULT: Qos = Qos {
        reliability: Reliability::Reliable,
        durability: Durability::Volatile,
        depth: 10,
    };

    pub fn reliable_volatile(depth: u32) -> Self {
        Qos {
            reliability: Reliability::Reliable,
            durability: Durability::Volatile,
            depth,
        }
    }

    pub fn reliable_transient_local(depth: u32) -> Self {
        Qos {
            reliability: Reliability::Reliable,
            durability: Durability::TransientLocal,
            depth,
        }
    }

    /// The profile as rosbag2 (metadata version 9) writes it.
    pub fn to_profile(self) -> metadata::QosProfile {
        metadata::QosProfile::from_qos(self)
    }
}

/// One recorded topic: name (absolute, e.g. `/job`), type (`pkg/msg/Type`),
/// the full `ros2msg` definition (nested definitions appended) and the QoS it
/// was offered with.
#[derive(Clone, Debug, PartialEq)]
pub struct TopicSpec {
    pub topic: String,
    pub type_name: String,
    pub definition: String,
    pub qos: Qos,
}

impl TopicSpec {
    pub fn new(topic: &str, type_name: &str, definition: &str, qos: Qos) -> Self {
        TopicSpec {
            topic: topic.to_string(),
            type_name: type_name.to_string(),
            definition: definition.to_string(),
            qos,
        }
    }

    /// Checks the names rosbag2 and the readers rely on.
    pub fn validate(&self) -> Result<()> {
        if !self.topic.starts_with('/')
            || self.topic.len() < 2
            || self.topic.contains(char::is_whitespace)
        {
            return Err(Error::invalid(
                "topic",
                format!("\"{}\" is not an absolute ROS topic name", self.topic),
            ));
        }
        let parts: Vec<&str> = self.type_name.split('/').collect();
        if parts.len() != 3
            || !matches!(parts[1], "msg" | "action")
            || parts.iter().any(|p| p.is_empty())
        {
            return Err(Error::invalid(
                "type_name",
                format!(
                    "\"{}\" is not of the form pkg/msg/Type (or pkg/action/Type)",
                    self.type_name
                ),
            ));
        }
        if self.definition.trim().is_empty() {
            return Err(Error::invalid(
                "definition",
                format!("empty definition for {}", self.type_name),
            ));
        }
        Ok(())
    }
}

/// `pkg/Type` -> `pkg/msg/Type` (names in schemas and metadata carry `/msg/`).
pub fn ros2_type_name(short: &str) -> String {
    match short.split_once('/') {
        Some((pkg, ty)) if !ty.contains('/') => format!("{pkg}/msg/{ty}"),
        _ => short.to_string(),
    }
}

/// Serialises `msg` as ROS 2 sends it: encapsulation header + little-endian CDR.
pub fn to_cdr<T: Serialize>(msg: &T) -> Result<Vec<u8>> {
    let body = cdr_encoding::to_vec::<T, byteorder::LittleEndian>(msg)
        .map_err(|e| Error::invalid("message", format!("CDR serialisation failed: {e}")))?;
    let mut out = Vec::with_capacity(body.len() + 4);
    out.extend_from_slice(&CDR_LE_HEADER);
    out.extend_from_slice(&body);
    Ok(out)
}

/// Decodes a CDR payload (with its encapsulation header, either byte order).
pub fn from_cdr<T: DeserializeOwned>(data: &[u8]) -> Result<T> {
    let Some((header, body)) = data.split_first_chunk::<4>() else {
        return Err(Error::invalid(
            "",
            format!("{} bytes is too short for a CDR message", data.len()),
        ));
    };
    let decoded = match header[..2] {
        [0x00, 0x01] => cdr_encoding::from_bytes::<T, byteorder::LittleEndian>(body),
        [0x00, 0x00] => cdr_encoding::from_bytes::<T, byteorder::BigEndian>(body),
        _ => {
            return Err(Error::invalid(
                "",
                format!(
                    "unsupported CDR encapsulation {:02x} {:02x}",
                    header[0], header[1]
                ),
            ))
        }
    };
    let (value, used) =
        decoded.map_err(|e| Error::invalid("", format!("CDR decoding failed: {e}")))?;
    // CDR pads to 4 bytes at most at the end; more left over means a wrong type.
    if body.len() > used + 3 {
        return Err(Error::invalid(
            "",
            format!(
                "{} bytes left over after decoding: the message is not of this type",
                body.len() - used
            ),
        ));
    }
    Ok(value)
}

/// A definition without comments, blank lines and surplus spaces: two texts
/// that describe the same fields compare equal.
pub fn normalize_definition(text: &str) -> String {
    text.lines()
        .map(|l| {
            let l = match l.find('#') {
                // `#` inside a string constant default is rare in our messages; keep it simple.
                Some(i) => &l[..i],
                None => l,
            };
            l.split_whitespace().collect::<Vec<_>>().join(" ")
        })
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;
    use toolpath_messages::plan_toolpath::{Feedback, FeedbackMessage};
    use toolpath_messages::Uuid;

    #[test]
    fn a_feedback_message_is_sixteen_goal_id_bytes_then_the_feedback() {
        let msg = FeedbackMessage {
            goal_id: Uuid {
                uuid: std::array::from_fn(|i| i as u8 + 1),
            },
            feedback: Feedback {
                stage: "planning".into(),
                progress: 0.5,
                eta_s: 2.5,
            },
        };
        let bytes = to_cdr(&msg).unwrap();
        // Header, 16 id bytes, then the string's length (9 with its NUL).
        assert_eq!(&bytes[4..20], &msg.goal_id.uuid);
        assert_eq!(&bytes[20..24], &9u32.to_le_bytes());
        assert_eq!(&bytes[24..33], b"planning\0");
        assert_eq!(from_cdr::<FeedbackMessage>(&bytes).unwrap(), msg);
    }
}
