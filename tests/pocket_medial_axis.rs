//! Medial axis of the reference pockets (docs/methods.md, "Pocket references")
//! against exact answers.

use toolpath_planner::geometry::medial_axis::medial_axis;
use toolpath_planner::geometry::Pocket;

fn rectangle(w: f64, h: f64) -> Pocket {
    Pocket::new(&[[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]], &[]).unwrap()
}

fn ellipse(a: f64, b: f64, n: usize) -> Pocket {
    let pts: Vec<[f64; 2]> = (0..n)
        .map(|i| {
            let t = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
            [a * t.cos(), b * t.sin()]
        })
        .collect();
    Pocket::new(&pts, &[]).unwrap()
}

/// Distance from p to the polygon boundary, brute force over all edges.
fn boundary_distance(loops: &[&[[f64; 2]]], p: [f64; 2]) -> f64 {
    let mut best = f64::INFINITY;
    for poly in loops {
        for i in 0..poly.len() {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            let d = [b[0] - a[0], b[1] - a[1]];
            let t = (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / (d[0] * d[0] + d[1] * d[1]))
                .clamp(0.0, 1.0);
            best = best.min((p[0] - a[0] - t * d[0]).hypot(p[1] - a[1] - t * d[1]));
        }
    }
    best
}

#[test]
fn rectangle_100_by_60() {
    let p = rectangle(100.0, 60.0);
    let ma = medial_axis(&p).unwrap();
    assert!((ma.dmax - 60.0).abs() < 0.01, "dmax {}", ma.dmax);
    let mut bps: Vec<_> = ma.branch_points().map(|n| (n.x, n.y, n.r)).collect();
    bps.sort_by(|a, b| a.0.total_cmp(&b.0));
    assert_eq!(bps.len(), 2, "{bps:?}");
    for (bp, want) in bps.iter().zip([(30.0, 30.0), (70.0, 30.0)]) {
        assert!((bp.0 - want.0).hypot(bp.1 - want.1) < 0.05, "{bp:?}");
        assert!((bp.2 - 30.0).abs() < 0.05);
    }
    // Five branches: the centre line and one to each corner, which end with r = 0.
    assert_eq!(ma.branches.len(), 5);
    assert_eq!(ma.end_points().count(), 4);
    assert!(ma.min_corner_radius.abs() < 1e-6);
    for b in &ma.branches {
        for q in &b.points {
            let d = boundary_distance(&[&p.outer], [q[0], q[1]]);
            assert!((d - q[2]).abs() < 1e-3);
        }
    }
}

#[test]
fn ellipse_50_by_30() {
    for n in [720, 2000] {
        let p = ellipse(50.0, 30.0, n);
        let ma = medial_axis(&p).unwrap();
        assert!((ma.dmax - 60.0).abs() < 0.01, "n {n}: dmax {}", ma.dmax);
        assert_eq!(ma.branch_points().count(), 0, "n {n}: {:?}", ma.nodes);
        let (mut xmin, mut xmax) = (f64::INFINITY, f64::NEG_INFINITY);
        for b in &ma.branches {
            for q in &b.points {
                assert!(q[1].abs() < 0.05, "n {n}: off-axis point {q:?}");
                let want = 30.0 * (1.0 - q[0] * q[0] / 1600.0).max(0.0).sqrt();
                assert!((q[2] - want).abs() < 0.02, "n {n}: r {q:?} vs {want}");
                xmin = xmin.min(q[0]);
                xmax = xmax.max(q[0]);
            }
        }
        assert!(
            (31.99..=32.01).contains(&xmax) && (-32.01..-31.99).contains(&xmin),
            "n {n}: {xmin} {xmax}"
        );
        assert!(
            (ma.min_corner_radius - 18.0).abs() < 0.002,
            "n {n}: {}",
            ma.min_corner_radius
        );
    }
}

/// The axis of a smooth lobe runs to the centre of curvature at the lobe's
/// tip: ellipses of several shapes and discretisations end at
/// x = +-(a^2 - b^2)/a with r = b^2/a (the exact evolute cusp), not short of it.
#[test]
fn smooth_lobes_end_at_the_centre_of_curvature() {
    for (a, b, n) in [
        (50.0, 30.0, 720),
        (50.0, 30.0, 2000),
        (50.0, 30.0, 5000),
        (40.0, 25.0, 1000),
        (80.0, 20.0, 3000),
        (30.0, 27.0, 1500),
    ] {
        let p = ellipse(a, b, n);
        let ma = medial_axis(&p).unwrap();
        let (rc, xe) = (b * b / a, (a * a - b * b) / a);
        assert!(
            (ma.min_corner_radius - rc).abs() < 0.005,
            "{a} x {b}, n {n}: min corner radius {} vs {rc}",
            ma.min_corner_radius
        );
        let ends: Vec<_> = ma.end_points().map(|e| (e.x, e.y, e.r)).collect();
        assert_eq!(ends.len(), 2, "{a} x {b}, n {n}: {ends:?}");
        for e in &ends {
            assert!(
                (e.0.abs() - xe).abs() < 0.01 && e.1.abs() < 0.01 && (e.2 - rc).abs() < 0.005,
                "{a} x {b}, n {n}: end {e:?}, want (+-{xe}, 0, {rc})"
            );
            // Its circle is inscribed (brute-force distance to the polygon).
            let d = boundary_distance(&[&p.outer], [e.0, e.1]);
            assert!((d - e.2).abs() < 2e-3, "{e:?}: distance {d}");
        }
    }
}

/// A lobe that is not symmetric about its axis: the limacon-like outline
/// r(t) = 40 + 8 cos t + 3 sin 2t has its tip curvature maximum off any
/// symmetry line. The end must be the centre of curvature at the point of
/// maximum curvature, found here by dense sampling of the exact curve.
#[test]
fn asymmetric_lobe_ends_at_its_curvature_centre() {
    let curve = |t: f64| {
        let r = 40.0 + 8.0 * t.cos() + 3.0 * (2.0 * t).sin();
        [r * t.cos(), r * t.sin()]
    };
    let n = 4000;
    let pts: Vec<[f64; 2]> = (0..n)
        .map(|i| curve(std::f64::consts::TAU * i as f64 / n as f64))
        .collect();
    let p = Pocket::new(&pts, &[]).unwrap();
    let ma = medial_axis(&p).unwrap();
    // Curvature maxima of the exact curve (finite differences, dense).
    let m = 200_000;
    let h = std::f64::consts::TAU / m as f64;
    let kappa = |t: f64| {
        let (a, b, c) = (curve(t - h), curve(t), curve(t + h));
        let d1 = [(c[0] - a[0]) / (2.0 * h), (c[1] - a[1]) / (2.0 * h)];
        let d2 = [
            (c[0] - 2.0 * b[0] + a[0]) / (h * h),
            (c[1] - 2.0 * b[1] + a[1]) / (h * h),
        ];
        (d1[0] * d2[1] - d1[1] * d2[0]) / (d1[0].hypot(d1[1])).powi(3)
    };
    let ks: Vec<f64> = (0..m).map(|i| kappa(i as f64 * h)).collect();
    let mut centres = Vec::new();
    for i in 0..m {
        let (prev, next) = (ks[(i + m - 1) % m], ks[(i + 1) % m]);
        if ks[i] > prev && ks[i] >= next {
            let t = i as f64 * h;
            let (a, c) = (curve(t - h), curve(t + h));
            let tan = [c[0] - a[0], c[1] - a[1]];
            let l = tan[0].hypot(tan[1]);
            let nrm = [-tan[1] / l, tan[0] / l];
            let q = curve(t);
            let rho = 1.0 / ks[i];
            centres.push([q[0] + rho * nrm[0], q[1] + rho * nrm[1], rho]);
        }
    }
    let ends: Vec<_> = ma.end_points().map(|e| [e.x, e.y, e.r]).collect();
    assert!(!ends.is_empty());
    // Every end is a curvature centre of a local curvature maximum, and the
    // smallest corner radius is the smallest end radius.
    for e in &ends {
        let best = centres
            .iter()
            .map(|c| ((c[0] - e[0]).hypot(c[1] - e[1]), c[2]))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .unwrap();
        assert!(
            best.0 < 0.01 && (best.1 - e[2]).abs() < 0.005,
            "end {e:?}: nearest curvature centre at {} with radius {} ({centres:?})",
            best.0,
            best.1
        );
    }
}
