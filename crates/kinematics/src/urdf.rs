//! URDF -> link tree -> serial chain between two links.
//!
//! The XML is read by `urdf-rs`; this module turns its joints into internal
//! units (URDF metres -> mm, radians stay) and walks the tree from a tip link
//! up to a base link. Fixed joints fold into the next joint's origin (or the
//! chain's tip); mimic, floating, planar and spherical joints cannot be part of
//! a serial chain of independent one-axis joints and are refused by name.

use crate::chain::{Chain, ChainJoint, JointKind, JointLimits};
use crate::error::{Error, Result};
use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};
use std::collections::BTreeMap;

/// URDF lengths are metres; internal lengths are mm.
pub const MM_PER_M: f64 = 1000.0;

/// A URDF joint type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UrdfJointType {
    Fixed,
    Revolute,
    Continuous,
    Prismatic,
    Floating,
    Planar,
    Spherical,
}

impl UrdfJointType {
    fn of(t: &urdf_rs::JointType) -> Self {
        match t {
            urdf_rs::JointType::Fixed => Self::Fixed,
            urdf_rs::JointType::Revolute => Self::Revolute,
            urdf_rs::JointType::Continuous => Self::Continuous,
            urdf_rs::JointType::Prismatic => Self::Prismatic,
            urdf_rs::JointType::Floating => Self::Floating,
            urdf_rs::JointType::Planar => Self::Planar,
            urdf_rs::JointType::Spherical => Self::Spherical,
        }
    }
    fn name(self) -> &'static str {
        match self {
            Self::Fixed => "fixed",
            Self::Revolute => "revolute",
            Self::Continuous => "continuous",
            Self::Prismatic => "prismatic",
            Self::Floating => "floating",
            Self::Planar => "planar",
            Self::Spherical => "spherical",
        }
    }
}

/// One URDF joint in internal units.
#[derive(Clone, Debug, PartialEq)]
pub struct UrdfJoint {
    pub name: String,
    pub kind: UrdfJointType,
    pub parent: String,
    pub child: String,
    /// Parent link -> joint frame (mm, rad).
    pub origin: Isometry3<f64>,
    /// As written (not yet normalised).
    pub axis: Vector3<f64>,
    /// Position limits as written (mm or rad); velocity and acceleration when given.
    pub limits: JointLimits,
    /// The joint this one mimics, if any.
    pub mimic: Option<String>,
}

/// The kinematic content of a URDF: its links and joints in document order.
#[derive(Clone, Debug, PartialEq)]
pub struct UrdfModel {
    pub name: String,
    pub links: Vec<String>,
    pub joints: Vec<UrdfJoint>,
    /// Child link -> index of the joint that carries it.
    parent_joint: BTreeMap<String, usize>,
}

/// A URDF `<origin>` as an isometry in mm.
pub fn origin_to_mm(xyz_m: [f64; 3], rpy: [f64; 3]) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(
            xyz_m[0] * MM_PER_M,
            xyz_m[1] * MM_PER_M,
            xyz_m[2] * MM_PER_M,
        ),
        UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
    )
}

fn limits_of(j: &urdf_rs::Joint, kind: UrdfJointType) -> JointLimits {
    let scale = if kind == UrdfJointType::Prismatic {
        MM_PER_M
    } else {
        1.0
    };
    let positive = |x: f64| (x.is_finite() && x > 0.0).then_some(x * scale);
    let (lower, upper) = match kind {
        UrdfJointType::Continuous => (f64::NEG_INFINITY, f64::INFINITY),
        _ => (j.limit.lower * scale, j.limit.upper * scale),
    };
    JointLimits {
        lower,
        upper,
        velocity: positive(j.limit.velocity),
        acceleration: positive(j.limit.acceleration),
    }
}

impl UrdfModel {
    /// Parses URDF text; checks that names are unique, that every joint
    /// joins two links of the model and that no link has two parents.
    pub fn parse(xml: &str) -> Result<Self> {
        let robot = urdf_rs::read_from_string(xml).map_err(|e| Error::Urdf(e.to_string()))?;
        let mut links = Vec::with_capacity(robot.links.len());
        for l in &robot.links {
            if links.contains(&l.name) {
                return Err(Error::Urdf(format!("link {:?} is defined twice", l.name)));
            }
            links.push(l.name.clone());
        }
        let mut joints: Vec<UrdfJoint> = Vec::with_capacity(robot.joints.len());
        let mut parent_joint = BTreeMap::new();
        for j in &robot.joints {
            if joints.iter().any(|k| k.name == j.name) {
                return Err(Error::Urdf(format!("joint {:?} is defined twice", j.name)));
            }
            for (role, link) in [("parent", &j.parent.link), ("child", &j.child.link)] {
                if !links.contains(link) {
                    return Err(Error::Urdf(format!(
                        "joint {:?} names {role} link {link:?}, which the URDF does not define",
                        j.name
                    )));
                }
            }
            if let Some(k) = parent_joint.insert(j.child.link.clone(), joints.len()) {
                return Err(Error::Urdf(format!(
                    "link {:?} is the child of two joints, {:?} and {:?} (a URDF is a tree)",
                    j.child.link, joints[k].name, j.name
                )));
            }
            let kind = UrdfJointType::of(&j.joint_type);
            joints.push(UrdfJoint {
                name: j.name.clone(),
                kind,
                parent: j.parent.link.clone(),
                child: j.child.link.clone(),
                origin: origin_to_mm(j.origin.xyz.0, j.origin.rpy.0),
                axis: Vector3::from(j.axis.xyz.0),
                limits: limits_of(j, kind),
                mimic: j.mimic.as_ref().map(|m| m.joint.clone()),
            });
        }
        Ok(Self {
            name: robot.name,
            links,
            joints,
            parent_joint,
        })
    }

    /// The names of the movable joints, in document order.
    pub fn joint_names(&self) -> Vec<String> {
        self.joints
            .iter()
            .filter(|j| j.kind != UrdfJointType::Fixed)
            .map(|j| j.name.clone())
            .collect()
    }

    pub fn joint(&self, name: &str) -> Option<&UrdfJoint> {
        self.joints.iter().find(|j| j.name == name)
    }

    fn check_link(&self, link: &str, role: &str) -> Result<()> {
        if self.links.iter().any(|l| l == link) {
            return Ok(());
        }
        Err(Error::Model(format!(
            "{role} {link:?} is not a link of URDF {:?} (its links: {})",
            self.name,
            self.links.join(", ")
        )))
    }

    /// The joints from `base` down to `tip`, base first; `base` must be an
    /// ancestor of `tip` (or `tip` itself).
    fn path(&self, base: &str, tip: &str) -> Result<Vec<&UrdfJoint>> {
        self.check_link(base, "base link")?;
        self.check_link(tip, "tip link")?;
        let mut path = Vec::new();
        let mut link = tip;
        while link != base {
            let Some(&k) = self.parent_joint.get(link) else {
                return Err(Error::Model(format!(
                    "link {tip:?} is not below link {base:?} in URDF {:?} (walking up from {tip:?} reaches the root {link:?}); a chain runs from a link down to one of its descendants",
                    self.name
                )));
            };
            let j = &self.joints[k];
            path.push(j);
            link = &j.parent;
        }
        path.reverse();
        Ok(path)
    }

    /// The serial chain from `base` to `tip`, fixed joints folded in.
    pub fn chain(&self, base: &str, tip: &str) -> Result<Chain> {
        let mut joints = Vec::new();
        let mut pending = Isometry3::identity();
        for j in self.path(base, tip)? {
            let kind = match j.kind {
                UrdfJointType::Fixed => {
                    pending *= j.origin;
                    continue;
                }
                UrdfJointType::Revolute => JointKind::Revolute,
                UrdfJointType::Continuous => JointKind::Continuous,
                UrdfJointType::Prismatic => JointKind::Prismatic,
                other => {
                    return Err(Error::Model(format!(
                        "joint {:?} between {base:?} and {tip:?} is {}: only revolute, continuous, prismatic and fixed joints can be part of a machine's chain",
                        j.name,
                        other.name()
                    )))
                }
            };
            if let Some(m) = &j.mimic {
                return Err(Error::Model(format!(
                    "joint {:?} between {base:?} and {tip:?} mimics joint {m:?}: a chain of coupled joints is not supported (give the machine independent joints)",
                    j.name
                )));
            }
            joints.push(chain_joint(j, kind, pending * j.origin)?);
            pending = Isometry3::identity();
        }
        Ok(Chain {
            base_link: base.to_string(),
            tip_link: tip.to_string(),
            joints,
            tip: pending,
        })
    }
}

fn chain_joint(j: &UrdfJoint, kind: JointKind, origin: Isometry3<f64>) -> Result<ChainJoint> {
    let n = j.axis.norm();
    if !n.is_finite() || n < 1e-9 {
        return Err(Error::Model(format!(
            "joint {:?} has axis {:?}, not a direction",
            j.name,
            j.axis.as_slice()
        )));
    }
    let limits = j.limits;
    if kind != JointKind::Continuous
        && limits.lower.partial_cmp(&limits.upper) != Some(std::cmp::Ordering::Less)
    {
        return Err(Error::Model(format!(
            "joint {:?} is {} but its <limit> gives no travel (lower {} >= upper {}, URDF units); give lower < upper",
            j.name,
            kind.name(),
            limits.lower / if kind == JointKind::Prismatic { MM_PER_M } else { 1.0 },
            limits.upper / if kind == JointKind::Prismatic { MM_PER_M } else { 1.0 },
        )));
    }
    Ok(ChainJoint {
        name: j.name.clone(),
        kind,
        origin,
        axis: Unit::new_normalize(j.axis),
        limits,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const TWO_BRANCHES: &str = r#"<robot name="cell">
      <link name="world"/><link name="a"/><link name="b"/><link name="flange"/><link name="tool0"/>
      <link name="table"/><link name="finger"/>
      <joint name="j1" type="revolute"><parent link="world"/><child link="a"/>
        <origin xyz="0 0 0.5" rpy="0 0 0"/><axis xyz="0 0 2"/>
        <limit lower="-3" upper="3" velocity="2" effort="10"/></joint>
      <joint name="fix" type="fixed"><parent link="a"/><child link="b"/>
        <origin xyz="0.1 0 0" rpy="0 0 1.5707963267948966"/></joint>
      <joint name="slide" type="prismatic"><parent link="b"/><child link="flange"/>
        <origin xyz="0 0.2 0"/><axis xyz="1 0 0"/>
        <limit lower="-0.5" upper="0.25" velocity="0.3" effort="1"/></joint>
      <joint name="flange_tool0" type="fixed"><parent link="flange"/><child link="tool0"/>
        <origin xyz="0 0 0.05" rpy="3.141592653589793 0 0"/></joint>
      <joint name="table_j" type="continuous"><parent link="world"/><child link="table"/>
        <axis xyz="0 0 1"/></joint>
      <joint name="finger_j" type="prismatic"><parent link="flange"/><child link="finger"/>
        <axis xyz="0 1 0"/><limit lower="0" upper="0.04" velocity="0.1" effort="1"/>
        <mimic joint="slide"/></joint>
    </robot>"#;

    #[test]
    fn fixed_joints_fold_into_the_next_origin_and_units_become_mm() {
        let m = UrdfModel::parse(TWO_BRANCHES).unwrap();
        assert_eq!(m.joint_names(), ["j1", "slide", "table_j", "finger_j"]);
        let c = m.chain("world", "tool0").unwrap();
        assert_eq!(c.joints.len(), 2);
        assert_eq!(c.joints[0].axis.into_inner(), Vector3::z());
        // slide origin = fix (0.1 m along x, yaw 90) * (0, 0.2 m, 0): the
        // slide's frame sits at (100 - 200, 0, 0) mm in a's frame.
        let o = c.joints[1].origin;
        assert!((o.translation.vector - Vector3::new(-100.0, 0.0, 0.0)).norm() < 1e-9);
        assert_eq!(c.joints[1].limits.lower, -500.0);
        assert_eq!(c.joints[1].limits.velocity, Some(300.0));
        assert_eq!(c.joints[0].limits.velocity, Some(2.0));
        assert_eq!(c.joints[0].limits.acceleration, None);
        assert!((c.tip.translation.vector - Vector3::new(0.0, 0.0, 50.0)).norm() < 1e-9);
        // Hand-composed: j1 at q1 about z at 500 mm height, then the fold,
        // the slide along its x (the base's y after yaw 90 and q1), the tool.
        let (q1, s) = (0.4_f64, 30.0);
        let t = c.forward(&[q1, s]);
        let (c1, s1) = (q1.cos(), q1.sin());
        // In a's frame the slide's x axis is a's y; tool tip is 50 mm below
        // along +z of flange (z is not turned by the yaw or q1).
        let local = Vector3::new(-100.0, s, 50.0);
        let expect = Vector3::new(
            c1 * local.x - s1 * local.y,
            s1 * local.x + c1 * local.y,
            500.0 + local.z,
        );
        assert!((t.translation.vector - expect).norm() < 1e-9, "{t:?}");
        let z_tool = t.rotation * Vector3::z();
        assert!((z_tool + Vector3::z()).norm() < 1e-12);
        assert_eq!(
            m.chain("world", "table").unwrap().joints[0].limits.upper,
            f64::INFINITY
        );
    }

    #[test]
    fn bad_chains_are_refused_by_name() {
        let m = UrdfModel::parse(TWO_BRANCHES).unwrap();
        let e = m.chain("world", "finger").unwrap_err().to_string();
        assert!(
            e.contains("joint \"finger_j\"") && e.contains("mimics joint \"slide\""),
            "{e}"
        );
        let e = m.chain("table", "tool0").unwrap_err().to_string();
        assert!(e.contains("is not below link \"table\""), "{e}");
        let e = m.chain("world", "nowhere").unwrap_err().to_string();
        assert!(e.contains("tip link \"nowhere\" is not a link"), "{e}");
        let floating = TWO_BRANCHES.replace(
            r#"name="j1" type="revolute""#,
            r#"name="j1" type="floating""#,
        );
        let e = UrdfModel::parse(&floating)
            .unwrap()
            .chain("world", "tool0")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("joint \"j1\"") && e.contains("is floating"),
            "{e}"
        );
        let e = UrdfModel::parse("<robot name='x'><link name='a'/><joint name='j' type='fixed'><parent link='a'/><child link='b'/></joint></robot>")
            .unwrap_err()
            .to_string();
        assert!(e.contains("child link \"b\""), "{e}");
        let e = UrdfModel::parse("<robot name='x'><link").unwrap_err();
        assert!(matches!(e, Error::Urdf(_)));
        let no_travel = TWO_BRANCHES.replace(r#"lower="-3" upper="3""#, r#"lower="0" upper="0""#);
        let e = UrdfModel::parse(&no_travel)
            .unwrap()
            .chain("world", "tool0")
            .unwrap_err()
            .to_string();
        assert!(e.contains("gives no travel"), "{e}");
    }
}
