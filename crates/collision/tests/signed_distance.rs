//! The assembly's signed distances against brute force: the minimum distance
//! to a dense (t, phi) sampling of each part's surface of revolution, zoomed
//! in on the best samples, with an inside test written from the sizes.

mod common;

use common::{tools, Rng};
use nalgebra::{Matrix3, Vector3};
use std::f64::consts::{FRAC_PI_2, TAU};
use toolpath_collision::assembly::any_perpendicular as perp;
use toolpath_collision::{Pose, ToolAssembly, ToolPart};

type Curve = Box<dyn Fn(f64) -> (f64, f64)>;

/// The generator curves (r(t), z(t)), t in [0, 1], of a part, from the sizes.
fn curves(tool: &ToolAssembly, part: ToolPart) -> Vec<Curve> {
    match part {
        ToolPart::Cutter => {
            let c = *tool.cutter();
            let (r, rc, l) = (c.radius, c.corner_radius, c.flute_length);
            let r0 = r - rc;
            vec![
                Box::new(move |t| (t * r0, 0.0)),
                Box::new(move |t| {
                    (
                        r0 + rc * (t * FRAC_PI_2).sin(),
                        rc - rc * (t * FRAC_PI_2).cos(),
                    )
                }),
                Box::new(move |t| (r, rc + t * (l - rc))),
                Box::new(move |t| ((1.0 - t) * r, l)),
            ]
        }
        ToolPart::Holder(k) => {
            let z0 = tool.cutter().flute_length
                + tool.holder()[..k].iter().map(|s| s.length).sum::<f64>();
            let s = tool.holder()[k];
            let (rb, rt, len) = (s.radius_bottom, s.radius_top, s.length);
            vec![
                Box::new(move |t| (t * rb, z0)),
                Box::new(move |t| (rb + t * (rt - rb), z0 + t * len)),
                Box::new(move |t| ((1.0 - t) * rt, z0 + len)),
            ]
        }
    }
}

fn inside(tool: &ToolAssembly, part: ToolPart, pose: &Pose, x: &Vector3<f64>) -> bool {
    let d = x - pose.tip;
    let z = d.dot(&pose.axis);
    let r = (d - pose.axis * z).norm();
    match part {
        ToolPart::Cutter => {
            let c = tool.cutter();
            let r0 = c.radius - c.corner_radius;
            let corner = r <= r0
                || z >= c.corner_radius
                || (r - r0).powi(2) + (z - c.corner_radius).powi(2) <= c.corner_radius.powi(2);
            (0.0..=c.flute_length).contains(&z) && r <= c.radius && corner
        }
        ToolPart::Holder(k) => {
            let z0 = tool.cutter().flute_length
                + tool.holder()[..k].iter().map(|s| s.length).sum::<f64>();
            let s = tool.holder()[k];
            (z0..=z0 + s.length).contains(&z)
                && r <= s.radius_bottom + (s.radius_top - s.radius_bottom) * (z - z0) / s.length
        }
    }
}

/// Least distance from `x` to the part's surface by dense sampling and zooming.
fn brute_distance(tool: &ToolAssembly, part: ToolPart, pose: &Pose, x: &Vector3<f64>) -> f64 {
    let e1 = perp(&pose.axis);
    let e2 = pose.axis.cross(&e1);
    let point = |c: &Curve, t: f64, phi: f64| {
        let (r, z) = c(t.clamp(0.0, 1.0));
        pose.tip + (e1 * phi.cos() + e2 * phi.sin()) * r + pose.axis * z
    };
    let mut best = f64::INFINITY;
    for c in curves(tool, part) {
        let mut coarse = Vec::new();
        for i in 0..=60 {
            for j in 0..120 {
                let (t, phi) = (i as f64 / 60.0, j as f64 / 120.0 * TAU);
                coarse.push(((point(&c, t, phi) - x).norm(), t, phi));
            }
        }
        coarse.sort_by(|a, b| a.0.total_cmp(&b.0));
        for &(d0, t0, p0) in coarse.iter().take(3) {
            let (mut d, mut t, mut phi) = (d0, t0, p0);
            let (mut st, mut sp) = (1.0 / 60.0, TAU / 120.0);
            for _ in 0..45 {
                let (ct, cp) = (t, phi);
                for a in -4..=4 {
                    for b in -4..=4 {
                        let tt = (ct + a as f64 * st / 4.0).clamp(0.0, 1.0);
                        let pp = cp + b as f64 * sp / 4.0;
                        let dd = (point(&c, tt, pp) - x).norm();
                        if dd < d {
                            (d, t, phi) = (dd, tt, pp);
                        }
                    }
                }
                st *= 0.6;
                sp *= 0.6;
            }
            best = best.min(d);
        }
    }
    best
}

fn parts(tool: &ToolAssembly) -> Vec<ToolPart> {
    (0..tool.part_count()).map(ToolPart::from_index).collect()
}

#[test]
fn signed_distances_match_brute_force_on_random_points() {
    let mut rng = Rng::new(7);
    let mut worst = 0.0f64;
    for tool in tools() {
        for _ in 0..60 {
            let pose = Pose::new(
                Vector3::new(
                    rng.range(-5.0, 5.0),
                    rng.range(-5.0, 5.0),
                    rng.range(-5.0, 5.0),
                ),
                rng.unit(),
            )
            .unwrap();
            let e1 = perp(&pose.axis);
            let e2 = pose.axis.cross(&e1);
            // Half the points anywhere round the tool, half within 0.5 mm of a part.
            let far = rng.range(0.0, 1.0) < 0.5;
            let (r, z) = if far {
                (
                    rng.range(0.0, 25.0),
                    rng.range(-8.0, tool.total_length() + 8.0),
                )
            } else {
                let part = parts(&tool)[(rng.next_u64() % tool.part_count() as u64) as usize];
                let c = curves(&tool, part);
                let (r, z) = c[(rng.next_u64() % c.len() as u64) as usize](rng.range(0.0, 1.0));
                ((r + rng.range(-0.5, 0.5)).abs(), z + rng.range(-0.5, 0.5))
            };
            let phi = rng.range(0.0, TAU);
            let x = pose.tip + (e1 * phi.cos() + e2 * phi.sin()) * r + pose.axis * z;
            let mut nearest = (ToolPart::Cutter, f64::INFINITY);
            for part in parts(&tool) {
                let d = brute_distance(&tool, part, &pose, &x);
                let want = if inside(&tool, part, &pose, &x) {
                    -d
                } else {
                    d
                };
                let got = tool.signed_distance(&pose, part, &x);
                worst = worst.max((got - want).abs());
                assert!(
                    (got - want).abs() < 1e-7,
                    "{part:?} at r {r} z {z}: {got} vs {want}"
                );
                if want < nearest.1 {
                    nearest = (part, want);
                }
            }
            let n = tool.nearest_part(&pose, &x);
            assert!((n.distance - nearest.1).abs() < 1e-7, "nearest part");
            if (n.distance - nearest.1).abs() > 1e-9 {
                assert_eq!(n.part, nearest.0);
            }
        }
    }
    assert!(worst < 1e-7, "worst {worst}");
}

#[test]
fn jet_matches_differences_of_the_distance() {
    let mut rng = Rng::new(11);
    let h = 1e-5;
    let mut checked = 0;
    for tool in tools() {
        for _ in 0..300 {
            let pose = Pose::new(Vector3::zeros(), rng.unit()).unwrap();
            let x = Vector3::new(
                rng.range(-15.0, 15.0),
                rng.range(-15.0, 15.0),
                rng.range(-15.0, 80.0),
            );
            for part in parts(&tool) {
                let f = |y: &Vector3<f64>| tool.signed_distance(&pose, part, y);
                let jet = tool.jet(&pose, part, &x);
                let mut grad = Vector3::zeros();
                let mut hess = Matrix3::zeros();
                for i in 0..3 {
                    let ei = Vector3::ith(i, h);
                    grad[i] = (f(&(x + ei)) - f(&(x - ei))) / (2.0 * h);
                    for j in 0..3 {
                        let ej = Vector3::ith(j, h);
                        hess[(i, j)] = (f(&(x + ei + ej)) - f(&(x + ei - ej)) - f(&(x - ei + ej))
                            + f(&(x - ei - ej)))
                            / (4.0 * h * h);
                    }
                }
                // Only where the distance is smooth: one nearest feature round x
                // (a kink shows as a gradient shorter than 1 or a huge Hessian).
                let r_axis = (x - pose.axis * x.dot(&pose.axis)).norm();
                if (grad.norm() - 1.0).abs() > 1e-6 || hess.norm() > 1e3 || r_axis < 0.05 {
                    continue;
                }
                checked += 1;
                assert!((jet.value - f(&x)).abs() < 1e-12);
                assert!(
                    (jet.gradient - grad).norm() < 1e-6,
                    "{part:?} {x:?}: {:?} vs {grad:?}",
                    jet.gradient
                );
                assert!(
                    (jet.hessian - hess).norm() < 1e-3 * (1.0 + hess.norm()),
                    "{part:?} {x:?}: {} vs {hess}",
                    jet.hessian
                );
            }
        }
    }
    assert!(checked > 1500, "only {checked} smooth points");
}
