//! Strategy `tensor_regions` (after Xu, Li, Liu 2016, with the corrections of
//! docs/methods.md, "The strip-width tensor and its degenerate points" and
//! "Partition at trisectors"): the strip-width tensor field, its degenerate
//! points, the separatrices of the trisectors, the regions they bound, and in
//! each region an initial pass through its widest-strip point along the
//! optimal feed, then iso-scallop passes offset to both sides.

use super::offset::{boundary_start, cover};
use super::parametric::plan_passes;
use super::passes::PassSettings;
use super::regions::degenerate_points::{self, Analysis};
use super::regions::partition::{partition, Region, Tracer};
use super::regions::whole_domain;
use super::width::{gouge_error, max_strip_width, WidthError};
use crate::error::Result;
use crate::formats::result::{DegeneratePoint, Region as RegionOut};
use crate::formats::{FeedDirection, Job, Pass, PlanResult};
use crate::geometry::{LocalGeometry, NurbsSurface};
use crate::planners::{CheckOnly, Progress};
use nalgebra::{Point3, Vector2, Vector3};

/// Grid cells per direction for the degenerate-point search.
const DEGENERATE_GRID: usize = 48;
/// Largest share of the surface area the regions may miss or double-count.
const TILING_TOLERANCE: f64 = 0.005;
/// Samples per direction when looking for a region's widest-strip point.
const WIDEST_GRID: usize = 48;

/// Index of the shortest plan in the list [`candidates`] returns.
const SHORTEST: usize = 0;

/// The candidate plans, in the order they are built (ties keep the first).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Candidate {
    /// The regions of the partition, each offset from its own field line.
    Partitioned,
    /// The whole surface as one region, offset from the field line through
    /// its widest-strip point.
    WholeField,
    /// The whole surface offset from a straight-heading walk through its
    /// middle along the area-weighted mean feed direction.
    MeanFeed,
    /// The whole surface offset from a boundary edge (feed along u or v;
    /// the edge at the start of the other parameter, or with `true` its end).
    EdgeOffset(FeedDirection, bool),
    /// Zig-zag passes along one parameter.
    IsoCurves(FeedDirection),
}

impl Candidate {
    fn label(self) -> String {
        let dir = |f: FeedDirection| match f {
            FeedDirection::U => "u",
            FeedDirection::V => "v",
        };
        match self {
            Candidate::Partitioned => "partitioned".into(),
            Candidate::WholeField => "whole_field".into(),
            Candidate::MeanFeed => "mean_feed".into(),
            Candidate::EdgeOffset(f, far) => {
                format!("edge_offset_{}{}", dir(f), if far { "_far" } else { "" })
            }
            Candidate::IsoCurves(f) => format!("iso_curves_{}", dir(f)),
        }
    }
}

/// The shortest candidate plan (see [`candidates`]).
pub fn plan(job: &Job, progress: &dyn Progress) -> Result<PlanResult> {
    let mut all = candidates(job, progress)?;
    Ok(all.swap_remove(SHORTEST))
}

/// Every candidate plan that could be built, shortest first (by cl path
/// length; equal lengths keep the build order). Whether partitioning pays
/// is decided by what it saves: a region boundary costs run-ins, run-outs
/// and the overlap of two covers, so the partitioned plan competes with the
/// whole surface offset from one field line, from either edge, and with
/// passes along either parameter (the plans the baselines would make, built
/// from the shared modules). Each result names its candidate and the others'
/// lengths in `plan_choice`.
pub fn candidates(job: &Job, progress: &dyn Progress) -> Result<Vec<PlanResult>> {
    let surface = job.surface()?;
    let settings = PassSettings::from_job(job)?;
    let k_b = settings.cutter.k_b();
    progress.check()?;
    let analysis = degenerate_points::find(surface, DEGENERATE_GRID)?;
    progress.set(0.1);
    progress.check()?;
    let mut warnings = Vec::new();
    let step = settings.point_step.min(settings.cutter.radius);
    let whole = whole_domain(surface);
    let (regions, separatrices_uv) =
        regions_of(surface, k_b, &analysis, step, &whole, &mut warnings);
    progress.set(0.2);
    progress.check()?;
    let mut kinds = Vec::new();
    if regions.len() > 1 {
        kinds.push(Candidate::Partitioned);
    }
    kinds.extend([
        Candidate::WholeField,
        Candidate::MeanFeed,
        Candidate::EdgeOffset(FeedDirection::U, false),
        Candidate::EdgeOffset(FeedDirection::V, false),
        Candidate::EdgeOffset(FeedDirection::U, true),
        Candidate::EdgeOffset(FeedDirection::V, true),
        Candidate::IsoCurves(FeedDirection::U),
        Candidate::IsoCurves(FeedDirection::V),
    ]);
    let whole_list = [whole.clone()];
    let checks = CheckOnly(progress);
    let built = crate::parallel::map_chunks(&kinds, 1, |kind| -> Result<Vec<Pass>> {
        checks.check()?;
        match kind[0] {
            Candidate::Partitioned => {
                cover_regions(surface, &settings, &regions, &analysis, step, &checks)
            }
            Candidate::MeanFeed => match mean_feed_line(surface, &settings) {
                Some(line) => cover(surface, &settings, &whole, &line, &checks),
                None => Ok(Vec::new()),
            },
            Candidate::WholeField => {
                cover_regions(surface, &settings, &whole_list, &analysis, step, &checks)
            }
            Candidate::EdgeOffset(feed, far) => cover(
                surface,
                &settings,
                &whole,
                &boundary_start(surface, &settings, feed, far),
                &checks,
            ),
            Candidate::IsoCurves(feed) => plan_passes(surface, &settings, feed, &checks),
        }
    });
    // A stop ends the job, not just the candidate it hit.
    if let Some(stop) = built.iter().find_map(|b| match b {
        Err(e @ crate::error::Error::Stopped { .. }) => Some(e.clone()),
        _ => None,
    }) {
        return Err(stop);
    }
    progress.set(0.95);
    progress.check()?;
    let bound = super::lower_bound::job_path_length_lower_bound(job, surface, &settings.cutter)?;
    let mut plans: Vec<(Candidate, PlanResult, f64)> = Vec::new();
    let mut first_error = None;
    for (kind, passes) in kinds.iter().zip(built) {
        let passes = match passes {
            Ok(p) if !p.is_empty() => p,
            Ok(_) => continue,
            Err(e) => {
                warnings.push(format!("candidate {} not built: {e}", kind.label()));
                first_error.get_or_insert(e);
                continue;
            }
        };
        let used: &[Region] = if *kind == Candidate::Partitioned {
            &regions
        } else {
            &whole_list
        };
        let result = candidate_result(
            job,
            surface,
            passes,
            used,
            bound,
            &analysis,
            &separatrices_uv,
        );
        let length = result.cl_path_length();
        plans.push((*kind, result, length));
    }
    if plans.is_empty() {
        return Err(first_error.unwrap_or_else(|| {
            crate::error::Error::planning("tensor_regions: no candidate plan has any pass")
        }));
    }
    Ok(ranked(plans, &warnings))
}

/// The regions to plan: the partition at the degenerate points when its
/// regions tile the surface, else the whole surface as one region (with a
/// warning saying why), and the separatrices in (u, v).
fn regions_of(
    surface: &NurbsSurface,
    k_b: f64,
    analysis: &degenerate_points::Analysis,
    step: f64,
    whole: &Region,
    warnings: &mut Vec<String>,
) -> (Vec<Region>, Vec<Vec<Vector2<f64>>>) {
    if analysis.everywhere {
        warnings.push(
            "the strip-width field is isotropic everywhere (every point is degenerate): one region, feed along u"
                .into(),
        );
        return (vec![whole.clone()], Vec::new());
    }
    let p = partition(surface, k_b, &analysis.points, step);
    // The regions must tile the surface: where the separatrix graph did
    // not close into faces covering it (separatrices ending near each
    // other or on a wedge), planning the faces found would leave the rest
    // uncut. Then the whole surface is one region.
    let covered: f64 = p.regions.iter().map(|r| r.area_mm2).sum();
    if (covered - whole.area_mm2).abs() > TILING_TOLERANCE * whole.area_mm2 {
        warnings.push(format!(
            "the separatrices split the surface into regions covering {covered:.0} of {:.0} mm^2: planned as one region",
            whole.area_mm2
        ));
        (vec![whole.clone()], p.separatrices_uv)
    } else {
        (p.regions, p.separatrices_uv)
    }
}

/// One candidate's result: its passes, the lower bound, and the analysis
/// it shares with the others (degenerate points, separatrices, the regions
/// it `used`, on a trimmed face their part on it).
fn candidate_result(
    job: &Job,
    surface: &NurbsSurface,
    passes: Vec<Pass>,
    used: &[Region],
    bound: f64,
    analysis: &degenerate_points::Analysis,
    separatrices_uv: &[Vec<Vector2<f64>>],
) -> PlanResult {
    let mut result = PlanResult::new(&job.job_id, job.strategy.name());
    result.passes = passes;
    result.stats.path_length_lower_bound_mm = Some(bound);
    result.degenerate_points = Some(
        analysis
            .points
            .iter()
            .map(|p| DegeneratePoint {
                uv: p.uv.into(),
                xyz: p.xyz.into(),
                kind: p.kind.name().to_string(),
            })
            .collect(),
    );
    result.separatrices = Some(
        separatrices_uv
            .iter()
            .map(|line| {
                line.iter()
                    .map(|uv| surface.point(uv.x, uv.y).into())
                    .collect()
            })
            .collect(),
    );
    result.regions = Some(
        used.iter()
            .map(|r| RegionOut {
                id: r.id,
                // On a trimmed face, the region's part on it.
                area_mm2: match surface.trim() {
                    Some(_) => {
                        super::regions::partition::polygon_face_area(surface, &r.boundary_uv, 48)
                    }
                    None => r.area_mm2,
                },
                boundary_uv: r.boundary_uv.iter().map(|p| [p.x, p.y]).collect(),
            })
            .collect(),
    );
    result
}

/// The plans shortest first (stable: equal lengths keep the build order),
/// each naming its candidate and every candidate's length in `plan_choice`.
fn ranked(mut plans: Vec<(Candidate, PlanResult, f64)>, warnings: &[String]) -> Vec<PlanResult> {
    // Stable: equal lengths keep the build order.
    plans.sort_by(|a, b| a.2.total_cmp(&b.2));
    let summary: Vec<String> = plans
        .iter()
        .map(|(k, _, l)| format!("{} {l:.0} mm", k.label()))
        .collect();
    let n = plans.len();
    plans
        .into_iter()
        .enumerate()
        .map(|(rank, (kind, mut result, _))| {
            result.plan_choice = Some(if rank == 0 {
                format!(
                    "{}: the shortest of {n} candidate plans ({})",
                    kind.label(),
                    summary.join(", ")
                )
            } else {
                format!(
                    "{}: candidate {} of {n} by length ({})",
                    kind.label(),
                    rank + 1,
                    summary.join(", ")
                )
            });
            result.warnings = warnings.to_vec();
            result
        })
        .collect()
}

/// Each region covered by passes offset from the field line through its
/// widest-strip point, regions in order.
fn cover_regions(
    surface: &NurbsSurface,
    settings: &PassSettings,
    regions: &[Region],
    analysis: &Analysis,
    step: f64,
    progress: &dyn Progress,
) -> Result<Vec<Pass>> {
    let mut passes = Vec::new();
    for region in regions {
        progress.check()?;
        let initial = initial_pass(surface, settings, region, analysis, step)?;
        passes.extend(cover(surface, settings, region, &initial, progress)?);
    }
    Ok(passes)
}

/// Samples per direction of the mean feed direction.
const MEAN_FEED_GRID: usize = 24;

/// A walk on the surface through the middle of the domain, both ways to
/// the boundary, heading along the mean optimal feed: the feed field's
/// directions averaged as axes (doubled angles in the frame of S_u and
/// n x S_u), each weighted by its area and by how much it gains over the
/// cross direction (mu_feed - mu_cross). `None` on an isotropic field.
fn mean_feed_line(surface: &NurbsSurface, s: &PassSettings) -> Option<Vec<Vector2<f64>>> {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let k_b = s.cutter.k_b();
    let (mut c2, mut s2) = (0.0, 0.0);
    for i in 0..MEAN_FEED_GRID {
        for j in 0..MEAN_FEED_GRID {
            let u = u0 + (u1 - u0) * (i as f64 + 0.5) / MEAN_FEED_GRID as f64;
            let v = v0 + (v1 - v0) * (j as f64 + 0.5) / MEAN_FEED_GRID as f64;
            let Some(g) = LocalGeometry::at(surface, u, v) else {
                continue;
            };
            let Some(f) = super::field::feed_at(&g, k_b) else {
                continue;
            };
            let Some(e1) = g.derivs.su.try_normalize(1e-300) else {
                continue;
            };
            let e2 = g.n.cross(&e1);
            let angle = f.feed.dot(&e2).atan2(f.feed.dot(&e1));
            let w = g.derivs.su.cross(&g.derivs.sv).norm() * (f.mu_feed - f.mu_cross);
            c2 += w * (2.0 * angle).cos();
            s2 += w * (2.0 * angle).sin();
        }
    }
    if c2.hypot(s2) <= 0.0 {
        return None;
    }
    let angle = 0.5 * s2.atan2(c2);
    let mid = Vector2::new(0.5 * (u0 + u1), 0.5 * (v0 + v1));
    let g = LocalGeometry::at(surface, mid.x, mid.y)?;
    let e1 = g.derivs.su.try_normalize(1e-300)?;
    let heading = e1 * angle.cos() + g.n.cross(&e1) * angle.sin();
    let step = s.point_step;
    let (lo, hi) = surface.bounding_box();
    let max_steps = ((4.0 * (hi - lo).norm() / step).ceil() as usize).max(2);
    let walk = |dir: Vector3<f64>| {
        let mut out = Vec::new();
        let (mut uv, mut d) = (mid, dir);
        for _ in 0..max_steps {
            let Some((next, nd, hit)) = super::passes::walk_on_surface(surface, uv, d, step) else {
                break;
            };
            out.push(next);
            if hit {
                break;
            }
            uv = next;
            d = nd;
        }
        out
    };
    let mut line: Vec<Vector2<f64>> = walk(-heading).into_iter().rev().collect();
    line.push(mid);
    line.extend(walk(heading));
    (line.len() >= 2).then_some(line)
}

/// The region's widest-strip point (sampled) and the feed field line through
/// it, traced both ways to the region boundary. For an isotropic field the
/// u iso-curve through the region's middle.
fn initial_pass(
    surface: &NurbsSurface,
    s: &PassSettings,
    region: &Region,
    analysis: &Analysis,
    step: f64,
) -> Result<Vec<Vector2<f64>>> {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let mut best: Option<(f64, Vector2<f64>, Vector3<f64>)> = None;
    for i in 0..WIDEST_GRID {
        for j in 0..WIDEST_GRID {
            let uv = Vector2::new(
                u0 + (u1 - u0) * (i as f64 + 0.5) / WIDEST_GRID as f64,
                v0 + (v1 - v0) * (j as f64 + 0.5) / WIDEST_GRID as f64,
            );
            if !region.contains(uv) {
                continue;
            }
            let Some(g) = LocalGeometry::at(surface, uv.x, uv.y) else {
                continue;
            };
            match max_strip_width(&s.cutter, s.scallop, &g) {
                Ok((w, t)) => {
                    if best.is_none_or(|(bw, _, _)| w > bw) {
                        best = Some((w, uv, t));
                    }
                }
                Err(WidthError::Gouge { depth }) => {
                    return Err(gouge_error(&s.cutter, uv.into(), g.k_max, depth));
                }
            }
        }
    }
    let Some((_, start, feed)) = best else {
        // A sliver region no sample fell in: its neighbours' passes overlap it.
        return Ok(Vec::new());
    };
    if analysis.everywhere {
        let curve_uv = |t: f64| Vector2::new(u0 + (u1 - u0) * t, start.y);
        let n = ((surface.point(u0, start.y) - surface.point(u1, start.y)).norm() / step)
            .ceil()
            .max(2.0) as usize;
        return Ok((0..=n).map(|k| curve_uv(k as f64 / n as f64)).collect());
    }
    let degenerate: Vec<Point3<f64>> = analysis.points.iter().map(|p| p.xyz).collect();
    let (lo, hi) = surface.bounding_box();
    let tracer = Tracer {
        surface,
        k_b: s.cutter.k_b(),
        step,
        max_len: 4.0 * (hi - lo).norm(),
        degenerate: &degenerate,
        snap: 0.5 * step,
    };
    let outside = |uv: Vector2<f64>| !region.contains(uv);
    let forward = tracer.trace(start, feed, &outside);
    let backward = tracer.trace(start, -feed, &outside);
    let mut line: Vec<Vector2<f64>> = backward.uv.iter().rev().copied().collect();
    line.extend(forward.uv.iter().skip(1).copied());
    Ok(line)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::Strategy;
    use crate::planners::{test_surfaces, NoProgress};

    #[test]
    fn plane_is_isotropic_everywhere_and_still_planned() {
        let job = test_surfaces::job(
            test_surfaces::sheared_plane(),
            Strategy::TensorRegions,
            2.5,
            5.0,
            0.05,
        );
        let r = plan(&job, &NoProgress).unwrap();
        assert!(r.warnings.iter().any(|w| w.contains("isotropic")));
        assert_eq!(r.regions.as_ref().map(|x| x.len()), Some(1));
        assert!(r.degenerate_points.as_ref().is_some_and(|d| d.is_empty()));
        // Parallel passes spaced for the exact plane width: about 100 / 2.9 of them.
        assert!(
            r.passes.len() >= 30 && r.passes.len() <= 40,
            "{}",
            r.passes.len()
        );
    }

    #[test]
    fn surface_without_umbilic_is_one_region_fed_along_the_axis() {
        let job = test_surfaces::job(
            test_surfaces::concave_cylinder(100.0, 100.0),
            Strategy::TensorRegions,
            2.5,
            5.0,
            0.05,
        );
        let r = plan(&job, &NoProgress).unwrap();
        assert_eq!(r.regions.as_ref().map(|x| x.len()), Some(1));
        // The optimal feed on a concave cylinder is along its axis (x)
        // (pass ends may bend where they meet the boundary).
        let pts: Vec<_> = r.passes.iter().flat_map(|p| p.points.iter()).collect();
        let along = pts
            .iter()
            .filter(|p| p.feed.unwrap()[0].abs() > 0.999)
            .count();
        assert!(
            along as f64 >= 0.95 * pts.len() as f64,
            "{along} of {}",
            pts.len()
        );
    }

    #[test]
    fn monkey_saddle_partitioned_candidate_carries_the_partition() {
        let job = test_surfaces::job(
            test_surfaces::monkey_saddle([0.0, 0.0], 0.0),
            Strategy::TensorRegions,
            2.5,
            5.0,
            0.05,
        );
        let all = candidates(&job, &NoProgress).unwrap();
        let labels: Vec<&str> = all
            .iter()
            .map(|r| r.plan_choice.as_deref().unwrap().split(':').next().unwrap())
            .collect();
        let mut sorted = labels.clone();
        sorted.sort();
        assert_eq!(
            sorted,
            [
                "edge_offset_u",
                "edge_offset_u_far",
                "edge_offset_v",
                "edge_offset_v_far",
                "iso_curves_u",
                "iso_curves_v",
                "mean_feed",
                "partitioned",
                "whole_field"
            ]
        );
        // Shortest first, and plan() returns the first.
        for w in all.windows(2) {
            assert!(w[0].cl_path_length() <= w[1].cl_path_length());
        }
        let best = plan(&job, &NoProgress).unwrap();
        assert_eq!(best.passes, all[0].passes);
        assert!(all[0]
            .plan_choice
            .as_deref()
            .unwrap()
            .contains("the shortest of 9"));
        let r = &all[labels.iter().position(|l| *l == "partitioned").unwrap()];
        let d = r.degenerate_points.as_ref().unwrap();
        assert_eq!(d.len(), 1);
        assert_eq!(d[0].kind, "trisector");
        assert_eq!(r.separatrices.as_ref().unwrap().len(), 3);
        let regions = r.regions.as_ref().unwrap();
        assert_eq!(regions.len(), 3);
        for k in 0..3 {
            assert!(r.passes.iter().any(|p| p.region == k));
        }
    }
}
