//! A serial chain of one-degree-of-freedom joints between two links (mm, rad).
//!
//! Each joint sits at a fixed transform (`origin`) from the previous joint's
//! frame, every fixed joint between them folded in, and moves about or along
//! its unit `axis` in its own frame, as URDF defines it:
//! `T(q) = origin_1 M_1(q_1) origin_2 M_2(q_2) ... origin_n M_n(q_n) tip`.

use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};

/// How a joint moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointKind {
    /// Turns about its axis within `[lower, upper]`.
    Revolute,
    /// Turns about its axis without limits.
    Continuous,
    /// Slides along its axis (mm).
    Prismatic,
}

impl JointKind {
    pub fn is_rotary(self) -> bool {
        self != JointKind::Prismatic
    }
    pub fn name(self) -> &'static str {
        match self {
            JointKind::Revolute => "revolute",
            JointKind::Continuous => "continuous",
            JointKind::Prismatic => "prismatic",
        }
    }
}

/// A joint's limits in internal units (mm or rad, per second, per second squared).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointLimits {
    /// Position range; infinite for a continuous joint.
    pub lower: f64,
    pub upper: f64,
    /// `None` when neither the URDF nor the configuration gives one.
    pub velocity: Option<f64>,
    pub acceleration: Option<f64>,
}

impl JointLimits {
    pub const UNLIMITED: JointLimits = JointLimits {
        lower: f64::NEG_INFINITY,
        upper: f64::INFINITY,
        velocity: None,
        acceleration: None,
    };
    /// Whether `x` lies in the position range (with `slack`).
    pub fn contains(&self, x: f64, slack: f64) -> bool {
        x >= self.lower - slack && x <= self.upper + slack
    }
    /// The travel, `upper - lower` (infinite for a continuous joint).
    pub fn travel(&self) -> f64 {
        self.upper - self.lower
    }
}

/// One moving joint of a chain.
#[derive(Clone, Debug, PartialEq)]
pub struct ChainJoint {
    pub name: String,
    pub kind: JointKind,
    /// From the previous joint's frame (or the chain's base link) to this
    /// joint's frame at zero.
    pub origin: Isometry3<f64>,
    /// Unit axis in this joint's frame.
    pub axis: Unit<Vector3<f64>>,
    pub limits: JointLimits,
}

impl ChainJoint {
    /// The joint's own motion at value `q`.
    pub fn motion(&self, q: f64) -> Isometry3<f64> {
        motion(self.kind, &self.axis, q)
    }
}

/// The transform of a joint of kind `kind` about/along `axis` at value `q`.
pub fn motion(kind: JointKind, axis: &Unit<Vector3<f64>>, q: f64) -> Isometry3<f64> {
    match kind {
        JointKind::Prismatic => Isometry3::from_parts(
            Translation3::from(axis.into_inner() * q),
            UnitQuaternion::identity(),
        ),
        _ => Isometry3::from_parts(
            Translation3::identity(),
            UnitQuaternion::from_axis_angle(axis, q),
        ),
    }
}

/// A serial chain from `base_link` to `tip_link`.
#[derive(Clone, Debug, PartialEq)]
pub struct Chain {
    pub base_link: String,
    pub tip_link: String,
    pub joints: Vec<ChainJoint>,
    /// From the last joint's frame (or the base link, without joints) to the tip link.
    pub tip: Isometry3<f64>,
}

impl Chain {
    /// A chain without joints: `tip_link` fixed at `tip` in `base_link`.
    pub fn fixed(base_link: &str, tip_link: &str, tip: Isometry3<f64>) -> Self {
        Self {
            base_link: base_link.to_string(),
            tip_link: tip_link.to_string(),
            joints: Vec::new(),
            tip,
        }
    }

    pub fn dof(&self) -> usize {
        self.joints.len()
    }

    /// The tip link's pose in the base link for joint values `q` (chain order).
    /// `q` must hold one value per joint.
    pub fn forward(&self, q: &[f64]) -> Isometry3<f64> {
        debug_assert_eq!(q.len(), self.joints.len());
        let mut t = Isometry3::identity();
        for (j, x) in self.joints.iter().zip(q) {
            t = t * j.origin * j.motion(*x);
        }
        t * self.tip
    }

    /// Each joint's frame in the base link for joint values `q`, before its
    /// own motion (its axis is fixed in it).
    pub fn joint_frames(&self, q: &[f64]) -> Vec<Isometry3<f64>> {
        let mut t = Isometry3::identity();
        let mut out = Vec::with_capacity(self.joints.len());
        for (j, x) in self.joints.iter().zip(q) {
            t *= j.origin;
            out.push(t);
            t *= j.motion(*x);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    #[test]
    fn a_planar_two_link_arm_matches_its_textbook_formula() {
        // Two revolute joints about z, links of 300 and 200 mm along x.
        let joint = |name: &str, x: f64| ChainJoint {
            name: name.into(),
            kind: JointKind::Revolute,
            origin: Isometry3::translation(x, 0.0, 0.0),
            axis: Vector3::z_axis(),
            limits: JointLimits::UNLIMITED,
        };
        let chain = Chain {
            base_link: "b".into(),
            tip_link: "t".into(),
            joints: vec![joint("j1", 0.0), joint("j2", 300.0)],
            tip: Isometry3::translation(200.0, 0.0, 0.0),
        };
        for (a, b) in [(0.3, -1.1), (FRAC_PI_2, FRAC_PI_2), (-2.0, 0.7)] {
            let t = chain.forward(&[a, b]);
            let x = 300.0 * a.cos() + 200.0 * (a + b).cos();
            let y = 300.0 * a.sin() + 200.0 * (a + b).sin();
            assert!((t.translation.x - x).abs() < 1e-9 && (t.translation.y - y).abs() < 1e-9);
            let r = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), a + b);
            assert!(t.rotation.angle_to(&r) < 1e-12);
        }
    }

    #[test]
    fn a_prismatic_joint_slides_along_its_axis_in_its_frame() {
        // The slide's frame is turned 90 deg about z: its x axis is the base's y.
        let chain = Chain {
            base_link: "b".into(),
            tip_link: "t".into(),
            joints: vec![ChainJoint {
                name: "s".into(),
                kind: JointKind::Prismatic,
                origin: Isometry3::new(Vector3::new(1.0, 2.0, 3.0), Vector3::z() * FRAC_PI_2),
                axis: Vector3::x_axis(),
                limits: JointLimits::UNLIMITED,
            }],
            tip: Isometry3::identity(),
        };
        let t = chain.forward(&[10.0]);
        assert!((t.translation.vector - Vector3::new(1.0, 12.0, 3.0)).norm() < 1e-12);
    }
}
