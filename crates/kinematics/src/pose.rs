//! Tool poses as the planners give them and as the solvers take them.
//!
//! The TCP frame follows the ROS-Industrial `tool0` convention: its z axis
//! points out of the flange along the tool, towards the tip. A planner's tool
//! axis runs from the tip to the spindle, so it is minus the TCP's z.

use crate::error::{Error, Result};
use nalgebra::{Isometry3, Point3, Rotation3, Translation3, Unit, UnitQuaternion, Vector3};

/// What a pose asks of the TCP, in the workpiece frame (mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target {
    /// A 5-axis tool pose: the tip at `tip`, the tool axis (tip -> spindle)
    /// along `axis`; the rotation about the axis is free.
    Axis {
        tip: Point3<f64>,
        axis: Unit<Vector3<f64>>,
    },
    /// A full 6-D pose of the TCP frame.
    Frame(Isometry3<f64>),
}

impl Target {
    /// A 5-axis pose from plain arrays; the axis need not be unit but must
    /// be a finite non-zero direction.
    pub fn axis(tip: [f64; 3], axis: [f64; 3]) -> Result<Self> {
        let a = Vector3::from(axis);
        let n = a.norm();
        if !n.is_finite() || n < 1e-12 || tip.iter().any(|x| !x.is_finite()) {
            return Err(Error::Input(format!(
                "tool pose with tip {tip:?} and axis {axis:?}: needs a finite tip and a finite non-zero axis"
            )));
        }
        Ok(Target::Axis {
            tip: Point3::from(tip),
            axis: Unit::new_unchecked(a / n),
        })
    }

    /// A 6-D pose from a position (mm) and a unit quaternion `[x, y, z, w]`.
    pub fn frame(xyz: [f64; 3], quat_xyzw: [f64; 4]) -> Result<Self> {
        let q = nalgebra::Quaternion::new(quat_xyzw[3], quat_xyzw[0], quat_xyzw[1], quat_xyzw[2]);
        let n = q.norm();
        if !n.is_finite() || n < 1e-9 || xyz.iter().any(|x| !x.is_finite()) {
            return Err(Error::Input(format!(
                "frame at {xyz:?} with quaternion {quat_xyzw:?}: needs a finite position and a finite non-zero quaternion"
            )));
        }
        Ok(Target::Frame(Isometry3::from_parts(
            Translation3::from(Vector3::from(xyz)),
            UnitQuaternion::from_quaternion(q),
        )))
    }

    pub fn tip(&self) -> Point3<f64> {
        match self {
            Target::Axis { tip, .. } => *tip,
            Target::Frame(f) => Point3::from(f.translation.vector),
        }
    }

    /// The tool axis (tip -> spindle) it asks for.
    pub fn tool_axis(&self) -> Unit<Vector3<f64>> {
        match self {
            Target::Axis { axis, .. } => *axis,
            Target::Frame(f) => Unit::new_unchecked(-(f.rotation * Vector3::z())),
        }
    }

    pub fn is_frame(&self) -> bool {
        matches!(self, Target::Frame(_))
    }
}

/// The tool axis (tip -> spindle) of a TCP frame: minus its z.
pub fn tool_axis_of(tcp: &Isometry3<f64>) -> Vector3<f64> {
    -(tcp.rotation * Vector3::z())
}

/// An isometry from a position (mm) and ROS roll, pitch, yaw (rad, about the
/// fixed x, y, z axes: `R = Rz(yaw) Ry(pitch) Rx(roll)`).
pub fn xyz_rpy(xyz: [f64; 3], rpy: [f64; 3]) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::from(Vector3::from(xyz)),
        UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
    )
}

/// A rotation whose z axis is `z` (unit), its x axis as near to `x_hint` as
/// the orthogonality allows (or to the base x / y when `x_hint` is along `z`).
pub fn frame_with_z(z: &Unit<Vector3<f64>>, x_hint: &Vector3<f64>) -> UnitQuaternion<f64> {
    let mut x = x_hint - z.into_inner() * z.dot(x_hint);
    for fallback in [Vector3::x(), Vector3::y()] {
        if x.norm() > 1e-6 {
            break;
        }
        x = fallback - z.into_inner() * z.dot(&fallback);
    }
    let x = x.normalize();
    let y = z.cross(&x);
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_basis_unchecked(&[x, y, z.into_inner()]))
}

/// The smallest rotation taking unit `a` to unit `b` (a half turn about a
/// perpendicular axis when they are opposite).
pub fn min_rotation(a: &Unit<Vector3<f64>>, b: &Unit<Vector3<f64>>) -> UnitQuaternion<f64> {
    UnitQuaternion::rotation_between_axis(a, b).unwrap_or_else(|| {
        let perp = if a.x.abs() < 0.9 {
            a.cross(&Vector3::x())
        } else {
            a.cross(&Vector3::y())
        };
        UnitQuaternion::from_axis_angle(&Unit::new_normalize(perp), std::f64::consts::PI)
    })
}

/// The TCP frames of a pass of 5-axis poses, each turned by 0 about its tool
/// axis: frames parallel-transported along the pass (each the previous one
/// turned by the smallest rotation that takes its z to the next), so that one
/// angle about the axis means the same thing at every point.
pub fn reference_frames(axes: &[Unit<Vector3<f64>>]) -> Vec<UnitQuaternion<f64>> {
    let mut out: Vec<UnitQuaternion<f64>> = Vec::with_capacity(axes.len());
    for a in axes {
        let z = Unit::new_unchecked(-a.into_inner());
        let r = match out.last() {
            None => frame_with_z(&z, &Vector3::x()),
            Some(prev) => {
                let prev_z = Unit::new_unchecked(prev * Vector3::z());
                let r = min_rotation(&prev_z, &z) * prev;
                // Re-orthonormalise so rounding cannot accumulate along long passes.
                frame_with_z(&z, &(r * Vector3::x()))
            }
        };
        out.push(r);
    }
    out
}

/// Position error (mm) and rotation error (rad) of `reached` against `target`;
/// for a 5-axis target the rotation error is the angle between the axes.
pub fn pose_error(reached: &Isometry3<f64>, target: &Target) -> (f64, f64) {
    let d = (reached.translation.vector - target.tip().coords).norm();
    let ang = match target {
        Target::Axis { axis, .. } => {
            let a = tool_axis_of(reached);
            a.cross(axis).norm().atan2(a.dot(axis))
        }
        Target::Frame(f) => reached.rotation.angle_to(&f.rotation),
    };
    (d, ang)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tool_axis_is_minus_z_of_the_tcp() {
        // TCP turned a half turn about x: its z points down, the tool axis up.
        let tcp = xyz_rpy([1.0, 2.0, 3.0], [std::f64::consts::PI, 0.0, 0.0]);
        assert!((tool_axis_of(&tcp) - Vector3::z()).norm() < 1e-12);
        let t = Target::Frame(tcp);
        assert!((t.tool_axis().into_inner() - Vector3::z()).norm() < 1e-12);
        let (d, a) = pose_error(
            &tcp,
            &Target::axis([1.0, 2.0, 3.0], [0.0, 0.0, 5.0]).unwrap(),
        );
        assert!(d == 0.0 && a < 1e-15);
        let (_, a) = pose_error(
            &tcp,
            &Target::axis([1.0, 2.0, 3.0], [1.0, 0.0, 1.0]).unwrap(),
        );
        assert!((a - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
    }

    #[test]
    fn reference_frames_follow_the_axis_without_twisting() {
        // An axis swinging in the x-z plane: the frames' y axes stay put.
        let axes: Vec<_> = (0..50)
            .map(|k| {
                let t = k as f64 * 0.03;
                Unit::new_normalize(Vector3::new(t.sin(), 0.0, t.cos()))
            })
            .collect();
        let frames = reference_frames(&axes);
        for (f, a) in frames.iter().zip(&axes) {
            assert!((f * Vector3::z() + a.into_inner()).norm() < 1e-12);
            assert!(
                ((f * Vector3::y()).dot(&frames[0].transform_vector(&Vector3::y())) - 1.0).abs()
                    < 1e-9
            );
        }
    }

    #[test]
    fn bad_input_is_refused() {
        assert!(Target::axis([0.0; 3], [0.0; 3]).is_err());
        assert!(Target::axis([f64::NAN, 0.0, 0.0], [0.0, 0.0, 1.0]).is_err());
        assert!(Target::frame([0.0; 3], [0.0; 4]).is_err());
    }
}
