//! Mid-point error control (MPEC) positioning of a torus cutter for 5-axis
//! finishing (docs/methods.md, "MPEC: error curve and lead").
//!
//! - [`error_curve`]: the error across the strip of a torus posed at a drive
//!   point with a given lead, from the cutter's spheres evaluated at their own
//!   feed coordinate; the lead search that puts the middle of the "W" at
//!   +delta and its dips at -delta.
//! - [`positioning`]: the strategy: drive points along iso-parametric passes,
//!   each positioned by the error curve, passes spaced so that neighbouring
//!   strips meet within the band.

pub mod error_curve;
pub(crate) mod positioning;

pub use positioning::Planner;
