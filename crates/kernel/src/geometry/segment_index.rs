//! Spatial indexes of segments (and of anything else given by its box), in
//! two or three dimensions: a uniform grid of cells in compressed rows, for
//! the queries "which items may meet this box" that run once per sample in
//! hot loops, and a bounding-box tree, for "the nearest item" and "is any
//! item within r" where the items are spread unevenly (a path with empty
//! space round it). The callers measure their own exact distances; the
//! indexes only list candidates, in an order fixed by the input alone, so the
//! answers do not depend on the index (docs/methods.md, "Tool sequence",
//! "Swept cutter and residual").
//!
//! Users: the scallop simulator's motions (3-D grid), the pocket's tool
//! paths and boundary (2-D grid for the nearest boundary point, tree for the
//! swept test) and the iso-scallop offset's fronts (3-D tree).

/// An axis-aligned box: its lowest and highest corner.
pub type Aabb<const D: usize> = ([f64; D], [f64; D]);

/// The box of the segment ab.
pub fn segment_box<const D: usize>(a: &[f64; D], b: &[f64; D]) -> Aabb<D> {
    (
        std::array::from_fn(|k| a[k].min(b[k])),
        std::array::from_fn(|k| a[k].max(b[k])),
    )
}

/// The smallest box holding the boxes (all zero for none).
fn hull<'a, const D: usize>(boxes: impl IntoIterator<Item = &'a Aabb<D>>) -> Aabb<D> {
    let mut lo = [f64::INFINITY; D];
    let mut hi = [f64::NEG_INFINITY; D];
    let mut any = false;
    for (a, b) in boxes {
        any = true;
        for k in 0..D {
            lo[k] = lo[k].min(a[k]);
            hi[k] = hi[k].max(b[k]);
        }
    }
    if any {
        (lo, hi)
    } else {
        ([0.0; D], [0.0; D])
    }
}

/// A uniform grid of cubic cells over the hull of a set of boxes; each cell
/// lists the items whose box meets it, in item order (compressed rows: the
/// items of cell c are `items[offsets[c]..offsets[c + 1]]`). Cells are
/// numbered row-major, the last coordinate fastest.
#[derive(Clone, Debug)]
pub struct BoxGrid<const D: usize> {
    origin: [f64; D],
    cell: f64,
    dims: [usize; D],
    offsets: Vec<u32>,
    items: Vec<u32>,
}

impl<const D: usize> BoxGrid<D> {
    /// The grid of `boxes` (item i has box i) with cells of `cell`, the cell
    /// enlarged by half again until the grid has at most `max_cells` cells.
    pub fn new(boxes: &[Aabb<D>], cell: f64, max_cells: usize) -> Self {
        let (lo, hi) = hull(boxes);
        let mut cell = cell;
        let dims_for = |cell: f64| -> [usize; D] {
            std::array::from_fn(|k| (((hi[k] - lo[k]) / cell).floor() as usize).saturating_add(1))
        };
        let mut dims = dims_for(cell);
        while dims.iter().map(|&d| d as f64).product::<f64>() > max_cells as f64 {
            cell *= 1.5;
            dims = dims_for(cell);
        }
        let mut grid = Self {
            origin: lo,
            cell,
            dims,
            offsets: Vec::new(),
            items: Vec::new(),
        };
        let ncell = dims.iter().product::<usize>();
        let range = |(a, b): &Aabb<D>| -> [(usize, usize); D] {
            std::array::from_fn(|k| {
                let i0 = (((a[k] - lo[k]) / cell).floor().max(0.0) as usize).min(dims[k] - 1);
                let i1 = (((b[k] - lo[k]) / cell).floor().max(0.0) as usize).min(dims[k] - 1);
                (i0, i1)
            })
        };
        let mut counts = vec![0u32; ncell + 1];
        for b in boxes {
            grid.for_cells(&range(b), |c| counts[c + 1] += 1);
        }
        for c in 0..ncell {
            counts[c + 1] += counts[c];
        }
        let mut fill = counts.clone();
        let mut items = vec![0u32; counts[ncell] as usize];
        for (id, b) in boxes.iter().enumerate() {
            grid.for_cells(&range(b), |c| {
                items[fill[c] as usize] = id as u32;
                fill[c] += 1;
            });
        }
        grid.offsets = counts;
        grid.items = items;
        grid
    }

    /// The side of a cell.
    pub fn cell(&self) -> f64 {
        self.cell
    }

    /// Calls `f` with the items of every cell meeting the box [lo, hi], in
    /// cell order; nothing when the box lies beyond the grid on some axis.
    pub fn visit(&self, lo: &[f64; D], hi: &[f64; D], f: impl FnMut(&[u32])) {
        let mut r = [(0usize, 0usize); D];
        for k in 0..D {
            let f0 = (lo[k] - self.origin[k]) / self.cell;
            let f1 = (hi[k] - self.origin[k]) / self.cell;
            if f1 < 0.0 || f0 >= self.dims[k] as f64 {
                return;
            }
            r[k] = (
                f0.floor().max(0.0) as usize,
                (f1.floor() as usize).min(self.dims[k] - 1),
            );
        }
        self.visit_range(&r, f);
    }

    /// [`Self::visit`] with the box's cell range clamped into the grid: a
    /// box beyond the grid visits the cells at its edge.
    pub fn visit_clamped(&self, lo: &[f64; D], hi: &[f64; D], f: impl FnMut(&[u32])) {
        let r: [(usize, usize); D] = std::array::from_fn(|k| {
            let last = (self.dims[k] - 1) as f64;
            let at = |v: f64| {
                ((v - self.origin[k]) / self.cell)
                    .floor()
                    .max(0.0)
                    .min(last) as usize
            };
            (at(lo[k]), at(hi[k]))
        });
        self.visit_range(&r, f);
    }

    fn visit_range(&self, r: &[(usize, usize); D], mut f: impl FnMut(&[u32])) {
        self.for_cells(r, |c| {
            f(&self.items[self.offsets[c] as usize..self.offsets[c + 1] as usize])
        });
    }

    /// Calls `f` with the number of every cell in the range (inclusive per
    /// axis), row-major: an odometer over the leading axes, a run of
    /// consecutive cells along the last.
    fn for_cells(&self, r: &[(usize, usize); D], mut f: impl FnMut(usize)) {
        if D == 0 || r.iter().any(|&(a, b)| a > b) {
            return;
        }
        let last = D - 1;
        let mut at: [usize; D] = std::array::from_fn(|k| r[k].0);
        loop {
            let row = (0..last).fold(0, |c, k| c * self.dims[k] + at[k]) * self.dims[last];
            for c in row + r[last].0..=row + r[last].1 {
                f(c);
            }
            let mut k = last;
            loop {
                if k == 0 {
                    return;
                }
                k -= 1;
                if at[k] < r[k].1 {
                    at[k] += 1;
                    break;
                }
                at[k] = r[k].0;
            }
        }
    }
}

/// A node of a [`BoxTree`]: the box of its items, and either two children
/// (`leaf == false`, nodes `a` and `b`) or the run `order[a..b]`.
#[derive(Clone, Copy, Debug)]
struct Node<const D: usize> {
    lo: [f64; D],
    hi: [f64; D],
    leaf: bool,
    a: u32,
    b: u32,
}

/// At most this many items in a leaf of a [`BoxTree`].
const LEAF_ITEMS: usize = 8;

/// A bounding-box tree: items split at the median of their box centres
/// along the longer side of the node's box, down to leaves of at most 8.
/// The same tree for the same boxes, whatever the platform (ties in the
/// split are broken by the item number).
#[derive(Clone, Debug)]
pub struct BoxTree<const D: usize> {
    nodes: Vec<Node<D>>,
    /// Item numbers in tree order (each leaf a contiguous run).
    order: Vec<u32>,
}

impl<const D: usize> BoxTree<D> {
    /// The tree of `boxes` (item i has box i).
    pub fn new(boxes: &[Aabb<D>]) -> Self {
        let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * boxes.len() / LEAF_ITEMS + 1);
        if !boxes.is_empty() {
            build(boxes, &mut order, 0, &mut nodes);
        }
        Self { nodes, order }
    }

    /// Depth first through the nodes whose box `key` admits (`Some(k)`, the
    /// child with the smaller k first; `None` leaves the node out), calling
    /// `leaf` with the items of each leaf reached; stops as soon as `leaf`
    /// returns true, and returns whether it did. `key` is asked again for
    /// every node as the search reaches it, so it may tighten as `leaf`
    /// finds items (a nearest search keeps its bound in a `Cell`).
    pub fn search(
        &self,
        mut key: impl FnMut(&[f64; D], &[f64; D]) -> Option<f64>,
        mut leaf: impl FnMut(&[u32]) -> bool,
    ) -> bool {
        let Some(root) = self.nodes.first() else {
            return false;
        };
        if key(&root.lo, &root.hi).is_none() {
            return false;
        }
        // Depth below 64 for any count of items that fits in u32.
        let mut stack: [u32; 128] = [0; 128];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let node = self.nodes[stack[top] as usize];
            if node.leaf {
                if leaf(&self.order[node.a as usize..node.b as usize]) {
                    return true;
                }
                continue;
            }
            let (ca, cb) = (self.nodes[node.a as usize], self.nodes[node.b as usize]);
            let (ka, kb) = (key(&ca.lo, &ca.hi), key(&cb.lo, &cb.hi));
            // Push the farther child first so that the nearer is searched first.
            let (near, kn, far, kf) = match (ka, kb) {
                (Some(x), Some(y)) if y < x => (node.b, kb, node.a, ka),
                (None, Some(_)) => (node.b, kb, node.a, ka),
                _ => (node.a, ka, node.b, kb),
            };
            if kf.is_some() {
                stack[top] = far;
                top += 1;
            }
            if kn.is_some() {
                stack[top] = near;
                top += 1;
            }
        }
        false
    }
}

/// Builds the tree over `order` (the items of positions `s..` of the full
/// order), split at the median of the box centres along the longer side of
/// the node's box; returns the node's number.
fn build<const D: usize>(
    boxes: &[Aabb<D>],
    order: &mut [u32],
    s: usize,
    nodes: &mut Vec<Node<D>>,
) -> u32 {
    let (lo, hi) = hull(order.iter().map(|&k| &boxes[k as usize]));
    let id = nodes.len();
    let n = order.len();
    nodes.push(Node {
        lo,
        hi,
        leaf: true,
        a: s as u32,
        b: (s + n) as u32,
    });
    if n <= LEAF_ITEMS {
        return id as u32;
    }
    let axis = (1..D).fold(0, |m, k| if hi[k] - lo[k] > hi[m] - lo[m] { k } else { m });
    // Twice the centre.
    let mid = |k: &u32| {
        let (a, b) = boxes[*k as usize];
        a[axis] + b[axis]
    };
    let half = n / 2;
    // Ties broken by the item number: the same tree whatever the input order.
    order.select_nth_unstable_by(half, |x, y| mid(x).total_cmp(&mid(y)).then(x.cmp(y)));
    let (left, right) = order.split_at_mut(half);
    let l = build(boxes, left, s, nodes);
    let r = build(boxes, right, s + half, nodes);
    nodes[id].leaf = false;
    nodes[id].a = l;
    nodes[id].b = r;
    id as u32
}

/// Squared distance from p to the box lo..hi (0 inside). A box inside
/// another is never nearer by this value, rounding included (each term is
/// monotone in the box's sides), so a node's value bounds its items'.
pub fn box_dist2<const D: usize>(lo: &[f64; D], hi: &[f64; D], p: &[f64; D]) -> f64 {
    (0..D).fold(0.0, |s, k| {
        let e = (lo[k] - p[k]).max(p[k] - hi[k]).max(0.0);
        s + e * e
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::XorShift;
    use std::cell::Cell;

    fn random_boxes<const D: usize>(rng: &mut XorShift, n: usize, size: f64) -> Vec<Aabb<D>> {
        (0..n)
            .map(|_| {
                let a: [f64; D] = std::array::from_fn(|_| 100.0 * rng.unit());
                let b: [f64; D] = std::array::from_fn(|k| a[k] + size * rng.unit());
                (a, b)
            })
            .collect()
    }

    fn meets<const D: usize>((a, b): &Aabb<D>, lo: &[f64; D], hi: &[f64; D]) -> bool {
        (0..D).all(|k| a[k] <= hi[k] && b[k] >= lo[k])
    }

    /// Every item whose box meets a query box is listed by the grid (brute
    /// force over all items), in 2-D and 3-D, with the cell enlarged to fit
    /// a small cell limit, and for query boxes partly or wholly off the grid.
    #[test]
    fn grid_lists_every_box_that_meets_the_query() {
        let mut rng = XorShift(0x9e37_79b9_7f4a_7c15);
        fn check<const D: usize>(rng: &mut XorShift, max_cells: usize) -> usize {
            let boxes = random_boxes::<D>(rng, 300, 8.0);
            let grid = BoxGrid::new(&boxes, 2.0, max_cells);
            let cells = grid.dims.iter().product::<usize>();
            assert!(cells <= max_cells, "{cells} cells");
            let mut found = 0;
            for _ in 0..300 {
                let lo: [f64; D] = std::array::from_fn(|_| 140.0 * rng.unit() - 20.0);
                let hi: [f64; D] = std::array::from_fn(|k| lo[k] + 30.0 * rng.unit());
                for clamped in [false, true] {
                    let mut listed = vec![false; boxes.len()];
                    let mut mark =
                        |ids: &[u32]| ids.iter().for_each(|&i| listed[i as usize] = true);
                    if clamped {
                        grid.visit_clamped(&lo, &hi, &mut mark);
                    } else {
                        grid.visit(&lo, &hi, &mut mark);
                    }
                    for (i, b) in boxes.iter().enumerate() {
                        if meets(b, &lo, &hi) {
                            assert!(listed[i], "box {i} {b:?} meets {lo:?}..{hi:?}");
                            found += 1;
                        }
                    }
                }
            }
            found
        }
        assert!(check::<2>(&mut rng, 1 << 20) > 1000);
        assert!(check::<3>(&mut rng, 1 << 20) > 100);
        assert!(check::<3>(&mut rng, 64) > 100);
        // No boxes: one cell, nothing listed.
        let grid = BoxGrid::<3>::new(&[], 1.0, 10);
        grid.visit(&[-1.0; 3], &[1.0; 3], |ids| assert!(ids.is_empty()));
    }

    /// Cells are visited row-major, the last coordinate fastest, and each
    /// cell lists its items in item order.
    #[test]
    fn grid_visits_cells_in_row_major_order() {
        // Unit boxes at the centres of a 3 x 2 grid of cells of 10.
        let boxes: Vec<Aabb<2>> = (0..6)
            .map(|i| {
                let c = [10.0 * (i / 2) as f64 + 5.0, 10.0 * (i % 2) as f64 + 5.0];
                ([c[0] - 0.5, c[1] - 0.5], [c[0] + 0.5, c[1] + 0.5])
            })
            .chain([([0.0, 0.0], [0.0, 0.0]), ([30.0, 20.0], [30.0, 20.0])])
            .collect();
        let grid = BoxGrid::new(&boxes, 10.0, 100);
        let mut seen = Vec::new();
        grid.visit(&[0.0, 0.0], &[25.0, 15.0], |ids| seen.push(ids.to_vec()));
        assert_eq!(
            seen,
            vec![vec![0, 6], vec![1], vec![2], vec![3], vec![4], vec![5]]
        );
    }

    /// The nearest item by a caller's distance, found by a search that
    /// prunes by the box distance against the bound so far, is the brute
    /// force's (the first of the nearest); the any-within search agrees with
    /// brute force; in 2-D and 3-D, with many ties (duplicated boxes).
    #[test]
    fn tree_nearest_and_within_match_brute_force() {
        let mut rng = XorShift(0x2545_f491_4f6c_dd1d);
        fn check<const D: usize>(rng: &mut XorShift) {
            for n in [1, 2, 7, 9, 64, 500] {
                let mut boxes = random_boxes::<D>(rng, n, 5.0);
                // Ties: every fifth box repeats the previous one.
                for i in (5..n).step_by(5) {
                    boxes[i] = boxes[i - 1];
                }
                let tree = BoxTree::new(&boxes);
                for _ in 0..200 {
                    let p: [f64; D] = std::array::from_fn(|_| 120.0 * rng.unit() - 10.0);
                    let dist = |i: u32| {
                        let (a, b) = boxes[i as usize];
                        box_dist2(&a, &b, &p)
                    };
                    let want = (0..n as u32)
                        .map(|i| (dist(i), i))
                        .min_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)))
                        .unwrap();
                    let best = Cell::new((f64::INFINITY, u32::MAX));
                    tree.search(
                        |lo, hi| {
                            let d = box_dist2(lo, hi, &p);
                            (d <= best.get().0).then_some(d)
                        },
                        |ids| {
                            for &i in ids {
                                let d = dist(i);
                                let (bd, bi) = best.get();
                                if d < bd || (d == bd && i < bi) {
                                    best.set((d, i));
                                }
                            }
                            false
                        },
                    );
                    assert_eq!(best.get(), want, "n {n} p {p:?}");
                    let r2 = 30.0 * rng.unit();
                    let within = tree.search(
                        |lo, hi| {
                            let d = box_dist2(lo, hi, &p);
                            (d <= r2).then_some(d)
                        },
                        |ids| ids.iter().any(|&i| dist(i) <= r2),
                    );
                    assert_eq!(within, want.0 <= r2, "n {n} p {p:?} r2 {r2}");
                }
            }
        }
        check::<2>(&mut rng);
        check::<3>(&mut rng);
        assert!(!BoxTree::<2>::new(&[]).search(|_, _| Some(0.0), |_| true));
    }

    #[test]
    fn boxes_of_segments() {
        assert_eq!(
            segment_box(&[3.0, -1.0, 2.0], &[1.0, 4.0, 2.0]),
            ([1.0, -1.0, 2.0], [3.0, 4.0, 2.0])
        );
        assert_eq!(box_dist2(&[0.0, 0.0], &[1.0, 1.0], &[4.0, -4.0]), 25.0);
        assert_eq!(box_dist2(&[0.0, 0.0], &[1.0, 1.0], &[0.5, 0.5]), 0.0);
    }
}
