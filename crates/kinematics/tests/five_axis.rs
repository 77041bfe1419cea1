//! 5-axis machines of every arrangement: table-table (trunnion5), head-head
//! and head-table, against hand-composed transforms, their own round trips,
//! and the numerical solver.

mod common;

use common::*;
use nalgebra::{Isometry3, Matrix4, Rotation3, Translation3, Vector3, Vector4};
use std::f64::consts::PI;
use toolpath_kinematics::{xyz_rpy, Machine, MachineDef, SolverChoice, Target, UrdfModel};

const TOOL_LENGTH: f64 = 80.0;

fn trunnion(workpiece: Isometry3<f64>) -> Machine {
    let model = UrdfModel::parse(&repo_file("launch_configs/urdf/trunnion5.urdf")).unwrap();
    let def = MachineDef {
        part_link: "table".into(),
        workpiece,
        ..MachineDef::holds_tool(
            "base_link",
            "tool0",
            xyz_rpy([0.0, 0.0, TOOL_LENGTH], [0.0; 3]),
            Isometry3::identity(),
        )
    };
    Machine::from_urdf(&model, &def).unwrap()
}

/// A B/C head on a gantry: C about z, B about y with the pivot 180 mm above
/// the gauge line and the spindle 20 mm off the B axis.
const HEAD_HEAD: &str = r#"<robot name="bc_head">
  <link name="base"/><link name="x"/><link name="y"/><link name="z"/><link name="c"/><link name="b"/><link name="tool0"/>
  <joint name="X" type="prismatic"><parent link="base"/><child link="x"/><axis xyz="1 0 0"/><limit lower="-2" upper="2" velocity="1" effort="0"/></joint>
  <joint name="Y" type="prismatic"><parent link="x"/><child link="y"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" velocity="1" effort="0"/></joint>
  <joint name="Z" type="prismatic"><parent link="y"/><child link="z"/><origin xyz="0 0 0.8"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1" effort="0"/></joint>
  <joint name="C" type="continuous"><parent link="z"/><child link="c"/><axis xyz="0 0 1"/></joint>
  <joint name="B" type="revolute"><parent link="c"/><child link="b"/><origin xyz="0.02 0 0"/><axis xyz="0 1 0"/><limit lower="-2.2" upper="2.2" velocity="1" effort="0"/></joint>
  <joint name="nose" type="fixed"><parent link="b"/><child link="tool0"/><origin xyz="0 0 -0.18" rpy="3.141592653589793 0 0"/></joint>
</robot>"#;

/// Head-table: C turns the table (part side), B tilts the head (tool side).
const HEAD_TABLE: &str = r#"<robot name="head_table">
  <link name="base"/><link name="x"/><link name="y"/><link name="z"/><link name="b"/><link name="tool0"/><link name="table"/>
  <joint name="X" type="prismatic"><parent link="base"/><child link="x"/><origin xyz="0 0 0.7"/><axis xyz="1 0 0"/><limit lower="-2" upper="2" velocity="1" effort="0"/></joint>
  <joint name="Y" type="prismatic"><parent link="x"/><child link="y"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" velocity="1" effort="0"/></joint>
  <joint name="Z" type="prismatic"><parent link="y"/><child link="z"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1" effort="0"/></joint>
  <joint name="B" type="revolute"><parent link="z"/><child link="b"/><axis xyz="0 1 0"/><limit lower="-1.7" upper="1.7" velocity="1" effort="0"/></joint>
  <joint name="nose" type="fixed"><parent link="b"/><child link="tool0"/><origin xyz="0 0 -0.25" rpy="3.141592653589793 0 0"/></joint>
  <joint name="C" type="continuous"><parent link="base"/><child link="table"/><origin xyz="0.1 -0.05 0.1"/><axis xyz="0 0 1"/></joint>
</robot>"#;

fn head_head() -> Machine {
    let model = UrdfModel::parse(HEAD_HEAD).unwrap();
    let def = MachineDef::holds_tool(
        "base",
        "tool0",
        xyz_rpy([0.0, 0.0, TOOL_LENGTH], [0.0; 3]),
        xyz_rpy([100.0, 200.0, 50.0], [0.0, 0.0, 0.3]),
    );
    Machine::from_urdf(&model, &def).unwrap()
}

fn head_table() -> Machine {
    let model = UrdfModel::parse(HEAD_TABLE).unwrap();
    let def = MachineDef {
        part_link: "table".into(),
        workpiece: xyz_rpy([30.0, 10.0, 40.0], [0.0, 0.0, 0.2]),
        ..MachineDef::holds_tool(
            "base",
            "tool0",
            xyz_rpy([0.0, 0.0, TOOL_LENGTH], [0.0; 3]),
            Isometry3::identity(),
        )
    };
    Machine::from_urdf(&model, &def).unwrap()
}

fn machines() -> Vec<(&'static str, Machine)> {
    vec![
        (
            "trunnion5",
            trunnion(xyz_rpy([20.0, -30.0, 15.0], [0.0, 0.0, 0.5])),
        ),
        ("head-head", head_head()),
        ("head-table", head_table()),
    ]
}

/// five_axis.rs's table formula: a workpiece point p sits in the machine at
/// `P_t + R_t (P_c - P_t + Rz(C) (W - P_c + p))`; the spindle is vertical,
/// its tip the tool length below the gauge point (X, Y, 600 + Z).
#[test]
fn the_trunnion_matches_the_table_formula() {
    let m = trunnion(Isometry3::translation(20.0, -30.0, 15.0));
    assert_eq!(m.joint_names(), ["X", "Y", "Z", "A", "C"]);
    let t = |p: Vector3<f64>| Translation3::from(p).to_homogeneous();
    let (pt, pc, w) = (
        Vector3::new(0.0, 0.0, 150.0),
        Vector3::new(0.0, 0.0, 200.0),
        Vector3::new(20.0, -30.0, 215.0),
    );
    let mut r = Rng::new(30);
    for _ in 0..100 {
        let q = random_joints(&m, &mut r, 0.0);
        let rt: Matrix4<f64> =
            Rotation3::from_axis_angle(&Vector3::x_axis(), q[3]).to_homogeneous();
        let rc: Matrix4<f64> =
            Rotation3::from_axis_angle(&Vector3::z_axis(), q[4]).to_homogeneous();
        let part = t(pt) * rt * t(-pt) * t(pc) * rc * t(-pc) * t(w);
        let inv = part.try_inverse().unwrap();
        let tip = inv * Vector4::new(q[0], q[1], 600.0 + q[2] - TOOL_LENGTH, 1.0);
        let axis = inv * Vector4::new(0.0, 0.0, 1.0, 0.0);
        let x = m.forward(&q).unwrap();
        assert!((x.translation.vector - tip.xyz()).norm() < 1e-9);
        assert!((-(x.rotation * Vector3::z()) - axis.xyz()).norm() < 1e-12);
    }
}

#[test]
fn every_arrangement_round_trips_with_both_rotary_solutions() {
    for (name, m) in machines() {
        assert!(
            m.solver_name().contains("2 rotary"),
            "{name}: {}",
            m.solver_name()
        );
        let mut r = Rng::new(31);
        let mut two = 0;
        for _ in 0..300 {
            let q = random_joints(&m, &mut r, 0.05);
            let target = axis_target(&m.forward(&q).unwrap());
            let Ok(sols) = m.inverse(&target, Some(&q)) else {
                panic!("{name}: {q:?} not solved");
            };
            for s in &sols {
                let (dp, da) =
                    toolpath_kinematics::pose::pose_error(&m.forward(s).unwrap(), &target);
                assert!(dp < 1e-6 && da < 1e-9, "{name}: {dp} {da}");
            }
            assert!(same(&m, &sols[0], &q, 1e-6), "{name}: {q:?} vs {sols:?}");
            if sols.len() == 2 {
                two += 1;
                // The other solution: the rotaries differ, the tool axis is the same.
                assert!(!same(&m, &sols[0], &sols[1], 1e-3));
            }
        }
        assert!(
            two > 100,
            "{name}: only {two} poses with two solutions in limits"
        );
    }
}

#[test]
fn the_closed_form_agrees_with_the_numerical_solver() {
    for (name, m) in machines() {
        let numeric = m.clone().with_solver(SolverChoice::Numeric);
        let mut r = Rng::new(32);
        for _ in 0..20 {
            let q = random_joints(&m, &mut r, 0.05);
            let target = axis_target(&m.forward(&q).unwrap());
            let closed = m.inverse(&target, None).unwrap();
            for s in numeric.inverse(&target, None).unwrap() {
                assert!(
                    closed.iter().any(|c| same(&m, c, &s, 1e-5)),
                    "{name}: {s:?} not in {closed:?}"
                );
            }
        }
    }
}

#[test]
fn a_precessing_axis_winds_the_continuous_table_without_jumps() {
    let m = trunnion(Isometry3::identity());
    // Axis 35 deg from the table's z, precessing three turns: C winds ~1080 deg.
    let pass: Vec<Target> = (0..=1080)
        .map(|k| {
            let az = (k as f64).to_radians();
            let tilt = 35f64.to_radians();
            Target::axis(
                [30.0 * az.cos(), 30.0 * az.sin(), 5.0],
                [tilt.sin() * az.cos(), tilt.sin() * az.sin(), tilt.cos()],
            )
            .unwrap()
        })
        .collect();
    let rows = m.solve_pass(0, &pass, None).unwrap();
    for (k, w) in rows.windows(2).enumerate() {
        assert!(
            (w[1][4] - w[0][4]).abs() < 2f64.to_radians(),
            "C jumps at {k}"
        );
        assert!((w[1][3] - w[0][3]).abs() < 1e-9, "A moves at {k}");
    }
    let span = (rows[1080][4] - rows[0][4]).abs().to_degrees();
    assert!((span - 1080.0).abs() < 1e-6, "{span}");
    // A within -120..30 deg: the tilt is -35 deg (the positive branch is out of its travel).
    assert!(
        (rows[0][3].to_degrees() + 35.0).abs() < 1e-9,
        "{}",
        rows[0][3].to_degrees()
    );
    for (t, q) in pass.iter().zip(&rows) {
        let (dp, da) = toolpath_kinematics::pose::pose_error(&m.forward(q).unwrap(), t);
        assert!(dp < 1e-6 && da < 1e-9);
    }
}

#[test]
fn passes_on_head_machines_are_smooth_and_exact() {
    for (name, m) in machines() {
        let mut r = Rng::new(33);
        for _ in 0..5 {
            let (p0, a0) = (r.range(0.2, 0.8), r.range(-PI, PI));
            let pass: Vec<Target> = (0..300)
                .map(|k| {
                    let t = k as f64 * 0.01;
                    let polar = p0 + 0.3 * t.sin();
                    let az = a0 + 2.0 * t;
                    Target::axis(
                        [40.0 * t.cos(), 20.0 * t, 10.0 * t.sin()],
                        [polar.sin() * az.cos(), polar.sin() * az.sin(), polar.cos()],
                    )
                    .unwrap()
                })
                .collect();
            let rows = m
                .solve_pass(0, &pass, None)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            for (t, q) in pass.iter().zip(&rows) {
                let (dp, da) = toolpath_kinematics::pose::pose_error(&m.forward(q).unwrap(), t);
                assert!(dp < 1e-6 && da < 1e-9, "{name}");
            }
            for w in rows.windows(2) {
                assert!(
                    (3..5).all(|j| (w[1][j] - w[0][j]).abs() < 0.1),
                    "{name}: {:?} -> {:?}",
                    w[0],
                    w[1]
                );
            }
        }
    }
}

#[test]
fn a_full_frame_on_a_five_axis_machine_is_refused() {
    let m = head_head();
    let e = m
        .inverse(&Target::Frame(Isometry3::identity()), None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("cannot set a full 6-D frame"), "{e}");
}
