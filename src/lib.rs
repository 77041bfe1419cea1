//! toolpath_planner: CNC toolpaths and tool-pose trajectories on freeform
//! surfaces, for a 5-axis mill and a 6-axis belt grinder, and 2.5-axis pockets.
//!
//! Layers, each depending only on those listed before it:
//! 1. `error`, `parallel` (deterministic chunked threads), `geometry` (NURBS,
//!    differential geometry, pockets), `tools`
//! 2. `formats` (surface, pocket, job and result files), `samples`
//! 3. `planners` (one module per method)
//! 4. `simulation` (scallop simulator, material removal)
//! 5. `machines` (kinematics, timed joint trajectories)
//! 6. `pipeline` (plan + verify + stats: what every edge calls), `post` (NC
//!    programs from results)
//! 7. `messages` (the node's ROS 2 messages, their conversions, topic names
//!    and the output messages of a planned job: what the node and the bags share)
//! 8. edges: `ipc` (iceoryx2), `plot` and `recording` (MCAP bags), none of
//!    which uses another; above them `ros` (the node, which records into
//!    bags); above all `cli`
//!
//! Nothing in layers 1-7 imports from an edge, and an edge imports only edges
//! below it (checked by tests/layering.rs).

pub mod error;
pub mod geometry;
pub mod parallel;
pub mod tools;

pub mod formats;
pub mod samples;

pub mod planners;

pub mod simulation;

pub mod machines;

pub mod pipeline;
pub mod post;

pub mod messages;

pub mod ipc;
pub mod plot;
pub mod recording;
pub mod ros;

pub mod cli;

pub use error::{Error, Result};
