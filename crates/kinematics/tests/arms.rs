//! 6R arms: closed forms (UR from published DH parameters, KUKA KR6 R700
//! and ABB IRB 2400 from published OPW parameters) against forward
//! kinematics and against the numerical solver; passes of 5-axis poses and
//! of full frames; out of reach and singular passes reported per point.

mod common;

use common::*;
use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};
use std::f64::consts::PI;
use toolpath_kinematics::{Error, Machine, MachineDef, SolverChoice, Target, UrdfModel};

fn arms() -> Vec<(&'static str, Machine)> {
    vec![
        (
            "ur5",
            machine(
                &dh_urdf("ur5", UR5_D, UR5_A, UR_ALPHA, 2.0 * PI),
                "base_link",
                "tool0",
            ),
        ),
        (
            "ur10",
            machine(
                &dh_urdf("ur10", UR10_D, UR10_A, UR_ALPHA, 2.0 * PI),
                "base_link",
                "tool0",
            ),
        ),
        (
            "kr6",
            machine(&opw_urdf("kr6", &KR6_R700, PI), "base_link", "tool0"),
        ),
        (
            "irb2400",
            machine(&opw_urdf("irb2400", &IRB2400, PI), "base_link", "tool0"),
        ),
    ]
}

#[test]
fn the_structures_are_recognised() {
    let names: Vec<&str> = arms().iter().map(|(_, m)| m.solver_name()).collect();
    assert!(
        names[0].contains("parallel axes 2-3-4") && names[1].contains("parallel axes 2-3-4"),
        "{names:?}"
    );
    assert!(
        names[2].contains("spherical wrist") && names[3].contains("spherical wrist"),
        "{names:?}"
    );
}

#[test]
fn the_published_opw_parameters_are_read_off_the_urdf() {
    for (name, p) in [("kr6", KR6_R700), ("irb2400", IRB2400)] {
        let m = machine(&opw_urdf(name, &p, PI), "base_link", "tool0");
        let o = m
            .opw_parameters()
            .unwrap_or_else(|| panic!("{name}: not recognised as OPW"));
        let got = [o.a1, o.a2, o.b, o.c1, o.c2, o.c3, o.c4];
        let want = [p.a1, p.a2, p.b, p.c1, p.c2, p.c3, p.c4].map(|x| x * 1000.0);
        assert!(
            got.iter().zip(&want).all(|(a, b)| (a - b).abs() < 1e-9),
            "{name}: {got:?} vs {want:?}"
        );
        assert!(
            o.offsets
                .iter()
                .zip(&p.offsets)
                .all(|(a, b)| (a - b).abs() < 1e-12),
            "{name}: {:?}",
            o.offsets
        );
        assert_eq!(o.signs, p.signs, "{name}");
        // The UR arms are not OPW (their wrist is not spherical).
    }
    let ur = machine(
        &dh_urdf("ur5", UR5_D, UR5_A, UR_ALPHA, 2.0 * PI),
        "base_link",
        "tool0",
    );
    assert!(ur.opw_parameters().is_none());
}

#[test]
fn random_joints_round_trip_through_every_closed_form_solution() {
    for (name, m) in arms() {
        let mut r = Rng::new(10);
        let mut counts = [0usize; 9];
        for _ in 0..300 {
            let q = random_joints(&m, &mut r, 0.0);
            let x = m.forward(&q).unwrap();
            let sols = m.inverse(&Target::Frame(x), Some(&q)).unwrap();
            counts[sols.len()] += 1;
            for s in &sols {
                let (dp, da) = distance(&m.forward(s).unwrap(), &x);
                assert!(dp < 1e-6 && da < 1e-9, "{name}: {dp} mm {da} rad");
                assert!(m.limits().iter().zip(s).all(|(l, v)| l.contains(*v, 1e-9)));
            }
            assert!(
                sols.iter().any(|s| same(&m, s, &q, 1e-6)),
                "{name}: {q:?} not among {sols:?}"
            );
            // Nearest first: the joints that made the pose come back first.
            assert!(same(&m, &sols[0], &q, 1e-6));
        }
        // Generic poses have all 8 configurations.
        assert!(counts[8] > 200, "{name}: solution counts {counts:?}");
    }
}

#[test]
fn the_closed_forms_agree_with_the_numerical_solver() {
    for (name, m) in arms() {
        let numeric = m.clone().with_solver(SolverChoice::Numeric);
        assert!(numeric.solver_name().contains("numerical"));
        let mut r = Rng::new(11);
        for _ in 0..15 {
            let q = random_joints(&m, &mut r, 0.0);
            let x = m.forward(&q).unwrap();
            let closed = m.inverse(&Target::Frame(x), None).unwrap();
            let found = numeric.inverse(&Target::Frame(x), None).unwrap();
            assert!(!found.is_empty());
            for s in &found {
                assert!(
                    closed.iter().any(|c| same(&m, c, s, 1e-5)),
                    "{name}: numeric {s:?} not in closed {closed:?}"
                );
            }
        }
    }
}

/// A smooth joint-space curve around `q0` (every joint swinging up to
/// `amp` rad), clear of the wrist and elbow singularities; `None` if it
/// leaves the limits or comes near one.
fn joint_curve(m: &Machine, r: &mut Rng, amp: f64, n: usize) -> Option<Vec<Vec<f64>>> {
    let q0 = random_joints(m, r, 0.2);
    let phase: Vec<f64> = (0..m.dof()).map(|_| r.range(0.0, 2.0 * PI)).collect();
    let a: Vec<f64> = (0..m.dof()).map(|_| r.range(-amp, amp)).collect();
    let rows: Vec<Vec<f64>> = (0..n)
        .map(|k| {
            let t = k as f64 / (n - 1) as f64;
            (0..m.dof())
                .map(|j| q0[j] + a[j] * (PI * t + phase[j]).sin())
                .collect()
        })
        .collect();
    let clear = rows.iter().all(|q| {
        m.limits().iter().zip(q).all(|(l, v)| l.contains(*v, -0.1)) && jacobian_ratio(m, q) > 0.05
    });
    clear.then_some(rows)
}

/// Smallest over largest singular value of the Jacobian, rotation rows in
/// mm per rad at a 500 mm lever.
fn jacobian_ratio(m: &Machine, q: &[f64]) -> f64 {
    let (_, mut j) = m.jacobian(q).unwrap();
    for r in 3..6 {
        for c in 0..j.ncols() {
            j[(r, c)] *= 500.0;
        }
    }
    let sv = j.singular_values();
    let mut v: Vec<f64> = sv.iter().copied().collect();
    v.sort_by(|a, b| b.total_cmp(a));
    v[5] / v[0]
}

/// The 5-axis poses (tip and tool axis) of a joint curve.
fn axis_pass(m: &Machine, rows: &[Vec<f64>]) -> Vec<Target> {
    rows.iter()
        .map(|q| axis_target(&m.forward(q).unwrap()))
        .collect()
}

fn check_pass(m: &Machine, targets: &[Target], rows: &[Vec<f64>], max_step: f64) {
    assert_eq!(rows.len(), targets.len());
    for (k, (t, q)) in targets.iter().zip(rows).enumerate() {
        let x = m.forward(q).unwrap();
        let (dp, da) = toolpath_kinematics::pose::pose_error(&x, t);
        assert!(dp < 1e-6 && da < 1e-9, "point {k}: {dp} {da}");
        assert!(
            m.limits().iter().zip(q).all(|(l, v)| l.contains(*v, 1e-9)),
            "point {k} {q:?}"
        );
    }
    for (k, w) in rows.windows(2).enumerate() {
        let step = w[0]
            .iter()
            .zip(&w[1])
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(
            step < max_step,
            "step {step} at {k}: {:?} -> {:?}",
            w[0],
            w[1]
        );
    }
}

#[test]
fn five_axis_passes_on_arms_keep_one_configuration_and_small_steps() {
    for (name, m) in arms() {
        let mut r = Rng::new(12);
        let mut solved = 0;
        while solved < 6 {
            let Some(rows) = joint_curve(&m, &mut r, 0.4, 150) else {
                continue;
            };
            let targets = axis_pass(&m, &rows);
            let got = m
                .solve_pass(0, &targets, None)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            check_pass(&m, &targets, &got, 0.1);
            solved += 1;
        }
    }
}

#[test]
fn a_pass_out_of_reach_is_reported_at_its_first_unreachable_point() {
    let (_, m) = arms().remove(0);
    let q0 = [0.3, -1.2, 1.3, -1.5, -1.4, 0.2];
    let x0 = m.forward(&q0).unwrap();
    let targets: Vec<Target> = (0..40)
        .map(|k| {
            // Moving straight away from the base at 50 mm per point.
            let dir = Vector3::new(x0.translation.x, x0.translation.y, 0.0).normalize();
            let tip = x0.translation.vector + dir * (50.0 * k as f64);
            Target::axis(tip.into(), (-(x0.rotation * Vector3::z())).into()).unwrap()
        })
        .collect();
    let e = m.solve_pass(3, &targets, None).unwrap_err();
    let at = e.at().expect("a place");
    assert_eq!(at.pass, 3);
    // UR5 reaches about 850 mm from the shoulder: the first point beyond is unreachable.
    let reach = |k: usize| {
        let t = targets[k].tip();
        let shoulder = Point3::new(0.0, 0.0, 89.159);
        (t - shoulder).norm()
    };
    assert!(
        reach(at.point) > 800.0 && reach(at.point - 1) < 1000.0,
        "{e} at {:.0} mm",
        reach(at.point)
    );
    assert!(matches!(e, Error::Unreachable { .. }), "{e}");
}

/// The machine with joints 1-3 limited to +-0.6 rad around `q` (one
/// shoulder and one elbow configuration within reach).
fn restricted(urdf: &str, q: &[f64]) -> Machine {
    let model = UrdfModel::parse(urdf).unwrap();
    let mut def = MachineDef::holds_tool(
        "base_link",
        "tool0",
        Isometry3::identity(),
        Isometry3::identity(),
    );
    def.limits = (0..3)
        .map(|j| toolpath_kinematics::LimitOverride {
            joint: model.joint_names()[j].clone(),
            lower: Some(q[j] - 0.6),
            upper: Some(q[j] + 0.6),
            ..Default::default()
        })
        .collect();
    Machine::from_urdf(&model, &def).unwrap()
}

#[test]
fn a_pass_of_frames_through_a_wrist_singularity_is_reported_there() {
    let urdfs = [
        ("ur5", dh_urdf("ur5", UR5_D, UR5_A, UR_ALPHA, 2.0 * PI)),
        ("kr6", opw_urdf("kr6", &KR6_R700, PI)),
    ];
    for (name, urdf) in urdfs {
        // Joint 5 sweeps through zero, the others still: the wrist's first
        // and last axes align at point 20.
        let rows: Vec<Vec<f64>> = (0..41)
            .map(|k| vec![0.4, -1.0, 1.2, 0.3, (k as f64 - 20.0) * 0.01, 0.5])
            .collect();
        let m = restricted(&urdf, &rows[0]);
        let targets: Vec<Target> = rows
            .iter()
            .map(|q| Target::Frame(m.forward(q).unwrap()))
            .collect();
        let e = m.solve_pass(1, &targets, None).unwrap_err();
        let at = e.at().unwrap();
        assert!(matches!(e, Error::Singular { .. }), "{name}: {e}");
        assert!(e.to_string().contains("wrist"), "{e}");
        // Conditioning below 0.02 (the default) is within about 1.2 deg of the singularity.
        let q5 = rows[at.point][4];
        assert!(
            at.pass == 1 && q5.abs() < 0.025 && q5.abs() > 0.015,
            "{name}: {e} (q5 {q5})"
        );
        // Away from it the same machine follows the frames.
        let ok = m.solve_pass(1, &targets[..10], None).unwrap();
        check_pass(&m, &targets[..10], &ok, 0.1);
    }
}

#[test]
fn a_robot_holding_the_part_against_a_fixed_belt_follows_the_contact_path() {
    let urdf = dh_urdf("ur10", UR10_D, UR10_A, UR_ALPHA, 2.0 * PI);
    let model = UrdfModel::parse(&urdf).unwrap();
    // The part 150 mm off the flange; the belt's contact frame in the cell
    // where the part's origin is with the arm at a working pose.
    let part = toolpath_kinematics::xyz_rpy([0.0, 0.0, 150.0], [0.0, 0.0, 0.0]);
    let q0 = [0.3, -1.3, 1.6, -1.9, -1.5, 0.2];
    let f0 = machine(&urdf, "base_link", "tool0").forward(&q0).unwrap();
    let belt = f0 * part * toolpath_kinematics::xyz_rpy([0.0; 3], [PI, 0.0, 0.0]);
    let m = Machine::from_urdf(
        &model,
        &MachineDef::holds_part("base_link", "tool0", part, belt),
    )
    .unwrap();
    assert!(m.solver_name().contains("parallel"), "{}", m.solver_name());
    // Contact points along a line on the part's face, the belt normal along the part's -z.
    let targets: Vec<Target> = (0..120)
        .map(|k| {
            let tip = [-60.0 + k as f64, 20.0 * (k as f64 * 0.05).sin(), 0.0];
            // The tool axis (from the contact into the belt) along the part's +z, tilted a little.
            Target::axis(tip, [0.1 * (k as f64 * 0.03).cos(), 0.0, 1.0]).unwrap()
        })
        .collect();
    let rows = m.solve_pass(0, &targets, None).unwrap();
    check_pass(&m, &targets, &rows, 0.1);
    // Independently: flange * part * X = belt at every point.
    for (t, q) in targets.iter().zip(&rows) {
        let flange = {
            let h = dh_forward(UR10_D, UR10_A, UR_ALPHA, q);
            let rot =
                nalgebra::Rotation3::from_matrix_unchecked(h.fixed_view::<3, 3>(0, 0).into_owned());
            Isometry3::from_parts(
                Vector3::new(h[(0, 3)], h[(1, 3)], h[(2, 3)]).into(),
                UnitQuaternion::from_rotation_matrix(&rot),
            )
        };
        let contact = (flange * part).inverse() * belt;
        let (dp, da) = toolpath_kinematics::pose::pose_error(&contact, t);
        assert!(dp < 1e-6 && da < 1e-9);
    }
}

#[test]
fn a_seven_axis_arm_falls_back_to_the_numerical_solver() {
    // A 7R arm (a UR5 with an extra roll joint before the wrist).
    let mut urdf = dh_urdf("ur5", UR5_D, UR5_A, UR_ALPHA, 2.0 * PI);
    urdf = urdf.replace(
        "<joint name=\"flange\" type=\"fixed\"><parent link=\"link6\"/>",
        "<link name=\"link7\"/><joint name=\"joint7\" type=\"revolute\"><parent link=\"link6\"/><child link=\"link7\"/><origin xyz=\"0 0 0.05\"/><axis xyz=\"1 0 0\"/><limit lower=\"-3\" upper=\"3\" velocity=\"1\" effort=\"1\"/></joint><joint name=\"flange\" type=\"fixed\"><parent link=\"link7\"/>",
    );
    let m = machine(&urdf, "base_link", "tool0");
    assert_eq!(m.dof(), 7);
    assert!(m.solver_name().contains("numerical"));
    let mut r = Rng::new(13);
    let mut solved = 0;
    while solved < 3 {
        let Some(rows) = joint_curve(&m, &mut r, 0.3, 60) else {
            continue;
        };
        let targets = axis_pass(&m, &rows);
        let got = m.solve_pass(0, &targets, Some(&rows[0])).unwrap();
        check_pass(&m, &targets, &got, 0.2);
        solved += 1;
    }
}
