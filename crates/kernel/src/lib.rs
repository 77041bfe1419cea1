//! The kernel of toolpath_planner: the one error type, deterministic
//! parallel maps, seeded random numbers, progress reporting, roots and
//! minima of functions of one variable, surface geometry (NURBS, differential
//! geometry, curves, pockets) and the tools.
//!
//! It depends on no other crate of the workspace and on no transport: the
//! planners, simulators and machines build on it.

pub mod error;
pub mod geometry;
pub mod numeric;
pub mod parallel;
pub mod progress;
pub mod rng;
pub mod tools;
pub mod validate;

pub use error::{Error, Result};
