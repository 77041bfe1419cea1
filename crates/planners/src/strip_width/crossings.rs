//! Pairs of passes that cross each other in the parameter plane: the
//! regularity check of an offsetting (docs/methods.md, "Iso-scallop
//! offsetting": folded fronts leave passes that cross). Two passes that
//! only meet on the domain's edge (the last passes of a side running along
//! it) are not counted; a pass that crosses itself is not either.

use nalgebra::Vector2;
use std::collections::{HashMap, HashSet};
use toolpath_formats::{Pass, PlanResult};

/// Crossings closer than this share of the domain's side to its edge are
/// passes meeting on the edge, not passes crossing.
pub(crate) const EDGE_SHARE: f64 = 0.002;

/// Grid cells per domain side for the segment hash.
const CELLS: f64 = 50.0;

type Uv = [f64; 2];

/// The number of pairs of different passes of `passes` that cross at least
/// once more than [`EDGE_SHARE`] of the domain's side from its edge, the
/// domain being `((u0, u1), (v0, v1))`.
pub fn crossing_pairs(passes: &[Pass], domain: ((f64, f64), (f64, f64))) -> usize {
    let ((u0, u1), (v0, v1)) = domain;
    let (du, dv) = (u1 - u0, v1 - v0);
    if !(du > 0.0 && dv > 0.0) {
        return 0;
    }
    let cell = |p: Uv| -> (i64, i64) {
        (
            ((p[0] - u0) / du * CELLS).floor() as i64,
            ((p[1] - v0) / dv * CELLS).floor() as i64,
        )
    };
    let mut segments: Vec<(usize, Uv, Uv)> = Vec::new();
    let mut grid: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
    for (id, pass) in passes.iter().enumerate() {
        for w in pass.points.windows(2) {
            let (a, b) = (w[0].uv, w[1].uv);
            if a == b {
                continue;
            }
            let k = segments.len();
            segments.push((id, a, b));
            let (lo, hi) = (
                cell([a[0].min(b[0]), a[1].min(b[1])]),
                cell([a[0].max(b[0]), a[1].max(b[1])]),
            );
            for i in lo.0..=hi.0 {
                for j in lo.1..=hi.1 {
                    grid.entry((i, j)).or_default().push(k);
                }
            }
        }
    }
    let inside = |p: Uv| {
        (p[0] - u0).min(u1 - p[0]) > EDGE_SHARE * du && (p[1] - v0).min(v1 - p[1]) > EDGE_SHARE * dv
    };
    let mut pairs: HashSet<(usize, usize)> = HashSet::new();
    for list in grid.values() {
        for (x, &k) in list.iter().enumerate() {
            for &m in &list[x + 1..] {
                let ((ia, a0, a1), (ib, b0, b1)) = (segments[k], segments[m]);
                if ia == ib {
                    continue;
                }
                let key = (ia.min(ib), ia.max(ib));
                if pairs.contains(&key) {
                    continue;
                }
                if crossing(a0, a1, b0, b1).is_some_and(inside) {
                    pairs.insert(key);
                }
            }
        }
    }
    pairs.len()
}

/// [`crossing_pairs`] of a plan's own passes: the repair passes the
/// pipeline appends (`repair_passes` in its stats) cross what they repair
/// by design and are left out.
pub fn plan_crossing_pairs(result: &PlanResult, domain: ((f64, f64), (f64, f64))) -> usize {
    let repair = result
        .stats
        .extra
        .get("repair_passes")
        .copied()
        .unwrap_or(0.0) as usize;
    let own = &result.passes[..result.passes.len().saturating_sub(repair)];
    crossing_pairs(own, domain)
}

/// The point where segments ab and cd cross (see [`segment_crossing`]).
fn crossing(a: Uv, b: Uv, c: Uv, d: Uv) -> Option<Uv> {
    let v = |p: Uv| Vector2::new(p[0], p[1]);
    let t = segment_crossing(v(a), v(b), v(c), v(d))?;
    Some([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])])
}

/// Where segments ab and cd cross (not collinear), as the parameter along
/// ab, each segment taken half-open, from its start up to but not including
/// its end: a crossing at a point two segments of a polyline share is found
/// once.
pub(crate) fn segment_crossing(
    a: Vector2<f64>,
    b: Vector2<f64>,
    c: Vector2<f64>,
    d: Vector2<f64>,
) -> Option<f64> {
    let (r, s) = (b - a, d - c);
    let den = r.perp(&s);
    if den.abs() <= 1e-12 * r.norm() * s.norm() {
        return None;
    }
    let q = c - a;
    let t = q.perp(&s) / den;
    let u = q.perp(&r) / den;
    ((0.0..1.0).contains(&t) && (0.0..1.0).contains(&u)).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use toolpath_formats::PathPoint;

    fn pass(uv: &[Uv]) -> Pass {
        Pass {
            region: 0,
            points: uv
                .iter()
                .map(|&uv| PathPoint {
                    cc: [uv[0], uv[1], 0.0],
                    cl: [uv[0], uv[1], 0.0],
                    axis: [0.0, 0.0, 1.0],
                    uv,
                    strip_width: None,
                    feed: None,
                    lead_deg: None,
                    mpec: None,
                    wheel_center: None,
                    wheel_axis: None,
                    normal: None,
                    gouge: None,
                })
                .collect(),
            min_strip_width: None,
        }
    }

    /// A polyline from `a` to `b` in `n` equal steps.
    fn line(a: Uv, b: Uv, n: usize) -> Vec<Uv> {
        (0..=n)
            .map(|k| {
                let f = k as f64 / n as f64;
                [a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])]
            })
            .collect()
    }

    const UNIT: ((f64, f64), (f64, f64)) = ((0.0, 1.0), (0.0, 1.0));

    #[test]
    fn parallel_passes_do_not_cross() {
        let passes: Vec<Pass> = (1..10)
            .map(|k| pass(&line([0.0, 0.1 * k as f64], [1.0, 0.1 * k as f64], 37)))
            .collect();
        assert_eq!(crossing_pairs(&passes, UNIT), 0);
    }

    /// Every pair of a fan of lines through one interior point crosses
    /// there, in whatever cell of the hash it lies; a grid of rows and
    /// columns crosses row by column only (the columns at points of the
    /// rows: a crossing at a polyline's point counts too).
    #[test]
    fn every_crossing_pair_is_counted_once() {
        for centre in [[0.5, 0.5], [0.3137, 0.7771], [0.02, 0.98]] {
            let fan: Vec<Pass> = (0..7)
                .map(|k| {
                    let a = 0.4 * k as f64 + 0.1;
                    let (dx, dy) = (0.01 * a.cos(), 0.01 * a.sin());
                    // The centre at 0.35 of each line: between its points.
                    let a0 = [centre[0] - 0.7 * dx, centre[1] - 0.7 * dy];
                    let a1 = [centre[0] + 1.3 * dx, centre[1] + 1.3 * dy];
                    pass(&line(a0, a1, 3 + k))
                })
                .collect();
            assert_eq!(crossing_pairs(&fan, UNIT), 21, "fan at {centre:?}");
        }
        let mut grid: Vec<Pass> = (1..6)
            .map(|k| pass(&line([0.05, 0.15 * k as f64], [0.95, 0.15 * k as f64], 90)))
            .collect();
        grid.extend(
            (1..5).map(|k| pass(&line([0.18 * k as f64, 0.05], [0.18 * k as f64, 0.95], 11))),
        );
        assert_eq!(crossing_pairs(&grid, UNIT), 5 * 4);
        // Passes that cross twice are one pair.
        let zig = pass(&[[0.1, 0.4], [0.5, 0.6], [0.9, 0.4]]);
        let flat = pass(&line([0.0, 0.5], [1.0, 0.5], 10));
        assert_eq!(crossing_pairs(&[zig, flat], UNIT), 1);
    }

    /// Passes meeting on the domain's edge (one running along it) and a pass
    /// crossing itself are not counted; just inside the edge they are.
    #[test]
    fn meetings_on_the_edge_and_self_crossings_are_not_counted() {
        let along = pass(&[[0.2, 0.9995], [0.8, 0.9995]]);
        let into = pass(&[[0.5, 0.9], [0.52, 1.0]]);
        assert_eq!(crossing_pairs(&[along.clone(), into.clone()], UNIT), 0);
        let inner = pass(&[[0.2, 0.99], [0.8, 0.99]]);
        assert_eq!(crossing_pairs(&[inner, into], UNIT), 1);
        let looped = pass(&[[0.1, 0.1], [0.5, 0.5], [0.5, 0.1], [0.1, 0.5]]);
        assert_eq!(crossing_pairs(&[looped, along], UNIT), 0);
        // The edge share is of each side: a domain of 100 x 1 units.
        let wide = ((0.0, 100.0), (0.0, 1.0));
        let a = pass(&[[10.0, 0.5], [10.3, 0.5]]);
        let b = pass(&[[10.1, 0.0], [10.1, 1.0]]);
        assert_eq!(crossing_pairs(&[a, b], wide), 1);
    }
}
