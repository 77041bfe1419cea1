//! rosbag2 `metadata.yaml`, format version 9 (rosbag2_storage/yaml.hpp and
//! qos.cpp: QoS policies as strings, `offered_qos_profiles` a YAML list in the
//! metadata file and the YAML text of that list in MCAP channel metadata).

use super::{Durability, Qos, Reliability};
use serde::{Deserialize, Serialize};
use std::path::Path;
use toolpath_kernel::error::{Error, Result};

/// rosbag2's `rmw_time_t`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct RmwTime {
    pub sec: i64,
    pub nsec: u64,
}

/// "No deadline / lifespan / lease" as rosbag2 writes it: rmw's
/// RMW_DURATION_INFINITE, i64::MAX nanoseconds split into seconds and
/// nanoseconds. rosbag2 turns the older per-vendor values back into this one
/// on playback, so a bag that carries it replays with any RMW.
pub const INFINITE: RmwTime = RmwTime {
    sec: 9_223_372_036,
    nsec: 854_775_807,
};

/// One offered QoS profile as rosbag2 writes it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct QosProfile {
    pub history: String,
    pub depth: u64,
    pub reliability: String,
    pub durability: String,
    pub deadline: RmwTime,
    pub lifespan: RmwTime,
    pub liveliness: String,
    pub liveliness_lease_duration: RmwTime,
    pub avoid_ros_namespace_conventions: bool,
}

impl QosProfile {
    pub fn from_qos(q: Qos) -> Self {
        QosProfile {
            history: "keep_last".into(),
            depth: q.depth as u64,
            reliability: match q.reliability {
                Reliability::Reliable => "reliable",
                Reliability::BestEffort => "best_effort",
            }
            .into(),
            durability: match q.durability {
                Durability::Volatile => "volatile",
                Durability::TransientLocal => "transient_local",
            }
            .into(),
            deadline: INFINITE,
            lifespan: INFINITE,
            liveliness: "automatic".into(),
            liveliness_lease_duration: INFINITE,
            avoid_ros_namespace_conventions: false,
        }
    }
}

/// The YAML text rosbag2 stores in the `offered_qos_profiles` channel metadata.
pub fn qos_yaml(q: Qos) -> String {
    serde_yaml_ng::to_string(&vec![QosProfile::from_qos(q)]).unwrap_or_default()
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Nanoseconds {
    pub nanoseconds: u64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct StartingTime {
    pub nanoseconds_since_epoch: u64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TopicMetadata {
    pub name: String,
    #[serde(rename = "type")]
    pub type_name: String,
    pub serialization_format: String,
    pub offered_qos_profiles: Vec<QosProfile>,
    pub type_description_hash: String,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TopicInformation {
    pub topic_metadata: TopicMetadata,
    pub message_count: u64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FileInformation {
    pub path: String,
    pub starting_time: StartingTime,
    pub duration: Nanoseconds,
    pub message_count: u64,
}

/// `rosbag2_bagfile_information` of metadata.yaml.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BagMetadata {
    pub version: u32,
    pub storage_identifier: String,
    pub duration: Nanoseconds,
    pub starting_time: StartingTime,
    pub message_count: u64,
    pub topics_with_message_count: Vec<TopicInformation>,
    pub compression_format: String,
    pub compression_mode: String,
    pub relative_file_paths: Vec<String>,
    pub files: Vec<FileInformation>,
    pub custom_data: std::collections::BTreeMap<String, String>,
    pub ros_distro: String,
}

#[derive(Serialize, Deserialize)]
struct MetadataFile {
    rosbag2_bagfile_information: BagMetadata,
}

/// The metadata format version written.
pub const VERSION: u32 = 9;

impl BagMetadata {
    pub fn to_yaml(&self) -> String {
        serde_yaml_ng::to_string(&MetadataFile {
            rosbag2_bagfile_information: self.clone(),
        })
        .unwrap_or_default()
    }

    /// Reads metadata.yaml; errors name the field.
    pub fn read(path: &Path) -> Result<Self> {
        let text = toolpath_formats::read_text(path)?;
        let de = serde_yaml_ng::Deserializer::from_str(&text);
        let file: MetadataFile = serde_path_to_error::deserialize(de).map_err(|e| {
            Error::invalid(
                format!("{}: {}", path.display(), e.path()),
                format!("not a rosbag2 metadata file: {}", e.inner()),
            )
        })?;
        let m = file.rosbag2_bagfile_information;
        if m.version < 9 {
            return Err(Error::invalid(
                format!("{}: rosbag2_bagfile_information.version", path.display()),
                format!(
                    "metadata version {} is not supported (this reader reads version 9)",
                    m.version
                ),
            ));
        }
        if m.storage_identifier != "mcap" {
            return Err(Error::invalid(
                format!(
                    "{}: rosbag2_bagfile_information.storage_identifier",
                    path.display()
                ),
                format!(
                    "storage \"{}\" is not supported (only mcap)",
                    m.storage_identifier
                ),
            ));
        }
        Ok(m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn infinite_durations_are_rmw_duration_infinite() {
        // RMW_DURATION_INFINITE is i64::MAX nanoseconds.
        let ns = INFINITE.sec as i128 * 1_000_000_000 + INFINITE.nsec as i128;
        assert_eq!(ns, i64::MAX as i128);
        const { assert!(INFINITE.nsec < 1_000_000_000) };
        let yaml = qos_yaml(Qos::reliable_transient_local(10));
        assert_eq!(yaml.matches("sec: 9223372036\n").count(), 3, "{yaml}");
        assert_eq!(yaml.matches("nsec: 854775807\n").count(), 3, "{yaml}");
    }
}
