//! Simulation: the scallop (residual height) simulator shared by every
//! milling planner's tests and stats, and the belt-grinding material-removal
//! simulation. Depends on geometry, tools, formats and planners' results only.

pub mod removal;
pub mod scallop;
