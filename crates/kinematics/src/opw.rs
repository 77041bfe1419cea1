//! The OPW parameters of a 6R arm with a spherical wrist (Brandstoetter,
//! Angerer, Hofbaur 2014: a1, a2, b, c1, c2, c3, c4, with joint offsets and
//! sign corrections), read off the chain's geometry with all joints at
//! zero. The solver itself works on the chain's axes directly (see `arm`);
//! these parameters are for reports and for comparing a URDF with a
//! vendor's or the literature's kinematic data.
//!
//! Conventions as opw_kinematics: `q_opw = sign * q - offset`; the OPW
//! frame has z along axis 1 (pointing up where the URDF's base z does) and
//! x towards the shoulder with every joint at zero; `base` places it in the
//! chain's base, `flange_to_end` takes the OPW flange to the chain's end frame.

use crate::arm::zero_axes;
use crate::chain::Chain;
use nalgebra::{Isometry3, Matrix3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};

/// OPW parameters in mm and rad.
#[derive(Clone, Debug, PartialEq)]
pub struct OpwParameters {
    pub a1: f64,
    pub a2: f64,
    pub b: f64,
    pub c1: f64,
    pub c2: f64,
    pub c3: f64,
    pub c4: f64,
    pub offsets: [f64; 6],
    pub signs: [f64; 6],
    pub base: Isometry3<f64>,
    pub flange_to_end: Isometry3<f64>,
}

fn ry(t: f64) -> Rotation3<f64> {
    Rotation3::from_axis_angle(&Vector3::y_axis(), t)
}
fn rz(t: f64) -> Rotation3<f64> {
    Rotation3::from_axis_angle(&Vector3::z_axis(), t)
}
fn sign(x: f64) -> f64 {
    if x < 0.0 {
        -1.0
    } else {
        1.0
    }
}

impl OpwParameters {
    /// The OPW forward kinematics (the paper's): the chain's end frame in
    /// its base for joints `q` (chain order).
    pub fn forward(&self, q: &[f64]) -> Isometry3<f64> {
        let t: Vec<f64> = (0..6)
            .map(|i| q[i] * self.signs[i] - self.offsets[i])
            .collect();
        let psi3 = self.a2.atan2(self.c3);
        let k = self.a2.hypot(self.c3);
        let cx1 = self.c2 * t[1].sin() + k * (t[1] + t[2] + psi3).sin() + self.a1;
        let cz1 = self.c2 * t[1].cos() + k * (t[1] + t[2] + psi3).cos();
        let c = rz(t[0]) * Vector3::new(cx1, self.b, cz1) + Vector3::new(0.0, 0.0, self.c1);
        let r = rz(t[0]) * ry(t[1] + t[2]) * rz(t[3]) * ry(t[4]) * rz(t[5]);
        let flange = Isometry3::from_parts(
            Translation3::from(c + r * Vector3::z() * self.c4),
            UnitQuaternion::from_rotation_matrix(&r),
        );
        self.base * flange * self.flange_to_end
    }

    /// The parameters of a 6R chain (end frame `end` on its tip) when it is an
    /// OPW arm: axis 2 perpendicular to axis 1, 3 parallel to 2, 4 in the
    /// arm's plane, 4-5-6 through one point; checked against the chain's
    /// forward kinematics.
    pub fn of_chain(chain: &Chain, end: &Isometry3<f64>) -> Option<Self> {
        if chain.dof() != 6 || chain.joints.iter().any(|j| !j.kind.is_rotary()) {
            return None;
        }
        let (w, p) = zero_axes(chain);
        let s1 = sign(w[0].z);
        let z0 = w[0].into_inner() * s1;
        let o0 = p[0] - z0 * z0.dot(&p[0].coords);
        if w[1].dot(&z0).abs() > 1e-9 {
            return None;
        }
        let mut y0 = w[1].into_inner();
        if y0.cross(&z0).dot(&(p[1] - o0)) < 0.0 {
            y0 = -y0;
        }
        let x0 = y0.cross(&z0);
        let rbase = Matrix3::from_columns(&[x0, y0, z0]);
        let local = |v: Vector3<f64>| rbase.transpose() * v;
        let (p2, p3) = (local(p[1] - o0), local(p[2] - o0));
        let wc = meet_all(&w, &p)?;
        let wcl = local(wc - o0);
        let (a1, c1) = (p2.x, p2.z);
        let d23 = p3 - p2;
        let c2 = d23.x.hypot(d23.z);
        let q2_0 = d23.x.atan2(d23.z);
        let w4 = local(w[3].into_inner());
        let along = (wcl - p3).dot(&w4);
        let f = if along < 0.0 { -w4 } else { w4 };
        if f.y.abs() > 1e-9 || local(w[2].into_inner()).cross(&Vector3::y()).norm() > 1e-9 {
            return None;
        }
        let q23_0 = f.x.atan2(f.z);
        let xp = Vector3::new(q23_0.cos(), 0.0, -q23_0.sin());
        let (a2, c3, b) = ((wcl - p3).dot(&xp), (wcl - p3).dot(&f), wcl.y);
        let wrist = ry(q23_0);
        let k5 = wrist.transpose() * local(w[4].into_inner());
        let (s5, q4_0) = if k5.y >= 0.0 {
            (1.0, (-k5.x).atan2(k5.y))
        } else {
            (-1.0, k5.x.atan2(-k5.y))
        };
        let w4r = wrist * rz(q4_0);
        let k6 = w4r.transpose() * local(w[5].into_inner());
        let (s6, q5_0) = if k6.z >= 0.0 {
            (1.0, k6.x.atan2(k6.z))
        } else {
            (-1.0, (-k6.x).atan2(-k6.z))
        };
        let re = w4r * ry(q5_0);
        let e0 = chain.forward(&[0.0; 6]) * end;
        let c4 = (local(e0.translation.vector - o0.coords) - wcl).dot(&(re * Vector3::z()));
        let signs = [
            s1,
            sign(local(w[1].into_inner()).y),
            sign(local(w[2].into_inner()).y),
            sign(w4.dot(&f)),
            s5,
            s6,
        ];
        let base = Isometry3::from_parts(
            Translation3::from(o0.coords),
            UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(rbase)),
        );
        let mut opw = Self {
            a1,
            a2,
            b,
            c1,
            c2,
            c3,
            c4,
            offsets: [0.0, -q2_0, -(q23_0 - q2_0), -q4_0, -q5_0, 0.0],
            signs,
            base,
            flange_to_end: Isometry3::identity(),
        };
        opw.flange_to_end = opw.forward(&[0.0; 6]).inverse() * e0;
        opw.matches(chain, end).then_some(opw)
    }

    /// Whether the parameters reproduce the chain on a fixed set of joints.
    fn matches(&self, chain: &Chain, end: &Isometry3<f64>) -> bool {
        (0..12).all(|k| {
            let q: Vec<f64> = (0..6)
                .map(|j| ((k * 7 + j * 3) % 11) as f64 * 0.55 - 2.7)
                .collect();
            let a = self.forward(&q);
            let b = chain.forward(&q) * end;
            (a.translation.vector - b.translation.vector).norm() < 1e-6
                && a.rotation.angle_to(&b.rotation) < 1e-9
        })
    }
}

/// The point where axes 4, 5 and 6 meet, if they do.
fn meet_all(w: &[nalgebra::Unit<Vector3<f64>>; 6], p: &[Point3<f64>; 6]) -> Option<Point3<f64>> {
    let (u, v) = (w[3].into_inner(), w[4].into_inner());
    let b = u.dot(&v);
    let denom = 1.0 - b * b;
    if denom < 1e-12 {
        return None;
    }
    let w0 = p[3] - p[4];
    let (d, e) = (u.dot(&w0), v.dot(&w0));
    let a = p[3] + u * ((b * e - d) / denom);
    let c = p[4] + v * ((e - b * d) / denom);
    let x = Point3::from((a.coords + c.coords) / 2.0);
    let r = x - p[5];
    let off6 = (r - w[5].into_inner() * w[5].dot(&r)).norm();
    ((a - c).norm() < 1e-6 && off6 < 1e-6).then_some(x)
}
