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
//! 7. edges: `cli`, `ros` (the node), `recording` (MCAP), `ipc` (iceoryx2), `plot`
//!
//! Nothing in layers 1-5 imports from `ros`, `recording`, `ipc`, `plot` or `cli`
//! (checked by tests/layering.rs).

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

pub mod cli;
pub mod ipc;
pub mod plot;
pub mod recording;
pub mod ros;

pub use error::{Error, Result};
