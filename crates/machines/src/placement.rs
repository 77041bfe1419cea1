//! Where the workpiece frame sits in a machine's frame: a translation (the
//! machine coordinates of the workpiece origin) and a rotation given as ROS's
//! roll, pitch, yaw (about the fixed x, y, z axes: `R = Rz(yaw) Ry(pitch)
//! Rx(roll)`, REP 103). A workpiece point `p` is at `origin + R p` in the
//! machine; a direction `d` is `R d`.
//!
//! Without a rotation the arithmetic is the plain translation, term for term,
//! so a machine whose frames are parallel gives the same bits as before the
//! rotation existed.

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

/// The pose of the workpiece frame in a machine frame (mm, rad).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    origin: [f64; 3],
    /// `None` when roll, pitch and yaw are all zero.
    rotation: Option<Matrix3<f64>>,
}

impl Placement {
    /// The placement with `origin` (mm) and ROS roll, pitch, yaw (rad).
    pub fn new(origin: [f64; 3], rpy: [f64; 3]) -> Self {
        let rotation = (rpy != [0.0; 3])
            .then(|| Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]).into_inner());
        Self { origin, rotation }
    }

    pub fn origin(&self) -> [f64; 3] {
        self.origin
    }

    /// The rotation as a unit quaternion `[x, y, z, w]` (TF's order).
    pub fn quaternion_xyzw(&self) -> [f64; 4] {
        match self.rotation {
            None => [0.0, 0.0, 0.0, 1.0],
            Some(m) => {
                let q = UnitQuaternion::from_matrix(&m);
                [q.i, q.j, q.k, q.w]
            }
        }
    }

    /// Machine direction of the workpiece direction `v`.
    pub fn vector_to_machine(&self, v: [f64; 3]) -> [f64; 3] {
        match self.rotation {
            None => v,
            Some(m) => arr(m * Vector3::from(v)),
        }
    }

    /// Workpiece direction of the machine direction `v`.
    pub fn vector_to_workpiece(&self, v: [f64; 3]) -> [f64; 3] {
        match self.rotation {
            None => v,
            Some(m) => arr(m.transpose() * Vector3::from(v)),
        }
    }

    /// Machine coordinates of the workpiece point `p`: `origin + R p`.
    pub fn point_to_machine(&self, p: [f64; 3]) -> [f64; 3] {
        let o = self.origin;
        let r = self.vector_to_machine(p);
        [o[0] + r[0], o[1] + r[1], o[2] + r[2]]
    }

    /// Workpiece coordinates of the machine point `m`: `R^T (m - origin)`.
    pub fn point_to_workpiece(&self, m: [f64; 3]) -> [f64; 3] {
        let o = self.origin;
        self.vector_to_workpiece([m[0] - o[0], m[1] - o[1], m[2] - o[2]])
    }
}

fn arr(v: Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        (0..3).all(|k| (a[k] - b[k]).abs() < 1e-12)
    }

    #[test]
    fn yaw_of_a_quarter_turn_maps_x_to_y() {
        let p = Placement::new([10.0, 20.0, 30.0], [0.0, 0.0, FRAC_PI_2]);
        assert!(close(p.vector_to_machine([1.0, 0.0, 0.0]), [0.0, 1.0, 0.0]));
        assert!(close(
            p.point_to_machine([1.0, 0.0, 0.0]),
            [10.0, 21.0, 30.0]
        ));
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let q = p.quaternion_xyzw();
        assert!((q[2] - h).abs() < 1e-12 && (q[3] - h).abs() < 1e-12);
    }

    #[test]
    fn rpy_is_yaw_after_pitch_after_roll_about_fixed_axes() {
        // Roll 90 deg takes y to z; then pitch 90 deg takes z to x: y ends on x.
        let p = Placement::new([0.0; 3], [FRAC_PI_2, FRAC_PI_2, 0.0]);
        assert!(close(p.vector_to_machine([0.0, 1.0, 0.0]), [1.0, 0.0, 0.0]));
    }

    #[test]
    fn points_round_trip_and_parallel_frames_only_translate() {
        let p = Placement::new([1.0, -2.0, 3.0], [0.3, -0.7, 2.1]);
        let x = [4.0, 5.0, -6.0];
        assert!(close(p.point_to_workpiece(p.point_to_machine(x)), x));
        let parallel = Placement::new([1.5, -2.25, 3.0], [0.0; 3]);
        assert_eq!(parallel.point_to_machine(x), [5.5, 2.75, -3.0]);
        assert_eq!(parallel.point_to_workpiece([5.5, 2.75, -3.0]), x);
        assert_eq!(parallel.quaternion_xyzw(), [0.0, 0.0, 0.0, 1.0]);
    }
}
