//! 2.5-axis pockets machined with tools chosen from the medial-axis transform
//! (docs/methods.md, "Medial-axis tool choice").
//!
//! - [`pocket_mat`]: the strategy: roughing, corner and root cleaning stages.
//! - [`tool_selection`]: the stage diameters from the medial axis, rounded to
//!   the catalogue.
//! - [`offset_passes`]: tool-centre paths as inward offsets of the outline.
//! - [`coverage`]: which medial points and walls the passes have machined, and
//!   the uncut area on a raster.

pub mod coverage;
pub mod offset_passes;
pub mod pocket_mat;
pub(crate) mod tool_selection;
