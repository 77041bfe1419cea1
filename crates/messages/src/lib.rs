//! The node's messages, below every edge that speaks them (the ROS node, the
//! bag recording and replay, the demo and bench clients): the ROS 2 message
//! structs with their .msg texts ([`RosMessage`], [`schema_text`]), the
//! conversions to and from the crate's formats ([`convert`]), the topic names
//! ([`topics`]) and the output messages of a planned job ([`job_outputs`]).
//!
//! Nothing here talks DDS or writes files: the node publishes these messages,
//! the recorder writes them into bags and replay compares them, so a bag and
//! a live node carry the same bytes for the same job.

pub mod convert;
pub mod diagnostics;
pub mod follow_joint_trajectory;
pub mod frames;
mod msgs;
pub mod outputs;
pub mod plan_toolpath;
pub mod topics;

pub use msgs::*;
pub use outputs::{final_state, job_outputs, JobOutputs};
