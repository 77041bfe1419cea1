//! Tool-centre paths from parallel offsets of the pocket (cavalier_contours:
//! true arcs, islands handled by its Shape offset), their flattening for the
//! result file, and their ordering to keep rapid moves short.

use cavalier_contours::polyline::{PlineCreation, PlineSource, PlineSourceMut, Polyline};
use cavalier_contours::shape_algorithms::{Shape, ShapeOffsetOptions};
use toolpath_kernel::geometry::pocket::{Pocket, Point2};

/// Chord error when arcs are flattened for output and distance checks, mm.
pub(crate) const FLATTEN_TOL: f64 = 1e-4;

/// The pocket as a cavalier shape (outer CCW, holes CW: positive offsets shrink it).
pub(crate) fn pocket_shape(pocket: &Pocket) -> Shape<f64> {
    let loops = std::iter::once(&pocket.outer)
        .chain(pocket.holes.iter())
        .map(|l| {
            let mut pl = Polyline::with_capacity(l.len(), true);
            for p in l {
                pl.add(p[0], p[1], 0.0);
            }
            pl
        });
    Shape::from_plines(loops)
}

/// Closed tool-centre loops at inward offset `d` (arcs kept as bulges).
pub(crate) fn inward_offset(shape: &Shape<f64>, d: f64) -> Vec<Polyline<f64>> {
    let off = shape.parallel_offset(d, &ShapeOffsetOptions::default());
    off.ccw_plines
        .into_iter()
        .chain(off.cw_plines)
        .map(|p| p.polyline)
        .collect()
}

/// Points of a polyline with arcs flattened to `FLATTEN_TOL`; closed loops
/// repeat their first point at the end.
pub fn flatten(pl: &Polyline<f64>) -> Vec<Point2> {
    let flat = pl.arcs_to_approx_lines(FLATTEN_TOL);
    let src = flat.as_ref().unwrap_or(pl);
    let mut out: Vec<Point2> = src.iter_vertexes().map(|v| [v.x, v.y]).collect();
    if src.is_closed() {
        if let Some(&first) = out.first() {
            out.push(first);
        }
    }
    out
}

/// Exact length of a polyline with arcs.
pub(crate) fn exact_length(pl: &Polyline<f64>) -> f64 {
    pl.path_length()
}

fn d2(a: Point2, b: Point2) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}

/// Orders paths greedily by nearest next start, from `start`: open paths may be
/// reversed, closed ones (first == last point) rotated to start at the vertex
/// nearest to the tool. Returns the paths and the final tool position.
pub(crate) fn order_paths(
    mut paths: Vec<Vec<Point2>>,
    start: Point2,
) -> (Vec<Vec<Point2>>, Point2) {
    let mut out = Vec::with_capacity(paths.len());
    let mut at = start;
    while !paths.is_empty() {
        let mut best = (f64::INFINITY, 0usize, 0usize, false);
        for (k, p) in paths.iter().enumerate() {
            let closed = p.len() > 2 && p.first() == p.last();
            if closed {
                for (i, &q) in p.iter().enumerate() {
                    let d = d2(q, at);
                    if d < best.0 {
                        best = (d, k, i, false);
                    }
                }
            } else if let (Some(&a), Some(&b)) = (p.first(), p.last()) {
                if d2(a, at) < best.0 {
                    best = (d2(a, at), k, 0, false);
                }
                if d2(b, at) < best.0 {
                    best = (d2(b, at), k, 0, true);
                }
            }
        }
        let (_, k, i, reverse) = best;
        let mut p = paths.swap_remove(k);
        if p.len() > 2 && p.first() == p.last() {
            p.pop();
            let len = p.len();
            p.rotate_left(i % len);
            let first = p[0];
            p.push(first);
        } else if reverse {
            p.reverse();
        }
        if let Some(&last) = p.last() {
            at = last;
        }
        out.push(p);
    }
    (out, at)
}

/// Length of the rapid moves between consecutive paths.
pub fn rapid_length(paths: &[Vec<Point2>]) -> f64 {
    paths
        .windows(2)
        .filter_map(|w| Some(d2(*w[0].last()?, *w[1].first()?).sqrt()))
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_of_square_with_hole_keeps_arcs_round_the_hole() {
        let hole: Vec<Point2> = vec![[40.0, 40.0], [40.0, 60.0], [60.0, 60.0], [60.0, 40.0]];
        let p = Pocket::new(
            &[[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]],
            &[hole],
        )
        .unwrap();
        let loops = inward_offset(&pocket_shape(&p), 5.0);
        assert_eq!(loops.len(), 2);
        let lengths: Vec<f64> = loops.iter().map(exact_length).collect();
        // Outer: square 90 x 90; around the hole: 4 x 20 + circle of radius 5.
        assert!(
            lengths.iter().any(|l| (l - 360.0).abs() < 1e-6),
            "{lengths:?}"
        );
        let around = 80.0 + 2.0 * std::f64::consts::PI * 5.0;
        assert!(
            lengths.iter().any(|l| (l - around).abs() < 1e-6),
            "{lengths:?}"
        );
        for l in &loops {
            let flat = flatten(l);
            assert_eq!(flat.first(), flat.last());
        }
    }

    #[test]
    fn ordering_reverses_and_rotates() {
        let a = vec![[10.0, 0.0], [0.0, 0.0]];
        let b = vec![[20.0, 0.0], [21.0, 0.0], [21.0, 1.0], [20.0, 0.0]];
        let (o, end) = order_paths(vec![b, a], [0.0, 0.0]);
        assert_eq!(o[0], vec![[0.0, 0.0], [10.0, 0.0]]);
        assert_eq!(o[1][0], [20.0, 0.0]);
        assert_eq!(end, [20.0, 0.0]);
    }
}
