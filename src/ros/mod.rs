//! The ROS 2 node (ros2-client, pure Rust): a thin adapter over
//! [`crate::pipeline::run`]. `msgs` holds the message structs and their .msg
//! texts, `convert` maps messages to the crate's formats and back, `node` is
//! the runtime, `config` the launch-config file, `recorder` the bag of a run.

pub mod config;
pub mod convert;
pub mod msgs;
pub mod node;
pub mod recorder;

pub use config::NodeConfig;
