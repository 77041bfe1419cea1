//! The Paden-Kahan subproblems: the geometric pieces every closed-form
//! inverse kinematics here is assembled from (docs/methods.md, "Machine
//! kinematics from URDF"). Axes are unit vectors; a rotation `Rot(u, t)` is
//! right-handed about `u`.
//!
//! Each returns every solution with a conditioning measure in [0, 1]: the
//! sine of the angle at which its two solutions meet, 0 where they merge (a
//! singularity of the mechanism that uses it).

use nalgebra::{Point3, Unit, UnitQuaternion, Vector3};

/// How far past the exact boundary (|cos| > 1, a negative square) rounding may
/// push a reachable pose; beyond it the pose is out of reach.
pub const ROUNDING: f64 = 1e-9;

pub fn rot(u: &Unit<Vector3<f64>>, t: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(u, t)
}

/// Subproblem 1: the angle `t` with `Rot(u, t) p = q` (the components of `p`
/// and `q` along `u` are assumed equal; only their perpendicular parts count).
pub fn sp1(u: &Unit<Vector3<f64>>, p: &Vector3<f64>, q: &Vector3<f64>) -> f64 {
    let pp = p - u.into_inner() * u.dot(p);
    let qp = q - u.into_inner() * u.dot(q);
    u.dot(&pp.cross(&qp)).atan2(pp.dot(&qp))
}

/// One solution of subproblem 2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sp2 {
    pub t1: f64,
    pub t2: f64,
    /// Sine of the angle between `u1` and `Rot(u2, t2) v`: 0 where `t1` is free.
    pub conditioning: f64,
}

/// Subproblem 2: the angles with `Rot(u1, t1) Rot(u2, t2) v = b` (`u1`, `u2`
/// not parallel, |v| = |b|). Up to two solutions; when `b` lies along `u1`
/// the first angle is free and `hold1` is kept (one solution); when `v` lies
/// along `u2` the second is free and `hold2` is kept. Empty when out of reach.
pub fn sp2(
    u1: &Unit<Vector3<f64>>,
    u2: &Unit<Vector3<f64>>,
    v: &Vector3<f64>,
    b: &Vector3<f64>,
    hold1: f64,
    hold2: f64,
) -> Vec<Sp2> {
    const ALONG: f64 = 1e-9;
    let scale = v.norm().max(1e-300);
    if (b - u1.into_inner() * u1.dot(b)).norm() <= ALONG * scale {
        // b on the first axis: c = b and only the second rotation matters.
        if (u2.dot(v) - u2.dot(b)).abs() > ROUNDING * scale {
            return Vec::new();
        }
        return vec![Sp2 {
            t1: hold1,
            t2: sp1(u2, v, b),
            conditioning: 0.0,
        }];
    }
    if (v - u2.into_inner() * u2.dot(v)).norm() <= ALONG * scale {
        if (u1.dot(v) - u1.dot(b)).abs() > ROUNDING * scale {
            return Vec::new();
        }
        let c = rot(u2, hold2) * v;
        return vec![Sp2 {
            t1: sp1(u1, &c, b),
            t2: hold2,
            conditioning: u1.cross(&c).norm() / scale,
        }];
    }
    let c12 = u1.dot(u2);
    let denom = 1.0 - c12 * c12;
    let (ub, uv) = (u1.dot(b), u2.dot(v));
    let alpha = (ub - c12 * uv) / denom;
    let beta = (uv - c12 * ub) / denom;
    let g2 = (v.norm_squared() - alpha * alpha - beta * beta - 2.0 * alpha * beta * c12) / denom;
    if g2 < -ROUNDING * scale * scale {
        return Vec::new();
    }
    let gamma = g2.max(0.0).sqrt();
    let n = u1.cross(u2);
    let mut out = Vec::with_capacity(2);
    for s in [1.0, -1.0] {
        let c = u1.into_inner() * alpha + u2.into_inner() * beta + n * (s * gamma);
        out.push(Sp2 {
            t1: sp1(u1, &c, b),
            t2: sp1(u2, v, &c),
            conditioning: u1.cross(&c).norm() / scale,
        });
        if gamma == 0.0 {
            break;
        }
    }
    out
}

/// A unit vector perpendicular to `u`.
pub fn perpendicular(u: &Unit<Vector3<f64>>) -> Vector3<f64> {
    let p = if u.x.abs() < 0.9 {
        u.cross(&Vector3::x())
    } else {
        u.cross(&Vector3::y())
    };
    p.normalize()
}

/// Below this sine the third axis, carried by the first two rotations,
/// counts as lying on the first (gimbal lock).
pub const GIMBAL_LOCK: f64 = 1e-9;

/// Three rotations giving a rotation: the angles with
/// `Rot(w1, t1) Rot(w2, t2) Rot(w3, t3) = g` (no two consecutive axes
/// parallel), each with its conditioning (the sine of the angle between `w1`
/// and the carried `w3`). Subproblem 2 on `w3`, then subproblem 1 for `t3`;
/// in gimbal lock `t3` keeps `hold3` and the first two follow.
pub fn three_rotations(
    w: [&Unit<Vector3<f64>>; 3],
    g: &UnitQuaternion<f64>,
    hold3: f64,
) -> Vec<([f64; 3], f64)> {
    let [w1, w2, w3] = w;
    let b = g * w3.into_inner();
    if w1.cross(&b).norm() <= GIMBAL_LOCK {
        let h = g * rot(w3, hold3).inverse();
        let t1 = sp1(w1, &w2.into_inner(), &(h * w2.into_inner()));
        let p = perpendicular(w2);
        let t2 = sp1(w2, &p, &(rot(w1, t1).inverse() * (h * p)));
        return vec![([t1, t2, hold3], 0.0)];
    }
    let p = perpendicular(w3);
    sp2(w1, w2, &w3.into_inner(), &b, 0.0, 0.0)
        .iter()
        .map(|s| {
            let back = (rot(w1, s.t1) * rot(w2, s.t2)).inverse() * g;
            ([s.t1, s.t2, sp1(w3, &p, &(back * p))], s.conditioning)
        })
        .collect()
}

/// The angles `t` (with their conditioning) that solve `A cos t + B sin t = C`.
fn cos_sin(a: f64, b: f64, c: f64) -> Vec<(f64, f64)> {
    let r = a.hypot(b);
    if r < 1e-300 {
        return Vec::new();
    }
    let k = c / r;
    if k.abs() > 1.0 + ROUNDING {
        return Vec::new();
    }
    let k = k.clamp(-1.0, 1.0);
    let base = b.atan2(a);
    let d = k.acos();
    let cond = (1.0 - k * k).max(0.0).sqrt();
    if d == 0.0 {
        return vec![(base, cond)];
    }
    vec![(base + d, cond), (base - d, cond)]
}

/// Subproblem 3: the angles `t` with `|Rot_axis(t) p - q| = delta`, the axis
/// through `r` along `u`; with their conditioning (0 where the two meet).
pub fn sp3(
    r: &Point3<f64>,
    u: &Unit<Vector3<f64>>,
    p: &Point3<f64>,
    q: &Point3<f64>,
    delta: f64,
) -> Vec<(f64, f64)> {
    let (pp, qq) = (p - r, q - r);
    let up = pp - u.into_inner() * u.dot(&pp);
    let vq = qq - u.into_inner() * u.dot(&qq);
    let along = u.dot(&(pp - qq));
    let d2 = delta * delta - along * along;
    // |Rot(t) up - vq|^2 = |up|^2 + |vq|^2 - 2 up.Rot(-t) vq: in the form
    // A cos t + B sin t = C with A = up.vq, B = u.(up x vq).
    let a = up.dot(&vq);
    let b = u.dot(&up.cross(&vq));
    let c = (up.norm_squared() + vq.norm_squared() - d2) / 2.0;
    cos_sin(a, b, c)
}

/// Subproblem 4: the angles `t` with `d . (r + Rot(u, t) (p - r)) = h`, the
/// axis through `r` along `u`, `d` a unit direction; with their conditioning.
pub fn sp4(
    r: &Point3<f64>,
    u: &Unit<Vector3<f64>>,
    p: &Point3<f64>,
    d: &Unit<Vector3<f64>>,
    h: f64,
) -> Vec<(f64, f64)> {
    let pp = p - r;
    let par = u.into_inner() * u.dot(&pp);
    let perp = pp - par;
    let a = perp.dot(d);
    let b = u.cross(&perp).dot(d);
    let c = h - d.dot(&r.coords) - par.dot(d);
    cos_sin(a, b, c)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit(x: f64, y: f64, z: f64) -> Unit<Vector3<f64>> {
        Unit::new_normalize(Vector3::new(x, y, z))
    }

    /// A deterministic stream of numbers in [-1, 1) for test inputs.
    fn stream(seed: u64) -> impl FnMut() -> f64 {
        let mut s = seed;
        move || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        }
    }

    #[test]
    fn sp2_recovers_the_angles_that_made_b() {
        let mut r = stream(7);
        for _ in 0..500 {
            let u1 = unit(r(), r(), r());
            let u2 = unit(r(), r(), r());
            let v = Vector3::new(r(), r(), r()) * 3.0;
            let (t1, t2) = (3.0 * r(), 3.0 * r());
            let b = rot(&u1, t1) * (rot(&u2, t2) * v);
            let sols = sp2(&u1, &u2, &v, &b, 0.0, 0.0);
            assert!(!sols.is_empty());
            for s in &sols {
                let back = rot(&u1, s.t1) * (rot(&u2, s.t2) * v);
                assert!((back - b).norm() < 1e-9, "{s:?}");
            }
            let hit = sols.iter().any(|s| {
                (crate::angles::wrap(s.t1 - t1)).abs() < 1e-6
                    && (crate::angles::wrap(s.t2 - t2)).abs() < 1e-6
            });
            assert!(hit, "{sols:?} vs {t1} {t2}");
        }
    }

    #[test]
    fn sp2_holds_the_free_angle_on_the_axis_and_refuses_the_unreachable() {
        // A/C head: u1 = z (C), u2 = x (A), tool along z. Straight down needs A = pi.
        let (z, x) = (Vector3::z_axis(), Vector3::x_axis());
        let s = sp2(&z, &x, &Vector3::z(), &-Vector3::z(), 0.7, 0.0);
        assert_eq!(s.len(), 1);
        assert_eq!(s[0].t1, 0.7);
        assert!((s[0].t2.abs() - std::f64::consts::PI).abs() < 1e-12);
        // A nutating 45-degree head cannot tilt the tool beyond 90 degrees.
        let tilted = unit(0.0, 1.0, 1.0);
        let down = unit(1.0, 0.0, -1.0).into_inner();
        assert!(sp2(&z, &tilted, &Vector3::z(), &down, 0.0, 0.0).is_empty());
    }

    #[test]
    fn three_rotations_rebuild_the_rotation_and_hold_in_gimbal_lock() {
        let mut r = stream(3);
        for _ in 0..300 {
            let w = [
                unit(r(), r(), r()),
                unit(r(), r(), r()),
                unit(r(), r(), r()),
            ];
            let t = [3.0 * r(), 3.0 * r(), 3.0 * r()];
            let g = rot(&w[0], t[0]) * rot(&w[1], t[1]) * rot(&w[2], t[2]);
            let sols = three_rotations([&w[0], &w[1], &w[2]], &g, 0.0);
            assert!(!sols.is_empty());
            for (s, _) in &sols {
                let back = rot(&w[0], s[0]) * rot(&w[1], s[1]) * rot(&w[2], s[2]);
                assert!(back.angle_to(&g) < 1e-9);
            }
        }
        // Roll-pitch-yaw at pitch 90 deg: roll and yaw share an axis; roll is held.
        let (z, y, x) = (Vector3::z_axis(), Vector3::y_axis(), Vector3::x_axis());
        let g = rot(&z, 0.4) * rot(&y, std::f64::consts::FRAC_PI_2) * rot(&x, 0.1);
        let sols = three_rotations([&z, &y, &x], &g, 0.3);
        assert_eq!(sols.len(), 1);
        assert_eq!(sols[0].0[2], 0.3);
        let s = sols[0].0;
        assert!((rot(&z, s[0]) * rot(&y, s[1]) * rot(&x, s[2])).angle_to(&g) < 1e-9);
    }

    #[test]
    fn sp3_and_sp4_solutions_satisfy_their_equations() {
        let mut r = stream(11);
        for _ in 0..300 {
            let axis_p = Point3::new(r(), r(), r()) * 100.0;
            let u = unit(r(), r(), r());
            let p = Point3::new(r(), r(), r()) * 300.0;
            let q = Point3::new(r(), r(), r()) * 300.0;
            let t = 3.0 * r();
            let moved = axis_p + rot(&u, t) * (p - axis_p);
            let delta = (moved - q).norm();
            let sols = sp3(&axis_p, &u, &p, &q, delta);
            assert!(
                sols.iter()
                    .any(|s| crate::angles::wrap(s.0 - t).abs() < 1e-6),
                "{sols:?} {t}"
            );
            for (s, _) in sols {
                let m = axis_p + rot(&u, s) * (p - axis_p);
                assert!(((m - q).norm() - delta).abs() < 1e-8);
            }
            let d = unit(r(), r(), r());
            let h = d.dot(&moved.coords);
            let sols = sp4(&axis_p, &u, &p, &d, h);
            assert!(
                sols.iter()
                    .any(|s| crate::angles::wrap(s.0 - t).abs() < 1e-6),
                "{sols:?} {t}"
            );
            for (s, _) in sols {
                let m = axis_p + rot(&u, s) * (p - axis_p);
                assert!((d.dot(&m.coords) - h).abs() < 1e-8);
            }
        }
        // Beyond reach: no solution.
        let o = Point3::origin();
        assert!(sp3(
            &o,
            &Vector3::z_axis(),
            &Point3::new(1.0, 0.0, 0.0),
            &Point3::new(5.0, 0.0, 0.0),
            10.0
        )
        .is_empty());
    }
}
