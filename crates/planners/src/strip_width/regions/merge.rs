//! Merging the regions of a partition where a boundary costs more than the
//! better feed directions on its two sides save (docs/methods.md, "Merging
//! regions"): separatrices are taken out one at a time while a removal
//! shortens the estimated cover.

use super::partition::{interior_point, polygon_contains, FaceGraph};
use super::Region;
use crate::Progress;
use std::collections::BTreeMap;
use toolpath_kernel::error::Result;
use toolpath_kernel::geometry::NurbsSurface;

/// Trials estimated at once after the first step (one per core): the first
/// group with a removal that shortens the total gives the step.
const TRIALS_AT_ONCE: usize = 2;

/// A face of the graph with some separatrices removed: the (sorted) traced
/// regions it holds, which name it, and its polygon as a region.
struct Face {
    held: Vec<usize>,
    region: Region,
}

/// The regions kept and what the search found.
pub(crate) struct Merged {
    pub regions: Vec<Region>,
    /// The separatrices left out (index as in the graph; the tests check
    /// the search by it).
    #[allow(dead_code)]
    pub removed: Vec<bool>,
    /// Estimated cover length of the traced partition and of the merged one, mm.
    pub traced_length: f64,
    pub merged_length: f64,
}

/// Merges the faces of `graph` (whose regions, as traced, are `traced`)
/// while that shortens the sum of `cost` over the regions. `cost` is the
/// estimated cover length of one region; it is called once per distinct
/// region, on up to two threads. A region of the merged partition is a
/// union of traced ones and is known by the set of them, so its cost is
/// computed once however many trials meet it. The first step tries every
/// separatrix and takes the removal with the shortest total (ties: the
/// lowest index). Later steps try the separatrices left in the order of
/// what they saved in the first step, [`TRIALS_AT_ONCE`] at a time, and take
/// the shorter of the first group that shortens the total: late in the
/// search the grown region's union with each neighbour is most of the
/// surface, so trying every removal at every step would estimate most of
/// the surface again per trial for, as a rule, the same regions
/// (docs/methods.md, "Merging regions"). It stops when no removal shortens
/// the total.
pub(crate) fn merge_regions<F>(
    surface: &NurbsSurface,
    graph: &FaceGraph,
    traced: &[Region],
    cost: F,
    progress: &dyn Progress,
) -> Result<Merged>
where
    F: Fn(&Region) -> Result<f64> + Sync,
{
    let mut search = Search {
        graph,
        traced,
        inside: traced
            .iter()
            .map(|r| interior_point(&r.boundary_uv))
            .collect(),
        cost,
        progress,
        costs: BTreeMap::new(),
    };
    let n = graph.separatrix_count();
    let mut removed = vec![false; n];
    let (start, _) = search.faces_without(&removed);
    search.fill(&start.iter().collect::<Vec<_>>())?;
    let traced_length = search.total(&start);
    let mut best = traced_length;
    // What removing each separatrix saved from the partition as traced:
    // the order later steps try them in.
    let mut first_saving: Option<Vec<f64>> = None;
    loop {
        progress.check()?;
        let mut trials = search.trials(&removed);
        let chunk = match &first_saving {
            // The first step tries every separatrix.
            None => trials.len().max(1),
            Some(saving) => {
                trials.sort_by(|a, b| saving[b.0].total_cmp(&saving[a.0]).then(a.0.cmp(&b.0)));
                TRIALS_AT_ONCE
            }
        };
        let pick = search.pick(&trials, chunk, best)?;
        if first_saving.is_none() {
            let mut saving = vec![f64::NEG_INFINITY; n];
            for (e, faces, _) in &trials {
                saving[*e] = best - search.total(faces);
            }
            first_saving = Some(saving);
        }
        let Some((t, k)) = pick else { break };
        best = t;
        removed = trials[k].2.clone();
    }
    let (regions, removed) = graph.regions_without(surface, &removed);
    Ok(Merged {
        regions,
        removed,
        traced_length,
        merged_length: best,
    })
}

/// One removal tried: the separatrix, the faces left and which
/// separatrices were left out.
type Trial = (usize, Vec<Face>, Vec<bool>);

/// The merge search's state: the graph, the traced regions with a point
/// inside each, the cost function and the costs met so far, by the traced
/// regions a face holds.
struct Search<'a, F> {
    graph: &'a FaceGraph,
    traced: &'a [Region],
    inside: Vec<Option<nalgebra::Vector2<f64>>>,
    cost: F,
    progress: &'a dyn Progress,
    costs: BTreeMap<Vec<usize>, f64>,
}

impl<F> Search<'_, F>
where
    F: Fn(&Region) -> Result<f64> + Sync,
{
    /// The faces left without the `removed` separatrices, each with the
    /// traced regions it holds, and which separatrices were left out.
    fn faces_without(&self, removed: &[bool]) -> (Vec<Face>, Vec<bool>) {
        let (polygons, out) = self.graph.faces_without(removed);
        let faces = polygons
            .into_iter()
            .map(|poly| {
                let held: Vec<usize> = (0..self.traced.len())
                    .filter(|&i| self.inside[i].is_some_and(|p| polygon_contains(&poly, p)))
                    .collect();
                let area_mm2 = held.iter().map(|&i| self.traced[i].area_mm2).sum();
                Face {
                    held,
                    region: Region {
                        id: 0,
                        boundary_uv: poly,
                        area_mm2,
                    },
                }
            })
            .collect();
        (faces, out)
    }

    /// The cost of every face not met before, two at a time.
    fn fill(&mut self, faces: &[&Face]) -> Result<()> {
        let mut todo: Vec<&Face> = Vec::new();
        for f in faces {
            if !self.costs.contains_key(&f.held) && !todo.iter().any(|t| t.held == f.held) {
                todo.push(f);
            }
        }
        let (cost, progress) = (&self.cost, self.progress);
        let done = toolpath_kernel::parallel::map_chunks(&todo, 1, |f| -> Result<f64> {
            progress.check()?;
            cost(&f[0].region)
        });
        for (f, c) in todo.iter().zip(done) {
            self.costs.insert(f.held.clone(), c?);
        }
        Ok(())
    }

    /// The summed cost of `faces` (every one filled).
    fn total(&self, faces: &[Face]) -> f64 {
        faces.iter().map(|f| self.costs[&f.held]).sum()
    }

    /// Each separatrix not yet removed taken out in turn, in index order.
    fn trials(&self, removed: &[bool]) -> Vec<Trial> {
        (0..removed.len())
            .filter(|&e| !removed[e])
            .map(|e| {
                let mut r = removed.to_vec();
                r[e] = true;
                let (faces, out) = self.faces_without(&r);
                (e, faces, out)
            })
            // Every face must hold a traced region (it does, unless the
            // graph's faces did not close).
            .filter(|(_, faces, _)| !faces.is_empty() && faces.iter().all(|f| !f.held.is_empty()))
            .collect()
    }

    /// The trial with the shortest total below `best` in the first group of
    /// `chunk` trials that has one (ties: the first), as (total, index).
    fn pick(&mut self, trials: &[Trial], chunk: usize, best: f64) -> Result<Option<(f64, usize)>> {
        let mut pick: Option<(f64, usize)> = None;
        for (c, group) in trials.chunks(chunk).enumerate() {
            let faces: Vec<&Face> = group.iter().flat_map(|t| t.1.iter()).collect();
            self.fill(&faces)?;
            for (k, (_, faces, _)) in group.iter().enumerate() {
                let t = self.total(faces);
                if t < best && pick.is_none_or(|(b, _)| t < b) {
                    pick = Some((t, c * chunk + k));
                }
            }
            if pick.is_some() {
                break;
            }
        }
        Ok(pick)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::strip_width::regions::degenerate_points;
    use crate::strip_width::regions::partition::{partition, Partition};
    use crate::{test_surfaces, NoProgress};

    fn monkey_saddle() -> (NurbsSurface, Partition) {
        let s = test_surfaces::monkey_saddle([0.0, 0.0], 0.0);
        let a = degenerate_points::find(&s, 32).unwrap();
        let p = partition(&s, 5f64.to_radians().sin() / 2.5, &a.points, 1.0);
        (s, p)
    }

    #[test]
    fn regions_merge_while_it_shortens_and_not_beyond() {
        let (s, p) = monkey_saddle();
        let whole: f64 = p.regions.iter().map(|r| r.area_mm2).sum();
        // A fixed cost per region (run-ins, run-outs) over a cost linear in
        // area: one region is cheapest.
        let m = merge_regions(
            &s,
            &p.graph,
            &p.regions,
            |r| Ok(100.0 + r.area_mm2),
            &NoProgress,
        )
        .unwrap();
        assert_eq!(m.regions.len(), 1);
        assert_eq!(m.removed, vec![true; 3]);
        assert!((m.traced_length - (300.0 + whole)).abs() < 1e-6 * whole);
        assert!((m.merged_length - (100.0 + whole)).abs() < 1e-6 * whole);
        // A cost growing faster than area: merging never pays.
        let m = merge_regions(
            &s,
            &p.graph,
            &p.regions,
            |r| Ok(r.area_mm2.powi(2)),
            &NoProgress,
        )
        .unwrap();
        assert_eq!(m.regions.len(), 3);
        assert_eq!(m.removed, vec![false; 3]);
        assert_eq!(m.traced_length, m.merged_length);
        // One sector costs double on its own (a poor feed field there),
        // nothing when merged: the merge takes exactly that sector into a
        // neighbour and stops, since the last merge would add 100.
        let small = p
            .regions
            .iter()
            .map(|r| r.area_mm2)
            .min_by(f64::total_cmp)
            .unwrap();
        let cost = |r: &Region| {
            let alone = (r.area_mm2 - small).abs() < 1e-6 * small;
            Ok(100.0
                + r.area_mm2 * if alone { 2.0 } else { 1.0 }
                + if r.area_mm2 > 0.9 * whole { 100.0 } else { 0.0 })
        };
        let m = merge_regions(&s, &p.graph, &p.regions, cost, &NoProgress).unwrap();
        assert_eq!(m.regions.len(), 2, "{:?}", m.removed);
        assert!(m.regions.iter().all(|r| (r.area_mm2 - small).abs() > 1.0));
        assert!(m.merged_length < m.traced_length);
    }

    #[test]
    fn a_failing_cost_fails_the_merge() {
        let (s, p) = monkey_saddle();
        let r = merge_regions(
            &s,
            &p.graph,
            &p.regions,
            |_| Err(toolpath_kernel::error::Error::planning("no cover")),
            &NoProgress,
        );
        assert!(r.is_err());
    }

    /// A merged region is known by the traced regions it holds, so each
    /// distinct region is estimated once however many trials meet it:
    /// round one trisector (three sectors, as on wing_mould) a merge into
    /// one region estimates 7 covers, the 3 sectors, the 3 pairs and the
    /// whole, 4 times the surface's area in all.
    #[test]
    fn each_distinct_region_is_estimated_once() {
        let (s, p) = monkey_saddle();
        let whole: f64 = p.regions.iter().map(|r| r.area_mm2).sum();
        let estimated = std::sync::Mutex::new(Vec::new());
        let m = merge_regions(
            &s,
            &p.graph,
            &p.regions,
            |r| {
                estimated.lock().unwrap().push(r.area_mm2);
                Ok(100.0 + r.area_mm2)
            },
            &NoProgress,
        )
        .unwrap();
        assert_eq!(m.regions.len(), 1);
        let estimated = estimated.into_inner().unwrap();
        assert_eq!(estimated.len(), 7, "{estimated:?}");
        let area: f64 = estimated.iter().sum();
        assert!(
            (area - 4.0 * whole).abs() < 1e-6 * whole,
            "{area} vs {whole}"
        );
    }
}
