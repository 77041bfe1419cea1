//! Base geometry: NURBS surfaces, their differential geometry, and the
//! curve operations the planners share. Depends on nothing else in the crate
//! but `error`.

pub mod differential;
pub mod field_trace;
pub mod interpolation;
pub mod inversion;
pub mod medial_axis;
pub mod nurbs;
pub mod plane_intersection;
pub mod pocket;
pub mod segment_index;
pub mod trim;

/// The one-variable solvers, at their former path.
pub use crate::numeric;
pub use differential::{FundamentalForms, LocalGeometry};
pub use nurbs::{NurbsSurface, SurfaceDerivs};
pub use pocket::Pocket;
pub use trim::{Trim, TrimCurve};
