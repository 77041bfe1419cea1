//! Shared test helpers: a seeded generator, URDFs written from published
//! kinematic parameters, and pose comparisons.
#![allow(dead_code)]

use nalgebra::{Isometry3, Matrix4, Rotation3, Vector3};
use toolpath_kinematics::{Machine, MachineDef, Target, UrdfModel};

/// A deterministic generator (SplitMix64) for seeded random test inputs.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }
    /// SplitMix64's next output ([`toolpath_kernel::rng::SplitMix64`]).
    pub fn next_u64(&mut self) -> u64 {
        let mut g = toolpath_kernel::rng::SplitMix64(self.0);
        let x = g.next_u64();
        self.0 = g.0;
        x
    }
    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
    }
}

pub fn repo_file(rel: &str) -> String {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(rel);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// A URDF of a 6R arm from standard Denavit-Hartenberg parameters (metres,
/// radians): `T_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)`; joint i turns
/// about z of frame i-1, so joint i's origin is frame i-1's fixed part.
pub fn dh_urdf(name: &str, d: [f64; 6], a: [f64; 6], alpha: [f64; 6], limit: f64) -> String {
    let mut s = format!("<robot name=\"{name}\">\n<link name=\"base_link\"/>\n");
    for i in 1..=6 {
        s += &format!("<link name=\"link{i}\"/>\n");
    }
    s += "<link name=\"tool0\"/>\n";
    for i in 0..6 {
        let parent = if i == 0 {
            "base_link".to_string()
        } else {
            format!("link{i}")
        };
        let (x, z, r) = if i == 0 {
            (0.0, 0.0, 0.0)
        } else {
            (a[i - 1], d[i - 1], alpha[i - 1])
        };
        s += &format!(
            "<joint name=\"joint{}\" type=\"revolute\"><parent link=\"{parent}\"/><child link=\"link{}\"/>\
             <origin xyz=\"{x} 0 {z}\" rpy=\"{r} 0 0\"/><axis xyz=\"0 0 1\"/>\
             <limit lower=\"{}\" upper=\"{limit}\" velocity=\"3.15\" effort=\"1\"/></joint>\n",
            i + 1,
            i + 1,
            -limit
        );
    }
    s += &format!(
        "<joint name=\"flange\" type=\"fixed\"><parent link=\"link6\"/><child link=\"tool0\"/>\
         <origin xyz=\"{} 0 {}\" rpy=\"{} 0 0\"/></joint>\n</robot>\n",
        a[5], d[5], alpha[5]
    );
    s
}

/// The DH product itself (mm), the independent reference for [`dh_urdf`].
pub fn dh_forward(d: [f64; 6], a: [f64; 6], alpha: [f64; 6], q: &[f64]) -> Matrix4<f64> {
    let mut t = Matrix4::identity();
    for i in 0..6 {
        let rz = Rotation3::from_axis_angle(&Vector3::z_axis(), q[i]).to_homogeneous();
        let tz = Matrix4::new_translation(&Vector3::new(0.0, 0.0, d[i] * 1000.0));
        let tx = Matrix4::new_translation(&Vector3::new(a[i] * 1000.0, 0.0, 0.0));
        let rx = Rotation3::from_axis_angle(&Vector3::x_axis(), alpha[i]).to_homogeneous();
        t = t * rz * tz * tx * rx;
    }
    t
}

pub const UR5_D: [f64; 6] = [0.089159, 0.0, 0.0, 0.10915, 0.09465, 0.0823];
pub const UR5_A: [f64; 6] = [0.0, -0.425, -0.39225, 0.0, 0.0, 0.0];
pub const UR10_D: [f64; 6] = [0.1273, 0.0, 0.0, 0.163941, 0.1157, 0.0922];
pub const UR10_A: [f64; 6] = [0.0, -0.612, -0.5723, 0.0, 0.0, 0.0];
pub const UR_ALPHA: [f64; 6] = [
    std::f64::consts::FRAC_PI_2,
    0.0,
    0.0,
    std::f64::consts::FRAC_PI_2,
    -std::f64::consts::FRAC_PI_2,
    0.0,
];

/// OPW parameters (Brandstoetter, Angerer, Hofbaur 2014), metres, with the
/// offsets and sign corrections of opw_kinematics' convention:
/// `q_opw = sign * q_robot - offset`.
#[derive(Clone, Copy, Debug)]
pub struct Opw {
    pub a1: f64,
    pub a2: f64,
    pub b: f64,
    pub c1: f64,
    pub c2: f64,
    pub c3: f64,
    pub c4: f64,
    pub offsets: [f64; 6],
    pub signs: [f64; 6],
}

/// KUKA KR6 R700 sixx, as published with opw_kinematics.
pub const KR6_R700: Opw = Opw {
    a1: 0.025,
    a2: -0.035,
    b: 0.0,
    c1: 0.400,
    c2: 0.315,
    c3: 0.365,
    c4: 0.080,
    offsets: [0.0, -std::f64::consts::FRAC_PI_2, 0.0, 0.0, 0.0, 0.0],
    signs: [-1.0, 1.0, 1.0, -1.0, 1.0, -1.0],
};

/// ABB IRB 2400/10, as published with opw_kinematics.
pub const IRB2400: Opw = Opw {
    a1: 0.100,
    a2: -0.135,
    b: 0.0,
    c1: 0.615,
    c2: 0.705,
    c3: 0.755,
    c4: 0.085,
    offsets: [0.0, 0.0, -std::f64::consts::FRAC_PI_2, 0.0, 0.0, 0.0],
    signs: [1.0; 6],
};

/// The OPW forward kinematics of the paper (mm): the flange in the base.
pub fn opw_forward(p: &Opw, q_robot: &[f64]) -> Isometry3<f64> {
    let q: Vec<f64> = (0..6)
        .map(|i| q_robot[i] * p.signs[i] - p.offsets[i])
        .collect();
    let psi3 = p.a2.atan2(p.c3);
    let k = (p.a2 * p.a2 + p.c3 * p.c3).sqrt();
    let cx1 = p.c2 * q[1].sin() + k * (q[1] + q[2] + psi3).sin() + p.a1;
    let cy1 = p.b;
    let cz1 = p.c2 * q[1].cos() + k * (q[1] + q[2] + psi3).cos();
    let c = Vector3::new(
        cx1 * q[0].cos() - cy1 * q[0].sin(),
        cx1 * q[0].sin() + cy1 * q[0].cos(),
        cz1 + p.c1,
    );
    let r0c = Rotation3::from_axis_angle(&Vector3::z_axis(), q[0])
        * Rotation3::from_axis_angle(&Vector3::y_axis(), q[1] + q[2]);
    let rce = Rotation3::from_axis_angle(&Vector3::z_axis(), q[3])
        * Rotation3::from_axis_angle(&Vector3::y_axis(), q[4])
        * Rotation3::from_axis_angle(&Vector3::z_axis(), q[5]);
    let r = r0c * rce;
    let u = (c + r * Vector3::z() * p.c4) * 1000.0;
    Isometry3::from_parts(u.into(), nalgebra::UnitQuaternion::from_rotation_matrix(&r))
}

/// A URDF of an OPW robot: every link frame parallel to the base at its
/// joint's point in the robot's zero pose (`q_opw = -offset`), each axis the
/// OPW axis there times the sign correction; `tool0` is the OPW flange.
pub fn opw_urdf(name: &str, p: &Opw, limit: f64) -> String {
    let q0: Vec<f64> = (0..6).map(|i| -p.offsets[i]).collect();
    let rz = |t: f64| Rotation3::from_axis_angle(&Vector3::z_axis(), t);
    let ry = |t: f64| Rotation3::from_axis_angle(&Vector3::y_axis(), t);
    let r1 = rz(q0[0]);
    let j2 = r1 * Vector3::new(p.a1, 0.0, p.c1);
    let j3 = j2 + r1 * ry(q0[1]) * Vector3::new(0.0, 0.0, p.c2);
    let r23 = r1 * ry(q0[1] + q0[2]);
    let wc =
        j3 + r1 * (ry(q0[1] + q0[2]) * Vector3::new(p.a2, 0.0, p.c3) + Vector3::new(0.0, p.b, 0.0));
    let j3 = j3 + r1 * Vector3::new(0.0, p.b, 0.0);
    let r4 = r23 * rz(q0[3]);
    let r5 = r4 * ry(q0[4]);
    let r6 = r5 * rz(q0[5]);
    let axes = [
        Vector3::z(),
        r1 * Vector3::y(),
        r1 * Vector3::y(),
        r23 * Vector3::z(),
        r4 * Vector3::y(),
        r5 * Vector3::z(),
    ];
    let points = [Vector3::zeros(), j2, j3, wc, wc, wc];
    let flange = wc + r6 * Vector3::z() * p.c4;
    let mut s =
        format!("<robot name=\"{name}\">\n<link name=\"base_link\"/><link name=\"tool0\"/>\n");
    let mut prev = Vector3::zeros();
    for i in 0..6 {
        let parent = if i == 0 {
            "base_link".to_string()
        } else {
            format!("link{i}")
        };
        let o = points[i] - prev;
        let a = axes[i] * p.signs[i];
        s += &format!(
            "<link name=\"link{}\"/><joint name=\"joint_{}\" type=\"revolute\"><parent link=\"{parent}\"/><child link=\"link{}\"/>\
             <origin xyz=\"{} {} {}\" rpy=\"0 0 0\"/><axis xyz=\"{} {} {}\"/>\
             <limit lower=\"{}\" upper=\"{limit}\" velocity=\"3\" effort=\"1\"/></joint>\n",
            i + 1, i + 1, i + 1, o.x, o.y, o.z, a.x, a.y, a.z, -limit
        );
        prev = points[i];
    }
    let o = flange - prev;
    let (r, pi, y) = r6.euler_angles();
    s += &format!(
        "<joint name=\"flange\" type=\"fixed\"><parent link=\"link6\"/><child link=\"tool0\"/>\
         <origin xyz=\"{} {} {}\" rpy=\"{r} {pi} {y}\"/></joint>\n</robot>\n",
        o.x, o.y, o.z
    );
    s
}

pub fn machine(urdf: &str, base: &str, tool: &str) -> Machine {
    let m = UrdfModel::parse(urdf).unwrap();
    Machine::from_urdf(
        &m,
        &MachineDef::holds_tool(base, tool, Isometry3::identity(), Isometry3::identity()),
    )
    .unwrap()
}

/// Position (mm) and rotation (rad) distance of two poses.
pub fn distance(a: &Isometry3<f64>, b: &Isometry3<f64>) -> (f64, f64) {
    (
        (a.translation.vector - b.translation.vector).norm(),
        a.rotation.angle_to(&b.rotation),
    )
}

/// Random joints inside each joint's limits (continuous: one turn), shrunk by `margin`.
pub fn random_joints(m: &Machine, r: &mut Rng, margin: f64) -> Vec<f64> {
    m.limits()
        .iter()
        .map(|l| {
            let (lo, hi) = if l.lower.is_finite() {
                (l.lower, l.upper)
            } else {
                (-std::f64::consts::PI, std::f64::consts::PI)
            };
            let w = (hi - lo) * margin;
            r.range(lo + w, hi - w)
        })
        .collect()
}

/// Whether `a` and `b` are the same joints (rotary modulo a turn).
pub fn same(m: &Machine, a: &[f64], b: &[f64], tol: f64) -> bool {
    a.iter().zip(b).zip(m.joint_kinds()).all(|((x, y), k)| {
        let d = if k.is_rotary() {
            toolpath_kinematics::angles::wrap(x - y)
        } else {
            x - y
        };
        d.abs() <= tol
    })
}

pub fn axis_target(x: &Isometry3<f64>) -> Target {
    let a = -(x.rotation * Vector3::z());
    Target::axis(x.translation.vector.into(), a.into()).unwrap()
}
