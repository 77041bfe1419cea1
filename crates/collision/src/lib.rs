//! Collision checking of a whole milling tool assembly against a whole part.
//!
//! - [`ToolAssembly`]: the cutter (flat end, ball, torus) and the shank and
//!   holder as a stack of revolved segments, each part with its exact signed
//!   distance (closed form in the meridian half-plane, [`Profile`]).
//! - [`Workpiece`]: the part's faces behind the [`Face`] trait, sampled on
//!   (u, v) inside their trims, each sample with a cover radius, indexed in a
//!   bounding-sphere hierarchy.
//! - Pose queries ([`Workpiece::query`], [`Workpiece::clear_by`],
//!   [`Workpiece::certified_margin`]): cutter penetration into the check
//!   faces, shank/holder clearance to every face, refined exactly on the
//!   faces, with certified lower bounds.
//! - [`check_motion`]: a straight motion between two poses (linear tip,
//!   slerped axis) by conservative advancement, with its first collision.
//! - [`find_clear_axis`]: the nearest collision-free axis in a cone, lead
//!   before tilt, keeping the caller's contact point.
//!
//! Units: mm and radians. Rules: docs/methods.md, "Collision checking".

pub mod assembly;
pub mod avoid;
pub mod bvh;
pub mod error;
pub mod face;
mod parallel;
pub mod profile;
pub mod query;
pub mod refine;
pub mod sampling;
pub mod shapes;
pub mod sweep;
pub mod workpiece;

pub use assembly::{Cutter, HolderSegment, PartDistance, Pose, SdfJet, ToolAssembly, ToolPart};
pub use avoid::{find_clear_axis, AxisSearch, ClearAxis};
pub use error::{Error, Result};
pub use face::{Face, FaceDerivs};
pub use profile::{Element, Nearest, Profile};
pub use query::{Contact, PartReport, PoseReport, QueryOptions};
pub use sampling::{Sample, SamplingOptions};
pub use sweep::{check_motion, Motion, SweepOptions, SweepOutcome};
pub use workpiece::Workpiece;

#[cfg(test)]
mod tests {
    /// Planners check poses in parallel: the part and the tool are shared.
    #[test]
    fn part_and_tool_are_shared_across_threads() {
        fn shared<T: Send + Sync>() {}
        shared::<crate::Workpiece>();
        shared::<crate::ToolAssembly>();
        shared::<crate::PoseReport>();
    }
}
