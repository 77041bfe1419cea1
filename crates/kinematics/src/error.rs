//! Errors: bad models and bad input say what is wrong; a pose that cannot be
//! reached says where (pass and point, when the caller solves a pass) and why
//! (out of reach, which joint at which value against which limit, how close
//! to which singularity), so that no joint value is ever silently wrong.

use std::fmt;

/// Where in a caller's toolpath a pose sits: its pass and its point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct At {
    pub pass: usize,
    pub point: usize,
}

impl fmt::Display for At {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "pass {} point {}", self.pass, self.point)
    }
}

fn place(at: &Option<At>) -> String {
    at.map_or_else(|| "the pose".to_string(), |a| a.to_string())
}

/// A joint value with its unit: degrees for rotary joints, mm for linear ones.
fn shown(value: f64, rotary: bool) -> String {
    if rotary {
        format!("{:.3} deg", value.to_degrees())
    } else {
        format!("{value:.3} mm")
    }
}

fn range(lower: f64, upper: f64, rotary: bool) -> String {
    if rotary {
        format!("{:.3}..{:.3} deg", lower.to_degrees(), upper.to_degrees())
    } else {
        format!("{lower:.3}..{upper:.3} mm")
    }
}

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Error {
    /// The URDF text is not valid URDF.
    #[error("URDF: {0}")]
    Urdf(String),
    /// The model cannot serve as a machine (links not connected, a mimic or
    /// floating joint in a chain, a degenerate axis, ...).
    #[error("machine model: {0}")]
    Model(String),
    /// A caller's argument is wrong (not finite, wrong length, unknown name).
    #[error("invalid input: {0}")]
    Input(String),
    /// No joint values put the tool there.
    #[error("{}: unreachable: {why}", place(at))]
    Unreachable { at: Option<At>, why: String },
    /// Every solution needs a joint beyond its limits; the nearest one is named.
    #[error("{}: needs joint {joint} = {}, outside its range {}", place(at), shown(*value, *rotary), range(*lower, *upper, *rotary))]
    JointLimit {
        at: Option<At>,
        joint: String,
        value: f64,
        lower: f64,
        upper: f64,
        rotary: bool,
    },
    /// A rotary joint would have to turn through more than its travel inside one pass.
    #[error("{} onwards turns joint {joint} through {:.1} deg, more than its travel {}", place(at), span.to_degrees(), range(*lower, *upper, true))]
    Travel {
        at: Option<At>,
        joint: String,
        span: f64,
        lower: f64,
        upper: f64,
    },
    /// The pose is at (or too near) a singularity of the solution the pass keeps.
    #[error("{}: singular: {why}", place(at))]
    Singular { at: Option<At>, why: String },
    /// Keeping the pass's configuration needs a joint step larger than allowed
    /// (a configuration flip or a jump through a singularity).
    #[error("{}: joint {joint} would step {}, more than the {} allowed between points (a configuration change inside the pass)", place(at), shown(*step, *rotary), shown(*max, *rotary))]
    Step {
        at: Option<At>,
        joint: String,
        step: f64,
        max: f64,
        rotary: bool,
    },
}

impl Error {
    /// The place of a pose error, if it has one.
    pub fn at(&self) -> Option<At> {
        match self {
            Error::Unreachable { at, .. }
            | Error::JointLimit { at, .. }
            | Error::Travel { at, .. }
            | Error::Singular { at, .. }
            | Error::Step { at, .. } => *at,
            _ => None,
        }
    }

    /// The same error placed at `at` (pose errors only).
    pub fn placed(mut self, place: At) -> Self {
        match &mut self {
            Error::Unreachable { at, .. }
            | Error::JointLimit { at, .. }
            | Error::Travel { at, .. }
            | Error::Singular { at, .. }
            | Error::Step { at, .. } => *at = Some(place),
            _ => {}
        }
        self
    }

    /// A short name of the kind, for machine-readable reports.
    pub fn kind(&self) -> &'static str {
        match self {
            Error::Urdf(_) => "urdf",
            Error::Model(_) => "model",
            Error::Input(_) => "input",
            Error::Unreachable { .. } => "unreachable",
            Error::JointLimit { .. } => "joint_limit",
            Error::Travel { .. } => "travel",
            Error::Singular { .. } => "singular",
            Error::Step { .. } => "step",
        }
    }

    /// The joint a pose error names, if any.
    pub fn joint(&self) -> Option<&str> {
        match self {
            Error::JointLimit { joint, .. }
            | Error::Travel { joint, .. }
            | Error::Step { joint, .. } => Some(joint),
            _ => None,
        }
    }
}

pub type Result<T> = std::result::Result<T, Error>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_the_place_the_joint_and_the_range() {
        let e = Error::JointLimit {
            at: Some(At { pass: 2, point: 17 }),
            joint: "wrist_2".into(),
            value: 200f64.to_radians(),
            lower: -std::f64::consts::PI,
            upper: std::f64::consts::PI,
            rotary: true,
        };
        assert_eq!(
            e.to_string(),
            "pass 2 point 17: needs joint wrist_2 = 200.000 deg, outside its range -180.000..180.000 deg"
        );
        let e = Error::Unreachable {
            at: None,
            why: "too far".into(),
        }
        .placed(At { pass: 0, point: 3 });
        assert_eq!(e.to_string(), "pass 0 point 3: unreachable: too far");
        assert_eq!(e.kind(), "unreachable");
    }
}
