//! mill5: gantry mill with an A/C swivel head (joints X Y Z A C).
//!
//! C turns about the machine Z axis, A tilts the spindle about the (C-rotated)
//! X axis. With A, C the tool axis (tip -> spindle) is
//! `Rz(C) Rx(A) (0, 0, 1) = (sin A sin C, -sin A cos C, cos A)`. The joints
//! X Y Z place the pivot (where the A and C axes meet), which sits the pivot
//! length L above the tool tip along the axis:
//! `pivot = origin + R tip + L R axis`, R the workpiece frame's rotation in
//! the machine ([`super::Placement`]; identity by default).

use super::config::Mill5Config;
use std::f64::consts::PI;
use toolpath_kernel::error::{Error, Result};

/// Below this |sin A| the C angle is undefined (tool vertical): C is held.
pub const SINGULAR_SIN_A: f64 = 1e-9;

/// Forward kinematics: joints [X, Y, Z, A, C] (mm, rad) -> (tip, axis).
pub fn forward(cfg: &Mill5Config, pivot_length: f64, q: &[f64; 5]) -> ([f64; 3], [f64; 3]) {
    let (sa, ca) = q[3].sin_cos();
    let (sc, cc) = q[4].sin_cos();
    let placement = cfg.placement();
    let axis = placement.vector_to_workpiece([sa * sc, -sa * cc, ca]);
    let pivot = placement.point_to_workpiece([q[0], q[1], q[2]]);
    let tip = [
        pivot[0] - pivot_length * axis[0],
        pivot[1] - pivot_length * axis[1],
        pivot[2] - pivot_length * axis[2],
    ];
    (tip, axis)
}

/// The C value congruent to `c` (mod 2 pi) nearest to `reference`.
pub fn unwrap_near(c: f64, reference: f64) -> f64 {
    c + 2.0 * PI * ((reference - c) / (2.0 * PI)).round()
}

/// Inverse kinematics of one pose. `prev` (the previous joints of the path)
/// selects the branch: of (A, C) and (-A, C + pi), the one nearer to `prev`,
/// with C unwrapped next to the previous C (no +-360 jumps). With the tool
/// vertical (A = 0) C is free: it keeps the previous value (or `c_hint`)
/// instead of spinning.
pub fn inverse(
    cfg: &Mill5Config,
    pivot_length: f64,
    tip: [f64; 3],
    axis: [f64; 3],
    prev: Option<&[f64; 5]>,
    c_hint: f64,
) -> Result<[f64; 5]> {
    let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
    if !n.is_finite() || n < 1e-12 || tip.iter().any(|x| !x.is_finite()) {
        return Err(Error::planning(format!(
            "mill5: cannot pose the tool at tip {tip:?} with axis {axis:?} (not a finite unit axis)"
        )));
    }
    let placement = cfg.placement();
    let a = placement.vector_to_machine([axis[0] / n, axis[1] / n, axis[2] / n]);
    let tip = placement.point_to_machine(tip);
    let xyz = [
        tip[0] + pivot_length * a[0],
        tip[1] + pivot_length * a[1],
        tip[2] + pivot_length * a[2],
    ];
    let (ang_a, ang_c) = tilt_and_turn(a, head_turn(a), prev.map(|p| (p[3], p[4])), c_hint);
    Ok([xyz[0], xyz[1], xyz[2], ang_a, ang_c])
}

/// C of the head's positive-A solution for a unit axis: the azimuth at which
/// `(sin A sin C, -sin A cos C)` points.
pub fn head_turn(axis: [f64; 3]) -> f64 {
    axis[0].atan2(-axis[1])
}

/// The (tilt, turn) pair of a two-rotary machine for a unit tool axis, given
/// `turn_pos`, the turn of its positive-tilt solution (the tilt is the axis'
/// angle from +z for every A/C and B/C machine here). Of (tilt, turn) and
/// (-tilt, turn + pi) it takes the one nearer to `prev` (tilt, turn), with the
/// turn unwrapped next to the previous turn (no +-360 jumps). With the axis on
/// the turn axis (tilt 0) the turn is free: it keeps the previous value (or
/// `turn_hint`) instead of spinning.
pub fn tilt_and_turn(
    axis: [f64; 3],
    turn_pos: f64,
    prev: Option<(f64, f64)>,
    turn_hint: f64,
) -> (f64, f64) {
    let sin_a = axis[0].hypot(axis[1]);
    let a_pos = sin_a.atan2(axis[2]);
    let (prev_a, prev_c) = prev.unwrap_or((a_pos, turn_hint));
    if sin_a < SINGULAR_SIN_A {
        // Tool on the turn axis (or opposite): any turn gives the same axis; hold it.
        return (
            if axis[2] > 0.0 {
                0.0
            } else {
                PI.copysign(prev_a)
            },
            prev_c,
        );
    }
    let c_pos = unwrap_near(turn_pos, prev_c);
    let c_neg = unwrap_near(c_pos + PI, prev_c);
    // Rotary distance in radians; tilt and turn weighted alike.
    let d_pos = (a_pos - prev_a).abs() + (c_pos - prev_c).abs();
    let d_neg = (-a_pos - prev_a).abs() + (c_neg - prev_c).abs();
    if prev.is_none() || d_pos <= d_neg {
        (a_pos, c_pos)
    } else {
        (-a_pos, c_neg)
    }
}

/// The C value the first non-singular axis of a path asks for (so that a path
/// that starts vertical does not spin C when it first tilts).
pub fn c_hint(axes: &[[f64; 3]]) -> f64 {
    axes.iter()
        .find(|a| {
            a[0].hypot(a[1]) >= SINGULAR_SIN_A * (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
        })
        .map_or(0.0, |a| head_turn(*a))
}

/// Joint values of a whole path (consecutive tool poses), continuous in A and C.
pub fn inverse_path(
    cfg: &Mill5Config,
    pivot_length: f64,
    poses: &[([f64; 3], [f64; 3])],
) -> Result<Vec<[f64; 5]>> {
    let axes: Vec<[f64; 3]> = poses.iter().map(|p| p.1).collect();
    let hint = c_hint(&axes);
    let mut out: Vec<[f64; 5]> = Vec::with_capacity(poses.len());
    for (tip, axis) in poses {
        let q = inverse(cfg, pivot_length, *tip, *axis, out.last(), hint)?;
        out.push(q);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    /// Independent forward kinematics: compose the head's homogeneous
    /// transforms (translate to the pivot, rotate C about z, A about x, go
    /// down the tool by L) as 4x4 matrices.
    fn fk_matrices(cfg: &Mill5Config, l: f64, q: &[f64; 5]) -> ([f64; 3], [f64; 3]) {
        use nalgebra::{Matrix4, Rotation3, Translation3, Vector3, Vector4};
        let o = cfg.workpiece_origin_mm;
        let to_pivot = Translation3::new(q[0] - o[0], q[1] - o[1], q[2] - o[2]).to_homogeneous();
        let rc: Matrix4<f64> =
            Rotation3::from_axis_angle(&Vector3::z_axis(), q[4]).to_homogeneous();
        let ra: Matrix4<f64> =
            Rotation3::from_axis_angle(&Vector3::x_axis(), q[3]).to_homogeneous();
        let down = Translation3::new(0.0, 0.0, -l).to_homogeneous();
        let m = to_pivot * rc * ra * down;
        let tip = m * Vector4::new(0.0, 0.0, 0.0, 1.0);
        let ax = m * Vector4::new(0.0, 0.0, 1.0, 0.0);
        ([tip.x, tip.y, tip.z], [ax.x, ax.y, ax.z])
    }

    fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
        (0..3).all(|k| (a[k] - b[k]).abs() <= tol)
    }

    #[test]
    fn a_workpiece_turned_a_quarter_about_z_turns_the_pose() {
        // Yaw 90 deg: workpiece +x is machine +y, workpiece +y is machine -x.
        let cfg = Mill5Config {
            workpiece_origin_mm: [1000.0, 500.0, 200.0],
            workpiece_rpy_deg: [0.0, 0.0, 90.0],
            ..Mill5Config::default()
        };
        let l = 300.0;
        // Tool vertical over workpiece (10, 0, 5): pivot at machine
        // (1000, 510, 205 + 300).
        let q = inverse(&cfg, l, [10.0, 0.0, 5.0], [0.0, 0.0, 1.0], None, 0.0).unwrap();
        assert!(
            close([q[0], q[1], q[2]], [1000.0, 510.0, 505.0], 1e-9),
            "{q:?}"
        );
        // Tool axis along workpiece +x = machine +y: A = 90 deg, C = 180 deg
        // ((sin A sin C, -sin A cos C, cos A) = (0, 1, 0)); pivot 300 mm along
        // machine +y from the tip at the workpiece origin.
        let q = inverse(&cfg, l, [0.0; 3], [1.0, 0.0, 0.0], None, 0.0).unwrap();
        assert!(
            close([q[0], q[1], q[2]], [1000.0, 800.0, 200.0], 1e-9),
            "{q:?}"
        );
        assert!(
            (q[3] - FRAC_PI_2).abs() < 1e-12 && (q[4].abs() - PI).abs() < 1e-12,
            "{q:?}"
        );
        let (tip, axis) = forward(&cfg, l, &q);
        assert!(close(tip, [0.0; 3], 1e-9) && close(axis, [1.0, 0.0, 0.0], 1e-12));
    }

    #[test]
    fn forward_matches_composed_transforms() {
        let cfg = Mill5Config::default();
        for &(a, c) in &[(0.3, 1.0), (-1.2, -2.5), (0.0, 0.7), (1.6, 3.5)] {
            let q = [100.0, 200.0, 300.0, a, c];
            let (t1, a1) = forward(&cfg, 280.0, &q);
            let (t2, a2) = fk_matrices(&cfg, 280.0, &q);
            assert!(
                close(t1, t2, 1e-9) && close(a1, a2, 1e-12),
                "{t1:?} {t2:?} {a1:?} {a2:?}"
            );
        }
    }

    #[test]
    fn inverse_then_independent_forward_round_trips() {
        let cfg = Mill5Config::default();
        let l = 312.5;
        let mut prev: Option<[f64; 5]> = None;
        // A deterministic scatter of tips and axes over the upper hemisphere.
        for k in 0..500 {
            let t = k as f64;
            let tip = [
                400.0 * (0.37 * t).sin(),
                300.0 * (0.11 * t).cos(),
                50.0 * (0.05 * t).sin(),
            ];
            let polar = 1.6 * ((0.013 * t).sin()).abs(); // 0 .. ~92 deg
            let az = 0.7 * t;
            let axis = [polar.sin() * az.cos(), polar.sin() * az.sin(), polar.cos()];
            let q = inverse(&cfg, l, tip, axis, prev.as_ref(), 0.0).unwrap();
            let (tip2, axis2) = fk_matrices(&cfg, l, &q);
            assert!(close(tip, tip2, 1e-9), "tip {tip:?} -> {q:?} -> {tip2:?}");
            assert!(
                close(axis, axis2, 1e-9),
                "axis {axis:?} -> {q:?} -> {axis2:?}"
            );
            prev = Some(q);
        }
    }

    #[test]
    fn vertical_tool_holds_c_instead_of_spinning() {
        let cfg = Mill5Config::default();
        // Tilted towards +x (C = -90 deg), through vertical, then tilted towards -x.
        let tilt = |s: f64| [s.sin(), 0.0, s.cos()];
        let poses: Vec<([f64; 3], [f64; 3])> = (-10..=10)
            .map(|k| ([k as f64, 0.0, 0.0], tilt(k as f64 * 0.02)))
            .collect();
        let q = inverse_path(&cfg, 250.0, &poses).unwrap();
        let c0 = q[0][4];
        for (k, j) in q.iter().enumerate() {
            assert!(
                (j[4] - c0).abs() < 1e-12,
                "C moved at {k}: {} vs {c0}",
                j[4]
            );
        }
        // A passes through 0 and changes sign rather than C flipping 180 deg.
        assert!(q[0][3] * q[20][3] < 0.0);
        assert_eq!(q[10][3], 0.0);
        // A path that starts vertical takes C from its first tilted pose.
        let poses: Vec<([f64; 3], [f64; 3])> = (0..5)
            .map(|k| {
                (
                    [0.0; 3],
                    [0.0, -(k as f64 * 0.1).sin(), (k as f64 * 0.1).cos()],
                )
            })
            .collect();
        let q = inverse_path(&cfg, 250.0, &poses).unwrap();
        assert!(q.iter().all(|j| j[4].abs() < 1e-12), "{q:?}");
    }

    #[test]
    fn c_is_continuous_across_the_half_turn() {
        let cfg = Mill5Config::default();
        // Axis precesses at 30 deg tilt through 300 deg of azimuth, across +-180.
        let poses: Vec<([f64; 3], [f64; 3])> = (0..=300)
            .map(|k| {
                let az = (100.0 + k as f64).to_radians();
                let p = 30f64.to_radians();
                ([0.0; 3], [p.sin() * az.cos(), p.sin() * az.sin(), p.cos()])
            })
            .collect();
        let q = inverse_path(&cfg, 250.0, &poses).unwrap();
        for w in q.windows(2) {
            assert!(
                (w[1][4] - w[0][4]).abs() < 2f64.to_radians(),
                "C jumps {} -> {}",
                w[0][4],
                w[1][4]
            );
            assert!((w[1][3] - w[0][3]).abs() < 1e-9);
        }
        let span = (q[300][4] - q[0][4]).to_degrees();
        assert!((span - 300.0).abs() < 1e-6, "{span}");
    }
}
