//! 2.5-axis pocket outlines: an outer loop and holes, as closed polylines.

use crate::error::{Error, Result};

pub type Point2 = [f64; 2];

/// A validated pocket: `outer` counter-clockwise, every hole clockwise,
/// no self-intersections, holes strictly inside the outer loop and disjoint.
#[derive(Clone, Debug, PartialEq)]
pub struct Pocket {
    pub outer: Vec<Point2>,
    pub holes: Vec<Vec<Point2>>,
}

/// Twice the signed area (positive for counter-clockwise).
pub fn signed_area(poly: &[Point2]) -> f64 {
    let n = poly.len();
    let mut s = 0.0;
    for i in 0..n {
        let a = poly[i];
        let b = poly[(i + 1) % n];
        s += a[0] * b[1] - a[1] * b[0];
    }
    0.5 * s
}

/// Point-in-polygon by the winding rule (polygon closed implicitly).
pub fn contains(poly: &[Point2], p: Point2) -> bool {
    let n = poly.len();
    let mut inside = false;
    let mut j = n - 1;
    for i in 0..n {
        let (a, b) = (poly[i], poly[j]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                inside = !inside;
            }
        }
        j = i;
    }
    inside
}

fn orient(a: Point2, b: Point2, c: Point2) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

fn on_segment(a: Point2, b: Point2, p: Point2) -> bool {
    p[0] >= a[0].min(b[0])
        && p[0] <= a[0].max(b[0])
        && p[1] >= a[1].min(b[1])
        && p[1] <= a[1].max(b[1])
}

/// Do closed segments ab and cd intersect (touching counts)?
pub(crate) fn segments_intersect(a: Point2, b: Point2, c: Point2, d: Point2) -> bool {
    let d1 = orient(c, d, a);
    let d2 = orient(c, d, b);
    let d3 = orient(a, b, c);
    let d4 = orient(a, b, d);
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    (d1 == 0.0 && on_segment(c, d, a))
        || (d2 == 0.0 && on_segment(c, d, b))
        || (d3 == 0.0 && on_segment(a, b, c))
        || (d4 == 0.0 && on_segment(a, b, d))
}

/// Segments of all loops, as (loop, index, a, b).
type Seg = (usize, usize, Point2, Point2);

/// Grid entries plus segment pairs the self-intersection check may visit:
/// about a second. Outlines far beyond any real part (tens of thousands of
/// segments all overlapping one another) are refused instead of checked
/// for minutes.
const CROSSING_CHECK_BUDGET: usize = 50_000_000;

/// Finds the first pair of crossing segments among all loops (adjacent
/// segments of one loop share a vertex and are not counted). A grid whose
/// column and row bounds are quantiles of the vertices keeps this
/// near-linear for the 10 000-vertex outlines of the benchmarks and for
/// loops whose vertices crowd into a small part of their box (one far
/// vertex beside thousands close together would put them all in one cell
/// of an even grid: quadratic).
/// `Err(())` when that would take more than [`CROSSING_CHECK_BUDGET`] steps.
fn first_crossing(loops: &[&[Point2]]) -> std::result::Result<Option<(Seg, Seg)>, ()> {
    let mut segs: Vec<Seg> = Vec::new();
    for (l, poly) in loops.iter().enumerate() {
        let n = poly.len();
        for i in 0..n {
            segs.push((l, i, poly[i], poly[(i + 1) % n]));
        }
    }
    let cells = ((segs.len() as f64).sqrt().ceil() as usize).clamp(1, 512);
    // Inner bounds of the columns (rows): every len/cells-th vertex x (y).
    let bounds = |t: usize| {
        let mut c: Vec<f64> = segs.iter().map(|s| s.2[t]).collect();
        c.sort_by(f64::total_cmp);
        (1..cells)
            .map(|k| c[k * c.len() / cells])
            .collect::<Vec<f64>>()
    };
    let (bx, by) = (bounds(0), bounds(1));
    let cell = |x: f64, y: f64| {
        (
            bx.partition_point(|&b| b <= x),
            by.partition_point(|&b| b <= y),
        )
    };
    let mut grid: Vec<Vec<usize>> = vec![Vec::new(); cells * cells];
    let mut steps = 0usize;
    for (k, s) in segs.iter().enumerate() {
        let (x0, y0) = cell(s.2[0].min(s.3[0]), s.2[1].min(s.3[1]));
        let (x1, y1) = cell(s.2[0].max(s.3[0]), s.2[1].max(s.3[1]));
        steps += (x1 - x0 + 1) * (y1 - y0 + 1);
        if steps > CROSSING_CHECK_BUDGET {
            return Err(());
        }
        for cx in x0..=x1 {
            for cy in y0..=y1 {
                grid[cy * cells + cx].push(k);
            }
        }
    }
    let mut best: Option<(usize, usize)> = None;
    for bucket in &grid {
        steps += bucket.len() * bucket.len().saturating_sub(1) / 2;
        if steps > CROSSING_CHECK_BUDGET {
            return Err(());
        }
        for (x, &i) in bucket.iter().enumerate() {
            for &j in &bucket[x + 1..] {
                let (si, sj) = (&segs[i], &segs[j]);
                if si.0 == sj.0 {
                    let n = loops[si.0].len();
                    let adjacent = (si.1 + 1) % n == sj.1 || (sj.1 + 1) % n == si.1;
                    if adjacent {
                        // Adjacent segments only share their common vertex, unless they fold back.
                        let (a, b, c) = if (si.1 + 1) % n == sj.1 {
                            (si.2, si.3, sj.3)
                        } else {
                            (sj.2, sj.3, si.3)
                        };
                        let folds = orient(a, b, c) == 0.0
                            && ((c[0] - b[0]) * (a[0] - b[0]) + (c[1] - b[1]) * (a[1] - b[1]))
                                > 0.0;
                        if folds {
                            let pair = (i.min(j), i.max(j));
                            best = Some(best.map_or(pair, |b| b.min(pair)));
                        }
                        continue;
                    }
                }
                if segments_intersect(si.2, si.3, sj.2, sj.3) {
                    let pair = (i.min(j), i.max(j));
                    best = Some(best.map_or(pair, |b| b.min(pair)));
                }
            }
        }
    }
    Ok(best.map(|(i, j)| (segs[i], segs[j])))
}

fn loop_name(l: usize) -> String {
    if l == 0 {
        "outer".to_string()
    } else {
        format!("holes[{}]", l - 1)
    }
}

fn clean_loop(field: &str, pts: &[Point2]) -> Result<Vec<Point2>> {
    for (i, p) in pts.iter().enumerate() {
        if !p[0].is_finite() || !p[1].is_finite() {
            return Err(Error::invalid(
                format!("{field}[{i}]"),
                "has a coordinate that is not a finite number",
            ));
        }
    }
    let mut out: Vec<Point2> = Vec::with_capacity(pts.len());
    for &p in pts {
        if out.last() != Some(&p) {
            out.push(p);
        }
    }
    if out.len() > 1 && out.first() == out.last() {
        out.pop();
    }
    if out.len() < 3 {
        return Err(Error::invalid(
            field,
            format!(
                "a closed loop needs at least 3 distinct points, got {}",
                out.len()
            ),
        ));
    }
    if signed_area(&out).abs() < 1e-12 {
        return Err(Error::invalid(field, "loop has zero area"));
    }
    Ok(out)
}

impl Pocket {
    /// Validates and normalises orientation (outer CCW, holes CW).
    pub fn new(outer: &[Point2], holes: &[Vec<Point2>]) -> Result<Self> {
        let mut outer = clean_loop("outer", outer)?;
        if signed_area(&outer) < 0.0 {
            outer.reverse();
        }
        let mut hs = Vec::with_capacity(holes.len());
        for (k, h) in holes.iter().enumerate() {
            let mut h = clean_loop(&format!("holes[{k}]"), h)?;
            if signed_area(&h) > 0.0 {
                h.reverse();
            }
            hs.push(h);
        }
        let mut loops: Vec<&[Point2]> = vec![&outer];
        loops.extend(hs.iter().map(|h| h.as_slice()));
        let crossing = first_crossing(&loops).map_err(|()| {
            Error::invalid(
                "outer",
                format!(
                    "{} segments overlap each other too much to check for self-intersection (more than {CROSSING_CHECK_BUDGET} steps): simplify the outline",
                    loops.iter().map(|l| l.len()).sum::<usize>()
                ),
            )
        })?;
        if let Some((a, b)) = crossing {
            let msg = if a.0 == b.0 {
                format!(
                    "outline intersects itself: segment {} ({:?} to {:?}) meets segment {} ({:?} to {:?})",
                    a.1, a.2, a.3, b.1, b.2, b.3
                )
            } else {
                format!(
                    "crosses {}: its segment {} ({:?} to {:?}) meets segment {} ({:?} to {:?})",
                    loop_name(a.0),
                    b.1,
                    b.2,
                    b.3,
                    a.1,
                    a.2,
                    a.3
                )
            };
            return Err(Error::invalid(loop_name(b.0.max(a.0)).to_string(), msg));
        }
        for (k, h) in hs.iter().enumerate() {
            if !contains(&outer, h[0]) {
                return Err(Error::invalid(
                    format!("holes[{k}]"),
                    "lies outside the outer loop",
                ));
            }
            for (m, other) in hs.iter().enumerate() {
                if m != k && contains(other, h[0]) {
                    return Err(Error::invalid(
                        format!("holes[{k}]"),
                        format!("lies inside holes[{m}]"),
                    ));
                }
            }
        }
        Ok(Self { outer, holes: hs })
    }

    /// Area of the pocket (outer minus holes).
    pub fn area(&self) -> f64 {
        signed_area(&self.outer) + self.holes.iter().map(|h| signed_area(h)).sum::<f64>()
    }

    /// Is the point inside the material-free region (inside outer, outside holes)?
    pub fn contains(&self, p: Point2) -> bool {
        contains(&self.outer, p) && !self.holes.iter().any(|h| contains(h, p))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A circle of `n` vertices with vertex 0 moved far up and right: a
    /// simple outline whose vertices all crowd into one corner of its box.
    fn crowded(n: usize) -> Vec<Point2> {
        (0..n)
            .map(|k| {
                if k == 0 {
                    return [1e6, 1e6];
                }
                let a = std::f64::consts::TAU * k as f64 / n as f64;
                [a.cos(), a.sin()]
            })
            .collect()
    }

    #[test]
    fn a_crowded_outline_is_checked_within_the_budget() {
        // An even grid would put the 20 000 circle vertices in one cell:
        // 2e8 pairs, over the budget. The quantile grid spreads them.
        let p = Pocket::new(&crowded(20_000), &[]).unwrap();
        assert_eq!(p.outer.len(), 20_000);
        // Moving one circle vertex across the far spike's segments makes
        // it cross itself, and that is found.
        let mut bad = crowded(20_000);
        bad[10_000] = [2e5, 2.1e5];
        let e = Pocket::new(&bad, &[]).unwrap_err().to_string();
        assert!(e.contains("intersects itself"), "{e}");
    }

    #[test]
    fn an_outline_of_long_segments_crossing_everywhere_is_refused_by_its_budget() {
        // A star polygon {n / (n - 1) / 2}: every segment crosses the middle.
        let n = 20_001;
        let star: Vec<Point2> = (0..n)
            .map(|k| {
                let a = std::f64::consts::TAU * ((k * (n - 1) / 2) % n) as f64 / n as f64;
                [a.cos(), a.sin()]
            })
            .collect();
        let e = Pocket::new(&star, &[]).unwrap_err().to_string();
        assert!(
            e.contains("20001 segments overlap each other too much"),
            "{e}"
        );
    }
}
