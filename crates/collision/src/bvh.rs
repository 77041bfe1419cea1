//! A bounding-sphere hierarchy over the samples' cover balls.
//!
//! Each node's sphere holds every cover ball of the samples under it, so it
//! holds every point of the faces those samples cover. The signed distance to
//! a tool part is 1-Lipschitz, so sd(centre) - radius bounds it from below
//! over the whole node: the one pruning rule of every query.
//!
//! Built top down: the samples' points are split at the median along the
//! longest side of their box (ties broken by face and parameters, so the tree
//! is the same bytes for the same samples), down to leaves of at most
//! [`LEAF_SIZE`].

use crate::sampling::Sample;
use nalgebra::Vector3;

/// Most samples in a leaf.
pub const LEAF_SIZE: usize = 4;

/// A node: its sphere, and either two children (`left`, `left + 1`) or a
/// range of the (reordered) samples.
#[derive(Clone, Copy, Debug)]
pub struct Node {
    pub centre: Vector3<f64>,
    pub radius: f64,
    /// Leaf: first sample; inner node: index of the left child.
    pub first: u32,
    /// Leaf: number of samples (> 0); inner node: 0.
    pub count: u32,
}

impl Node {
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

/// The hierarchy; `nodes[0]` is the root (absent for no samples).
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    pub nodes: Vec<Node>,
    /// Deepest level (root 1): bounds the traversal stack.
    pub depth: usize,
}

impl Bvh {
    /// Builds over `samples`, reordering them into leaf order (in place:
    /// each split partitions its range of the slice, so the build reads
    /// memory in order).
    pub fn build(samples: &mut [Sample]) -> Self {
        let mut bvh = Self::default();
        if samples.is_empty() {
            return bvh;
        }
        bvh.nodes.push(placeholder());
        let mut work = vec![(0usize, 0usize, samples.len(), 1usize)];
        while let Some((node, lo, hi, level)) = work.pop() {
            bvh.depth = bvh.depth.max(level);
            let slice = &mut samples[lo..hi];
            let (centre, radius, axis) = bound(slice);
            if hi - lo <= LEAF_SIZE {
                bvh.nodes[node] = Node {
                    centre,
                    radius,
                    first: lo as u32,
                    count: (hi - lo) as u32,
                };
                continue;
            }
            let mid = (hi - lo) / 2;
            // A total order (coordinate, then face and parameters), so the
            // partition is the same for the same samples.
            slice.select_nth_unstable_by(mid, |a, b| {
                a.point[axis]
                    .total_cmp(&b.point[axis])
                    .then(a.face.cmp(&b.face))
                    .then(a.u.total_cmp(&b.u))
                    .then(a.v.total_cmp(&b.v))
            });
            let left = bvh.nodes.len();
            bvh.nodes.push(placeholder());
            bvh.nodes.push(placeholder());
            bvh.nodes[node] = Node {
                centre,
                radius,
                first: left as u32,
                count: 0,
            };
            work.push((left + 1, lo + mid, hi, level + 1));
            work.push((left, lo, lo + mid, level + 1));
        }
        bvh
    }
}

fn placeholder() -> Node {
    Node {
        centre: Vector3::zeros(),
        radius: 0.0,
        first: 0,
        count: 0,
    }
}

/// The sphere holding the cover balls of `samples` (centred on their
/// points' box), and the box's longest axis.
fn bound(samples: &[Sample]) -> (Vector3<f64>, f64, usize) {
    let mut lo = Vector3::repeat(f64::INFINITY);
    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
    for s in samples {
        lo = lo.inf(&s.point);
        hi = hi.sup(&s.point);
    }
    let centre = (lo + hi) * 0.5;
    let radius = samples
        .iter()
        .map(|s| (s.point - centre).norm() + s.cover)
        .fold(0.0, f64::max);
    let ext = hi - lo;
    let axis = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    (centre, radius, axis)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_cover_ball_lies_in_every_ancestor() {
        let mut samples: Vec<Sample> = (0..1000)
            .map(|k| {
                let t = k as f64;
                Sample {
                    point: Vector3::new((t * 0.37).sin() * 50.0, (t * 0.11).cos() * 30.0, t * 0.01),
                    cover: 0.1 + 0.05 * (t * 0.7).sin().abs(),
                    face: (k % 3) as u32,
                    u: t,
                    v: 0.0,
                }
            })
            .collect();
        let bvh = Bvh::build(&mut samples);
        let mut seen = vec![0u32; samples.len()];
        // Walk every root-to-leaf path, checking containment on the way.
        let mut stack = vec![(0usize, Vec::<usize>::new())];
        while let Some((n, mut path)) = stack.pop() {
            path.push(n);
            let node = bvh.nodes[n];
            if node.is_leaf() {
                for s in &samples[node.first as usize..(node.first + node.count) as usize] {
                    seen[s.u as usize] += 1;
                    for &a in &path {
                        let a = bvh.nodes[a];
                        assert!((s.point - a.centre).norm() + s.cover <= a.radius * (1.0 + 1e-12));
                    }
                }
            } else {
                stack.push((node.first as usize, path.clone()));
                stack.push((node.first as usize + 1, path));
            }
        }
        assert!(
            seen.iter().all(|&c| c == 1),
            "every sample in exactly one leaf"
        );
        assert!(bvh.depth <= 12, "median splits: depth {}", bvh.depth);
    }
}
