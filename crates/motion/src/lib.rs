//! Time parameterisation of joint paths for machine tools and robots
//! (docs/methods.md, "Time-optimal path parameterisation"). Units: mm and
//! rad, seconds.
//!
//! - [`parameterise`]: time-optimal path parameterisation by reachability
//!   analysis (TOPP-RA) of a C2 joint spline through the waypoints, under
//!   joint velocity and acceleration limits and a cap on the tool tip's
//!   speed (pointwise along the path), with an optional jerk limit applied
//!   by filtering the profile ([`smooth`]).
//! - [`jtc`]: the interpolation ros2_control's joint_trajectory_controller
//!   applies between trajectory points, and a sampler at its period.
//! - [`place`] / [`plan`]: which states go to the controller so that its
//!   interpolation keeps the limits and the tool within a chord and axis
//!   tolerance of the planned cut.
//! - [`check()`]: the controller's motion sampled every period against limits,
//!   the planned cut and the tip speed caps, per kind of segment.
//!
//! Nothing here knows a machine: forward kinematics come in as a closure.

pub mod check;
pub mod error;
pub mod jtc;
mod lp;
pub mod path;
pub mod place;
pub mod smooth;
pub mod spline;
pub mod timing;
pub mod topp;

pub use check::{check, KindReport, Planned, Report, Tolerance};
pub use error::{Error, Result};
pub use jtc::{Interpolation, JointState, Trajectory};
pub use path::{Kinematics, Limits, Parameter, Path, Segment, SegmentKind, Tips, ToolPose};
pub use place::{place, plan, plan_timed, Follow, Plan};
pub use timing::{parameterise, GridPoint, PathState, Profile, Timing};
pub use topp::{Options, PieceProfile};
