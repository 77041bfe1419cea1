//! Built-in sample pockets (outer loop counter-clockwise, holes clockwise).

use std::f64::consts::PI;
use toolpath_kernel::geometry::pocket::Point2;
use toolpath_kernel::geometry::Pocket;

fn built(p: toolpath_kernel::error::Result<Pocket>) -> Pocket {
    // Fixed data; the sample tests build every pocket.
    p.expect("built-in sample pocket is valid")
}

/// Rectangle 100 x 60 mm with corners (0, 0) and (100, 60).
pub fn rect_pocket() -> Pocket {
    built(Pocket::new(
        &[[0.0, 0.0], [100.0, 0.0], [100.0, 60.0], [0.0, 60.0]],
        &[],
    ))
}

/// Circle (or ellipse) as a clockwise polygon, for holes.
fn ellipse_cw(c: Point2, a: f64, b: f64, n: usize) -> Vec<Point2> {
    (0..n)
        .map(|k| {
            let t = -2.0 * PI * k as f64 / n as f64;
            [c[0] + a * t.cos(), c[1] + b * t.sin()]
        })
        .collect()
}

/// Rectangle 120 x 80 mm with a round hole of radius 15 at (75, 40).
pub fn pocket_with_hole() -> Pocket {
    built(Pocket::new(
        &[[0.0, 0.0], [120.0, 0.0], [120.0, 80.0], [0.0, 80.0]],
        &[ellipse_cw([75.0, 40.0], 15.0, 15.0, 72)],
    ))
}

/// Leaf length, mm.
pub(crate) const LEAF_LENGTH: f64 = 180.0;
/// Radius of the rounded leaf tips, mm.
pub(crate) const LEAF_TIP_RADIUS: f64 = 1.5;

/// Half-widths of the leaf above and below its midrib at x: a sine envelope
/// pinched at two necks (x = 62 and x = 122), slightly asymmetric.
fn leaf_half_widths(x: f64) -> (f64, f64) {
    let s = (PI * x / LEAF_LENGTH).sin();
    let neck = |x0: f64, depth: f64| 1.0 - depth * (-((x - x0) / 9.0).powi(2)).exp();
    let pinch = neck(62.0, 0.78) * neck(122.0, 0.72);
    let upper = 36.0 * s * pinch * (1.0 + 0.08 * (2.0 * PI * x / LEAF_LENGTH).sin());
    let lower = 30.0 * s * pinch;
    (upper, lower)
}

/// Rounds the leaf tip at x = `apex_x` (y = 0) with an arc of radius
/// `LEAF_TIP_RADIUS` tangent to the two edge lines leaving the apex. Returns
/// the x where the edges are cut and the arc points in counter-clockwise order
/// (`sign` = +1 for the tip at x = 0, -1 at x = L).
fn tip_arc(apex_x: f64, sign: f64, n: usize) -> (f64, Vec<Point2>) {
    // Edge directions from the apex (the envelope is straight near the tips).
    let h = 1e-4;
    let (up, lo) = leaf_half_widths(apex_x + sign * h);
    let d1 = [sign * h, up];
    let d2 = [sign * h, -lo];
    let unit = |d: [f64; 2]| {
        let l = d[0].hypot(d[1]);
        [d[0] / l, d[1] / l]
    };
    let (d1, d2) = (unit(d1), unit(d2));
    let alpha = (d1[0] * d2[0] + d1[1] * d2[1]).clamp(-1.0, 1.0).acos();
    let bis = unit([d1[0] + d2[0], d1[1] + d2[1]]);
    let dist_c = LEAF_TIP_RADIUS / (alpha / 2.0).sin();
    let dist_t = LEAF_TIP_RADIUS / (alpha / 2.0).tan();
    let c = [apex_x + dist_c * bis[0], dist_c * bis[1]];
    let t1 = [apex_x + dist_t * d1[0], dist_t * d1[1]];
    let t2 = [apex_x + dist_t * d2[0], dist_t * d2[1]];
    let a1 = (t1[1] - c[1]).atan2(t1[0] - c[0]);
    let a2 = (t2[1] - c[1]).atan2(t2[0] - c[0]);
    // Counter-clockwise round the apex: upper to lower at x = 0, lower to upper at x = L.
    let (from, mut to) = if sign > 0.0 { (a1, a2) } else { (a2, a1) };
    while to <= from {
        to += 2.0 * PI;
    }
    let arc = (0..=n)
        .map(|k| from + (to - from) * k as f64 / n as f64)
        .map(|t| {
            [
                c[0] + LEAF_TIP_RADIUS * t.cos(),
                c[1] + LEAF_TIP_RADIUS * t.sin(),
            ]
        })
        .collect();
    (t1[0], arc)
}

/// A leaf-like outline, 180 mm long, with three lobes joined by two narrow
/// necks (about 15 mm wide), tips rounded with radius 1.5 mm, and two holes
/// (a circle and an ellipse) in the larger lobes. About 430 vertices.
pub fn leaf_pocket() -> Pocket {
    let (x_start, tip0) = tip_arc(0.0, 1.0, 12);
    let (x_end, tip1) = tip_arc(LEAF_LENGTH, -1.0, 12);
    let n = 150;
    let xs: Vec<f64> = (1..n)
        .map(|k| x_start + (x_end - x_start) * k as f64 / n as f64)
        .collect();
    let mut outer: Vec<Point2> = Vec::new();
    // Counter-clockwise: lower edge left to right, tip at L, upper edge right to left, tip at 0.
    for &x in &xs {
        outer.push([x, -leaf_half_widths(x).1]);
    }
    // Tip at x = L from the lower tangent point to the upper one (counter-clockwise).
    outer.extend(tip1.iter());
    for &x in xs.iter().rev() {
        outer.push([x, leaf_half_widths(x).0]);
    }
    outer.extend(tip0.iter());
    let holes = vec![
        ellipse_cw([30.0, 2.0], 8.0, 8.0, 48),
        ellipse_cw([92.0, 0.0], 14.0, 10.0, 64),
    ];
    built(Pocket::new(&outer, &holes))
}
