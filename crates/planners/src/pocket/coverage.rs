//! What the tools sweep: exact point-to-path distances through a uniform
//! grid of segments (nearest point) and a box tree of them (within reach),
//! and a raster of the pocket for the uncut area (docs/methods.md, "Tool
//! sequence").

use toolpath_kernel::geometry::pocket::{Pocket, Point2};
use toolpath_kernel::geometry::segment_index::{box_dist2, segment_box, BoxGrid, BoxTree};

/// Segments in a uniform grid of buckets, for nearest-segment queries, and
/// in a bounding-box tree, for within-reach tests.
pub struct SegmentIndex {
    segs: Vec<(Point2, Point2)>,
    /// The grid's cells hold (y, x) boxes: rows of constant y, the order in
    /// which `nearest` meets the segments (it keeps the last of equals).
    grid: BoxGrid<2>,
    /// Bounding-box tree of the same segments, for `within`: it skips the
    /// empty space round a point no path reaches in a few box tests, where
    /// the grid scans every bucket within reach.
    tree: BoxTree<2>,
}

/// The grid's coordinates of a point: (y, x).
fn yx(p: Point2) -> Point2 {
    [p[1], p[0]]
}

/// Nearest point of segment ab to p.
pub fn segment_foot(a: Point2, b: Point2, p: Point2) -> Point2 {
    let d = [b[0] - a[0], b[1] - a[1]];
    let l2 = d[0] * d[0] + d[1] * d[1];
    let t = if l2 > 0.0 {
        (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    [a[0] + t * d[0], a[1] + t * d[1]]
}

fn dist(a: Point2, b: Point2) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

impl SegmentIndex {
    /// Segments of the polylines (each a list of points; consecutive points joined).
    pub fn from_polylines<'a>(lines: impl IntoIterator<Item = &'a [Point2]>) -> Self {
        let mut segs = Vec::new();
        for l in lines {
            if l.len() == 1 {
                segs.push((l[0], l[0]));
            }
            segs.extend(l.windows(2).map(|w| (w[0], w[1])));
        }
        Self::new(segs)
    }

    /// Segments of the closed loops of a pocket.
    pub fn from_pocket(pocket: &Pocket) -> Self {
        let mut segs = Vec::new();
        for l in std::iter::once(&pocket.outer).chain(pocket.holes.iter()) {
            for i in 0..l.len() {
                segs.push((l[i], l[(i + 1) % l.len()]));
            }
        }
        Self::new(segs)
    }

    pub fn new(segs: Vec<(Point2, Point2)>) -> Self {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        let mut total = 0.0;
        for &(a, b) in &segs {
            for p in [a, b] {
                for t in 0..2 {
                    lo[t] = lo[t].min(p[t]);
                    hi[t] = hi[t].max(p[t]);
                }
            }
            total += dist(a, b);
        }
        if segs.is_empty() {
            lo = [0.0; 2];
            hi = [0.0; 2];
        }
        let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-6);
        // About two segments per bucket along a path, at most 512 x 512
        // buckets (513 along a side: the cell is at least 1/512 of the
        // extent, so the limit never enlarges it).
        let mean = total / segs.len().max(1) as f64;
        let cell = (2.0 * mean).max(extent / 512.0).max(1e-6);
        let yx_boxes: Vec<_> = segs
            .iter()
            .map(|&(a, b)| segment_box(&yx(a), &yx(b)))
            .collect();
        let boxes: Vec<_> = segs.iter().map(|(a, b)| segment_box(a, b)).collect();
        Self {
            grid: BoxGrid::new(&yx_boxes, cell, 513 * 513),
            tree: BoxTree::new(&boxes),
            segs,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.segs.is_empty()
    }

    /// Nearest point on the segments within `max_dist` of p: (distance, foot).
    pub fn nearest(&self, p: Point2, max_dist: f64) -> Option<(f64, Point2)> {
        if self.segs.is_empty() {
            return None;
        }
        let mut best: Option<(f64, Point2)> = None;
        let mut bound = max_dist;
        // Squared distances screen the segments without a square root; one
        // clearly beyond the bound (by more than hypot's rounding) is left out,
        // any other is measured exactly as before, so the answer is the same.
        let slack = 1.0 + 1e-12;
        let mut bound2 = bound * bound * slack;
        let (lo, hi) = (
            yx([p[0] - max_dist, p[1] - max_dist]),
            yx([p[0] + max_dist, p[1] + max_dist]),
        );
        self.grid.visit_clamped(&lo, &hi, |cell| {
            for &k in cell {
                let (a, b) = self.segs[k as usize];
                // Distance to the segment's box first: a cheap lower bound.
                let bx = (a[0].min(b[0]) - p[0]).max(p[0] - a[0].max(b[0])).max(0.0);
                let by = (a[1].min(b[1]) - p[1]).max(p[1] - a[1].max(b[1])).max(0.0);
                if bx * bx + by * by > bound2 {
                    continue;
                }
                let f = segment_foot(a, b, p);
                let (dx, dy) = (f[0] - p[0], f[1] - p[1]);
                if dx * dx + dy * dy > bound2 {
                    continue;
                }
                let d = dist(f, p);
                if d <= bound {
                    bound = d;
                    bound2 = bound * bound * slack;
                    best = Some((d, f));
                }
            }
        });
        best
    }

    /// Is any segment within `r` of p? The same answer as
    /// `nearest(p, r).is_some()`: squared distances decide unless within
    /// rounding of r, where `hypot` decides as in [`SegmentIndex::nearest`].
    /// The search walks the box tree, nearer child first, leaves out the
    /// boxes beyond reach and stops at the first segment found; the answer
    /// does not depend on the order.
    pub fn within(&self, p: Point2, r: f64) -> bool {
        if self.segs.is_empty() || r.is_nan() || r < 0.0 {
            return false;
        }
        let r2 = r * r;
        let (inside, outside) = (r2 * (1.0 - 1e-12), r2 * (1.0 + 1e-12));
        let hit = |k: u32| -> bool {
            let (a, b) = self.segs[k as usize];
            let (lo, hi) = segment_box(&a, &b);
            if box_dist2(&lo, &hi, &p) > outside {
                return false;
            }
            let f = segment_foot(a, b, p);
            let (dx, dy) = (f[0] - p[0], f[1] - p[1]);
            let d2 = dx * dx + dy * dy;
            d2 <= inside || (d2 <= outside && dist(f, p) <= r)
        };
        self.tree.search(
            |lo, hi| {
                let d = box_dist2(lo, hi, &p);
                (d <= outside).then_some(d)
            },
            |ks| ks.iter().any(|&k| hit(k)),
        )
    }
}

/// Tools already used: their paths and radii.
#[derive(Default)]
pub(crate) struct Swept {
    tools: Vec<(SegmentIndex, f64)>,
}

impl Swept {
    pub fn add(&mut self, paths: &[Vec<Point2>], radius: f64) {
        self.tools.push((
            SegmentIndex::from_polylines(paths.iter().map(|p| p.as_slice())),
            radius,
        ));
    }
    /// Is p swept by some tool, with `tol` slack?
    pub fn covers(&self, p: Point2, tol: f64) -> bool {
        self.tools.iter().any(|(idx, r)| idx.within(p, r + tol))
    }
    /// Is p swept by one of the tools numbered `tools` (in the order added)?
    pub(crate) fn covers_by(&self, tools: std::ops::Range<usize>, p: Point2, tol: f64) -> bool {
        self.tools
            .get(tools)
            .is_some_and(|t| t.iter().any(|(idx, r)| idx.within(p, r + tol)))
    }
    /// Number of tools added.
    pub fn len(&self) -> usize {
        self.tools.len()
    }
}

/// A raster of the pocket (cell centres inside the pocket) and which cells
/// the tools have swept, for the uncut area.
pub(crate) struct Raster {
    origin: Point2,
    pub h: f64,
    nx: usize,
    ny: usize,
    /// 0 outside the pocket, 1 inside and uncut, 2 inside and swept.
    cells: Vec<u8>,
}

/// The capsule of radius r around segment ab, with its rectangle's corners
/// a +- r n, b +- r n worked out once for all the rows it crosses.
struct Capsule {
    ends: [Point2; 2],
    r: f64,
    /// None for a zero-length segment (a disc).
    rect: Option<[Point2; 4]>,
}

impl Capsule {
    fn new(a: Point2, b: Point2, r: f64) -> Self {
        let d = [b[0] - a[0], b[1] - a[1]];
        let l = d[0].hypot(d[1]);
        let rect = (l > 0.0).then(|| {
            let n = [-d[1] / l * r, d[0] / l * r];
            [
                [a[0] + n[0], a[1] + n[1]],
                [b[0] + n[0], b[1] + n[1]],
                [b[0] - n[0], b[1] - n[1]],
                [a[0] - n[0], a[1] - n[1]],
            ]
        });
        Self {
            ends: [a, b],
            r,
            rect,
        }
    }

    /// The x-interval where the horizontal line at y meets the capsule.
    fn span(&self, y: f64) -> Option<(f64, f64)> {
        let r = self.r;
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        for c in self.ends {
            let dy = y - c[1];
            if dy.abs() <= r {
                let w = (r * r - dy * dy).sqrt();
                lo = lo.min(c[0] - w);
                hi = hi.max(c[0] + w);
            }
        }
        // The rectangle: intersect its four edges with the line.
        if let Some(q) = &self.rect {
            for i in 0..4 {
                let (p0, p1) = (q[i], q[(i + 1) % 4]);
                if (p0[1] - y) * (p1[1] - y) <= 0.0 && p0[1] != p1[1] {
                    let x = p0[0] + (y - p0[1]) / (p1[1] - p0[1]) * (p1[0] - p0[0]);
                    lo = lo.min(x);
                    hi = hi.max(x);
                }
            }
        }
        (lo <= hi).then_some((lo, hi))
    }
}

impl Raster {
    /// Cells of size `h` over the pocket's bounding box; a cell belongs to the
    /// pocket when its centre does (even-odd rule along each row).
    pub fn new(pocket: &Pocket, h: f64) -> Self {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in &pocket.outer {
            for t in 0..2 {
                lo[t] = lo[t].min(p[t]);
                hi[t] = hi[t].max(p[t]);
            }
        }
        let nx = ((hi[0] - lo[0]) / h).ceil().max(1.0) as usize;
        let ny = ((hi[1] - lo[1]) / h).ceil().max(1.0) as usize;
        let mut cells = vec![0u8; nx * ny];
        let loops: Vec<&Vec<Point2>> = std::iter::once(&pocket.outer)
            .chain(pocket.holes.iter())
            .collect();
        let mut xs: Vec<f64> = Vec::new();
        for j in 0..ny {
            let y = lo[1] + (j as f64 + 0.5) * h;
            xs.clear();
            for l in &loops {
                for i in 0..l.len() {
                    let (a, b) = (l[i], l[(i + 1) % l.len()]);
                    if (a[1] > y) != (b[1] > y) {
                        xs.push(a[0] + (y - a[1]) / (b[1] - a[1]) * (b[0] - a[0]));
                    }
                }
            }
            xs.sort_by(f64::total_cmp);
            for pair in xs.chunks_exact(2) {
                let i0 = ((pair[0] - lo[0]) / h - 0.5).ceil().max(0.0) as usize;
                let i1 = ((pair[1] - lo[0]) / h - 0.5).floor();
                if i1 < 0.0 {
                    continue;
                }
                let i1 = (i1 as usize).min(nx - 1);
                for c in cells[j * nx..(j + 1) * nx].iter_mut().take(i1 + 1).skip(i0) {
                    *c = 1;
                }
            }
        }
        Self {
            origin: lo,
            h,
            nx,
            ny,
            cells,
        }
    }

    /// Marks the cells whose centres the tool of radius r sweeps along the paths.
    pub fn sweep(&mut self, paths: &[Vec<Point2>], r: f64) {
        let mut rows: Vec<Vec<(f64, f64)>> = vec![Vec::new(); self.ny];
        let h = self.h;
        for path in paths {
            let segs: Vec<(Point2, Point2)> = if path.len() == 1 {
                vec![(path[0], path[0])]
            } else {
                path.windows(2).map(|w| (w[0], w[1])).collect()
            };
            for (a, b) in segs {
                let y0 = ((a[1].min(b[1]) - r - self.origin[1]) / h - 0.5)
                    .ceil()
                    .max(0.0) as usize;
                let y1 = ((a[1].max(b[1]) + r - self.origin[1]) / h - 0.5).floor();
                if y1 < 0.0 {
                    continue;
                }
                let y1 = (y1 as usize).min(self.ny.saturating_sub(1));
                let capsule = Capsule::new(a, b, r);
                for (j, row) in rows.iter_mut().enumerate().take(y1 + 1).skip(y0) {
                    let y = self.origin[1] + (j as f64 + 0.5) * h;
                    if let Some(s) = capsule.span(y) {
                        // Consecutive segments' spans mostly overlap: an
                        // overlapping span joins the row's last one. The
                        // cell range of the union is the union of the two
                        // cell ranges (the cell bounds are monotone in x),
                        // so the same cells are marked, each once.
                        match row.last_mut() {
                            Some(last) if s.0 <= last.1 && s.1 >= last.0 => {
                                last.0 = last.0.min(s.0);
                                last.1 = last.1.max(s.1);
                            }
                            _ => row.push(s),
                        }
                    }
                }
            }
        }
        // Each span marks its cells whatever the order: no sorting.
        for (j, row) in rows.iter().enumerate() {
            let line = &mut self.cells[j * self.nx..(j + 1) * self.nx];
            for &(x0, x1) in row.iter() {
                let i0 = ((x0 - self.origin[0]) / h - 0.5).ceil().max(0.0) as usize;
                let i1 = ((x1 - self.origin[0]) / h - 0.5).floor();
                if i1 < 0.0 {
                    continue;
                }
                let i1 = (i1 as usize).min(self.nx - 1);
                for c in line.iter_mut().take(i1 + 1).skip(i0) {
                    if *c == 1 {
                        *c = 2;
                    }
                }
            }
        }
    }

    /// Area of pocket cells not swept yet, mm^2.
    pub fn uncut_area(&self) -> f64 {
        self.cells.iter().filter(|&&c| c == 1).count() as f64 * self.h * self.h
    }

    /// Area of the pocket as rasterised, mm^2.
    #[cfg(test)]
    pub(crate) fn pocket_area(&self) -> f64 {
        self.cells.iter().filter(|&&c| c != 0).count() as f64 * self.h * self.h
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The segments of polylines for the brute-force checks (a lone point
    /// is a segment of length zero).
    fn segments<'a>(lines: impl IntoIterator<Item = &'a [Point2]>) -> Vec<(Point2, Point2)> {
        lines
            .into_iter()
            .flat_map(|l| {
                if l.len() == 1 {
                    vec![(l[0], l[0])]
                } else {
                    l.windows(2).map(|w| (w[0], w[1])).collect()
                }
            })
            .collect()
    }

    #[test]
    fn disc_swept_area_matches_pi_r_squared() {
        let p = Pocket::new(&[[0.0, 0.0], [40.0, 0.0], [40.0, 40.0], [0.0, 40.0]], &[]).unwrap();
        let mut r = Raster::new(&p, 0.02);
        assert!((r.pocket_area() - 1600.0).abs() < 1e-6);
        r.sweep(&[vec![[20.0, 20.0]]], 10.0);
        let swept = 1600.0 - r.uncut_area();
        assert!(
            (swept - std::f64::consts::PI * 100.0).abs() < 0.05,
            "{swept}"
        );
        // A straight stroke: rectangle plus two half discs.
        let mut r = Raster::new(&p, 0.02);
        r.sweep(&[vec![[10.0, 10.0], [30.0, 30.0]]], 5.0);
        let want = 20.0 * 2f64.sqrt() * 10.0 + std::f64::consts::PI * 25.0;
        assert!((1600.0 - r.uncut_area() - want).abs() < 0.05);
    }

    #[test]
    fn swept_cells_match_brute_force_distances() {
        // Wavy paths of short segments (their spans overlap row by row and
        // are joined), a path doubling back, and a lone point; each cell
        // centre is marked when within r of some segment (brute force),
        // except within 1e-9 of r, where rounding may decide either way.
        let p = Pocket::new(&[[0.0, 0.0], [30.0, 0.0], [30.0, 20.0], [0.0, 20.0]], &[]).unwrap();
        let wave: Vec<Point2> = (0..160)
            .map(|i| [2.0 + i as f64 * 0.16, 8.0 + (i as f64 * 0.11).sin() * 4.0])
            .collect();
        let back: Vec<Point2> = vec![[5.0, 17.0], [25.0, 15.0], [6.0, 14.5], [29.5, 19.5]];
        let lone = vec![[27.0, 3.0]];
        let paths = vec![wave, back, lone];
        for r in [0.3, 1.7] {
            let mut raster = Raster::new(&p, 0.05);
            raster.sweep(&paths, r);
            let segs = segments(paths.iter().map(Vec::as_slice));
            let mut swept = 0;
            for j in 0..raster.ny {
                for i in 0..raster.nx {
                    let c = [
                        raster.origin[0] + (i as f64 + 0.5) * raster.h,
                        raster.origin[1] + (j as f64 + 0.5) * raster.h,
                    ];
                    let d = segs
                        .iter()
                        .map(|&(a, b)| dist(segment_foot(a, b, c), c))
                        .fold(f64::INFINITY, f64::min);
                    if (d - r).abs() < 1e-9 {
                        continue;
                    }
                    let marked = raster.cells[j * raster.nx + i] == 2;
                    assert_eq!(marked, d < r, "cell {c:?} d {d} r {r}");
                    swept += marked as usize;
                }
            }
            assert!(swept > 1000, "{swept}");
        }
    }

    #[test]
    fn nearest_segment_matches_brute_force() {
        let pts: Vec<Point2> = (0..200)
            .map(|i| [i as f64 * 0.37, (i as f64 * 0.21).sin() * 5.0])
            .collect();
        let idx = SegmentIndex::from_polylines([pts.as_slice()]);
        for k in 0..50 {
            let p = [k as f64 * 1.3 - 3.0, (k as f64).cos() * 8.0];
            let brute = pts
                .windows(2)
                .map(|w| dist(segment_foot(w[0], w[1], p), p))
                .fold(f64::INFINITY, f64::min);
            let got = idx.nearest(p, 100.0).map(|x| x.0).unwrap();
            assert!((got - brute).abs() < 1e-12);
            assert!(!idx.within(p, brute * 0.999));
        }
    }

    #[test]
    fn within_matches_brute_force_and_nearest() {
        // Two crossing wavy polylines and a lone point: buckets hold several
        // segments, some points lie outside the grid.
        let a: Vec<Point2> = (0..300)
            .map(|i| [i as f64 * 0.23, (i as f64 * 0.17).sin() * 6.0])
            .collect();
        let b: Vec<Point2> = (0..120)
            .map(|i| [30.0 + (i as f64 * 0.3).cos() * 9.0, i as f64 * 0.2 - 8.0])
            .collect();
        let lone = [[55.0, 20.0]];
        let lines = [a.as_slice(), b.as_slice(), lone.as_slice()];
        let idx = SegmentIndex::from_polylines(lines);
        let segs = segments(lines);
        let mut hits = 0;
        for k in 0..4000 {
            let t = k as f64;
            let p = [
                -5.0 + (t * 0.618_034).fract() * 80.0,
                -15.0 + (t * 0.414_214).fract() * 45.0,
            ];
            let brute = segs
                .iter()
                .map(|&(s0, s1)| dist(segment_foot(s0, s1, p), p))
                .fold(f64::INFINITY, f64::min);
            for r in [0.05, 0.4, 1.3, 3.0, 12.0] {
                let want = brute <= r;
                assert_eq!(idx.within(p, r), want, "p {p:?} r {r} brute {brute}");
                hits += want as usize;
            }
            // At exactly the nearest distance (and one ulp either side) the
            // answer is the one `nearest` gives.
            for r in [brute, brute.next_down(), brute.next_up()] {
                assert_eq!(
                    idx.within(p, r),
                    idx.nearest(p, r).is_some(),
                    "p {p:?} r {r}"
                );
            }
        }
        assert!(hits > 1000 && hits < 19000, "{hits}");
        assert!(!idx.within([10.0, 0.0], -1.0));
        assert!(!idx.within([10.0, 0.0], f64::NAN));
    }
}
