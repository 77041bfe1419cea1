//! Time per pose of the solvers (a benchmark, not a test: run it in release,
//! `cargo run --release --example ik_speed`), with the largest FK error of
//! the answers.

use nalgebra::{Isometry3, Vector3};
use std::f64::consts::PI;
use std::time::Instant;
use toolpath_kinematics::pose::pose_error;
use toolpath_kinematics::{xyz_rpy, Machine, MachineDef, SolverChoice, Target, UrdfModel};

/// UR5 from its published DH parameters (standard DH, metres).
fn ur5_urdf() -> String {
    let d = [0.089159, 0.0, 0.0, 0.10915, 0.09465, 0.0823];
    let a = [0.0, -0.425, -0.39225, 0.0, 0.0, 0.0];
    let alpha = [PI / 2.0, 0.0, 0.0, PI / 2.0, -PI / 2.0, 0.0];
    let mut s =
        String::from("<robot name=\"ur5\"><link name=\"base_link\"/><link name=\"tool0\"/>");
    for i in 0..6 {
        let parent = if i == 0 {
            "base_link".to_string()
        } else {
            format!("l{i}")
        };
        let (x, z, r) = if i == 0 {
            (0.0, 0.0, 0.0)
        } else {
            (a[i - 1], d[i - 1], alpha[i - 1])
        };
        s += &format!(
            "<link name=\"l{}\"/><joint name=\"j{}\" type=\"revolute\"><parent link=\"{parent}\"/><child link=\"l{}\"/>\
             <origin xyz=\"{x} 0 {z}\" rpy=\"{r} 0 0\"/><axis xyz=\"0 0 1\"/><limit lower=\"-6.283\" upper=\"6.283\" velocity=\"3\" effort=\"1\"/></joint>",
            i + 1,
            i + 1,
            i + 1
        );
    }
    s + &format!(
        "<joint name=\"f\" type=\"fixed\"><parent link=\"l6\"/><child link=\"tool0\"/><origin xyz=\"0 0 {}\"/></joint></robot>",
        d[5]
    )
}

fn machine(urdf: &str, base: &str, tool: &str, tcp: Isometry3<f64>, wp: Isometry3<f64>) -> Machine {
    let m = UrdfModel::parse(urdf).unwrap();
    Machine::from_urdf(&m, &MachineDef::holds_tool(base, tool, tcp, wp)).unwrap()
}

/// Poses of a smooth joint curve of `m` around `q0`.
fn poses(m: &Machine, q0: &[f64], n: usize, frames: bool) -> Vec<Target> {
    (0..n)
        .map(|k| {
            let t = k as f64 / n as f64;
            let q: Vec<f64> = q0
                .iter()
                .enumerate()
                .map(|(j, x)| {
                    x + 0.3
                        * (PI * t + j as f64).sin()
                        * if j < 3 && m.joint_kinds()[j].is_rotary() {
                            1.0
                        } else if j < 3 {
                            100.0
                        } else {
                            1.0
                        }
                })
                .collect();
            let x = m.forward(&q).unwrap();
            if frames {
                Target::Frame(x)
            } else {
                let a = -(x.rotation * Vector3::z());
                Target::axis(x.translation.vector.into(), a.into()).unwrap()
            }
        })
        .collect()
}

fn report(
    name: &str,
    m: &Machine,
    targets: &[Target],
    f: impl Fn(&Machine, &[Target]) -> Vec<Vec<f64>>,
) {
    let t0 = Instant::now();
    let rows = f(m, targets);
    let dt = t0.elapsed().as_secs_f64();
    let (mut dp, mut da) = (0.0f64, 0.0f64);
    for (q, t) in rows.iter().zip(targets) {
        let (p, a) = pose_error(&m.forward(q).unwrap(), t);
        dp = dp.max(p);
        da = da.max(a);
    }
    println!(
        "{name:<44} {:>4} poses {:>9.1} us/pose   max FK error {dp:.1e} mm {da:.1e} rad   [{}]",
        rows.len(),
        dt * 1e6 / targets.len() as f64,
        m.solver_name()
    );
}

fn main() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../../launch_configs/urdf/");
    let read = |f: &str| std::fs::read_to_string(format!("{root}{f}")).unwrap();
    let mill5 = machine(
        &read("mill5.urdf"),
        "mill5_base",
        "tool0",
        xyz_rpy([0.0, 0.0, 30.0], [0.0; 3]),
        xyz_rpy([2500.0, 1000.0, 300.0], [0.0; 3]),
    );
    let belt6 = machine(
        &read("belt6.urdf"),
        "belt6_base",
        "wheel",
        Isometry3::identity(),
        xyz_rpy([1500.0, 1000.0, 400.0], [0.0; 3]),
    );
    let ur5 = machine(
        &ur5_urdf(),
        "base_link",
        "tool0",
        Isometry3::identity(),
        Isometry3::identity(),
    );
    let pass = |m: &Machine, t: &[Target]| m.solve_pass(0, t, None).unwrap();
    let single = |m: &Machine, t: &[Target]| {
        t.iter()
            .map(|x| m.inverse(x, None).unwrap().remove(0))
            .collect()
    };
    let n = 2000;
    report(
        "mill5 pass, 5-axis poses",
        &mill5,
        &poses(&mill5, &[2500.0, 1000.0, 800.0, 0.4, 0.3], n, false),
        pass,
    );
    report(
        "belt6 pass, frames",
        &belt6,
        &poses(&belt6, &[1500.0, 1000.0, 800.0, 0.2, 0.3, 0.4], n, true),
        pass,
    );
    let q0 = [0.3, -1.2, 1.3, -1.5, -1.4, 0.2];
    report(
        "UR5 single frame, all 8 solutions",
        &ur5,
        &poses(&ur5, &q0, n, true),
        single,
    );
    report(
        "UR5 pass, frames (one configuration)",
        &ur5,
        &poses(&ur5, &q0, n, true),
        pass,
    );
    report(
        "UR5 pass, 5-axis poses (72 angles about the axis)",
        &ur5,
        &poses(&ur5, &q0, 300, false),
        pass,
    );
    let numeric = ur5.clone().with_solver(SolverChoice::Numeric);
    report(
        "UR5 pass, frames, numerical",
        &numeric,
        &poses(&ur5, &q0, 300, true),
        pass,
    );
    report(
        "UR5 single frame, numerical, all seeds",
        &numeric,
        &poses(&ur5, &q0, 20, true),
        single,
    );
}
