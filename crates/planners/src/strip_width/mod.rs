//! Flat-end (and ball) 5-axis finishing on the strip-width model
//! (docs/methods.md, "Strip width of a tilted flat end").
//!
//! A pass leaves a strip whose width depends on the feed direction; the
//! strip-width tensor gives the direction of the widest strip at every point.
//! The stages, each in its own module:
//! - [`width`]: the exact strip width of one pose from the cutter's real
//!   profile, and the gouge check.
//! - [`field`]: the strip-width tensor, the feed direction field and its
//!   deviator (whose zeros are the degenerate points).
//! - [`lower_bound`]: the path-length lower bound every strategy reports.
//! - [`regions`]: degenerate points and the partition of the surface along the
//!   separatrices of trisectors.
//! - [`offset`]: iso-scallop offsetting of passes across a region, from an
//!   initial pass to full coverage.
//! - [`passes`] and [`pass_ends`]: contacts and poses along a pass, sampling,
//!   and the run-ins and run-outs past edges.
//! - [`parametric`]: zig-zag passes along iso-parameter curves.
//! - [`repair`]: rest-finishing passes over the islands the simulator finds
//!   above the scallop height (called by the pipeline after verification).
//!
//! The strategies: [`iso_parametric`] (passes along one parameter, spaced by
//! the narrowest strip), [`iso_scallop`] (the whole surface as one region,
//! offset from one boundary curve) and [`tensor_regions`] (regions from the
//! tensor field, each offset from a pass along its feed direction). No
//! strategy imports another; what they share lives in the modules above
//! (`tensor_regions` keeps the shortest of its candidate plans, among them
//! the baselines' plans built from [`parametric`] and [`offset`]).

pub mod crossings;
pub(crate) mod field;
pub(crate) mod iso_parametric;
pub(crate) mod iso_scallop;
pub mod lower_bound;
pub mod offset;
pub(crate) mod parametric;
pub(crate) mod pass_ends;
pub mod passes;
pub mod regions;
pub mod repair;
pub mod tensor_regions;
pub mod width;
