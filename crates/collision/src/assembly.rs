//! The tool assembly: the cutter and, above its flutes, the shank and holder
//! as a stack of revolved segments, all about the tool axis, measured from
//! the tip (cl) up.
//!
//! Each part is a convex solid of revolution ([`Profile`]); its signed
//! distance at a point is the 2-D distance in the meridian half-plane, so it
//! is exact inside and outside. Parts are kept apart (not merged into one
//! union) because the rules differ: the cutter may touch the faces it
//! machines, the shank and holder may touch nothing.

use crate::error::{non_negative, positive, Error, Result};
use crate::profile::{Element, Nearest, Profile, Rz};
use nalgebra::Vector3;
use std::f64::consts::FRAC_PI_2;

/// The cutting part: flat end (corner radius 0), ball (corner radius =
/// radius) or torus (in between). Sizes in mm; `radius` is D/2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cutter {
    pub radius: f64,
    pub corner_radius: f64,
    /// Height of the fluted part above the tip; the holder stack starts there.
    pub flute_length: f64,
}

impl Cutter {
    pub fn flat_end(radius: f64, flute_length: f64) -> Self {
        Self {
            radius,
            corner_radius: 0.0,
            flute_length,
        }
    }

    pub fn ball(radius: f64, flute_length: f64) -> Self {
        Self {
            radius,
            corner_radius: radius,
            flute_length,
        }
    }

    pub fn torus(radius: f64, corner_radius: f64, flute_length: f64) -> Self {
        Self {
            radius,
            corner_radius,
            flute_length,
        }
    }

    /// Checks sizes; fields relative to the cutter.
    pub fn validate(&self) -> Result<()> {
        positive("radius", self.radius)?;
        non_negative("corner_radius", self.corner_radius)?;
        positive("flute_length", self.flute_length)?;
        if self.corner_radius > self.radius {
            return Err(Error::invalid(
                "corner_radius",
                format!(
                    "corner radius {} is larger than the cutter radius {}",
                    self.corner_radius, self.radius
                ),
            ));
        }
        if self.flute_length < self.corner_radius {
            return Err(Error::invalid(
                "flute_length",
                format!(
                    "flute length {} is shorter than the corner radius {}",
                    self.flute_length, self.corner_radius
                ),
            ));
        }
        Ok(())
    }

    /// The meridian boundary: bottom disc of radius R0 = R - rc, the corner
    /// quarter circle centred at (R0, rc), the side up to the flute length,
    /// the top back to the axis.
    fn profile(&self) -> Result<Profile> {
        let (big_r, rc, len) = (self.radius, self.corner_radius, self.flute_length);
        let r0 = big_r - rc;
        let mut e = vec![Element::Line {
            a: [0.0, 0.0],
            b: [r0, 0.0],
        }];
        if rc > 0.0 {
            e.push(Element::Arc {
                centre: [r0, rc],
                radius: rc,
                from: -FRAC_PI_2,
                to: 0.0,
            });
        }
        e.push(Element::Line {
            a: [big_r, rc],
            b: [big_r, len],
        });
        e.push(Element::Line {
            a: [big_r, len],
            b: [0.0, len],
        });
        Profile::new(&e)
    }
}

/// One segment of the shank/holder stack: a cylinder (equal radii) or a cone
/// frustum, `length` along the axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HolderSegment {
    pub length: f64,
    pub radius_bottom: f64,
    pub radius_top: f64,
}

impl HolderSegment {
    pub fn cylinder(length: f64, radius: f64) -> Self {
        Self {
            length,
            radius_bottom: radius,
            radius_top: radius,
        }
    }

    pub fn cone(length: f64, radius_bottom: f64, radius_top: f64) -> Self {
        Self {
            length,
            radius_bottom,
            radius_top,
        }
    }

    /// Checks sizes; fields relative to the segment.
    pub fn validate(&self) -> Result<()> {
        positive("length", self.length)?;
        positive("radius_bottom", self.radius_bottom)?;
        positive("radius_top", self.radius_top)
    }

    fn profile(&self, z0: f64) -> Result<Profile> {
        let z1 = z0 + self.length;
        let (rb, rt) = (self.radius_bottom, self.radius_top);
        Profile::new(&[
            Element::Line {
                a: [0.0, z0],
                b: [rb, z0],
            },
            Element::Line {
                a: [rb, z0],
                b: [rt, z1],
            },
            Element::Line {
                a: [rt, z1],
                b: [0.0, z1],
            },
        ])
    }
}

/// A part of the assembly.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ToolPart {
    Cutter,
    /// Segment `k` of the stack above the flutes, counted from the bottom
    /// (the shank is the first segment or segments, the holder the rest).
    Holder(usize),
}

impl ToolPart {
    /// Index into [`ToolAssembly::profiles`]: the cutter 0, segment k at k + 1.
    pub fn index(self) -> usize {
        match self {
            ToolPart::Cutter => 0,
            ToolPart::Holder(k) => k + 1,
        }
    }

    pub fn from_index(i: usize) -> Self {
        if i == 0 {
            ToolPart::Cutter
        } else {
            ToolPart::Holder(i - 1)
        }
    }
}

/// Where the tool is: the tip (cl, the lowest point of the axis) and the
/// unit axis from the tip towards the spindle. The queries take the axis as
/// unit; [`Pose::new`] normalises it and refuses non-finite input.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    pub tip: Vector3<f64>,
    pub axis: Vector3<f64>,
}

impl Pose {
    /// A pose with its axis normalised; refuses a non-finite tip or an axis
    /// of length below 1e-12.
    pub fn new(tip: Vector3<f64>, axis: Vector3<f64>) -> Result<Self> {
        if !tip.iter().all(|x| x.is_finite()) {
            return Err(Error::invalid("tip", format!("{tip:?} is not finite")));
        }
        let n = axis.norm();
        if !n.is_finite() || n < 1e-12 {
            return Err(Error::invalid(
                "axis",
                format!("{axis:?} is not a direction"),
            ));
        }
        Ok(Self {
            tip,
            axis: axis / n,
        })
    }

    /// The point in the meridian half-plane: (radial distance, height above
    /// the tip), and the unit radial direction (any unit vector across the
    /// axis when the point is on it).
    #[inline]
    pub fn meridian(&self, x: &Vector3<f64>) -> (Rz, Vector3<f64>) {
        let d = x - self.tip;
        let z = d.dot(&self.axis);
        let w = d - self.axis * z;
        let r = w.norm();
        let e_r = if r > 1e-300 {
            w / r
        } else {
            any_perpendicular(&self.axis)
        };
        ([r, z], e_r)
    }
}

/// A unit vector perpendicular to the unit `a`.
pub fn any_perpendicular(a: &Vector3<f64>) -> Vector3<f64> {
    let helper = if a.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    a.cross(&helper).normalize()
}

/// Cutter plus shank/holder stack, validated, with each part's profile.
#[derive(Clone, Debug)]
pub struct ToolAssembly {
    cutter: Cutter,
    holder: Vec<HolderSegment>,
    profiles: Vec<Profile>,
    reach: f64,
}

/// The signed distance of one part at a point, with its nearest-point data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PartDistance {
    pub part: ToolPart,
    pub distance: f64,
}

impl ToolAssembly {
    /// Validates every size; errors name `cutter.*` or `holder[k].*`.
    pub fn new(cutter: Cutter, holder: Vec<HolderSegment>) -> Result<Self> {
        cutter.validate().map_err(|e| e.within("cutter"))?;
        if holder.len() >= crate::query::MAX_PARTS {
            return Err(Error::invalid(
                "holder",
                format!(
                    "{} segments, at most {} are supported",
                    holder.len(),
                    crate::query::MAX_PARTS - 1
                ),
            ));
        }
        let mut profiles = vec![cutter.profile().map_err(|e| e.within("cutter"))?];
        let mut z = cutter.flute_length;
        for (k, s) in holder.iter().enumerate() {
            let field = format!("holder[{k}]");
            s.validate().map_err(|e| e.within(&field))?;
            profiles.push(s.profile(z).map_err(|e| e.within(&field))?);
            z += s.length;
        }
        let reach = profiles.iter().map(Profile::reach).fold(0.0, f64::max);
        Ok(Self {
            cutter,
            holder,
            profiles,
            reach,
        })
    }

    pub fn cutter(&self) -> &Cutter {
        &self.cutter
    }

    pub fn holder(&self) -> &[HolderSegment] {
        &self.holder
    }

    /// Each part's meridian profile, the cutter first.
    pub fn profiles(&self) -> &[Profile] {
        &self.profiles
    }

    /// Number of parts (cutter plus holder segments).
    pub fn part_count(&self) -> usize {
        self.profiles.len()
    }

    /// Largest distance of any point of the assembly from the tip: how far a
    /// point of the tool moves, per radian, when the axis turns about the tip.
    pub fn reach(&self) -> f64 {
        self.reach
    }

    /// Height of the top of the stack above the tip.
    pub fn total_length(&self) -> f64 {
        self.cutter.flute_length + self.holder.iter().map(|s| s.length).sum::<f64>()
    }

    /// Signed distance from `x` to `part` at `pose`, negative inside.
    pub fn signed_distance(&self, pose: &Pose, part: ToolPart, x: &Vector3<f64>) -> f64 {
        let (rz, _) = pose.meridian(x);
        self.profiles[part.index()].signed_distance(rz)
    }

    /// The part with the smallest signed distance from `x` (the first one on
    /// a tie, cutter before holder, lower segments before higher).
    pub fn nearest_part(&self, pose: &Pose, x: &Vector3<f64>) -> PartDistance {
        let (rz, _) = pose.meridian(x);
        let mut best = PartDistance {
            part: ToolPart::Cutter,
            distance: f64::INFINITY,
        };
        for (i, p) in self.profiles.iter().enumerate() {
            let d = p.signed_distance(rz);
            if d < best.distance {
                best = PartDistance {
                    part: ToolPart::from_index(i),
                    distance: d,
                };
            }
        }
        best
    }

    /// The inside branches -d_k of `part`'s signed distance at `x`, one per
    /// boundary element, to second order (see [`Profile::inside_piece`]).
    pub fn inside_jets(
        &self,
        pose: &Pose,
        part: ToolPart,
        x: &Vector3<f64>,
        out: &mut Vec<SdfJet>,
    ) {
        let (rz, e_r) = pose.meridian(x);
        let profile = &self.profiles[part.index()];
        out.clear();
        for k in 0..profile.piece_count() {
            let n = profile.inside_piece(k, rz);
            out.push(SdfJet::from_meridian(&n, rz, &e_r, &pose.axis));
        }
    }

    /// Signed distance with its gradient and Hessian in 3-D, for the exact
    /// refinement (see [`SdfJet`]).
    pub fn jet(&self, pose: &Pose, part: ToolPart, x: &Vector3<f64>) -> SdfJet {
        let (rz, e_r) = pose.meridian(x);
        let n = self.profiles[part.index()].nearest(rz);
        SdfJet::from_meridian(&n, rz, &e_r, &pose.axis)
    }
}

/// The signed distance of a solid of revolution at a point to second order:
/// value, unit gradient and Hessian.
///
/// With g(r, z) the 2-D signed distance, the revolved distance has gradient
/// g_r e_r + g_z a and Hessian k_m T T^T + (g_r / r) e_phi e_phi^T: k_m the
/// meridian curvature of the level set, T its unit meridian tangent, and
/// g_r / r the curvature of the parallel circle (a sphere's 1/rho in both
/// directions on the axis, where r -> 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SdfJet {
    pub value: f64,
    pub gradient: Vector3<f64>,
    pub hessian: nalgebra::Matrix3<f64>,
}

impl SdfJet {
    fn from_meridian(n: &Nearest, rz: Rz, e_r: &Vector3<f64>, axis: &Vector3<f64>) -> Self {
        let gradient = e_r * n.normal[0] + axis * n.normal[1];
        let t = e_r * (-n.normal[1]) + axis * n.normal[0];
        let e_phi = axis.cross(e_r);
        let k_par = if rz[0] > 1e-9 * (1.0 + rz[1].abs()) {
            n.normal[0] / rz[0]
        } else {
            n.curvature
        };
        let hessian = t * t.transpose() * n.curvature + e_phi * e_phi.transpose() * k_par;
        Self {
            value: n.distance,
            gradient,
            hessian,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_sizes_name_their_field() {
        let e = ToolAssembly::new(Cutter::torus(5.0, 6.0, 20.0), vec![]).unwrap_err();
        assert_eq!(e.field, "cutter.corner_radius");
        let e = ToolAssembly::new(
            Cutter::ball(3.0, 20.0),
            vec![
                HolderSegment::cylinder(30.0, 3.0),
                HolderSegment::cone(10.0, 8.0, f64::NAN),
            ],
        )
        .unwrap_err();
        assert_eq!(e.field, "holder[1].radius_top");
        assert!(e.message.contains("finite"), "{e}");
        let e = ToolAssembly::new(Cutter::ball(3.0, 2.0), vec![]).unwrap_err();
        assert_eq!(e.field, "cutter.flute_length");
        assert!(Pose::new(Vector3::zeros(), Vector3::zeros()).is_err());
    }

    #[test]
    fn holder_segments_stack_above_the_flutes() {
        let t = ToolAssembly::new(
            Cutter::flat_end(5.0, 30.0),
            vec![
                HolderSegment::cylinder(40.0, 5.0),
                HolderSegment::cone(60.0, 16.0, 20.0),
            ],
        )
        .unwrap();
        assert_eq!(t.profiles()[2].z_range(), (70.0, 130.0));
        assert!((t.reach() - 20f64.hypot(130.0)).abs() < 1e-12);
        let pose = Pose::new(Vector3::new(1.0, 2.0, 3.0), Vector3::z()).unwrap();
        // 2 mm outside the cone halfway up: radius 18 there.
        let x = Vector3::new(1.0 + 20.0, 2.0, 3.0 + 100.0);
        let want = 2.0 * (60.0 / 60.0f64.hypot(4.0));
        let d = t.signed_distance(&pose, ToolPart::Holder(1), &x);
        assert!((d - want).abs() < 1e-12, "{d} vs {want}");
        assert_eq!(t.nearest_part(&pose, &x).part, ToolPart::Holder(1));
        // On the axis inside the shank: 5 from its side.
        let x = Vector3::new(1.0, 2.0, 3.0 + 50.0);
        assert!((t.signed_distance(&pose, ToolPart::Holder(0), &x) + 5.0).abs() < 1e-12);
    }
}
