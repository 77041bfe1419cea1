//! Strategy `pocket_mat`: multi-tool 2.5-axis pocketing from the medial-axis
//! transform (after Ba & Cao 2013; docs/methods.md, "Medial-axis tool
//! choice", "Tool sequence").
//!
//! 1. Medial axis (x, y, r) of the pocket; Dmax; minimum concave-corner radius.
//! 2. Roughing with Dc in [Dmax/2, Dmax] (rounded to the catalogue): contour
//!    passes at offsets R, R + H, ... (one pass when Dc >= Dmax/2); leftover
//!    islands, which lie on the medial axis, are cleared along it.
//! 3. Corner/neck cleaning, tools in decreasing order: Dmax_i is the largest
//!    medial-axis circle not yet machined (where the axis leaves the machined
//!    region); D_i >= Dmax_i / 2 clears it in one one-way pass along the
//!    boundary offset, only where that offset meets unmachined wall.
//! 4. Root cleaning with D <= 2 x minimum corner radius along the boundary offset,
//!    again only where it removes material.
//!
//! Coverage (which medial points and walls are machined) uses exact distances
//! to the tool-centre paths; the reported uncut area comes from a raster.

use super::coverage::{Raster, SegmentIndex, Swept};
use super::offset_passes::{exact_length, flatten, inward_offset, order_paths, pocket_shape};
use super::tool_selection::{cleaning_diameter, root_diameter, roughing_diameter};
use crate::{NoProgress, Progress};
use cavalier_contours::shape_algorithms::Shape;
use toolpath_formats::result::{polyline_length_2d, MedialBranch, PocketTool};
use toolpath_formats::{Job, PlanResult};
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::medial_axis::{medial_axis, MedialAxis};
use toolpath_kernel::geometry::pocket::{Pocket, Point2};

/// Stepover between roughing contours as a fraction of the diameter. The paper
/// uses the full diameter and clears corner islands along the medial axis; a
/// little overlap keeps straight stretches from leaving zero-width ridges.
pub const STEPOVER_FRACTION: f64 = 0.9;

/// A point counts as machined when within R + this of a tool-centre path, mm.
const COVER_TOL: f64 = 1e-3;

/// Wall material thinner than this is left to the finishing cut: a cleaning
/// tool does not run along a wall just for the micrometre cusps a previous
/// tool leaves at the faint vertices of a polygonised curve, mm.
pub const WALL_TOL: f64 = 0.01;

/// Spacing of the medial-axis samples used for coverage, mm.
const MA_STEP: f64 = 0.1;

/// One tool of the sequence.
#[derive(Clone, Debug, PartialEq)]
pub struct Stage {
    /// "roughing" | "corner" | "root".
    pub stage: &'static str,
    pub diameter: f64,
    /// Tool-centre paths, in machining order.
    pub passes: Vec<Vec<Point2>>,
    /// Cutting path length, mm (arcs exact where the paths are whole offsets).
    pub path_length: f64,
    /// Corner tools: the residual medial-axis circle diameter it was chosen from.
    pub residual_dmax: Option<f64>,
    /// Uncut area after this tool, mm^2 (raster).
    pub uncut_after: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct PocketPlan {
    pub medial_axis: MedialAxis,
    pub stages: Vec<Stage>,
    /// Raster cell size used for the uncut area, mm.
    pub resolution: f64,
    pub warnings: Vec<String>,
}

impl PocketPlan {
    pub fn uncut_area(&self) -> f64 {
        self.stages.last().map_or(0.0, |s| s.uncut_after)
    }
    pub fn path_length(&self) -> f64 {
        self.stages.iter().map(|s| s.path_length).sum()
    }
}

/// Default raster cell: 1/1500 of the pocket's larger extent, within 5 um .. 1 mm.
pub fn default_resolution(pocket: &Pocket) -> f64 {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in &pocket.outer {
        for t in 0..2 {
            lo[t] = lo[t].min(p[t]);
            hi[t] = hi[t].max(p[t]);
        }
    }
    ((hi[0] - lo[0]).max(hi[1] - lo[1]) / 1500.0).clamp(0.005, 1.0)
}

/// Medial-axis samples, at most `MA_STEP` apart, per branch (x, y, r).
fn dense_branches(ma: &MedialAxis) -> Vec<Vec<[f64; 3]>> {
    ma.branches
        .iter()
        .map(|b| {
            let mut out: Vec<[f64; 3]> = Vec::new();
            for w in b.points.windows(2) {
                let (a, c) = (w[0], w[1]);
                let n = ((a[0] - c[0]).hypot(a[1] - c[1]) / MA_STEP).ceil().max(1.0) as usize;
                for k in 0..n {
                    let t = k as f64 / n as f64;
                    out.push([
                        a[0] + t * (c[0] - a[0]),
                        a[1] + t * (c[1] - a[1]),
                        a[2] + t * (c[2] - a[2]),
                    ]);
                }
            }
            if let Some(&last) = b.points.last() {
                out.push(last);
            }
            out
        })
        .collect()
}

fn lerp3(a: [f64; 3], b: [f64; 3], t: f64) -> [f64; 3] {
    [
        a[0] + t * (b[0] - a[0]),
        a[1] + t * (b[1] - a[1]),
        a[2] + t * (b[2] - a[2]),
    ]
}

/// Which medial-axis samples the tools swept so far, kept from one corner
/// tool to the next: tools are only ever added, so a swept sample stays
/// swept and an unswept one need only be tested against the new tools.
#[derive(Default)]
struct SweptFlags {
    flags: Vec<Vec<bool>>,
    /// Tools of the `Swept` already tested against every unswept sample.
    tools_done: usize,
}

impl SweptFlags {
    fn update(&mut self, dense: &[Vec<[f64; 3]>], swept: &Swept) {
        if self.flags.is_empty() {
            self.flags = dense.iter().map(|b| vec![false; b.len()]).collect();
        }
        let new = self.tools_done..swept.len();
        for (b, flags) in dense.iter().zip(&mut self.flags) {
            for (q, f) in b.iter().zip(flags.iter_mut()) {
                if !*f {
                    *f = swept.covers_by(new.clone(), [q[0], q[1]], 1e-9);
                }
            }
        }
        self.tools_done = swept.len();
    }
}

/// Twice the largest radius of the medial-axis points that no tool has swept
/// (the transitions refined by bisection): Dmax_i of the paper. 0 when all
/// swept. `flags` carries the samples' swept flags from the previous call.
fn residual_dmax(dense: &[Vec<[f64; 3]>], swept: &Swept, flags: &mut SweptFlags) -> f64 {
    let covered = |q: [f64; 3]| swept.covers([q[0], q[1]], 1e-9);
    flags.update(dense, swept);
    let mut best: f64 = 0.0;
    for (b, flags) in dense.iter().zip(&flags.flags) {
        for (k, &q) in b.iter().enumerate() {
            if flags[k] {
                continue;
            }
            best = best.max(q[2]);
            for j in [k.wrapping_sub(1), k + 1] {
                if j < b.len() && flags[j] {
                    // Bisect between the swept neighbour and this point.
                    let (mut lo, mut hi) = (0.0, 1.0);
                    for _ in 0..40 {
                        let mid = 0.5 * (lo + hi);
                        if covered(lerp3(b[j], q, mid)) {
                            lo = mid;
                        } else {
                            hi = mid;
                        }
                    }
                    best = best.max(lerp3(b[j], q, hi)[2]);
                }
            }
        }
    }
    2.0 * best
}

/// Roughing (or single-tool) passes: contour offsets R, R + H, ... and medial-axis
/// moves through the islands the contours leave. `progress` is checked once
/// per contour.
fn contour_passes(
    shape: &Shape<f64>,
    dense: &[Vec<[f64; 3]>],
    diameter: f64,
    progress: &dyn Progress,
) -> Result<(Vec<Vec<Point2>>, f64)> {
    let r = 0.5 * diameter;
    let h = STEPOVER_FRACTION * diameter;
    let mut passes = Vec::new();
    let mut length = 0.0;
    let mut d = r;
    for _ in 0..100_000 {
        progress.check()?;
        let loops = inward_offset(shape, d);
        if loops.is_empty() {
            break;
        }
        for l in &loops {
            length += exact_length(l);
            passes.push(flatten(l));
        }
        d += h;
    }
    let mut swept = Swept::default();
    swept.add(&passes, r);
    // Islands between contours lie on the medial axis: follow it where r >= R
    // (tool fits) and its points are not swept yet.
    let margin = 1e-2;
    for b in dense {
        let mut run: Vec<Point2> = Vec::new();
        let flush = |run: &mut Vec<Point2>, passes: &mut Vec<Vec<Point2>>, length: &mut f64| {
            if run.len() >= 2 {
                *length += polyline_length_2d(run);
                passes.push(std::mem::take(run));
            }
            run.clear();
        };
        for (k, q) in b.iter().enumerate() {
            let fits = q[2] >= r + margin;
            let need = fits && !swept.covers([q[0], q[1]], COVER_TOL);
            if need {
                if run.is_empty() && k > 0 && b[k - 1][2] >= r + margin {
                    run.push([b[k - 1][0], b[k - 1][1]]);
                }
                run.push([q[0], q[1]]);
            } else if !run.is_empty() {
                if fits {
                    run.push([q[0], q[1]]);
                }
                flush(&mut run, &mut passes, &mut length);
            }
        }
        flush(&mut run, &mut passes, &mut length);
    }
    Ok((passes, length))
}

/// Points of a closed flattened loop, at most `step` apart (last == first).
fn densify(loop_pts: &[Point2], step: f64) -> Vec<Point2> {
    let mut out = Vec::new();
    for w in loop_pts.windows(2) {
        let n = ((w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]) / step)
            .ceil()
            .max(1.0) as usize;
        for k in 0..n {
            let t = k as f64 / n as f64;
            out.push([
                w[0][0] + t * (w[1][0] - w[0][0]),
                w[0][1] + t * (w[1][1] - w[0][1]),
            ]);
        }
    }
    if let Some(&last) = loop_pts.last() {
        out.push(last);
    }
    out
}

/// One-way cleaning passes of a tool of `diameter`: the stretches of the
/// boundary offset whose wall contact is not machined yet, extended by R at
/// both ends so the tool enters and leaves through machined material.
fn cleaning_passes(
    shape: &Shape<f64>,
    boundary: &SegmentIndex,
    swept: &Swept,
    diameter: f64,
) -> Vec<Vec<Point2>> {
    let r = 0.5 * diameter;
    let step = (0.25 * r).clamp(0.02, 1.0);
    let mut passes = Vec::new();
    for l in inward_offset(shape, r) {
        let pts = densify(&flatten(&l), step);
        // Closed: drop the repeated last point while classifying.
        let n = pts.len().saturating_sub(1);
        if n < 2 {
            continue;
        }
        let useful: Vec<bool> = pts[..n]
            .iter()
            .map(|&c| match boundary.nearest(c, 1.5 * r + 1e-3) {
                Some((_, foot)) => !swept.covers(foot, WALL_TOL),
                None => false,
            })
            .collect();
        if !useful.iter().any(|&u| u) {
            continue;
        }
        // Grow each useful stretch by about R of path on both sides.
        let grow = ((r / step).ceil() as usize).max(1);
        let mut keep = vec![false; n];
        for (i, &u) in useful.iter().enumerate() {
            if u {
                for k in 0..=2 * grow {
                    keep[(i + n + k - grow) % n] = true;
                }
            }
        }
        if keep.iter().all(|&k| k) {
            passes.push(pts);
            continue;
        }
        // Start after a gap so that stretches do not wrap.
        let Some(gap) = keep.iter().position(|&k| !k) else {
            continue;
        };
        let mut run: Vec<Point2> = Vec::new();
        for k in 1..=n {
            let i = (gap + k) % n;
            if keep[i] {
                run.push(pts[i]);
            } else if !run.is_empty() {
                passes.push(std::mem::take(&mut run));
            }
        }
        if !run.is_empty() {
            passes.push(run);
        }
    }
    passes.retain(|p| p.len() >= 2);
    passes
}

fn stage_length(passes: &[Vec<Point2>]) -> f64 {
    passes.iter().map(|p| polyline_length_2d(p)).sum()
}

/// The stages planned so far, with what they have machined: the swept
/// tool-centre paths (exact), the raster of uncut area, and where the tool is.
struct Stages {
    stages: Vec<Stage>,
    swept: Swept,
    raster: Raster,
    at: Point2,
}

impl Stages {
    /// Adds a stage: its passes ordered from where the tool is, swept into
    /// the coverage, with the uncut area after it.
    fn push(
        &mut self,
        stage: &'static str,
        d: f64,
        passes: Vec<Vec<Point2>>,
        length: Option<f64>,
        residual: Option<f64>,
    ) {
        let (passes, end) = order_paths(passes, self.at);
        self.at = end;
        self.swept.add(&passes, 0.5 * d);
        self.raster.sweep(&passes, 0.5 * d);
        let path_length = length.unwrap_or_else(|| stage_length(&passes));
        self.stages.push(Stage {
            stage,
            diameter: d,
            passes,
            path_length,
            residual_dmax: residual,
            uncut_after: self.raster.uncut_area(),
        });
    }
}

/// The multi-tool plan of the paper for `pocket` and a sorted catalogue.
pub fn plan_pocket(
    pocket: &Pocket,
    catalogue: &[f64],
    resolution: Option<f64>,
    progress: &dyn Progress,
) -> Result<PocketPlan> {
    if catalogue.is_empty() {
        return Err(Error::invalid(
            "tool_catalogue",
            "is empty: list at least one tool diameter",
        ));
    }
    let ma = medial_axis(pocket)?;
    progress.set(0.2);
    let d_rough = roughing_diameter(ma.dmax, catalogue)?;
    let d_root = root_diameter(ma.min_corner_radius, catalogue).unwrap_or(d_rough);
    let shape = pocket_shape(pocket);
    let boundary = SegmentIndex::from_pocket(pocket);
    let dense = dense_branches(&ma);
    let h = resolution.unwrap_or_else(|| default_resolution(pocket));
    let mut done = Stages {
        stages: Vec::new(),
        swept: Swept::default(),
        raster: Raster::new(pocket, h),
        at: pocket.outer[0],
    };

    progress.check()?;
    let (passes, length) = contour_passes(&shape, &dense, d_rough, progress)?;
    if passes.is_empty() {
        return Err(Error::planning(format!(
            "no room for the roughing tool of diameter {d_rough} mm"
        )));
    }
    done.push("roughing", d_rough, passes, Some(length), None);
    progress.set(0.5);
    progress.check()?;

    // Corner cleaning: tools in decreasing order while the medial axis still
    // leaves circles unmachined that the root tool would not clear.
    let mut previous = d_rough;
    let mut flags = SweptFlags::default();
    loop {
        progress.check()?;
        let residual = residual_dmax(&dense, &done.swept, &mut flags);
        if residual <= 0.0 {
            break;
        }
        let Some(d) = cleaning_diameter(residual, previous, catalogue) else {
            break;
        };
        if d <= d_root + 1e-9 {
            break;
        }
        previous = d;
        let passes = cleaning_passes(&shape, &boundary, &done.swept, d);
        if !passes.is_empty() {
            done.push("corner", d, passes, None, Some(residual));
        }
    }
    progress.set(0.8);
    progress.check()?;

    if d_root < previous - 1e-9 {
        let passes = cleaning_passes(&shape, &boundary, &done.swept, d_root);
        if !passes.is_empty() {
            done.push("root", d_root, passes, None, None);
        }
    }
    let mut warnings = Vec::new();
    if d_root > 2.0 * ma.min_corner_radius + 1e-9 {
        warnings.push(format!(
            "the smallest concave-corner radius is {:.3} mm: the root tool ({} mm) leaves the sharpest corners uncut",
            ma.min_corner_radius, d_root
        ));
    }
    Ok(PocketPlan {
        medial_axis: ma,
        stages: done.stages,
        resolution: h,
        warnings,
    })
}

/// The same pocket machined by one tool alone: contour-parallel passes at the
/// same stepover plus the medial-axis moves (the paper's baseline).
pub fn plan_single_tool(
    pocket: &Pocket,
    diameter: f64,
    resolution: Option<f64>,
) -> Result<PocketPlan> {
    let ma = medial_axis(pocket)?;
    if diameter > ma.dmax + 1e-9 {
        return Err(Error::invalid(
            "tool_catalogue",
            format!(
                "the tool of diameter {diameter} mm does not fit: Dmax = {:.3} mm",
                ma.dmax
            ),
        ));
    }
    let shape = pocket_shape(pocket);
    let dense = dense_branches(&ma);
    let (passes, length) = contour_passes(&shape, &dense, diameter, &NoProgress)?;
    let (passes, _) = order_paths(passes, pocket.outer[0]);
    let h = resolution.unwrap_or_else(|| default_resolution(pocket));
    let mut raster = Raster::new(pocket, h);
    raster.sweep(&passes, 0.5 * diameter);
    let uncut_after = raster.uncut_area();
    Ok(PocketPlan {
        medial_axis: ma,
        stages: vec![Stage {
            stage: "single",
            diameter,
            passes,
            path_length: length,
            residual_dmax: None,
            uncut_after,
        }],
        resolution: h,
        warnings: Vec::new(),
    })
}

/// The strategy `pocket_mat`.
pub struct PocketMat;

impl crate::Strategy for PocketMat {
    fn id(&self) -> toolpath_formats::Strategy {
        toolpath_formats::Strategy::PocketMat
    }
    fn plan(&self, job: &Job, progress: &dyn Progress) -> Result<PlanResult> {
        let pocket = job.pocket()?;
        let plan = plan_pocket(
            pocket,
            &job.tool_catalogue,
            job.simulation_resolution,
            progress,
        )?;
        let mut result = PlanResult::new(&job.job_id, job.strategy.name());
        result.medial_axis = Some(
            plan.medial_axis
                .branches
                .iter()
                .map(|b| MedialBranch {
                    points: b.points.clone(),
                })
                .collect(),
        );
        result.dmax = Some(plan.medial_axis.dmax);
        result.min_corner_radius = Some(plan.medial_axis.min_corner_radius);
        result.stats.uncut_area_mm2 = Some(plan.uncut_area());
        result.stats.path_length_per_tool_mm =
            Some(plan.stages.iter().map(|s| s.path_length).collect());
        for (i, s) in plan.stages.iter().enumerate() {
            result
                .stats
                .extra
                .insert(format!("tools[{i}].uncut_area_after_mm2"), s.uncut_after);
            if let Some(r) = s.residual_dmax {
                result
                    .stats
                    .extra
                    .insert(format!("tools[{i}].residual_dmax"), r);
            }
        }
        result
            .stats
            .extra
            .insert("coverage_resolution_mm".into(), plan.resolution);
        result.tools = Some(
            plan.stages
                .into_iter()
                .map(|s| PocketTool {
                    stage: s.stage.to_string(),
                    diameter: s.diameter,
                    passes: s.passes,
                    path_length_mm: Some(s.path_length),
                })
                .collect(),
        );
        result.warnings = plan.warnings;
        progress.set(1.0);
        Ok(result)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn residual_with_carried_flags_matches_exact_answers() {
        // One branch from (0, 0) with r = 5 to (20, 0) with r = 1, samples
        // 0.1 mm apart: r = 5 - x / 5. Tools are discs (one-point paths),
        // each sweeping an interval of the branch, added one at a time; the
        // residual is twice r at the unswept end nearest x = 0.
        let dense = vec![(0..=200)
            .map(|i| {
                let x = i as f64 * 0.1;
                [x, 0.0, 5.0 - x / 5.0]
            })
            .collect::<Vec<[f64; 3]>>()];
        let mut swept = Swept::default();
        let mut flags = SweptFlags::default();
        // Sweeps x <= 3: residual 2 (5 - 3/5) = 8.8.
        swept.add(&[vec![[-3.0, 0.0]]], 6.0);
        // Sweeps 8 <= x <= 16: the residual stays 8.8.
        let tools = [([12.0, 0.0], 4.0, 8.8), ([5.5, 0.0], 3.5, 3.6)];
        let got = residual_dmax(&dense, &swept, &mut flags);
        assert!((got - 8.8).abs() < 1e-8, "{got}");
        for (centre, r, want) in tools {
            swept.add(&[vec![centre]], r);
            let got = residual_dmax(&dense, &swept, &mut flags);
            // The same with flags worked out afresh.
            let fresh = residual_dmax(&dense, &swept, &mut SweptFlags::default());
            assert_eq!(got.to_bits(), fresh.to_bits());
            assert!((got - want).abs() < 1e-8, "{got} want {want}");
        }
        // Sweeps the rest: nothing left.
        swept.add(&[vec![[18.0, 0.0]]], 2.5);
        assert_eq!(residual_dmax(&dense, &swept, &mut flags), 0.0);
    }
}
