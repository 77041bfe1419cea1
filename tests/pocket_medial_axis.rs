//! Medial axis of the reference pockets (methods.md C) against exact answers.

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
            (31.5..=32.05).contains(&xmax) && (-32.05..-31.5).contains(&xmin),
            "n {n}: {xmin} {xmax}"
        );
        assert!(
            (ma.min_corner_radius - 18.0).abs() < 0.1,
            "n {n}: {}",
            ma.min_corner_radius
        );
    }
}
