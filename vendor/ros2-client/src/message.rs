//! Defines [`Message`] trait, which defines data that is to be sent over
//! Topics.

use serde::{Serialize, de::DeserializeOwned};

/// Trait to ensure Messages can be (de)serialized
pub trait Message: Serialize + DeserializeOwned {}

/// Every (de)serializable type is a message, so that message types defined in
/// a crate that does not depend on ros2-client can be used in actions.
impl<T: Serialize + DeserializeOwned> Message for T {}
