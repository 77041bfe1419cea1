//! Forward kinematics and the Jacobian against independent references:
//! hand-composed transforms, the DH product, the built-in machines' own
//! formulas, and finite differences.

mod common;

use common::*;
use nalgebra::{Isometry3, Matrix4, Rotation3, Translation3, UnitQuaternion, Vector3};
use std::f64::consts::PI;
use toolpath_kinematics::{xyz_rpy, Machine, MachineDef, UrdfModel};

/// A small arm with every kind of joint, offsets and rotated origins.
const SMALL: &str = r#"<robot name="small">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="l3"/><link name="tip"/>
  <joint name="turn" type="continuous"><parent link="base"/><child link="l1"/>
    <origin xyz="0.1 0.2 0.3" rpy="0.1 0.2 0.3"/><axis xyz="0 0 1"/></joint>
  <joint name="slide" type="prismatic"><parent link="l1"/><child link="l2"/>
    <origin xyz="0 0.05 0" rpy="0 1.5707963267948966 0"/><axis xyz="0 1 1"/>
    <limit lower="-0.2" upper="0.2" velocity="0.1" effort="1"/></joint>
  <joint name="bend" type="revolute"><parent link="l2"/><child link="l3"/>
    <origin xyz="0.4 0 0" rpy="0 0 -0.5"/><axis xyz="1 0 0"/>
    <limit lower="-2" upper="2" velocity="1" effort="1"/></joint>
  <joint name="tip_j" type="fixed"><parent link="l3"/><child link="tip"/>
    <origin xyz="0 0 0.1" rpy="3.141592653589793 0 0"/></joint>
</robot>"#;

fn h(xyz_m: [f64; 3], rpy: [f64; 3]) -> Matrix4<f64> {
    let t =
        Translation3::new(xyz_m[0] * 1000.0, xyz_m[1] * 1000.0, xyz_m[2] * 1000.0).to_homogeneous();
    let r = Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]).to_homogeneous();
    t * r
}

#[test]
fn a_small_urdf_matches_hand_composed_transforms() {
    let m = machine(SMALL, "base", "tip");
    assert_eq!(m.joint_names(), ["turn", "slide", "bend"]);
    let mut r = Rng::new(1);
    for _ in 0..50 {
        let q = [
            r.range(-7.0, 7.0),
            r.range(-200.0, 200.0),
            r.range(-2.0, 2.0),
        ];
        let axis = Vector3::new(0.0, 1.0, 1.0).normalize();
        let expect = h([0.1, 0.2, 0.3], [0.1, 0.2, 0.3])
            * Rotation3::from_axis_angle(&Vector3::z_axis(), q[0]).to_homogeneous()
            * h([0.0, 0.05, 0.0], [0.0, PI / 2.0, 0.0])
            * Translation3::from(axis * q[1]).to_homogeneous()
            * h([0.4, 0.0, 0.0], [0.0, 0.0, -0.5])
            * Rotation3::from_axis_angle(&Vector3::x_axis(), q[2]).to_homogeneous()
            * h([0.0, 0.0, 0.1], [PI, 0.0, 0.0]);
        let got = m.forward(&q).unwrap().to_homogeneous();
        assert!((got - expect).abs().max() < 1e-9, "{got} vs {expect}");
    }
}

#[test]
fn a_dh_urdf_of_ur5_and_ur10_matches_the_dh_product() {
    for (d, a) in [(UR5_D, UR5_A), (UR10_D, UR10_A)] {
        let m = machine(
            &dh_urdf("ur", d, a, UR_ALPHA, 2.0 * PI),
            "base_link",
            "tool0",
        );
        let mut r = Rng::new(2);
        for _ in 0..100 {
            let q = random_joints(&m, &mut r, 0.0);
            let got = m.forward(&q).unwrap().to_homogeneous();
            let expect = dh_forward(d, a, UR_ALPHA, &q);
            assert!((got - expect).abs().max() < 1e-9);
        }
    }
}

#[test]
fn urdfs_of_published_opw_robots_match_the_opw_forward_kinematics() {
    for p in [KR6_R700, IRB2400] {
        let m = machine(&opw_urdf("opw", &p, PI), "base_link", "tool0");
        let mut r = Rng::new(3);
        for _ in 0..100 {
            let q = random_joints(&m, &mut r, 0.0);
            let (dp, da) = distance(&m.forward(&q).unwrap(), &opw_forward(&p, &q));
            assert!(dp < 1e-9 && da < 1e-12, "{dp} {da}");
        }
    }
}

/// mill5's formulas (src/machines/mill5.rs): axis = Rz(C) Rx(A) z =
/// (sin A sin C, -sin A cos C, cos A); tip = pivot - L axis in the
/// workpiece frame, `pivot = origin + R p`, R the workpiece rotation.
fn mill5_formula(origin: [f64; 3], rpy: [f64; 3], l: f64, q: &[f64]) -> ([f64; 3], [f64; 3]) {
    let (sa, ca) = q[3].sin_cos();
    let (sc, cc) = q[4].sin_cos();
    let r = Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]);
    let axis = r.transpose() * Vector3::new(sa * sc, -sa * cc, ca);
    let pivot = r.transpose() * (Vector3::new(q[0], q[1], q[2]) - Vector3::from(origin));
    let tip = pivot - axis * l;
    (tip.into(), axis.into())
}

#[test]
fn mill5_as_urdf_equals_the_mill5_formulas() {
    let model = UrdfModel::parse(&repo_file("launch_configs/urdf/mill5.urdf")).unwrap();
    let (origin, rpy, tool_length) = ([2500.0, 1000.0, 300.0], [0.1, -0.2, 0.7], 30.0);
    let def = MachineDef::holds_tool(
        "mill5_base",
        "tool0",
        xyz_rpy([0.0, 0.0, tool_length], [0.0; 3]),
        xyz_rpy(origin, rpy),
    );
    let m = Machine::from_urdf(&model, &def).unwrap();
    assert_eq!(m.joint_names(), ["X", "Y", "Z", "A", "C"]);
    let l = m.limits();
    assert_eq!(
        (l[0].lower, l[0].upper, l[0].velocity),
        (0.0, 6000.0, Some(500.0))
    );
    assert!(
        (l[3].upper.to_degrees() - 95.0).abs() < 1e-9
            && (l[4].lower.to_degrees() + 220.0).abs() < 1e-9
    );
    let mut r = Rng::new(4);
    for _ in 0..200 {
        let q = random_joints(&m, &mut r, 0.0);
        let x = m.forward(&q).unwrap();
        let (tip, axis) = mill5_formula(origin, rpy, 250.0 + tool_length, &q);
        assert!((x.translation.vector - Vector3::from(tip)).norm() < 1e-9);
        assert!((-(x.rotation * Vector3::z()) - Vector3::from(axis)).norm() < 1e-12);
    }
}

/// belt6's formulas (src/machines/belt6.rs): wheel frame Rz(C) Ry(B) Rx(A)
/// at (X, Y, Z); axis = its x, normal = its z, all in the workpiece frame.
#[test]
fn belt6_as_urdf_equals_the_belt6_formulas() {
    let model = UrdfModel::parse(&repo_file("launch_configs/urdf/belt6.urdf")).unwrap();
    let (origin, rpy) = ([1500.0, 1000.0, 400.0], [0.3, 0.0, -1.2]);
    let def = MachineDef::holds_tool(
        "belt6_base",
        "wheel",
        Isometry3::identity(),
        xyz_rpy(origin, rpy),
    );
    let m = Machine::from_urdf(&model, &def).unwrap();
    assert_eq!(m.joint_names(), ["X", "Y", "Z", "A", "B", "C"]);
    let mut r = Rng::new(5);
    for _ in 0..200 {
        let q = random_joints(&m, &mut r, 0.0);
        let x = m.forward(&q).unwrap();
        let w = Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]);
        let frame = Rotation3::from_euler_angles(q[3], q[4], q[5]);
        let centre = w.transpose() * (Vector3::new(q[0], q[1], q[2]) - Vector3::from(origin));
        let axis = w.transpose() * (frame * Vector3::x());
        let normal = w.transpose() * (frame * Vector3::z());
        assert!((x.translation.vector - centre).norm() < 1e-9);
        assert!((x.rotation * Vector3::x() - axis).norm() < 1e-12);
        assert!((x.rotation * Vector3::z() - normal).norm() < 1e-12);
    }
}

#[test]
fn the_jacobian_matches_finite_differences_on_both_sides() {
    // trunnion5: the part rides A and C (its joints move the part, so they
    // count negative in the tool's motion relative to the part).
    let model = UrdfModel::parse(&repo_file("launch_configs/urdf/trunnion5.urdf")).unwrap();
    let def = MachineDef {
        part_link: "table".into(),
        workpiece: xyz_rpy([20.0, -10.0, 30.0], [0.0, 0.0, 0.4]),
        ..MachineDef::holds_tool(
            "base_link",
            "tool0",
            xyz_rpy([0.0, 0.0, 80.0], [0.0; 3]),
            Isometry3::identity(),
        )
    };
    let machines = [
        Machine::from_urdf(&model, &def).unwrap(),
        machine(SMALL, "base", "tip"),
        machine(
            &dh_urdf("ur", UR5_D, UR5_A, UR_ALPHA, 2.0 * PI),
            "base_link",
            "tool0",
        ),
    ];
    let mut r = Rng::new(6);
    for m in &machines {
        for _ in 0..30 {
            let q = random_joints(m, &mut r, 0.1);
            let (x, j) = m.jacobian(&q).unwrap();
            for c in 0..m.dof() {
                let h = 1e-6;
                let (mut qp, mut qm) = (q.clone(), q.clone());
                qp[c] += h;
                qm[c] -= h;
                let (xp, xm) = (m.forward(&qp).unwrap(), m.forward(&qm).unwrap());
                let v = (xp.translation.vector - xm.translation.vector) / (2.0 * h);
                let w = (xp.rotation * xm.rotation.inverse()).scaled_axis() / (2.0 * h);
                let col = j.column(c);
                assert!(
                    (v - Vector3::new(col[0], col[1], col[2])).norm() < 1e-4 * (1.0 + v.norm()),
                    "{v} {col}"
                );
                assert!(
                    (w - Vector3::new(col[3], col[4], col[5])).norm() < 1e-6,
                    "{w} {col}"
                );
            }
            assert!(x.translation.vector.iter().all(|c| c.is_finite()));
        }
    }
}

#[test]
fn a_robot_holding_the_part_sees_the_fixed_tool_through_the_inverse_flange() {
    // tool fixed in the cell at T; part on the flange at W: X = (F W)^-1 T.
    let urdf = dh_urdf("ur", UR5_D, UR5_A, UR_ALPHA, 2.0 * PI);
    let model = UrdfModel::parse(&urdf).unwrap();
    let tool = xyz_rpy([600.0, -200.0, 300.0], [PI, 0.2, 0.0]);
    let part = xyz_rpy([0.0, 0.0, 120.0], [0.0, 0.3, 0.0]);
    let m = Machine::from_urdf(
        &model,
        &MachineDef::holds_part("base_link", "tool0", part, tool),
    )
    .unwrap();
    let q = [0.1, -1.2, 1.4, -0.3, 1.1, 0.5];
    let flange = Isometry3::from(
        dh_forward(UR5_D, UR5_A, UR_ALPHA, &q)
            .fixed_view::<3, 1>(0, 3)
            .into_owned(),
    );
    let rot = UnitQuaternion::from_matrix(
        &dh_forward(UR5_D, UR5_A, UR_ALPHA, &q)
            .fixed_view::<3, 3>(0, 0)
            .into_owned(),
    );
    let f = Isometry3::from_parts(flange.translation, rot);
    let expect = (f * part).inverse() * tool;
    let (dp, da) = distance(&m.forward(&q).unwrap(), &expect);
    assert!(dp < 1e-9 && da < 1e-12);
}

#[test]
fn configured_limits_complete_and_override_the_urdf() {
    let model = UrdfModel::parse(&repo_file("launch_configs/urdf/trunnion5.urdf")).unwrap();
    let mut def = MachineDef {
        part_link: "table".into(),
        ..MachineDef::holds_tool(
            "base_link",
            "tool0",
            Isometry3::identity(),
            Isometry3::identity(),
        )
    };
    def.limits = vec![
        toolpath_kinematics::LimitOverride {
            joint: "X".into(),
            velocity: Some(250.0),
            acceleration: Some(1500.0),
            ..Default::default()
        },
        toolpath_kinematics::LimitOverride {
            joint: "C".into(),
            lower: Some(-4.0),
            upper: Some(4.0),
            ..Default::default()
        },
    ];
    let m = Machine::from_urdf(&model, &def).unwrap();
    let l = m.limits();
    // X: the URDF's travel (-400..400 mm) kept, its 500 mm/s replaced, acceleration added.
    assert_eq!(
        (l[0].lower, l[0].upper, l[0].velocity, l[0].acceleration),
        (-400.0, 400.0, Some(250.0), Some(1500.0))
    );
    // Y untouched: URDF 1.0 has no acceleration.
    assert_eq!((l[1].velocity, l[1].acceleration), (Some(500.0), None));
    // C was continuous (unlimited); a configured range limits it.
    assert_eq!((l[4].lower, l[4].upper), (-4.0, 4.0));
    def.limits[0].joint = "W".into();
    let e = Machine::from_urdf(&model, &def).unwrap_err().to_string();
    assert!(
        e.contains("joint \"W\", which is not one of the machine's joints (X, Y, Z, A, C)"),
        "{e}"
    );
    def.limits[0].joint = "X".into();
    def.limits[0].velocity = Some(-1.0);
    let e = Machine::from_urdf(&model, &def).unwrap_err().to_string();
    assert!(
        e.contains("velocity = -1 is not a positive finite number"),
        "{e}"
    );
    def.joint_order = Some(vec!["A".into(), "C".into(), "X".into(), "Y".into()]);
    let e = Machine::from_urdf(&model, &def).unwrap_err().to_string();
    assert!(e.contains("must name joint \"Z\" exactly once"), "{e}");
}
