//! toolpath_planner: CNC toolpaths and tool-pose trajectories on freeform
//! surfaces, for a 5-axis mill and a 6-axis belt grinder, and 2.5-axis pockets.
//!
//! The work is done by the workspace's layer crates, each depending only on
//! those before it (Cargo checks it; docs/architecture.md, "Layers"):
//! 1. `toolpath_kernel`: errors, parallel maps, RNG, progress, geometry, tools
//! 2. `toolpath_formats` (files, STEP), `toolpath_samples`
//! 3. `toolpath_planners`, `toolpath_simulation`
//! 4. `toolpath_machines` (kinematics, timing), `toolpath_post` (NC programs)
//! 5. `toolpath_pipeline` (plan + verify + stats: what every edge calls)
//! 6. `toolpath_messages` (ROS 2 messages and a job's outputs)
//! 7. edges: `toolpath_ipc`, `toolpath_plot`, `toolpath_recording`, and
//!    `toolpath_node` above the recording
//!
//! This package is the top: the CLI (`cli`, binary `toolpath`). It
//! re-exports the layers under their module names, so that the integration
//! tests, benches and examples see one tree.

pub use toolpath_kernel::{error, geometry, parallel, progress, rng, tools};

pub use toolpath_formats as formats;
pub use toolpath_samples as samples;

pub use toolpath_planners as planners;
pub use toolpath_simulation as simulation;

pub use toolpath_machines as machines;
pub use toolpath_post as post;

pub use toolpath_pipeline as pipeline;

pub use toolpath_messages as messages;

pub use toolpath_ipc as ipc;
pub use toolpath_node as ros;
pub use toolpath_plot as plot;
pub use toolpath_recording as recording;

pub mod cli;

pub use error::{Error, Result};
