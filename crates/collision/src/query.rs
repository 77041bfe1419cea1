//! Pose queries: how deep the cutter enters the check faces, how close the
//! shank and holder come to any face, and the certified "clear by at least".
//!
//! One branch-and-bound traversal of the sphere hierarchy serves all of them.
//! For a node with sphere (c, rho) and a tool part, sd(c) - rho is a lower
//! bound of the part's signed distance over every face point the node holds
//! (the signed distance is 1-Lipschitz and the node's sphere holds its
//! samples' cover balls). A node is pruned for a part when that bound is at
//! least the part's threshold; below the hierarchy, each sample gives its
//! exact value and the bound value - cover. The certified lower bound of a
//! query is the least bound met (pruned nodes and visited samples), so it
//! holds over the faces themselves, not only their samples, within the
//! cover radii's assumption (docs/methods.md, "Collision checking").

use crate::assembly::{Pose, ToolAssembly, ToolPart};
use crate::profile::Rz;
use crate::refine::refine;
use crate::workpiece::Workpiece;
use nalgebra::Vector3;

/// What a pose must keep, and how far beyond that to measure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QueryOptions {
    /// Least signed distance of the cutter to a check face that is allowed:
    /// minus the job's gouge tolerance.
    pub cutter_limit: f64,
    /// Least signed distance of a shank or holder segment to any face that is
    /// allowed: the clearance.
    pub holder_limit: f64,
    /// Judge the cutter against every face, machined ones included (links and
    /// rapids, where the cutter cuts nothing).
    pub cutter_all_faces: bool,
    /// Distances up to limit + this are found and refined exactly; beyond, a
    /// part is only reported clear with its certified bound.
    pub search_margin: f64,
}

impl QueryOptions {
    /// Cutter within `gouge_tolerance` of the check faces, shank and holder
    /// at least `clearance` from everything, nothing measured beyond.
    pub fn new(gouge_tolerance: f64, clearance: f64) -> Self {
        Self {
            cutter_limit: -gouge_tolerance,
            holder_limit: clearance,
            cutter_all_faces: false,
            search_margin: 0.0,
        }
    }

    /// Refuses non-finite limits and a negative or non-finite search margin
    /// (the queries themselves do not check, being the hot path).
    pub fn validate(&self) -> crate::Result<()> {
        for (field, v) in [
            ("cutter_limit", self.cutter_limit),
            ("holder_limit", self.holder_limit),
        ] {
            if !v.is_finite() {
                return Err(crate::Error::invalid(
                    field,
                    format!("{v} is not a finite number"),
                ));
            }
        }
        crate::error::non_negative("search_margin", self.search_margin)
    }

    /// The limit of a part.
    pub fn limit(&self, part: ToolPart) -> f64 {
        match part {
            ToolPart::Cutter => self.cutter_limit,
            ToolPart::Holder(_) => self.holder_limit,
        }
    }
}

/// A point of a face.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    pub face: usize,
    pub u: f64,
    pub v: f64,
    pub point: Vector3<f64>,
}

/// The outcome for one part of the tool.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PartReport {
    pub part: ToolPart,
    /// The limit the part was judged against.
    pub limit: f64,
    /// Least signed distance found, attained at `contact`: refined on the
    /// face (exact near contact) where a sample's cover ball could hold a
    /// value below limit + search margin, else the best sample's value;
    /// +inf when the hierarchy pruned every sample.
    pub distance: f64,
    /// Certified lower bound of the signed distance over the eligible faces,
    /// at most `distance`.
    pub lower_bound: f64,
    pub contact: Option<Contact>,
    /// Whether `distance` comes from a refinement on the face (else it is a
    /// sample's value, certified above limit + search margin anyway).
    pub refined: bool,
    /// The least value over the samples before refinement, with the
    /// sample's index in [`Workpiece::samples`].
    pub best_sample: Option<(f64, usize)>,
    /// Least bound of the hierarchy's nodes the query pruned for this part:
    /// every face point not under a visited sample is at least this far.
    pub pruned_bound: f64,
}

impl PartReport {
    /// Does the part come closer than its limit (by the refined distance)?
    pub fn collides(&self) -> bool {
        self.distance < self.limit
    }

    /// Is the part certified clear of its limit?
    pub fn certified_clear(&self) -> bool {
        self.lower_bound >= self.limit
    }

    /// How deep the part is inside the nearest face point: max(0, -distance).
    pub fn penetration(&self) -> f64 {
        (-self.distance).max(0.0)
    }
}

/// The outcome of a pose query, one report per part (the cutter first).
#[derive(Clone, Debug, PartialEq)]
pub struct PoseReport {
    pub parts: Vec<PartReport>,
}

impl PoseReport {
    pub fn cutter(&self) -> &PartReport {
        &self.parts[0]
    }

    /// Does any part come closer than its limit?
    pub fn collides(&self) -> bool {
        self.parts.iter().any(PartReport::collides)
    }

    /// The part furthest below its limit (the first on a tie), if any.
    pub fn worst(&self) -> Option<&PartReport> {
        self.parts
            .iter()
            .filter(|p| p.collides())
            .fold(None, |best: Option<&PartReport>, p| match best {
                Some(b) if b.limit - b.distance >= p.limit - p.distance => Some(b),
                _ => Some(p),
            })
    }

    /// Least distance (refined) of any shank or holder segment to the part;
    /// +inf without a holder or when nothing came within the search range.
    pub fn holder_clearance(&self) -> f64 {
        self.parts[1..]
            .iter()
            .map(|p| p.distance)
            .fold(f64::INFINITY, f64::min)
    }

    /// Least of `distance - limit` over the parts: negative in collision.
    pub fn margin(&self) -> f64 {
        self.parts
            .iter()
            .map(|p| p.distance - p.limit)
            .fold(f64::INFINITY, f64::min)
    }
}

/// What a traversal does at its nodes and samples.
trait Visitor {
    /// Nodes whose bound for `part` is at least this are pruned for it.
    fn threshold(&self, part: usize) -> f64;
    /// A node pruned for `part` with bound `lb`.
    fn pruned(&mut self, _part: usize, _lb: f64) {}
    /// A sample met for `part`: its exact value and its bound; `false` stops
    /// the traversal.
    fn sample(&mut self, part: usize, index: usize, value: f64, lb: f64) -> bool;
}

/// A lower bound of a part's signed distance from the rectangle [0, r_max] x
/// [z0, z1] that holds the part: outside, the distance to the rectangle;
/// inside, minus the distance to its nearest side other than the axis (the
/// axis is inside the solid, not on its surface).
#[inline]
fn rect_bound(rz: Rz, r_max: f64, (z0, z1): (f64, f64)) -> f64 {
    let dr = rz[0] - r_max;
    let dz = (z0 - rz[1]).max(rz[1] - z1);
    if dr <= 0.0 && dz <= 0.0 {
        return dr.max(dz);
    }
    let (dr, dz) = (dr.max(0.0), dz.max(0.0));
    (dr * dr + dz * dz).sqrt()
}

/// Most parts a query handles (cutter plus holder segments).
pub const MAX_PARTS: usize = 32;

impl Workpiece {
    /// Walks the hierarchy for the parts in `mask` (bit i: part i); returns
    /// `false` when the visitor stopped it.
    fn traverse(
        &self,
        tool: &ToolAssembly,
        pose: &Pose,
        cutter_all_faces: bool,
        mask: u32,
        visitor: &mut impl Visitor,
    ) -> bool {
        let nodes = &self.bvh.nodes;
        if nodes.is_empty() || mask == 0 {
            return true;
        }
        let profiles = tool.profiles();
        let mut stack: Vec<(u32, u32)> = Vec::with_capacity(self.bvh.depth + 2);
        stack.push((0, mask));
        while let Some((n, mut active)) = stack.pop() {
            let node = &nodes[n as usize];
            let (rz, _) = pose.meridian(&node.centre);
            if !cutter_all_faces && !self.node_check[n as usize] {
                active &= !1;
            }
            let mut bits = active;
            while bits != 0 {
                let i = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let p = &profiles[i];
                let thr = visitor.threshold(i);
                let lb_rect = rect_bound(rz, p.r_max(), p.z_range()) - node.radius;
                let lb = if lb_rect >= thr {
                    lb_rect
                } else {
                    p.signed_distance(rz) - node.radius
                };
                if lb >= thr {
                    visitor.pruned(i, lb);
                    active &= !(1 << i);
                }
            }
            if active == 0 {
                continue;
            }
            if node.is_leaf() {
                if !self.visit_leaf(tool, pose, cutter_all_faces, node, active, visitor) {
                    return false;
                }
            } else {
                stack.push((node.first + 1, active));
                stack.push((node.first, active));
            }
        }
        true
    }

    fn visit_leaf(
        &self,
        tool: &ToolAssembly,
        pose: &Pose,
        cutter_all_faces: bool,
        node: &crate::bvh::Node,
        active: u32,
        visitor: &mut impl Visitor,
    ) -> bool {
        let profiles = tool.profiles();
        let first = node.first as usize;
        for (k, s) in self.samples[first..first + node.count as usize]
            .iter()
            .enumerate()
        {
            let (rz, _) = pose.meridian(&s.point);
            let mut bits = active;
            if !cutter_all_faces && self.machined[s.face as usize] {
                bits &= !1;
            }
            while bits != 0 {
                let i = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let value = profiles[i].signed_distance(rz);
                if !visitor.sample(i, first + k, value, value - s.cover) {
                    return false;
                }
            }
        }
        true
    }

    /// Certified: is every part at least its limit from every eligible face
    /// (cover radii's assumption)? `false` means "not proven", not "collides":
    /// run [`Self::query`] then. The fast path of the check.
    pub fn clear_by(&self, tool: &ToolAssembly, pose: &Pose, opts: &QueryOptions) -> bool {
        struct Clear<'a>(&'a [f64]);
        impl Visitor for Clear<'_> {
            fn threshold(&self, part: usize) -> f64 {
                self.0[part]
            }
            fn sample(&mut self, part: usize, _: usize, _: f64, lb: f64) -> bool {
                lb >= self.0[part]
            }
        }
        let limits = limits(tool, opts);
        self.traverse(
            tool,
            pose,
            opts.cutter_all_faces,
            all_parts(tool),
            &mut Clear(&limits),
        )
    }

    /// Certified margin: the least over the parts of (lower bound - limit),
    /// the lower bound being the least sample bound value - cover over the
    /// eligible samples; at most `cap` (the search stops there). Never above
    /// the true least (distance - limit) under the cover radii's assumption.
    pub fn certified_margin(
        &self,
        tool: &ToolAssembly,
        pose: &Pose,
        opts: &QueryOptions,
        cap: f64,
    ) -> f64 {
        struct Margin<'a> {
            limits: &'a [f64],
            best: f64,
        }
        impl Visitor for Margin<'_> {
            fn threshold(&self, part: usize) -> f64 {
                self.limits[part] + self.best
            }
            fn sample(&mut self, part: usize, _: usize, _: f64, lb: f64) -> bool {
                self.best = self.best.min(lb - self.limits[part]);
                true
            }
        }
        let limits = limits(tool, opts);
        let mut m = Margin {
            limits: &limits,
            best: cap,
        };
        self.traverse(tool, pose, opts.cutter_all_faces, all_parts(tool), &mut m);
        m.best
    }

    /// The full query: per part, the least signed distance to the eligible
    /// faces, refined on the faces from the best samples (the best one of
    /// each of up to [`CANDIDATE_FACES`] faces), its contact point, and the
    /// certified lower bound.
    pub fn query(&self, tool: &ToolAssembly, pose: &Pose, opts: &QueryOptions) -> PoseReport {
        let limits = limits(tool, opts);
        let mut v = Best {
            thresholds: limits.iter().map(|l| l + opts.search_margin).collect(),
            best: vec![f64::INFINITY; limits.len()],
            lower: limits.iter().map(|l| l + opts.search_margin).collect(),
            pruned: vec![f64::INFINITY; limits.len()],
            candidates: vec![Vec::new(); limits.len()],
            pool: vec![Vec::new(); limits.len()],
            samples: &self.samples,
        };
        self.traverse(tool, pose, opts.cutter_all_faces, all_parts(tool), &mut v);
        let parts = (0..limits.len())
            .map(|i| self.part_report(tool, pose, i, limits[i], &v))
            .collect();
        PoseReport { parts }
    }

    fn part_report(
        &self,
        tool: &ToolAssembly,
        pose: &Pose,
        i: usize,
        limit: f64,
        v: &Best,
    ) -> PartReport {
        let part = ToolPart::from_index(i);
        let mut report = PartReport {
            part,
            limit,
            distance: f64::INFINITY,
            lower_bound: v.lower[i],
            contact: None,
            refined: false,
            best_sample: None,
            pruned_bound: v.pruned[i],
        };
        let mut starts = v.candidates[i].clone();
        starts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        report.best_sample = starts.first().copied();
        if let Some(&(value, index)) = starts.first() {
            // The best sample, attained; refined below only where a sample's
            // ball could hold a value under the threshold.
            let s = &self.samples[index];
            report.distance = value;
            report.contact = Some(Contact {
                face: s.face as usize,
                u: s.u,
                v: s.v,
                point: s.point,
            });
        }
        let thr = v.thresholds[i];
        starts.retain(|&(value, index)| value - self.samples[index].cover < thr);
        // Then other basins: the best pooled samples that could still hide a
        // lower value (bound below the best refined distance so far) and lie
        // clear of every start and refined point.
        let mut seen: Vec<Vector3<f64>> = Vec::new();
        let mut k = 0;
        let refine_more = !starts.is_empty();
        while k < starts.len() || (refine_more && starts.len() < REFINEMENTS && k == starts.len()) {
            if k == starts.len() {
                let next = v.pool[i].iter().find(|&&(value, index)| {
                    let s = &self.samples[index];
                    value - s.cover < report.distance.min(thr)
                        && seen.iter().all(|q| (q - s.point).norm() > 2.0 * s.cover)
                });
                match next {
                    Some(&c) => starts.push(c),
                    None => break,
                }
            }
            let s = &self.samples[starts[k].1];
            let face = s.face as usize;
            let r = refine(
                self.faces[face].as_ref(),
                tool,
                pose,
                part,
                (s.u, s.v),
                s.cover,
            );
            seen.push(s.point);
            seen.push(r.point);
            report.refined = true;
            if r.distance < report.distance {
                report.distance = r.distance;
                report.contact = Some(Contact {
                    face,
                    u: r.u,
                    v: r.v,
                    point: r.point,
                });
            }
            k += 1;
        }
        report.lower_bound = report.lower_bound.min(report.distance);
        report
    }
}

/// Faces whose best samples are refined, per part and query.
pub const CANDIDATE_FACES: usize = 4;

/// Best samples kept per part for refinements from further basins.
pub const POOL: usize = 16;

/// Refinements per part and query at most (the best sample of each
/// candidate face first, then the pool's further basins).
pub const REFINEMENTS: usize = 6;

/// The full query's visitor: per part the best sample of each of up to
/// [`CANDIDATE_FACES`] faces, and the least bound met.
struct Best<'a> {
    thresholds: Vec<f64>,
    best: Vec<f64>,
    lower: Vec<f64>,
    pruned: Vec<f64>,
    candidates: Vec<Vec<(f64, usize)>>,
    /// The best [`POOL`] samples by value (any face), sorted.
    pool: Vec<Vec<(f64, usize)>>,
    samples: &'a [crate::sampling::Sample],
}

impl Visitor for Best<'_> {
    fn threshold(&self, part: usize) -> f64 {
        self.thresholds[part].min(self.best[part])
    }

    fn pruned(&mut self, part: usize, lb: f64) {
        self.lower[part] = self.lower[part].min(lb);
        self.pruned[part] = self.pruned[part].min(lb);
    }

    fn sample(&mut self, part: usize, index: usize, value: f64, lb: f64) -> bool {
        self.lower[part] = self.lower[part].min(lb);
        self.best[part] = self.best[part].min(value);
        let pool = &mut self.pool[part];
        if pool.len() < POOL || value < pool[pool.len() - 1].0 {
            let at = pool.partition_point(|&(v, k)| v < value || (v == value && k < index));
            pool.insert(at, (value, index));
            pool.truncate(POOL);
        }
        let face = self.samples[index].face;
        let c = &mut self.candidates[part];
        let samples = self.samples;
        if let Some(slot) = c.iter_mut().find(|(_, k)| samples[*k].face == face) {
            if value < slot.0 {
                *slot = (value, index);
            }
        } else if c.len() < CANDIDATE_FACES {
            c.push((value, index));
        } else if let Some(worst) = c
            .iter_mut()
            .max_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
        {
            if value < worst.0 {
                *worst = (value, index);
            }
        }
        true
    }
}

fn limits(tool: &ToolAssembly, opts: &QueryOptions) -> Vec<f64> {
    (0..tool.part_count())
        .map(|i| opts.limit(ToolPart::from_index(i)))
        .collect()
}

fn all_parts(tool: &ToolAssembly) -> u32 {
    let n = tool.part_count().min(MAX_PARTS);
    if n == 32 {
        u32::MAX
    } else {
        (1u32 << n) - 1
    }
}
