//! 6-axis belt grinding (docs/methods.md, "Belt contact and removal").
//!
//! - [`contact`]: the contact wheel's line contact, its pose, the scallop
//!   between neighbouring contact paths and the gouge of a rigid belt on a
//!   concave section.
//! - [`iso_parametric`]: contact paths along one parameter, stepped so the
//!   scallop between paths stays within h.
//! - [`iso_planar`]: contact paths in parallel section planes whose normal is
//!   the dominant minimum-curvature direction (orientation tensor), stepped the
//!   same way.

pub mod contact;
pub(crate) mod iso_parametric;
pub mod iso_planar;
