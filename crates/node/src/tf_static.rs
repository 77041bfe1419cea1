//! `/tf_static`: the node's frames (`toolpath_messages::frames`) as tf2's
//! static broadcaster publishes them: reliable, transient-local, keep last 1,
//! so a listener that starts later still receives the tree.

use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::ros2::QosProfile;
use ros2_client::{MessageTypeName, Name, Node, Publisher};
use std::time::Duration;
use toolpath_kernel::error::{Error, Result};
use toolpath_messages::frames::{Frames, TfMessage};
use toolpath_messages::{Header, RosMessage, Time};

pub const TOPIC: &str = "/tf_static";

/// tf2_ros::StaticTransformBroadcaster's QoS.
pub fn qos() -> QosProfile {
    QosProfile::subscription_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_millis(100)))
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
}

/// Publishes `frames` once on `/tf_static`; the returned publisher keeps the
/// message for late listeners as long as it lives.
pub fn publish(node: &mut Node, frames: &Frames) -> Result<Publisher<TfMessage>> {
    let name =
        Name::new("/", "tf_static").map_err(|e| Error::dds(format!("topic {TOPIC}: {e:?}")))?;
    let topic = node
        .create_topic(
            &name,
            MessageTypeName::new(TfMessage::PACKAGE, TfMessage::NAME),
            &qos(),
        )
        .map_err(|e| Error::dds(format!("cannot create topic {TOPIC}: {e:?}")))?;
    let publisher = node
        .create_publisher(&topic, Some(qos()))
        .map_err(|e| Error::dds(format!("cannot publish on {TOPIC}: {e:?}")))?;
    let stamp = Header {
        stamp: Time::now(),
        frame_id: String::new(),
    };
    publisher
        .publish(frames.tf_static(&stamp))
        .map_err(|e| Error::dds(format!("cannot publish on {TOPIC}: {e:?}")))?;
    Ok(publisher)
}
