//! Shared pieces of the 2.5-axis pocket planners: tool sizes from the
//! catalogue, offset tool-centre paths, and swept-area bookkeeping.

pub mod coverage;
pub mod offset_passes;
pub mod tool_selection;
