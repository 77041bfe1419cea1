//! Tools pushed into a plane, a cylinder and a sphere by a known depth, and
//! a holder above a box at a known height: the queries' refined distances
//! against the closed-form answers, with samples far coarser than the
//! accuracy asked (the refinement, not the sampling, makes them exact).

mod common;

use common::Rng;
use nalgebra::Vector3;
use std::f64::consts::{PI, TAU};
use std::sync::Arc;
use toolpath_collision::shapes::{box_faces, horizontal_rectangle, Cylinder, Sphere};
use toolpath_collision::{
    Cutter, Face, HolderSegment, Pose, QueryOptions, SamplingOptions, ToolAssembly, ToolPart,
    Workpiece,
};

fn coarse() -> SamplingOptions {
    let mut o = SamplingOptions::for_cutter_radius(8.0);
    o.threads = 1;
    o
}

fn part(faces: Vec<Arc<dyn Face>>) -> Workpiece {
    Workpiece::new(faces, coarse()).unwrap()
}

fn pose(tip: Vector3<f64>, axis: Vector3<f64>) -> Pose {
    Pose::new(tip, axis).unwrap()
}

/// Judge everything down to 20 mm beyond contact.
fn measure() -> QueryOptions {
    QueryOptions {
        cutter_limit: 0.0,
        holder_limit: 0.0,
        cutter_all_faces: false,
        search_margin: 20.0,
    }
}

fn bare(c: Cutter) -> ToolAssembly {
    ToolAssembly::new(c, vec![]).unwrap()
}

#[test]
fn cutters_pushed_into_a_plane_by_a_known_depth() {
    let w = part(vec![Arc::new(horizontal_rectangle(
        0.0,
        [-60.0, 60.0],
        [-60.0, 60.0],
    ))]);
    let mut rng = Rng::new(3);
    for _ in 0..40 {
        let d = rng.range(0.01, 1.2);
        let (x, y) = (rng.range(-30.0, 30.0), rng.range(-30.0, 30.0));
        // Vertical flat end and torus: the bottom is d deep (d < corner and side).
        for c in [Cutter::flat_end(5.0, 20.0), Cutter::torus(5.0, 1.5, 20.0)] {
            let r = w.query(
                &bare(c),
                &pose(Vector3::new(x, y, -d), Vector3::z()),
                &measure(),
            );
            let cut = r.cutter();
            assert!(
                (cut.distance + d).abs() < 1e-9,
                "{c:?}: {} vs {}",
                cut.distance,
                -d
            );
            assert!(cut.collides() && (cut.penetration() - d).abs() < 1e-9);
            assert!(cut.lower_bound <= cut.distance);
            assert_eq!(cut.contact.unwrap().face, 0);
        }
        // A tilted ball: its centre is R - d above the plane.
        let a = rng.axis_near_z(1.2);
        let ball = bare(Cutter::ball(4.0, 20.0));
        let centre = Vector3::new(x, y, 4.0 - d);
        let r = w.query(&ball, &pose(centre - a * 4.0, a), &measure());
        let c = r.cutter().contact.unwrap();
        assert!(
            (r.cutter().distance + d).abs() < 1e-9,
            "{} vs {}",
            r.cutter().distance,
            -d
        );
        assert!(
            (c.point - Vector3::new(x, y, 0.0)).norm() < 1e-4,
            "deepest under the centre"
        );
    }
}

#[test]
fn cutter_side_pushed_into_a_post_and_a_bore() {
    let mut rng = Rng::new(5);
    let (rc, big_r) = (12.0, 5.0);
    let post = Cylinder {
        base: Vector3::zeros(),
        x: Vector3::x(),
        y: Vector3::y(),
        axis: Vector3::z(),
        radius: rc,
        theta: [0.0, TAU],
        height: [-10.0, 40.0],
    };
    let w = part(vec![Arc::new(post)]);
    let tool = bare(Cutter::flat_end(big_r, 25.0));
    for _ in 0..40 {
        let d = rng.range(0.01, 2.0);
        let phi = rng.range(0.0, TAU);
        let dir = Vector3::new(phi.cos(), phi.sin(), 0.0);
        // Outside the post, axes parallel: the deepest point faces the axis.
        let tip = dir * (rc + big_r - d) + Vector3::new(0.0, 0.0, rng.range(0.0, 10.0));
        let r = w.query(&tool, &pose(tip, Vector3::z()), &measure());
        assert!(
            (r.cutter().distance + d).abs() < 1e-9,
            "post: {} vs {}",
            r.cutter().distance,
            -d
        );
        // Inside a bore of the same radius, pushed into its wall.
        let bore = Cylinder {
            radius: 20.0,
            ..post
        };
        let wb = part(vec![Arc::new(bore)]);
        let tip = dir * (20.0 - big_r + d) + Vector3::new(0.0, 0.0, 5.0);
        let r = wb.query(&tool, &pose(tip, Vector3::z()), &measure());
        assert!(
            (r.cutter().distance + d).abs() < 1e-9,
            "bore: {} vs {}",
            r.cutter().distance,
            -d
        );
    }
}

#[test]
fn ball_pushed_into_a_sphere_and_a_spherical_cavity() {
    let mut rng = Rng::new(9);
    let centre = Vector3::new(3.0, -2.0, 1.0);
    let rs = 15.0;
    let sphere = Sphere {
        centre,
        radius: rs,
        theta: [0.0, TAU],
        phi: [-0.5 * PI, 0.5 * PI],
    };
    let w = part(vec![Arc::new(sphere)]);
    let ball = bare(Cutter::ball(4.0, 20.0));
    for _ in 0..40 {
        let d = rng.range(0.01, 2.0);
        let n = rng.unit();
        // Outside: the ball's axis along the normal, centre at rs + R - d.
        let c = centre + n * (rs + 4.0 - d);
        let r = w.query(&ball, &pose(c - n * 4.0, n), &measure());
        assert!(
            (r.cutter().distance + d).abs() < 1e-9,
            "sphere: {} vs {}",
            r.cutter().distance,
            -d
        );
        let p = r.cutter().contact.unwrap().point;
        assert!((p - (centre + n * rs)).norm() < 1e-3);
        // Inside the cavity, the axis pointing back to its centre.
        let c = centre + n * (rs - 4.0 + d);
        let r = w.query(&ball, &pose(c + n * 4.0, -n), &measure());
        assert!(
            (r.cutter().distance + d).abs() < 1e-9,
            "cavity: {} vs {}",
            r.cutter().distance,
            -d
        );
    }
}

#[test]
fn holder_above_a_box_at_a_known_height() {
    let w = part(box_faces(
        Vector3::new(-80.0, -80.0, -30.0),
        Vector3::new(80.0, 80.0, 0.0),
    ));
    let tool = ToolAssembly::new(
        Cutter::torus(5.0, 1.0, 20.0),
        vec![
            HolderSegment::cylinder(30.0, 4.0),
            HolderSegment::cone(40.0, 10.0, 15.0),
        ],
    )
    .unwrap();
    let mut rng = Rng::new(13);
    let mut opts = measure();
    opts.cutter_all_faces = true;
    opts.search_margin = 200.0;
    for _ in 0..30 {
        let beta = rng.range(0.0, 0.6);
        // Tip high enough for the cutter to stay above the box (a buried
        // cutter's distance is not its lowest point's height).
        let h = rng.range(0.1, 20.0) + 4.0 * beta.sin() + 1.0 - beta.cos();
        let psi = rng.range(0.0, TAU);
        let a = Vector3::new(beta.sin() * psi.cos(), beta.sin() * psi.sin(), beta.cos());
        let tip = Vector3::new(rng.range(-20.0, 20.0), rng.range(-20.0, 20.0), h);
        let r = w.query(&tool, &pose(tip, a), &opts);
        // Lowest point of a revolved part over a plane: the lower of its
        // bottom and top rims (cone sides are straight), z cos b - rho sin b.
        let rim = |z: f64, rho: f64| h + z * beta.cos() - rho * beta.sin();
        let low_corner = (h + 1.0 * beta.cos() - 1.0) - 4.0 * beta.sin();
        let want = [
            low_corner.min(h).min(rim(20.0, 5.0)),
            rim(20.0, 4.0).min(rim(50.0, 4.0)),
            rim(50.0, 10.0).min(rim(90.0, 15.0)),
        ];
        for (i, w) in want.iter().enumerate() {
            let p = r.parts[i];
            assert_eq!(p.part, ToolPart::from_index(i));
            assert!(
                (p.distance - w).abs() < 1e-8,
                "part {i}, h {h} b {beta}: {} vs {w}",
                p.distance
            );
            assert!(p.lower_bound <= p.distance + 1e-12);
            assert!(!p.collides());
        }
        assert!((r.holder_clearance() - want[1].min(want[2])).abs() < 1e-8);
    }
}

/// A floor (machined) meeting a concave fillet of radius 6 along x = 50,
/// then a wall: the flat end's rim passing the shared edge gouges the
/// fillet by the depth where the rim's two branches meet, max over t of
/// min(z(t), overhang - t), z(t) = 6 - sqrt(36 - t^2) (the fillet's height
/// t past the edge).
#[test]
fn flat_end_rim_over_a_fillet_edge() {
    let floor: Arc<dyn Face> = Arc::new(horizontal_rectangle(0.0, [0.0, 50.0], [-40.0, 40.0]));
    let fillet: Arc<dyn Face> = Arc::new(Cylinder {
        base: Vector3::new(50.0, 0.0, 6.0),
        x: Vector3::x(),
        y: Vector3::z(),
        axis: Vector3::y(),
        radius: 6.0,
        theta: [-0.5 * PI, 0.0],
        height: [-40.0, 40.0],
    });
    let mut w = part(vec![floor, fillet]);
    w.set_machined(&[0]).unwrap();
    let tool = bare(Cutter::flat_end(5.0, 20.0));
    let opts = QueryOptions::new(0.01, 1.0);
    // Rim 0.01 short of the edge: clear by exactly 0.01 (corner to edge).
    let r = w.query(
        &tool,
        &pose(Vector3::new(44.99, 3.0, 0.0), Vector3::z()),
        &measure(),
    );
    assert!(
        (r.cutter().distance - 0.01).abs() < 1e-9,
        "{}",
        r.cutter().distance
    );
    assert!(!w
        .query(
            &tool,
            &pose(Vector3::new(44.99, 3.0, 0.0), Vector3::z()),
            &opts
        )
        .collides());
    for overhang in [0.05, 0.2, 0.5, 1.0, 2.0] {
        let z = |t: f64| 6.0 - (36.0 - t * t).sqrt();
        let (mut lo, mut hi) = (0.0, overhang);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if z(mid) < overhang - mid {
                lo = mid
            } else {
                hi = mid
            }
        }
        let want = z(lo);
        let r = w.query(
            &tool,
            &pose(Vector3::new(45.0 + overhang, 3.0, 0.0), Vector3::z()),
            &opts,
        );
        let cut = r.cutter();
        assert!(cut.collides() == (want > 0.01), "overhang {overhang}");
        assert!(
            (cut.distance + want).abs() < 1e-9,
            "overhang {overhang}: {} vs {}",
            cut.distance,
            -want
        );
        let c = cut.contact.unwrap();
        assert_eq!(c.face, 1);
        assert!(
            (c.point.y - 3.0).abs() < 1e-4,
            "deepest across the axis: {:?}",
            c.point
        );
    }
}
