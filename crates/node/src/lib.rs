//! The ROS 2 node (ros2-client, pure Rust): a thin adapter over
//! [`toolpath_pipeline::run`] that speaks the messages of [`toolpath_messages`].
//! `node` is the runtime (and the DDS helpers the clients share), `config`
//! the launch-config file, `recorder` the bag of a run, `republish` the
//! replay of a bag's inputs to a running node, `ros_args` the `--ros-args`
//! block, `parameters` the config as ROS parameters, `logging` the log on
//! stderr and `/rosout`, `shape_readers` the QoS-tolerant shape inputs, `diagnostics` the
//! node's health on `/diagnostics`, `security` DDS Security from an SROS2 enclave.

pub mod config;
pub mod dds;
pub mod diagnostics;
pub mod execute;
pub mod fake_controller;
pub mod joint_states;
mod journal;
pub mod logging;
pub mod node;
pub mod parameter_descriptors;
pub mod parameters;
pub mod plan_action;
pub mod qos;
pub mod recorder;
pub mod republish;
pub mod ros_args;
pub mod security;
pub mod shape_readers;
pub mod tf_static;

pub use config::NodeConfig;
