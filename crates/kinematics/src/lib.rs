//! Kinematics of any machine from its URDF (docs/methods.md, "Machine
//! kinematics from URDF").
//!
//! - [`UrdfModel`] reads a URDF (metres, radians) into internal units (mm,
//!   radians); [`UrdfModel::chain`] picks the serial chain between two links.
//! - [`Machine`] joins a tool chain and a part chain from one base link (a
//!   head, a table, both, or a robot holding the part against a fixed tool):
//!   forward kinematics and the geometric Jacobian of the TCP in the
//!   workpiece frame, and inverse kinematics of 5-axis poses (tip and tool
//!   axis) and full frames, closed form where the structure allows
//!   (three linear + two or three rotary axes; 6R arms with a spherical
//!   wrist or with parallel axes 2-3-4), numerical otherwise, every solution
//!   checked by forward kinematics.
//! - [`Machine::solve_pass`] turns a pass of poses into joint vectors that
//!   keep one configuration, unwrap rotary axes and fit the joint limits by
//!   whole turns, and choose the free rotation about the tool axis of a
//!   5-axis pose on a 6-axis machine along the whole pass; a pose that
//!   cannot be reached is reported with its pass, point and reason.

pub mod angles;
pub mod arm;
pub mod cartesian;
pub mod chain;
pub mod error;
mod free_angle;
pub mod machine;
pub mod numeric;
pub mod opw;
mod pass;
pub mod pose;
pub mod relchain;
pub mod solve;
pub mod subproblems;
pub mod urdf;

pub use chain::{Chain, ChainJoint, JointKind, JointLimits};
pub use error::{At, Error, Result};
pub use machine::{LimitOverride, Machine, MachineDef, Options, SolverChoice};
pub use pose::{xyz_rpy, Target};
pub use urdf::UrdfModel;
