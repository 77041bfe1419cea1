//! belt6: 6-axis gantry belt grinder posing the contact wheel (joints X Y Z A B C).
//!
//! The wheel frame: x = wheel axis (across the belt), z = contact normal (from
//! the contact point towards the wheel centre), y = z x x (the belt's running
//! direction at the contact). Its orientation is `Rz(C) Ry(B) Rx(A)` (fixed-axis
//! roll A, pitch B, yaw C); X Y Z place the wheel centre:
//! `xyz = origin + R wheel_centre`, R the workpiece frame's rotation in the
//! machine ([`super::Placement`]; identity by default); the wheel frame is
//! rotated by R too.

use super::config::Belt6Config;
use super::mill5::unwrap_near;
use nalgebra::{Matrix3, Rotation3, Vector3};
use std::f64::consts::PI;
use toolpath_kernel::error::{Error, Result};

/// Below this |cos B| roll and yaw share one axis: A is held.
pub const SINGULAR_COS_B: f64 = 1e-9;

/// The wheel frame as a rotation matrix from axis and contact normal; the
/// normal is orthogonalised against the axis.
pub fn wheel_frame(axis: [f64; 3], normal: [f64; 3]) -> Result<Matrix3<f64>> {
    let x = Vector3::from(axis);
    let n = Vector3::from(normal);
    let xn = x.norm();
    if !xn.is_finite() || xn < 1e-12 {
        return Err(Error::planning(format!(
            "belt6: wheel axis {axis:?} is not a finite non-zero vector"
        )));
    }
    let x = x / xn;
    let z = n - x * x.dot(&n);
    let zn = z.norm();
    if !zn.is_finite() || zn < 1e-9 {
        return Err(Error::planning(format!(
            "belt6: contact normal {normal:?} is parallel to the wheel axis {axis:?}; the wheel cannot be posed"
        )));
    }
    let z = z / zn;
    let y = z.cross(&x);
    Ok(Matrix3::from_columns(&[x, y, z]))
}

/// Forward kinematics: joints [X, Y, Z, A, B, C] -> (wheel centre, wheel axis, contact normal).
pub fn forward(cfg: &Belt6Config, q: &[f64; 6]) -> ([f64; 3], [f64; 3], [f64; 3]) {
    let r = Rotation3::from_euler_angles(q[3], q[4], q[5]);
    let m = r.matrix();
    let placement = cfg.placement();
    (
        placement.point_to_workpiece([q[0], q[1], q[2]]),
        placement.vector_to_workpiece([m[(0, 0)], m[(1, 0)], m[(2, 0)]]),
        placement.vector_to_workpiece([m[(0, 2)], m[(1, 2)], m[(2, 2)]]),
    )
}

/// Inverse kinematics of one wheel pose, nearest to `prev` (A and C unwrapped
/// next to their previous values; of the two Euler branches the nearer one).
pub fn inverse(
    cfg: &Belt6Config,
    centre: [f64; 3],
    axis: [f64; 3],
    normal: [f64; 3],
    prev: Option<&[f64; 6]>,
) -> Result<[f64; 6]> {
    if centre.iter().any(|x| !x.is_finite()) {
        return Err(Error::planning(format!(
            "belt6: wheel centre {centre:?} is not finite"
        )));
    }
    let placement = cfg.placement();
    let m = wheel_frame(
        placement.vector_to_machine(axis),
        placement.vector_to_machine(normal),
    )?;
    let xyz = placement.point_to_machine(centre);
    let sb = (-m[(2, 0)]).clamp(-1.0, 1.0);
    let cb = m[(0, 0)].hypot(m[(1, 0)]);
    let (pa, pb, pc) = match prev {
        Some(p) => (p[3], p[4], p[5]),
        None => (0.0, 0.0, 0.0),
    };
    let (a, b, c) = if cb < SINGULAR_COS_B {
        // B = +-90 deg: only A - C (or A + C) is defined; hold A.
        let b = sb.asin();
        let a = pa;
        // Column y of Rz(C) Ry(+-90) Rx(A): (cC sB sA - sC cA, sC sB sA + cC cA, 0).
        let c = if sb > 0.0 {
            // y = (sin(A - C), cos(A - C), 0)  ->  A - C = atan2(y0, y1)
            a - m[(0, 1)].atan2(m[(1, 1)])
        } else {
            // y = (-sin(A + C), cos(A + C), 0)
            (-m[(0, 1)]).atan2(m[(1, 1)]) - a
        };
        (a, b, unwrap_near(c, pc))
    } else {
        let b1 = sb.atan2(cb);
        let a1 = m[(2, 1)].atan2(m[(2, 2)]);
        let c1 = m[(1, 0)].atan2(m[(0, 0)]);
        let b2 = PI - b1;
        let first = (
            unwrap_near(a1, pa),
            unwrap_near(b1, pb),
            unwrap_near(c1, pc),
        );
        let second = (
            unwrap_near(a1 + PI, pa),
            unwrap_near(b2, pb),
            unwrap_near(c1 + PI, pc),
        );
        let lim_b = cfg.b.axis("B");
        let fits = |s: &(f64, f64, f64)| s.1 >= lim_b.min - 1e-12 && s.1 <= lim_b.max + 1e-12;
        let dist = |s: &(f64, f64, f64)| (s.0 - pa).abs() + (s.1 - pb).abs() + (s.2 - pc).abs();
        match (fits(&first), fits(&second)) {
            (true, false) => first,
            (false, true) => second,
            _ if prev.is_none() => first,
            _ if dist(&second) < dist(&first) => second,
            _ => first,
        }
    };
    Ok([xyz[0], xyz[1], xyz[2], a, b, c])
}

/// Joint values of a whole path of wheel poses (centre, axis, normal).
pub fn inverse_path(
    cfg: &Belt6Config,
    poses: &[([f64; 3], [f64; 3], [f64; 3])],
) -> Result<Vec<[f64; 6]>> {
    let mut out: Vec<[f64; 6]> = Vec::with_capacity(poses.len());
    for (c, a, n) in poses {
        let q = inverse(cfg, *c, *a, *n, out.last())?;
        out.push(q);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    /// Independent FK: rotate the wheel-frame basis vectors one elementary
    /// rotation at a time (x first, then y, then z, all about fixed axes).
    fn fk_elementary(cfg: &Belt6Config, q: &[f64; 6]) -> ([f64; 3], [f64; 3], [f64; 3]) {
        let rx = |v: [f64; 3], t: f64| {
            [
                v[0],
                t.cos() * v[1] - t.sin() * v[2],
                t.sin() * v[1] + t.cos() * v[2],
            ]
        };
        let ry = |v: [f64; 3], t: f64| {
            [
                t.cos() * v[0] + t.sin() * v[2],
                v[1],
                -t.sin() * v[0] + t.cos() * v[2],
            ]
        };
        let rz = |v: [f64; 3], t: f64| {
            [
                t.cos() * v[0] - t.sin() * v[1],
                t.sin() * v[0] + t.cos() * v[1],
                v[2],
            ]
        };
        let rot = |v: [f64; 3]| rz(ry(rx(v, q[3]), q[4]), q[5]);
        let o = cfg.workpiece_origin_mm;
        (
            [q[0] - o[0], q[1] - o[1], q[2] - o[2]],
            rot([1.0, 0.0, 0.0]),
            rot([0.0, 0.0, 1.0]),
        )
    }

    fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
        (0..3).all(|k| (a[k] - b[k]).abs() <= tol)
    }

    #[test]
    fn a_workpiece_rolled_a_quarter_about_x_rolls_the_wheel() {
        // Roll 90 deg: workpiece +y is machine +z, workpiece +z is machine -y.
        let cfg = Belt6Config {
            workpiece_origin_mm: [800.0, 900.0, 300.0],
            workpiece_rpy_deg: [90.0, 0.0, 0.0],
            ..Belt6Config::default()
        };
        // Wheel axis workpiece +x, normal workpiece +z = machine -y: the wheel
        // frame is Rx(90 deg) of the machine's, so A = 90 deg, B = C = 0;
        // centre workpiece (0, 10, 20) = machine origin + (0, -20, 10).
        let q = inverse(
            &cfg,
            [0.0, 10.0, 20.0],
            [1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0],
            None,
        )
        .unwrap();
        assert!(
            close([q[0], q[1], q[2]], [800.0, 880.0, 310.0], 1e-9),
            "{q:?}"
        );
        assert!(
            close([q[3], q[4], q[5]], [FRAC_PI_2, 0.0, 0.0], 1e-12),
            "{q:?}"
        );
        let (centre, axis, normal) = forward(&cfg, &q);
        assert!(close(centre, [0.0, 10.0, 20.0], 1e-9));
        assert!(close(axis, [1.0, 0.0, 0.0], 1e-12) && close(normal, [0.0, 0.0, 1.0], 1e-12));
    }

    #[test]
    fn forward_matches_elementary_rotations() {
        let cfg = Belt6Config::default();
        let q = [10.0, 20.0, 30.0, 0.4, -0.9, 2.2];
        let (c1, a1, n1) = forward(&cfg, &q);
        let (c2, a2, n2) = fk_elementary(&cfg, &q);
        assert!(close(c1, c2, 1e-12) && close(a1, a2, 1e-12) && close(n1, n2, 1e-12));
    }

    #[test]
    fn inverse_then_independent_forward_round_trips() {
        let cfg = Belt6Config::default();
        let mut prev = None;
        for k in 0..400 {
            let t = k as f64 * 0.07;
            // Random-ish orthonormal frame from three angles.
            let r = Rotation3::from_euler_angles(
                1.3 * t.sin(),
                1.2 * (0.7 * t).cos(),
                2.9 * (0.3 * t).sin(),
            );
            let m = r.matrix();
            let axis = [m[(0, 0)], m[(1, 0)], m[(2, 0)]];
            let normal = [m[(0, 2)], m[(1, 2)], m[(2, 2)]];
            let centre = [100.0 * t.cos(), 50.0 * t.sin(), 20.0];
            let q = inverse(&cfg, centre, axis, normal, prev.as_ref()).unwrap();
            let (c2, a2, n2) = fk_elementary(&cfg, &q);
            assert!(close(centre, c2, 1e-9));
            assert!(close(axis, a2, 1e-9), "{axis:?} {a2:?} {q:?}");
            assert!(close(normal, n2, 1e-9), "{normal:?} {n2:?} {q:?}");
            if let Some(p) = prev {
                for j in 3..6 {
                    assert!(
                        (q[j] - p[j]).abs() < 0.5,
                        "joint {j} jumps {} -> {}",
                        p[j],
                        q[j]
                    );
                }
            }
            prev = Some(q);
        }
    }

    #[test]
    fn gimbal_lock_holds_roll_and_round_trips() {
        let cfg = Belt6Config::default();
        // Wheel axis pointing straight down (B = 90 deg), normal along x.
        let prev = [0.0, 0.0, 0.0, 0.3, 1.5, 0.1];
        let q = inverse(
            &cfg,
            [0.0; 3],
            [0.0, 0.0, -1.0],
            [1.0, 0.0, 0.0],
            Some(&prev),
        )
        .unwrap();
        assert_eq!(q[3], 0.3);
        let (_, a, n) = fk_elementary(&cfg, &q);
        assert!(
            close(a, [0.0, 0.0, -1.0], 1e-9) && close(n, [1.0, 0.0, 0.0], 1e-9),
            "{q:?} {a:?} {n:?}"
        );
        let q = inverse(
            &cfg,
            [0.0; 3],
            [0.0, 0.0, 1.0],
            [0.0, 1.0, 0.0],
            Some(&prev),
        )
        .unwrap();
        let (_, a, n) = fk_elementary(&cfg, &q);
        assert!(
            close(a, [0.0, 0.0, 1.0], 1e-9) && close(n, [0.0, 1.0, 0.0], 1e-9),
            "{q:?} {a:?} {n:?}"
        );
    }

    #[test]
    fn parallel_normal_is_a_clear_error() {
        let cfg = Belt6Config::default();
        let e = inverse(&cfg, [0.0; 3], [0.0, 1.0, 0.0], [0.0, 2.0, 0.0], None).unwrap_err();
        assert!(e.to_string().contains("parallel to the wheel axis"), "{e}");
    }
}
