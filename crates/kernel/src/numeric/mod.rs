//! Functions of one variable: roots and minima. Each algorithm is written
//! once here and every caller uses it: the planners, the plane sections, the
//! tools and the simulators (docs/methods.md, "One root finder").
//!
//! - [`Bracket`], [`illinois_root`], [`newton_root`]: a root's bracket
//!   narrowed by regula falsi (Illinois), and Newton's iteration kept inside
//!   such a bracket.
//! - [`golden_min`]: golden-section search over a bracket, to an abscissa
//!   tolerance.
//! - [`brent_min`]: Brent's minimisation (parabolic steps, golden-section
//!   fallback), for smooth minima.
//! - [`bracket_min`]: the minimum of a unimodal function from points already
//!   known, by secant-kink or parabola models, for kinked minima (a flat
//!   end's rim crossing).
//!
//! They are separate algorithms, not one with options: each caller's
//! results depend on the exact sequence of trial points of its own.

mod bracket_min;
mod brent;
mod golden;
mod roots;

pub use bracket_min::bracket_min;
pub use brent::brent_min;
pub use golden::golden_min;
pub use roots::{illinois_root, newton_root, Bracket};
