//! Strategy `tensor_regions` (after Xu, Li, Liu 2016, with the corrections of
//! docs/methods.md, "The strip-width tensor and its degenerate points" and
//! "Partition at trisectors"): the strip-width tensor field, its degenerate
//! points, the separatrices of the trisectors, the regions they bound, and in
//! each region an initial pass along the optimal feed through its
//! widest-strip point (the next widest seed's where that line is a stub),
//! then iso-scallop passes offset to both sides.

use super::offset::{boundary_start, cover, cover_from_edge, MIN_RUN_SPAN};
use super::parametric::plan_passes;
use super::passes::PassSettings;
use super::regions::degenerate_points::{self, Analysis};
use super::regions::merge::merge_regions;
use super::regions::partition::{partition, FaceGraph, Region, Tracer};
use super::regions::whole_domain;
use super::width::{gouge_error, max_strip_width, WidthError};
use crate::{CheckOnly, Progress};
use nalgebra::{Point3, Vector2, Vector3};
use toolpath_formats::result::polyline_length;
use toolpath_formats::result::{DegeneratePoint, Region as RegionOut};
use toolpath_formats::{FeedDirection, Job, Pass, PlanResult};
use toolpath_kernel::error::Result;
use toolpath_kernel::geometry::{LocalGeometry, NurbsSurface};

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
    /// The regions of the partition, each offset from its own field line
    /// (merged where a boundary costs more than it saves).
    Partitioned,
    /// The partition as traced, unmerged: built on request only (see
    /// [`candidate`]), to compare with.
    PartitionedAsTraced,
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
            Candidate::PartitionedAsTraced => "partitioned_as_traced".into(),
            Candidate::WholeField => "whole_field".into(),
            Candidate::MeanFeed => "mean_feed".into(),
            Candidate::EdgeOffset(f, far) => {
                format!("edge_offset_{}{}", dir(f), if far { "_far" } else { "" })
            }
            Candidate::IsoCurves(f) => format!("iso_curves_{}", dir(f)),
        }
    }
}

/// The strategy `tensor_regions`: several candidate plans, the pipeline
/// keeps the shortest that verifies.
pub struct TensorRegions;

/// The candidates of every job, after [`Candidate::Partitioned`] where the
/// partition has more than one region.
const UNPARTITIONED: [Candidate; 8] = [
    Candidate::WholeField,
    Candidate::MeanFeed,
    Candidate::EdgeOffset(FeedDirection::U, false),
    Candidate::EdgeOffset(FeedDirection::V, false),
    Candidate::EdgeOffset(FeedDirection::U, true),
    Candidate::EdgeOffset(FeedDirection::V, true),
    Candidate::IsoCurves(FeedDirection::U),
    Candidate::IsoCurves(FeedDirection::V),
];

/// Candidate kinds of a job at most: planning holds one plan of each until
/// it has ranked them.
const CANDIDATE_KINDS: usize = 1 + UNPARTITIONED.len();

impl crate::Strategy for TensorRegions {
    fn id(&self) -> toolpath_formats::Strategy {
        toolpath_formats::Strategy::TensorRegions
    }
    fn plan(&self, job: &Job, progress: &dyn Progress) -> Result<PlanResult> {
        let mut all = candidates(job, progress)?;
        Ok(all.swap_remove(SHORTEST))
    }
    fn candidates(&self, job: &Job, progress: &dyn Progress) -> Result<Vec<PlanResult>> {
        candidates(job, progress)
    }
    fn plans_held(&self) -> usize {
        CANDIDATE_KINDS
    }
}

/// Candidate plans built exactly: the shortest by estimate (see
/// [`candidates`]); one per core, so they take the time of one.
const EXACT_BUILDS: usize = 2;

/// How much coarser than the job's point step the estimates are built
/// (docs/methods.md, "Candidate plans of tensor_regions").
const ESTIMATE_COARSENING: f64 = 4.0;

/// The candidate plans built exactly, shortest first (by cl path length;
/// equal lengths keep the build order). Whether partitioning pays is
/// decided by what it saves: a region boundary costs run-ins, run-outs and
/// the overlap of two covers, so the partitioned plan competes with the
/// whole surface offset from one field line, from either edge, and with
/// passes along either parameter (the plans the baselines would make, built
/// from the shared modules). Every candidate is first built with a coarser
/// point step ([`PassSettings::coarsened`]) as an estimate of its length,
/// except the two plans the baselines make (`edge_offset` and `iso_curves`
/// along the job's feed direction), which are always built exactly at the
/// job's settings; the [`EXACT_BUILDS`] shortest of the others by estimate
/// are then built exactly too. Each result names its candidate, the exact
/// lengths and every estimate in `plan_choice`.
pub(crate) fn candidates(job: &Job, progress: &dyn Progress) -> Result<Vec<PlanResult>> {
    let setup = Setup::new(job, progress)?;
    let checks = CheckOnly(progress);
    // The plans the baselines make are always built exactly, so the kept
    // plan is never longer than either however the estimates err (Lee
    // offsetting reacts to its sampling; docs/methods.md, "Candidate plans
    // of tensor_regions"): they are built at
    // once, not estimated, next to the estimates of the other candidates
    // (every candidate at the coarse settings, its length on the face,
    // clipped to the trim like the exact plans). Exact builds first: they
    // are the longest jobs, and the estimates fill the other core.
    let feed = job.feed_direction.unwrap_or(FeedDirection::U);
    let baselines: Vec<Candidate> = [
        Candidate::EdgeOffset(feed, false),
        Candidate::IsoCurves(feed),
    ]
    .into_iter()
    .filter(|b| setup.kinds.contains(b))
    .collect();
    let first: Vec<(Candidate, bool)> = baselines
        .iter()
        .map(|&b| (b, true))
        .chain(
            setup
                .kinds
                .iter()
                .filter(|k| !baselines.contains(k))
                .map(|&k| (k, false)),
        )
        .collect();
    let done = setup.first_builds(&first, &checks)?;
    progress.set(0.6);
    progress.check()?;
    let (order, exact) = by_estimate(&first, done, &baselines);
    let estimates: Vec<String> = order
        .iter()
        .filter_map(|&(k, e)| e.map(|l| format!("{} {l:.0} mm", k.label())))
        .collect();
    let top: Vec<Candidate> = order.iter().take(EXACT_BUILDS).map(|&(k, _)| k).collect();
    let built = toolpath_kernel::parallel::map_chunks(&top, 1, |kind| -> Result<Vec<Pass>> {
        checks.check()?;
        setup.build(kind[0], &setup.settings, &checks)
    });
    stop_if_stopped(&built)?;
    // The build order (ties keep the first): the estimates' choice, then
    // the baselines.
    let chosen: Vec<(Candidate, Result<Vec<Pass>>)> =
        top.into_iter().zip(built).chain(exact).collect();
    progress.set(0.95);
    progress.check()?;
    setup.ranked_plans(chosen, &estimates)
}

/// Candidates ordered by estimate, shortest first; those that could not be
/// built coarse are still tried exactly after those (their error is the one
/// to report); empty ones are dropped. Returns them with the exact builds
/// (the baselines), which are not ranked by estimate.
#[allow(clippy::type_complexity)]
fn by_estimate(
    first: &[(Candidate, bool)],
    done: Vec<Result<Built>>,
    baselines: &[Candidate],
) -> (
    Vec<(Candidate, Option<f64>)>,
    Vec<(Candidate, Result<Vec<Pass>>)>,
) {
    let mut order: Vec<(Candidate, Option<f64>)> = Vec::new();
    let mut exact: Vec<(Candidate, Result<Vec<Pass>>)> = Vec::new();
    for (&(kind, _), d) in first.iter().zip(done) {
        match d {
            Ok(Built::Exact(p)) => exact.push((kind, Ok(p))),
            Ok(Built::Estimate(l)) if l > 0.0 => order.push((kind, Some(l))),
            Ok(Built::Estimate(_)) => {}
            Err(e) if baselines.contains(&kind) => exact.push((kind, Err(e))),
            Err(_) => order.push((kind, None)),
        }
    }
    order.sort_by(|a, b| match (a.1, b.1) {
        (Some(x), Some(y)) => x.total_cmp(&y),
        (x, y) => y.is_some().cmp(&x.is_some()),
    });
    (order, exact)
}

/// One candidate plan built at the job's settings, named by its label as
/// in `plan_choice` (`partitioned`, `whole_field`, `mean_feed`,
/// `edge_offset_u`, ..., `iso_curves_v`): for looking at a candidate the
/// estimates did not keep, or `partitioned_as_traced` (the partition before
/// merging, never a candidate of `TensorRegions::candidates`). `None` when the job has no such
/// candidate (`partitioned` needs more than one region after merging,
/// `partitioned_as_traced` before) or it has no pass.
pub fn candidate(job: &Job, label: &str, progress: &dyn Progress) -> Result<Option<PlanResult>> {
    let setup = Setup::new(job, progress)?;
    let on_request = (setup.traced_regions.len() > 1).then_some(Candidate::PartitionedAsTraced);
    let Some(kind) = setup
        .kinds
        .iter()
        .copied()
        .chain(on_request)
        .find(|k| k.label() == label)
    else {
        return Ok(None);
    };
    let passes = setup.build(kind, &setup.settings, progress)?;
    if passes.is_empty() {
        return Ok(None);
    }
    let mut result = setup.result(kind, passes, setup.bound()?);
    result.plan_choice = Some(
        format!("{label}: built on request")
            + &setup
                .partition_note
                .as_deref()
                .map(|n| format!("; {n}"))
                .unwrap_or_default(),
    );
    result.warnings = setup.warnings.clone();
    Ok(Some(result))
}

/// What a candidate's first build gives: the length of its estimate, or
/// (the baselines' plans) its exact passes.
enum Built {
    Estimate(f64),
    Exact(Vec<Pass>),
}

/// A stop ends the job, not just the candidate it hit.
fn stop_if_stopped<T>(built: &[Result<T>]) -> Result<()> {
    match built.iter().find_map(|b| match b {
        Err(e @ toolpath_kernel::error::Error::Stopped { .. }) => Some(e.clone()),
        _ => None,
    }) {
        Some(stop) => Err(stop),
        None => Ok(()),
    }
}

/// An estimate's length: its passes' on the face (clipped to the trim like
/// the exact plans; `reach` as [`crate::trim_clip::reach`]), mm.
fn estimate_length(surface: &NurbsSurface, passes: &[Pass], reach: f64) -> f64 {
    match surface.trim() {
        Some(_) => crate::trim_clip::clip_passes(surface, passes, reach)
            .iter()
            .map(pass_length)
            .sum(),
        None => passes.iter().map(pass_length).sum(),
    }
}

/// Length of a pass's cl polyline, mm.
fn pass_length(pass: &Pass) -> f64 {
    toolpath_formats::result::polyline_length(pass.points.iter().map(|q| q.cl))
}

/// What every candidate plan of a job is built from: its settings, the
/// field's degenerate points, the regions and the candidates to consider.
struct Setup<'a> {
    job: &'a Job,
    surface: &'a NurbsSurface,
    settings: PassSettings,
    analysis: Analysis,
    whole: Region,
    /// The merged partition, and the partition as traced.
    regions: Vec<Region>,
    traced_regions: Vec<Region>,
    separatrices_uv: Vec<Vec<Vector2<f64>>>,
    warnings: Vec<String>,
    kinds: Vec<Candidate>,
    /// How the partition was merged, for `plan_choice`.
    partition_note: Option<String>,
    /// The estimated length of the merged partition's cover (the sum of its
    /// regions' estimates), mm, and how many regions it has.
    partitioned_estimate: Option<(f64, usize)>,
}

impl<'a> Setup<'a> {
    fn new(job: &'a Job, progress: &dyn Progress) -> Result<Self> {
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
        let (regions, separatrices_uv, graph) =
            regions_of(surface, k_b, &analysis, step, &whole, &mut warnings);
        progress.set(0.15);
        progress.check()?;
        // The partition merged where a region boundary costs more than it
        // saves, judged by the estimated covers (docs/methods.md, "Merging
        // regions").
        let coarse = settings.coarsened(ESTIMATE_COARSENING);
        let reach = crate::trim_clip::reach(job.tool()?);
        let mut traced_regions = Vec::new();
        let (regions, partition_note, partitioned_estimate) = match graph {
            Some(graph) if regions.len() > 1 => {
                let cost = |region: &Region| -> Result<f64> {
                    let passes = cover_regions(
                        surface,
                        &coarse,
                        std::slice::from_ref(region),
                        &analysis,
                        coarse.point_step.min(coarse.cutter.radius),
                        &CheckOnly(progress),
                    )?;
                    Ok(estimate_length(surface, &passes, reach))
                };
                traced_regions = regions.clone();
                match merge_regions(surface, &graph, &regions, cost, progress) {
                    Ok(merged) => {
                        let note = format!(
                            "partition: {} regions as traced, {} after merging where a boundary cost more than it saved (estimates {:.0} -> {:.0} mm)",
                            regions.len(),
                            merged.regions.len(),
                            merged.traced_length,
                            merged.merged_length
                        );
                        let estimate = (merged.merged_length, merged.regions.len());
                        (merged.regions, Some(note), Some(estimate))
                    }
                    Err(e @ toolpath_kernel::error::Error::Stopped { .. }) => return Err(e),
                    // A region whose cover cannot be estimated: the
                    // partition as traced stays a candidate (its build
                    // reports the error if it fails too).
                    Err(e) => {
                        warnings.push(format!("partition not merged: {e}"));
                        (regions, None, None)
                    }
                }
            }
            _ => (regions, None, None),
        };
        progress.set(0.2);
        progress.check()?;
        let mut kinds = Vec::new();
        if regions.len() > 1 {
            kinds.push(Candidate::Partitioned);
        }
        kinds.extend(UNPARTITIONED);
        Ok(Self {
            job,
            surface,
            settings,
            analysis,
            whole,
            regions,
            traced_regions,
            separatrices_uv,
            warnings,
            kinds,
            partition_note,
            partitioned_estimate,
        })
    }

    /// The first round, on up to two threads: each `(kind, exact)` built at
    /// the job's settings when `exact`, else its length estimated from a
    /// build at coarser settings.
    fn first_builds(
        &self,
        first: &[(Candidate, bool)],
        checks: &dyn Progress,
    ) -> Result<Vec<Result<Built>>> {
        let reach = crate::trim_clip::reach(self.job.tool()?);
        let coarse = self.settings.coarsened(ESTIMATE_COARSENING);
        let done = toolpath_kernel::parallel::map_chunks(first, 1, |work| -> Result<Built> {
            checks.check()?;
            let (kind, exact) = work[0];
            if exact {
                return Ok(Built::Exact(self.build(kind, &self.settings, checks)?));
            }
            // The merge search estimated the merged partition's cover already
            // (the whole field's too where it merged every region).
            match (kind, self.partitioned_estimate) {
                (Candidate::Partitioned | Candidate::WholeField, Some((l, regions)))
                    if (kind == Candidate::WholeField) == (regions == 1) =>
                {
                    return Ok(Built::Estimate(l));
                }
                _ => {}
            }
            let passes = self.build(kind, &coarse, checks)?;
            Ok(Built::Estimate(estimate_length(
                self.surface,
                &passes,
                reach,
            )))
        });
        stop_if_stopped(&done)?;
        Ok(done)
    }

    /// The plans of the `chosen` builds, ranked ([`ranked`]); a build that
    /// failed is a warning, and the first error is returned when none has a
    /// pass.
    fn ranked_plans(
        &self,
        chosen: Vec<(Candidate, Result<Vec<Pass>>)>,
        estimates: &[String],
    ) -> Result<Vec<PlanResult>> {
        let bound = self.bound()?;
        let mut warnings = self.warnings.clone();
        let mut plans: Vec<(Candidate, PlanResult, f64)> = Vec::new();
        let mut first_error = None;
        for (kind, passes) in chosen {
            let passes = match passes {
                Ok(p) if !p.is_empty() => p,
                Ok(_) => continue,
                Err(e) => {
                    warnings.push(format!("candidate {} not built: {e}", kind.label()));
                    first_error.get_or_insert(e);
                    continue;
                }
            };
            let result = self.result(kind, passes, bound);
            let length = result.cl_path_length();
            plans.push((kind, result, length));
        }
        if plans.is_empty() {
            return Err(first_error.unwrap_or_else(|| {
                toolpath_kernel::error::Error::planning(
                    "tensor_regions: no candidate plan has any pass",
                )
            }));
        }
        Ok(ranked(
            plans,
            estimates,
            self.kinds.len(),
            self.partition_note.as_deref(),
            &warnings,
        ))
    }

    fn bound(&self) -> Result<f64> {
        super::lower_bound::job_path_length_lower_bound(
            self.job,
            self.surface,
            &self.settings.cutter,
        )
    }

    /// The regions candidate `kind` covers.
    fn regions_of(&self, kind: Candidate) -> &[Region] {
        match kind {
            Candidate::Partitioned => &self.regions,
            Candidate::PartitionedAsTraced => &self.traced_regions,
            _ => std::slice::from_ref(&self.whole),
        }
    }

    /// The passes of candidate `kind` at `settings` (the job's, or coarser
    /// for an estimate).
    fn build(
        &self,
        kind: Candidate,
        settings: &PassSettings,
        checks: &dyn Progress,
    ) -> Result<Vec<Pass>> {
        let (surface, whole) = (self.surface, &self.whole);
        let step = settings.point_step.min(settings.cutter.radius);
        match kind {
            Candidate::Partitioned | Candidate::PartitionedAsTraced => cover_regions(
                surface,
                settings,
                self.regions_of(kind),
                &self.analysis,
                step,
                checks,
            ),
            Candidate::MeanFeed => match mean_feed_line(surface, settings) {
                Some(line) => cover(surface, settings, whole, &line, checks),
                None => Ok(Vec::new()),
            },
            Candidate::WholeField => cover_regions(
                surface,
                settings,
                std::slice::from_ref(whole),
                &self.analysis,
                step,
                checks,
            ),
            Candidate::EdgeOffset(feed, far) => cover_from_edge(
                surface,
                settings,
                whole,
                &boundary_start(surface, settings, feed, far),
                checks,
            ),
            Candidate::IsoCurves(feed) => plan_passes(surface, settings, feed, checks),
        }
    }

    /// Candidate `kind`'s result: its passes, the lower bound, and the
    /// analysis it shares with the others (see [`candidate_result`]).
    fn result(&self, kind: Candidate, passes: Vec<Pass>, bound: f64) -> PlanResult {
        let used = self.regions_of(kind);
        candidate_result(
            self.job,
            self.surface,
            passes,
            used,
            bound,
            &self.analysis,
            &self.separatrices_uv,
        )
    }
}

/// The regions to plan: the partition at the degenerate points when its
/// regions tile the surface, else the whole surface as one region (with a
/// warning saying why), the separatrices in (u, v) and the graph the regions
/// are the faces of (none where the regions are not its faces).
fn regions_of(
    surface: &NurbsSurface,
    k_b: f64,
    analysis: &degenerate_points::Analysis,
    step: f64,
    whole: &Region,
    warnings: &mut Vec<String>,
) -> (Vec<Region>, Vec<Vec<Vector2<f64>>>, Option<FaceGraph>) {
    if analysis.everywhere {
        warnings.push(
            "the strip-width field is isotropic everywhere (every point is degenerate): one region, feed along u"
                .into(),
        );
        return (vec![whole.clone()], Vec::new(), None);
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
        (vec![whole.clone()], p.separatrices_uv, None)
    } else {
        (p.regions, p.separatrices_uv, Some(p.graph))
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
/// each naming its candidate, the exact lengths and the `estimates` of all
/// `considered` candidates in `plan_choice`.
fn ranked(
    mut plans: Vec<(Candidate, PlanResult, f64)>,
    estimates: &[String],
    considered: usize,
    partition_note: Option<&str>,
    warnings: &[String],
) -> Vec<PlanResult> {
    plans.sort_by(|a, b| a.2.total_cmp(&b.2));
    let summary: Vec<String> = plans
        .iter()
        .map(|(k, _, l)| format!("{} {l:.0} mm", k.label()))
        .collect();
    let n = plans.len();
    let why = format!(
        "{n} built of {considered} candidate plans ({}): the baselines' plans and the {EXACT_BUILDS} shortest of the others by an estimate at {ESTIMATE_COARSENING} x the point step ({})",
        summary.join(", "),
        estimates.join(", ")
    ) + &partition_note.map(|n| format!("; {n}")).unwrap_or_default();
    plans
        .into_iter()
        .enumerate()
        .map(|(rank, (kind, mut result, _))| {
            result.plan_choice = Some(if rank == 0 {
                format!("{}: the shortest of {why}", kind.label())
            } else {
                format!(
                    "{}: candidate {} by length of {why}",
                    kind.label(),
                    rank + 1
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
            let Some(e1) = g.forms.derivs.su.try_normalize(1e-300) else {
                continue;
            };
            let e2 = g.forms.n.cross(&e1);
            let angle = f.feed.dot(&e2).atan2(f.feed.dot(&e1));
            let w = g.forms.derivs.su.cross(&g.forms.derivs.sv).norm() * (f.mu_feed - f.mu_cross);
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
    let e1 = g.forms.derivs.su.try_normalize(1e-300)?;
    let heading = e1 * angle.cos() + g.forms.n.cross(&e1) * angle.sin();
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

/// Share of the widest sampled strip that a seed of the initial field line
/// must reach (see [`initial_pass`]).
const SEED_WIDTH_SHARE: f64 = 0.8;

/// Blocks per domain side among which seeds of the initial field line are
/// spread (the widest sample of each block is a seed).
const SEED_BLOCKS: usize = 6;

/// Field lines traced at most to pick the initial one.
const MAX_SEEDS: usize = 12;

/// A seed of the initial field line: strip width (mm), uv, feed direction.
type Seed = (f64, Vector2<f64>, Vector3<f64>);

/// The feed field line that starts the region's cover, traced both ways to
/// the region boundary: the line through the widest-strip sample, unless it
/// is shorter than a fragment (runs under [`MIN_RUN_SPAN`] radii are not
/// passes); then the line through the next widest seed that is not (the
/// widest sample of each of [`SEED_BLOCKS`]^2 blocks, within
/// [`SEED_WIDTH_SHARE`] of the widest, at most [`MAX_SEEDS`]), else the
/// longest of them. The widest sample often lies at a corner of the region,
/// where its line leaves the region within a few millimetres: a front that
/// short is offset into fragments, and the region was left to gap passes
/// (docs/methods.md, "Candidate plans of tensor_regions"). For an isotropic
/// field the u iso-curve through the widest sample.
fn initial_pass(
    surface: &NurbsSurface,
    s: &PassSettings,
    region: &Region,
    analysis: &Analysis,
    step: f64,
) -> Result<Vec<Vector2<f64>>> {
    let ((u0, u1), (v0, v1)) = surface.domain();
    // The widest sample of each block.
    let mut blocks: Vec<Option<Seed>> = vec![None; SEED_BLOCKS * SEED_BLOCKS];
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
                    let b = &mut blocks[i * SEED_BLOCKS / WIDEST_GRID * SEED_BLOCKS
                        + j * SEED_BLOCKS / WIDEST_GRID];
                    if b.is_none_or(|(bw, _, _)| w > bw) {
                        *b = Some((w, uv, t));
                    }
                }
                Err(WidthError::Gouge { depth }) => {
                    return Err(gouge_error(&s.cutter, uv.into(), g.k_max, depth));
                }
            }
        }
    }
    let mut seeds: Vec<Seed> = blocks.into_iter().flatten().collect();
    // Widest first; equal widths in block order (the sort is stable).
    seeds.sort_by(|a, b| b.0.total_cmp(&a.0));
    let Some(&(widest, start, _)) = seeds.first() else {
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
    // Widest first, the first line that is no fragment; else the longest.
    let fragment = MIN_RUN_SPAN * s.cutter.radius;
    let mut longest: Option<(f64, Vec<Vector2<f64>>)> = None;
    for &(_, start, feed) in seeds
        .iter()
        .take_while(|(w, _, _)| *w >= SEED_WIDTH_SHARE * widest)
        .take(MAX_SEEDS)
    {
        let forward = tracer.trace(start, feed, &outside);
        let backward = tracer.trace(start, -feed, &outside);
        let mut line: Vec<Vector2<f64>> = backward.uv.iter().rev().copied().collect();
        line.extend(forward.uv.iter().skip(1).copied());
        let length = polyline_length(line.iter().map(|p| surface.point(p.x, p.y).coords.into()));
        if length >= fragment {
            return Ok(line);
        }
        if longest.as_ref().is_none_or(|(l, _)| length > *l) {
            longest = Some((length, line));
        }
    }
    Ok(longest.map(|(_, line)| line).unwrap_or_default())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Strategy as _;
    use crate::{test_surfaces, NoProgress};
    use toolpath_formats::Strategy;

    #[test]
    fn plane_is_isotropic_everywhere_and_still_planned() {
        let job = test_surfaces::job(
            test_surfaces::sheared_plane(),
            Strategy::TensorRegions,
            2.5,
            5.0,
            0.05,
        );
        let r = TensorRegions.plan(&job, &NoProgress).unwrap();
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
        let r = TensorRegions.plan(&job, &NoProgress).unwrap();
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

    /// tensor_regions with a flat end R 2.5, lead 5 deg, h 0.05 on the monkey saddle.
    fn monkey_saddle_job() -> Job {
        test_surfaces::job(
            test_surfaces::monkey_saddle([0.0, 0.0], 0.0),
            Strategy::TensorRegions,
            2.5,
            5.0,
            0.05,
        )
    }

    #[test]
    fn monkey_saddle_candidates_are_estimated_and_the_shortest_built() {
        let job = monkey_saddle_job();
        let all = candidates(&job, &NoProgress).unwrap();
        // The two best estimates and the baselines' two plans.
        assert!((EXACT_BUILDS..=EXACT_BUILDS + 2).contains(&all.len()));
        // Shortest first, and plan() returns the first.
        for w in all.windows(2) {
            assert!(w[0].cl_path_length() <= w[1].cl_path_length());
        }
        let best = TensorRegions.plan(&job, &NoProgress).unwrap();
        assert_eq!(best.passes, all[0].passes);
        let choice = all[0].plan_choice.as_deref().unwrap();
        // Its three sectors merge into one (the whole field): a boundary
        // costs more than the sectors' feed directions save.
        assert!(choice.contains("built of 8 candidate plans"), "{choice}");
        assert!(
            choice.contains("partition: 3 regions as traced, 1 after merging"),
            "{choice}"
        );
        // Every candidate has an estimate in the choice.
        for label in [
            "whole_field",
            "mean_feed",
            "edge_offset_u",
            "edge_offset_v",
            "edge_offset_u_far",
            "edge_offset_v_far",
            "iso_curves_u",
            "iso_curves_v",
        ] {
            assert!(choice.contains(&format!("{label} ")), "{label}: {choice}");
        }
        // The kept plan is no longer than the baselines' plans built exactly,
        // whatever the estimates say.
        for label in ["edge_offset_u", "iso_curves_u"] {
            let c = candidate(&job, label, &NoProgress).unwrap().unwrap();
            assert!(
                all[0].cl_path_length() <= c.cl_path_length() * 1.0001,
                "{label}: {} < {}",
                c.cl_path_length(),
                all[0].cl_path_length()
            );
        }
    }

    #[test]
    fn monkey_saddle_partitioned_candidate_carries_the_partition() {
        let job = monkey_saddle_job();
        // Merged into one region, the partition is no candidate; as traced
        // it is built on request.
        assert!(candidate(&job, "partitioned", &NoProgress)
            .unwrap()
            .is_none());
        let r = candidate(&job, "partitioned_as_traced", &NoProgress)
            .unwrap()
            .unwrap();
        assert!(r
            .plan_choice
            .as_deref()
            .unwrap()
            .starts_with("partitioned_as_traced:"));
        assert!(candidate(&job, "no_such_plan", &NoProgress)
            .unwrap()
            .is_none());
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
