//! Surface geometry against exact answers: sphere, cylinder and torus as exact
//! rational surfaces, a hyperbolic paraboloid and a quadric with a sheared,
//! non-uniform parametrisation (closed-form curvatures of the graph), derivatives
//! against finite differences, and round trips of inversion, plane
//! intersection and field tracing.

use nalgebra::{Matrix2, Point3, Rotation3, Vector2, Vector3};
use proptest::prelude::*;
use std::f64::consts::{FRAC_1_SQRT_2, PI};
use toolpath_planner::geometry::field_trace::{
    principal_field, trace_field, Principal, TraceOptions, TraceStop,
};
use toolpath_planner::geometry::interpolation::{interpolate_height_field, interpolate_surface};
use toolpath_planner::geometry::inversion::{closest_point, closest_point_near};
use toolpath_planner::geometry::plane_intersection::{intersect_plane, Plane, SectionOptions};
use toolpath_planner::geometry::{LocalGeometry, NurbsSurface};
use toolpath_planner::samples::surfaces;

/// Full unit circle as 9 rational quadratic control points (x, y, weight).
fn unit_circle() -> (Vec<[f64; 3]>, Vec<f64>) {
    let w = FRAC_1_SQRT_2;
    let pts = vec![
        [1.0, 0.0, 1.0],
        [1.0, 1.0, w],
        [0.0, 1.0, 1.0],
        [-1.0, 1.0, w],
        [-1.0, 0.0, 1.0],
        [-1.0, -1.0, w],
        [0.0, -1.0, 1.0],
        [1.0, -1.0, w],
        [1.0, 0.0, 1.0],
    ];
    let knots = vec![
        0.0, 0.0, 0.0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1.0, 1.0, 1.0,
    ];
    (pts, knots)
}

/// Surface of revolution about z: u the full circle, v the meridian given as
/// rational quadratic control points (r, z, weight) with `knots_v`.
fn revolve(meridian: &[[f64; 3]], knots_v: Vec<f64>) -> NurbsSurface {
    let (circle, knots_u) = unit_circle();
    let cps: Vec<Vec<[f64; 3]>> = circle
        .iter()
        .map(|c| {
            meridian
                .iter()
                .map(|m| [c[0] * m[0], c[1] * m[0], m[1]])
                .collect()
        })
        .collect();
    let ws: Vec<Vec<f64>> = circle
        .iter()
        .map(|c| meridian.iter().map(|m| c[2] * m[2]).collect())
        .collect();
    NurbsSurface::new(2, 2, knots_u, knots_v, &cps, Some(&ws)).unwrap()
}

/// Sphere of radius r about the origin, poles at v = 0 and 1, normal outwards.
fn sphere(r: f64) -> NurbsSurface {
    let w = FRAC_1_SQRT_2;
    let meridian = [
        [0.0, -r, 1.0],
        [r, -r, w],
        [r, 0.0, 1.0],
        [r, r, w],
        [0.0, r, 1.0],
    ];
    revolve(&meridian, vec![0.0, 0.0, 0.0, 0.5, 0.5, 1.0, 1.0, 1.0])
}

/// Torus: tube radius `r` round a circle of radius `r0` in the xy plane.
/// The meridian starts at the outer equator and runs counter-clockwise in (r, z).
fn torus(r0: f64, r: f64) -> NurbsSurface {
    let (circle, knots) = unit_circle();
    let meridian: Vec<[f64; 3]> = circle
        .iter()
        .map(|c| [r0 + r * c[0], r * c[1], c[2]])
        .collect();
    revolve(&meridian, knots)
}

/// Cylinder of radius r about z, height h, normal outwards.
fn cylinder(r: f64, h: f64) -> NurbsSurface {
    let (circle, knots_u) = unit_circle();
    let cps: Vec<Vec<[f64; 3]>> = circle
        .iter()
        .map(|c| vec![[r * c[0], r * c[1], 0.0], [r * c[0], r * c[1], h]])
        .collect();
    let ws: Vec<Vec<f64>> = circle.iter().map(|c| vec![c[2], c[2]]).collect();
    NurbsSurface::new(2, 1, knots_u, vec![0.0, 0.0, 1.0, 1.0], &cps, Some(&ws)).unwrap()
}

fn params(n: usize) -> Vec<(f64, f64)> {
    // Irregular interior sample points (avoid knots and poles).
    (0..n)
        .map(|k| {
            let a = (k as f64 * 0.618_033_988_75 + 0.05).fract();
            let b = (k as f64 * 0.414_213_562_37 + 0.11).fract();
            (0.02 + 0.96 * a, 0.04 + 0.92 * b)
        })
        .collect()
}

fn parallel(a: &Vector3<f64>, b: &Vector3<f64>, tol: f64) -> bool {
    a.normalize().cross(&b.normalize()).norm() < tol
}

#[test]
fn sphere_is_umbilic_everywhere_with_curvature_minus_one_over_r() {
    let r = 37.5;
    let s = sphere(r);
    for (u, v) in params(60) {
        let g = LocalGeometry::at(&s, u, v).unwrap();
        let p = g.point();
        assert!((p.coords.norm() - r).abs() < 1e-10);
        assert!(
            (g.forms.n - p.coords / r).norm() < 1e-10,
            "normal points outwards"
        );
        // Convex towards the tool side (outside): kappa = -1/r in every direction.
        assert!(
            (g.k_min + 1.0 / r).abs() < 1e-9 && (g.k_max + 1.0 / r).abs() < 1e-9,
            "{} {}",
            g.k_min,
            g.k_max
        );
        assert!(g.is_umbilic(1e-9));
        assert!((g.gaussian_curvature() - 1.0 / (r * r)).abs() < 1e-9);
        let t = Vector3::new(0.3, -0.2, 0.7).cross(&g.forms.n);
        assert!((g.normal_curvature(t) + 1.0 / r).abs() < 1e-9);
    }
}

#[test]
fn cylinder_has_curvatures_zero_and_one_over_r_along_axis_and_circle() {
    let (r, h) = (12.0, 30.0);
    let s = cylinder(r, h);
    for (u, v) in params(60) {
        let g = LocalGeometry::at(&s, u, v).unwrap();
        let p = g.point();
        assert!((p.x.hypot(p.y) - r).abs() < 1e-10);
        assert!((g.k_min + 1.0 / r).abs() < 1e-9, "{}", g.k_min);
        assert!(g.k_max.abs() < 1e-9, "{}", g.k_max);
        assert!(
            parallel(&g.dir_max, &Vector3::z(), 1e-9),
            "zero curvature along the axis"
        );
        let around = Vector3::new(-p.y, p.x, 0.0);
        assert!(parallel(&g.dir_min, &around, 1e-9));
        // Directions in uv map to the 3-D ones.
        assert!(parallel(&g.uv_to_tangent(g.dir_min_uv), &g.dir_min, 1e-12));
        assert!((g.uv_to_tangent(g.dir_max_uv).norm() - 1.0).abs() < 1e-12);
    }
}

#[test]
fn torus_curvatures_match_the_closed_form() {
    let (r0, r) = (40.0, 10.0);
    let s = torus(r0, r);
    for (u, v) in params(80) {
        let g = LocalGeometry::at(&s, u, v).unwrap();
        let p = g.point();
        let rho = p.x.hypot(p.y);
        let phi = p.z.atan2(rho - r0);
        assert!(((rho - r0).hypot(p.z) - r).abs() < 1e-10);
        let k_meridian = -1.0 / r;
        let k_parallel = -phi.cos() / (r0 + r * phi.cos());
        assert!(
            (g.k_min - k_meridian).abs() < 1e-9,
            "{} vs {k_meridian}",
            g.k_min
        );
        assert!(
            (g.k_max - k_parallel).abs() < 1e-9,
            "{} vs {k_parallel}",
            g.k_max
        );
        let around = Vector3::new(-p.y, p.x, 0.0);
        assert!(
            parallel(&g.dir_max, &around, 1e-8),
            "parallel circle is the max direction"
        );
        assert!(g.dir_min.dot(&around).abs() < 1e-8);
        assert!((g.gaussian_curvature() - k_meridian * k_parallel).abs() < 1e-12);
    }
}

/// Closed-form curvatures of a graph z = f(x, y) with gradient (p, q) and
/// Hessian (fxx, fxy, fyy), normal upwards: (k_min, k_max, dir_min, dir_max),
/// directions computed in the (x, y) parametrisation.
fn graph_curvatures(
    p: f64,
    q: f64,
    fxx: f64,
    fxy: f64,
    fyy: f64,
) -> (f64, f64, Vector3<f64>, Vector3<f64>) {
    let w = (1.0 + p * p + q * q).sqrt();
    let k = (fxx * fyy - fxy * fxy) / (w * w * w * w);
    let h = ((1.0 + q * q) * fxx - 2.0 * p * q * fxy + (1.0 + p * p) * fyy) / (2.0 * w * w * w);
    let disc = (h * h - k).max(0.0).sqrt();
    let (kmin, kmax) = (h - disc, h + disc);
    // Principal directions: (D - k G) t = 0 in the (x, y) parametrisation.
    let g = Matrix2::new(1.0 + p * p, p * q, p * q, 1.0 + q * q);
    let d = Matrix2::new(fxx, fxy, fxy, fyy) / w;
    let dir = |kk: f64| {
        let m = d - g * kk;
        // Null vector of the 2x2 matrix: pick the better-conditioned row.
        let t = if m.row(0).norm() >= m.row(1).norm() {
            Vector2::new(-m[(0, 1)], m[(0, 0)])
        } else {
            Vector2::new(-m[(1, 1)], m[(1, 0)])
        };
        Vector3::new(t.x, t.y, p * t.x + q * t.y).normalize()
    };
    (kmin, kmax, dir(kmin), dir(kmax))
}

#[test]
fn hyperbolic_paraboloid_matches_the_closed_form() {
    // z = x y / 40 + (x^2 - y^2) / 300 on [-30, 30]^2, exact bicubic.
    let f = |x: f64, y: f64| x * y / 40.0 + (x * x - y * y) / 300.0;
    let s = interpolate_height_field(f, (-30.0, 30.0), (-30.0, 30.0), (3, 2), (3, 3)).unwrap();
    for (u, v) in params(80) {
        let g = LocalGeometry::at(&s, u, v).unwrap();
        let pt = g.point();
        let (p, q) = (
            pt.y / 40.0 + 2.0 * pt.x / 300.0,
            pt.x / 40.0 - 2.0 * pt.y / 300.0,
        );
        let (kmin, kmax, dmin, dmax) =
            graph_curvatures(p, q, 2.0 / 300.0, 1.0 / 40.0, -2.0 / 300.0);
        assert!(kmin < 0.0 && kmax > 0.0);
        assert!(
            (g.k_min - kmin).abs() < 1e-12 && (g.k_max - kmax).abs() < 1e-12,
            "{} {kmin} {} {kmax}",
            g.k_min,
            g.k_max
        );
        assert!(parallel(&g.dir_min, &dmin, 1e-8) && parallel(&g.dir_max, &dmax, 1e-8));
    }
}

/// A quadric graph with a sheared, curved, non-uniform parametrisation:
/// x = u + 0.4 v^2 - 10, y = 0.3 u + v (u in [0, 20], v in [-8, 12]), on knots
/// with uneven spans. z(x, y) is quadratic, so the surface is polynomial of
/// degree (2, 4) in (u, v) and a degree (3, 4) spline represents it exactly.
#[test]
fn curvatures_do_not_depend_on_the_parametrisation() {
    let f = |x: f64, y: f64| (x * x + 0.5 * x * y - 0.8 * y * y) / 90.0 + 0.1 * x;
    let map = |u: f64, v: f64| {
        let (uu, vv) = (20.0 * u, -8.0 + 20.0 * v);
        let x = uu + 0.4 * vv * vv / 10.0 - 10.0;
        let y = 0.3 * uu + vv;
        [x, y, f(x, y)]
    };
    let ku = vec![0.0, 0.0, 0.0, 0.0, 0.13, 0.5, 0.58, 1.0, 1.0, 1.0, 1.0];
    let kv = vec![
        0.0, 0.0, 0.0, 0.0, 0.0, 0.3, 0.31, 0.8, 1.0, 1.0, 1.0, 1.0, 1.0,
    ];
    let s = interpolate_surface(map, 3, ku, 4, kv).unwrap();
    let mut max_skew: f64 = 0.0;
    for (u, v) in params(100) {
        let want = map(u, v);
        let g = LocalGeometry::at(&s, u, v).unwrap();
        let pt = g.point();
        assert!(
            (pt - Point3::from(want)).norm() < 1e-9,
            "exact reproduction"
        );
        // Non-orthogonal: F != 0.
        max_skew = max_skew.max(
            g.forms.first[(0, 1)].abs() / (g.forms.first[(0, 0)] * g.forms.first[(1, 1)]).sqrt(),
        );
        let (x, y) = (pt.x, pt.y);
        let (p, q) = ((2.0 * x + 0.5 * y) / 90.0 + 0.1, (0.5 * x - 1.6 * y) / 90.0);
        let (kmin, kmax, dmin, dmax) = graph_curvatures(p, q, 2.0 / 90.0, 0.5 / 90.0, -1.6 / 90.0);
        let n_up = g.forms.n.z > 0.0;
        let (kmin, kmax, dmin, dmax) = if n_up {
            (kmin, kmax, dmin, dmax)
        } else {
            (-kmax, -kmin, dmax, dmin)
        };
        assert!(
            (g.k_min - kmin).abs() < 1e-9 && (g.k_max - kmax).abs() < 1e-9,
            "{} {kmin} {} {kmax}",
            g.k_min,
            g.k_max
        );
        assert!(parallel(&g.dir_min, &dmin, 1e-7) && parallel(&g.dir_max, &dmax, 1e-7));
        // The uv directions map to unit, orthogonal 3-D tangents.
        let (tmin, tmax) = (g.uv_to_tangent(g.dir_min_uv), g.uv_to_tangent(g.dir_max_uv));
        assert!(
            (tmin.norm() - 1.0).abs() < 1e-9
                && (tmax.norm() - 1.0).abs() < 1e-9
                && tmin.dot(&tmax).abs() < 1e-9
        );
        assert!((g.normal_curvature_uv(g.dir_min_uv) - g.k_min).abs() < 1e-12);
    }
    assert!(
        max_skew > 0.3,
        "the parametrisation is far from orthogonal: {max_skew}"
    );
}

fn check_derivatives(s: &NurbsSurface, u: f64, v: f64) {
    let h = 1e-5;
    let d = s.derivs(u, v);
    let scale = d.su.norm().max(d.sv.norm());
    let pu = (s.point(u + h, v) - s.point(u - h, v)) / (2.0 * h);
    let pv = (s.point(u, v + h) - s.point(u, v - h)) / (2.0 * h);
    assert!(
        (pu - d.su).norm() < 1e-6 * scale,
        "S_u {pu:?} vs {:?}",
        d.su
    );
    assert!((pv - d.sv).norm() < 1e-6 * scale, "S_v");
    let du1 = s.derivs(u + h, v);
    let du0 = s.derivs(u - h, v);
    let dv1 = s.derivs(u, v + h);
    let dv0 = s.derivs(u, v - h);
    let scale2 = d.suu.norm().max(d.svv.norm()).max(d.suv.norm()).max(scale);
    assert!(
        ((du1.su - du0.su) / (2.0 * h) - d.suu).norm() < 1e-5 * scale2,
        "S_uu"
    );
    assert!(
        ((dv1.sv - dv0.sv) / (2.0 * h) - d.svv).norm() < 1e-5 * scale2,
        "S_vv"
    );
    assert!(
        ((du1.sv - du0.sv) / (2.0 * h) - d.suv).norm() < 1e-5 * scale2,
        "S_uv from S_v"
    );
    assert!(
        ((dv1.su - dv0.su) / (2.0 * h) - d.suv).norm() < 1e-5 * scale2,
        "S_uv from S_u"
    );
    assert!((s.first_derivs(u, v).su - d.su).norm() == 0.0);
}

#[test]
fn derivatives_match_finite_differences() {
    let surfaces = [
        torus(40.0, 10.0),
        sphere(20.0),
        surfaces::concave_cylinder(),
        surfaces::wing_mould(),
        surfaces::egg_crate(),
        surfaces::turbine_blade(),
    ];
    for s in &surfaces {
        for (u, v) in params(40) {
            check_derivatives(s, u, v);
        }
    }
}

#[test]
fn inversion_recovers_points_offset_along_the_normal() {
    let t = torus(40.0, 10.0);
    for (u, v) in params(50) {
        let g = LocalGeometry::at(&t, u, v).unwrap();
        // Outwards (convex side) any distance is safe; inwards less than the tube radius.
        for off in [3.0, -4.0] {
            let q = g.point() + g.forms.n * off;
            let c = closest_point(&t, &q);
            assert!(
                (c.distance - off.abs()).abs() < 1e-9,
                "({u}, {v}): {} vs {off} at {:?}",
                c.distance,
                c.uv
            );
            assert!(
                (c.point - g.point()).norm() < 1e-8,
                "({u}, {v}) {off}: {:?} vs {:?}",
                c.point,
                g.point()
            );
        }
    }
}

#[test]
fn inversion_is_robust_at_boundaries_corners_and_poles() {
    let plate = surfaces::plane();
    // Beyond an edge: lands on the edge, distance exact.
    let c = closest_point(&plate, &Point3::new(130.0, 40.0, 5.0));
    assert!((c.uv.x - 1.0).abs() == 0.0 && (c.uv.y - 0.4).abs() < 1e-12);
    assert!((c.distance - 30f64.hypot(5.0)).abs() < 1e-9);
    // Beyond a corner.
    let c = closest_point(&plate, &Point3::new(-3.0, 104.0, 0.0));
    assert_eq!(c.uv, Vector2::new(0.0, 1.0));
    assert!((c.distance - 5.0).abs() < 1e-12);
    // Near a pole of the sphere (S_u = 0 there) and exactly above it.
    let s = sphere(20.0);
    for q in [
        Point3::new(0.3, -0.2, 30.0),
        Point3::new(0.0, 0.0, -25.0),
        Point3::new(0.0, 0.0, 0.5),
    ] {
        let c = closest_point(&s, &q);
        let want = (q.coords.norm() - 20.0).abs();
        assert!(
            (c.distance - want).abs() < 1e-7,
            "{q:?}: {} vs {want}",
            c.distance
        );
    }
    // The saddle of the die: a point below the surface inverts to the point straight above it.
    let die = surfaces::die_saddle();
    let p = die.point(0.3, 0.8);
    let n = die.normal(0.3, 0.8).unwrap();
    let c = closest_point_near(&die, &(p - n * 50.0), Vector2::new(0.5, 0.5));
    assert!((c.uv - Vector2::new(0.3, 0.8)).norm() < 1e-10);
}

#[test]
fn plane_sections_of_the_sphere_are_circles() {
    let r = 25.0;
    let s = sphere(r);
    for h in [-20.0, 0.0, 7.5, 24.0] {
        let plane = Plane::new(Point3::new(0.0, 0.0, h), Vector3::z()).unwrap();
        let opts = SectionOptions {
            max_segment: 0.5,
            ..SectionOptions::for_surface(&s)
        };
        let curves = intersect_plane(&s, &plane, &opts);
        // The seam u = 0 = 1 cuts the circle open.
        assert_eq!(curves.len(), 1, "h = {h}");
        let c = &curves[0];
        let rc = (r * r - h * h).sqrt();
        for (uv, p) in c.uv.iter().zip(&c.xyz) {
            let q = s.point(uv[0], uv[1]);
            assert!((q - Point3::from(*p)).norm() < 1e-12);
            assert!((p[2] - h).abs() < 1e-9, "on the plane");
            assert!((p[0].hypot(p[1]) - rc).abs() < 1e-9, "on the circle");
        }
        let chord_error = rc * (1.0 - (0.25 / rc).asin().cos());
        let len = c.length();
        assert!(
            len <= 2.0 * PI * rc + 1e-9 && len > 2.0 * PI * rc * (1.0 - 2.0 * chord_error / rc),
            "{len}"
        );
        assert!(c
            .xyz
            .windows(2)
            .all(|w| Point3::from(w[0]) != Point3::from(w[1])));
        // Runs along n_plane x n_surface = z x radial: counter-clockwise seen from +z.
        let (a, b) = (c.xyz[0], c.xyz[1]);
        assert!(a[0] * b[1] - a[1] * b[0] > 0.0);
    }
}

#[test]
fn plane_sections_find_closed_loops_in_order() {
    let egg = surfaces::egg_crate();
    let plane = Plane::new(Point3::new(0.0, 0.0, 1.0), Vector3::z()).unwrap();
    let curves = intersect_plane(&egg, &plane, &SectionOptions::for_surface(&egg));
    assert_eq!(curves.len(), 8, "one loop round each of the 8 crests");
    assert!(curves.iter().all(|c| c.closed));
    let k = 2.0 * PI / 50.0;
    for c in &curves {
        for p in &c.xyz {
            assert!((2.0 * (k * p[0]).sin() * (k * p[1]).sin() - 1.0).abs() < 1e-3);
            assert!((p[2] - 1.0).abs() < 1e-9);
        }
        // A level loop round a crest of 2 sin sin = 1: |sin sin| = 1/2, diameter about 2 * 8.4 mm.
        assert!(c.length() > 40.0 && c.length() < 70.0, "{}", c.length());
    }
    // Deterministic: the same call gives the same curves.
    assert_eq!(
        curves,
        intersect_plane(&egg, &plane, &SectionOptions::for_surface(&egg))
    );
    // A plane missing the surface gives nothing.
    let above = Plane::new(Point3::new(0.0, 0.0, 3.0), Vector3::z()).unwrap();
    assert!(intersect_plane(&egg, &above, &SectionOptions::for_surface(&egg)).is_empty());
}

#[test]
fn plane_sections_of_the_sine_wave_are_straight_rulings_or_sine_profiles() {
    let s = surfaces::sine_wave();
    // Planes y = const: the sine profile, one open curve from x = 0 to 100.
    let plane = Plane::new(Point3::new(0.0, 40.0, 0.0), Vector3::y()).unwrap();
    let curves = intersect_plane(&s, &plane, &SectionOptions::for_surface(&s));
    assert_eq!(curves.len(), 1);
    let c = &curves[0];
    assert!(!c.closed);
    let first = c.xyz[0];
    let last = c.xyz[c.xyz.len() - 1];
    // Direction y x n: +x for an upward normal... runs from x = 100 to 0 or back, consistently.
    assert!(
        (first[0] - 0.0).abs() < 1e-9 && (last[0] - 100.0).abs() < 1e-9
            || (first[0] - 100.0).abs() < 1e-9 && last[0].abs() < 1e-9
    );
    // Exact arc length of one period of 5 sin(2 pi x / 100) is 102.42 mm
    // (docs/methods.md, "Belt references").
    assert!((c.length() - 102.42).abs() < 0.01, "{}", c.length());
}

#[test]
fn principal_lines_of_the_torus_are_parallels_and_meridians() {
    let (r0, r) = (40.0, 10.0);
    let t = torus(r0, r);
    let opts = TraceOptions {
        tolerance: 1e-9,
        ..TraceOptions::default()
    };
    // Max-curvature line from (0.1, 0.1), heading +u: the parallel circle, stops on u = 1.
    let start = Vector2::new(0.1, 0.1);
    let tr = trace_field(
        &t,
        principal_field(&t, Principal::Max, 1e-9),
        start,
        Vector2::new(1.0, 0.0),
        &opts,
    );
    assert_eq!(tr.stop, TraceStop::Boundary);
    let last = tr.uv[tr.uv.len() - 1];
    assert_eq!(last[0], 1.0, "ends exactly on the boundary");
    assert!(
        (last[1] - 0.1).abs() < 1e-8,
        "stays on the parallel: v = {}",
        last[1]
    );
    let p0 = t.point(start.x, start.y);
    let rho = p0.x.hypot(p0.y);
    let angle = p0.y.atan2(p0.x);
    let want = rho * (2.0 * PI - angle);
    assert!((tr.length - want).abs() < 1e-6, "{} vs {want}", tr.length);
    for p in &tr.xyz {
        assert!((p[0].hypot(p[1]) - rho).abs() < 1e-6 && (p[2] - p0.z).abs() < 1e-6);
    }
    // Min-curvature line heading -v: the meridian back to v = 0.
    let tr = trace_field(
        &t,
        principal_field(&t, Principal::Min, 1e-9),
        start,
        Vector2::new(0.0, -1.0),
        &opts,
    );
    assert_eq!(tr.stop, TraceStop::Boundary);
    let phi = p0.z.atan2(rho - r0);
    assert!(
        (tr.length - r * phi).abs() < 1e-6,
        "{} vs {}",
        tr.length,
        r * phi
    );
    assert_eq!(tr.uv[tr.uv.len() - 1][1], 0.0);
}

#[test]
fn tracing_stops_at_max_length_and_where_the_field_is_undefined() {
    let c = cylinder(12.0, 300.0);
    let opts = TraceOptions {
        max_length: 37.0,
        ..TraceOptions::default()
    };
    // Zero-curvature direction of the cylinder: the axis.
    let tr = trace_field(
        &c,
        principal_field(&c, Principal::Max, 1e-9),
        Vector2::new(0.3, 0.1),
        Vector2::new(0.0, 1.0),
        &opts,
    );
    assert_eq!(tr.stop, TraceStop::MaxLength);
    assert!((tr.length - 37.0).abs() < 1e-12);
    let (a, b) = (tr.xyz[0], tr.xyz[tr.xyz.len() - 1]);
    assert!((b[2] - a[2] - 37.0).abs() < 1e-9 && (b[0] - a[0]).abs() < 1e-9);
    // On the sphere every point is umbilic: the principal field is undefined at the start.
    let s = sphere(10.0);
    let tr = trace_field(
        &s,
        principal_field(&s, Principal::Min, 1e-9),
        Vector2::new(0.3, 0.4),
        Vector2::new(1.0, 0.0),
        &opts,
    );
    assert_eq!(tr.stop, TraceStop::FieldUndefined);
    assert_eq!(tr.uv.len(), 1);
    // Towards the monkey saddle's umbilic at the centre: stops just before it.
    let m = surfaces::monkey_saddle();
    let field = principal_field(&m, Principal::Max, 1e-7);
    // Along y = 0 the max direction is x (a separatrix), so the trace runs into the umbilic.
    let tr = trace_field(
        &m,
        field,
        Vector2::new(0.9, 0.5),
        Vector2::new(-1.0, 0.0),
        &TraceOptions::default(),
    );
    assert_eq!(tr.stop, TraceStop::FieldUndefined);
    let end = tr.xyz[tr.xyz.len() - 1];
    assert!(
        end[0] > 0.0 && end[0] < 1.0 && end[1].abs() < 1e-6,
        "{end:?}"
    );
}

#[test]
fn line_fields_are_made_sign_consistent() {
    let t = torus(40.0, 10.0);
    let clean = principal_field(&t, Principal::Max, 1e-9);
    // The same line field with its sign flipped in a checkerboard pattern.
    let flipping = |x: Vector2<f64>| {
        let d = clean(x)?;
        let flip = ((x.x * 157.0).floor() + (x.y * 91.0).floor()) as i64 % 2 == 0;
        Some(if flip { -d } else { d })
    };
    let start = Vector2::new(0.2, 0.7);
    let opts = TraceOptions::default();
    let a = trace_field(&t, &clean, start, Vector2::new(-1.0, 0.0), &opts);
    let b = trace_field(&t, flipping, start, Vector2::new(-1.0, 0.0), &opts);
    assert_eq!(a.stop, TraceStop::Boundary);
    assert_eq!(b.stop, TraceStop::Boundary);
    assert!((a.length - b.length).abs() < 1e-9);
    assert_eq!(a.uv[a.uv.len() - 1][0], 0.0, "went towards -u as asked");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Curvatures are invariant under rigid motions and scale as 1/s.
    #[test]
    fn curvature_is_invariant_under_rotation_and_scales_inversely(
        ax in -1.0f64..1.0, ay in -1.0f64..1.0, az in 0.1f64..1.0, angle in 0.0f64..6.0,
        scale in 0.2f64..5.0, u in 0.01f64..0.99, v in 0.01f64..0.99,
    ) {
        let base = surfaces::wing_mould();
        let rot = Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(Vector3::new(ax, ay, az)), angle);
        let cps: Vec<Vec<[f64; 3]>> = base.control_grid().iter().map(|row| row.iter().map(|p| {
            let q = rot * Vector3::from(*p) * scale + Vector3::new(5.0, -3.0, 2.0);
            [q.x, q.y, q.z]
        }).collect()).collect();
        let moved = NurbsSurface::new(3, 3, base.knots_u().to_vec(), base.knots_v().to_vec(), &cps, None).unwrap();
        let g0 = LocalGeometry::at(&base, u, v).unwrap();
        let g1 = LocalGeometry::at(&moved, u, v).unwrap();
        prop_assert!((g1.k_min * scale - g0.k_min).abs() < 1e-9 * g0.k_max.abs().max(1e-3));
        prop_assert!((g1.k_max * scale - g0.k_max).abs() < 1e-9 * g0.k_max.abs().max(1e-3));
        prop_assert!((g1.forms.n - rot * g0.forms.n).norm() < 1e-9);
    }

    /// Inversion round trip on the sphere: any point off the centre projects radially.
    #[test]
    fn sphere_inversion_projects_radially(x in -60.0f64..60.0, y in -60.0f64..60.0, z in -60.0f64..60.0) {
        let q = Point3::new(x, y, z);
        prop_assume!(q.coords.norm() > 1.0);
        let s = sphere(20.0);
        let c = closest_point(&s, &q);
        let want = q.coords.normalize() * 20.0;
        prop_assert!((c.point.coords - want).norm() < 1e-6, "{:?} vs {:?}", c.point, want);
    }

    /// A section through a traced point contains that point (trace and section agree).
    #[test]
    fn a_section_through_a_surface_point_passes_through_it(u in 0.05f64..0.95, v in 0.05f64..0.95, nx in -1.0f64..1.0) {
        let s = surfaces::wing_mould();
        let p = s.point(u, v);
        let plane = Plane::new(p, Vector3::new(nx, 1.0, 0.2)).unwrap();
        let opts = SectionOptions { max_segment: 0.5, ..SectionOptions::for_surface(&s) };
        let curves = intersect_plane(&s, &plane, &opts);
        let closest = curves.iter().flat_map(|c| c.xyz.iter()).map(|q| (Point3::from(*q) - p).norm()).fold(f64::INFINITY, f64::min);
        prop_assert!(closest < 0.5, "{closest}");
        for c in &curves {
            for q in &c.xyz {
                prop_assert!(plane.distance(&Point3::from(*q)).abs() < 1e-8);
            }
        }
    }
}
