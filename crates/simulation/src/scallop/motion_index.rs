//! The motions of a result indexed by their swept boxes in a uniform 3-D
//! grid of cells the size of the tool (the kernel's [`BoxGrid`]), and the
//! listing of the motions whose box meets a query box, each once.

use super::motion::Motion;
use nalgebra::Vector3;
use toolpath_kernel::geometry::segment_index::BoxGrid;

/// At most this many cells in the grid (the cell grows to fit).
const MAX_CELLS: usize = 4_000_000;

/// The motions' swept boxes in a uniform grid.
pub(super) struct MotionIndex {
    grid: BoxGrid<3>,
    /// Box of each motion's swept tool (what the grid indexes).
    boxes: Vec<(Vector3<f64>, Vector3<f64>)>,
}

fn array(v: &Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

impl MotionIndex {
    /// The index of `motions` of a cutter of radius `big_r` and length
    /// `len`, with cells of the radius.
    pub(super) fn new(motions: &[Motion], big_r: f64, len: f64) -> Self {
        let boxes: Vec<_> = motions.iter().map(|s| s.swept_box(big_r, len)).collect();
        let arrays: Vec<_> = boxes.iter().map(|(a, b)| (array(a), array(b))).collect();
        Self {
            grid: BoxGrid::new(&arrays, big_r, MAX_CELLS),
            boxes,
        }
    }

    /// Appends the ids of motions in cells meeting the box [a, b] (unsorted, with repeats).
    pub(super) fn query(&self, a: &Vector3<f64>, b: &Vector3<f64>, out: &mut Vec<u32>) {
        self.grid
            .visit(&array(a), &array(b), |ids| out.extend_from_slice(ids));
    }

    /// Whether motion `id`'s own box meets [lo, hi].
    pub(super) fn meets(&self, id: u32, lo: &Vector3<f64>, hi: &Vector3<f64>) -> bool {
        self.boxes
            .get(id as usize)
            .is_some_and(|(a, b)| boxes_meet(a, b, lo, hi))
    }

    /// Ids of the motions whose own box meets [lo, hi], once each (marked in a
    /// per-motion stamp array instead of sorted), into `sc.ids`, in the order
    /// the grid lists them.
    pub(super) fn collect_stamped(&self, lo: &Vector3<f64>, hi: &Vector3<f64>, sc: &mut Scratch) {
        sc.ids.clear();
        sc.query = sc.query.wrapping_add(1);
        if sc.query == 0 {
            sc.stamp.fill(0);
            sc.query = 1;
        }
        let (stamp, ids, query) = (&mut sc.stamp, &mut sc.ids, sc.query);
        let boxes = &self.boxes;
        self.grid.visit(&array(lo), &array(hi), |cell| {
            for &id in cell {
                if let Some(m) = stamp.get_mut(id as usize) {
                    if *m != query {
                        *m = query;
                        // A cell is larger than both boxes: keep only the
                        // motions whose own box meets the line's.
                        if boxes
                            .get(id as usize)
                            .is_some_and(|(a, b)| boxes_meet(a, b, lo, hi))
                        {
                            ids.push(id);
                        }
                    }
                }
            }
        });
    }
}

/// Per-thread working memory of the queries and of the fast residual.
pub(super) struct Scratch {
    /// The motions listed by the last query.
    pub(super) ids: Vec<u32>,
    /// Per motion, the number of the last query that listed it.
    stamp: Vec<u32>,
    query: u32,
    /// The motion that gave the previous sample's residual.
    pub(super) last_best: Option<u32>,
}

impl Scratch {
    pub(super) fn new(motions: usize) -> Self {
        Self {
            ids: Vec::new(),
            stamp: vec![0; motions],
            query: 0,
            last_best: None,
        }
    }
}

/// Whether the boxes [a, b] and [lo, hi] meet.
fn boxes_meet(a: &Vector3<f64>, b: &Vector3<f64>, lo: &Vector3<f64>, hi: &Vector3<f64>) -> bool {
    a.x <= hi.x && a.y <= hi.y && a.z <= hi.z && b.x >= lo.x && b.y >= lo.y && b.z >= lo.z
}
