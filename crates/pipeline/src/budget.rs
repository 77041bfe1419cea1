//! Budgets decided before the work: a cheap estimate of the passes, points
//! and memory a job will need, from the path-length lower bound (or the
//! pocket's area and the belt's width), checked against configurable limits
//! before any planning starts. A job over a limit is refused with what it
//! would need and which parameter to change (docs/limits.md).
//!
//! The estimate is meant as an honest upper-ish bound: on the built-in
//! samples and random surfaces it is above the planned counts (see the
//! tests), by a factor of a few, so the limits refuse only jobs far beyond
//! what the machine can hold, never a normal one.

use serde::{Deserialize, Serialize};
use toolpath_formats::Job;
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::{LocalGeometry, NurbsSurface};

/// The limits a job's estimate is checked against.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Budget {
    /// Most passes (over all tools of a pocket).
    pub max_passes: f64,
    /// Most toolpath points.
    pub max_points: f64,
    /// Most memory one job may need, MB.
    pub max_memory_mb: f64,
}

impl Budget {
    /// Defaults for a 2-core, 24 GB machine with one worker per core: two
    /// jobs at their limit take 2 x 6 GB, leaving half the memory to the
    /// node and the system. 20 000 passes and 20 million points are 10 to
    /// 100 times what the samples need.
    pub const DEFAULT: Budget = Budget {
        max_passes: 20_000.0,
        max_points: 20_000_000.0,
        max_memory_mb: 6_144.0,
    };

    /// Checks the limits themselves: `field` is the config section, or `--`
    /// for the command line's flags.
    pub fn validate(&self, field: &str) -> Result<()> {
        for (name, v) in [
            ("max_passes", self.max_passes),
            ("max_points", self.max_points),
            ("max_memory_mb", self.max_memory_mb),
        ] {
            if !v.is_finite() || v < 1.0 {
                // `--` names the command line's flags, else a config section.
                let named = match field {
                    "--" => format!("--{}", name.replace('_', "-")),
                    _ => format!("{field}.{name}"),
                };
                return Err(Error::invalid(
                    named,
                    format!("{v} is not a limit: give a finite number >= 1"),
                ));
            }
        }
        Ok(())
    }

    /// Refuses `job` when its [`estimate`] exceeds a limit.
    pub fn check(&self, job: &Job) -> Result<Estimate> {
        let e = estimate(job)?;
        let mut over = Vec::new();
        if e.passes > self.max_passes {
            over.push(format!(
                "about {:.3e} passes (limit {})",
                e.passes, self.max_passes
            ));
        }
        if e.points > self.max_points {
            over.push(format!(
                "about {:.3e} toolpath points (limit {})",
                e.points, self.max_points
            ));
        }
        if e.memory_mb > self.max_memory_mb {
            over.push(format!(
                "about {:.0} MB of memory (limit {} MB)",
                e.memory_mb, self.max_memory_mb
            ));
        }
        if over.is_empty() {
            return Ok(e);
        }
        Err(Error::planning(format!(
            "refused before planning: the job would need {} ({}); {}",
            over.join(", "),
            e.basis,
            e.remedy
        )))
    }
}

impl Default for Budget {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// What a job is estimated to need.
#[derive(Clone, Debug, PartialEq)]
pub struct Estimate {
    pub passes: f64,
    pub points: f64,
    pub memory_mb: f64,
    /// The figures the estimate comes from, in words.
    pub basis: String,
    /// Which parameters make the job lighter.
    pub remedy: String,
}

/// Memory per toolpath point while planning, bytes: the point itself (cc,
/// cl, axis, normal: 12 f64), the contact it came from, the offset front
/// and the simulator's segment and index entries, rounded up.
const BYTES_PER_POINT: f64 = 600.0;
/// Memory per simulator grid sample, bytes: (u, v), the point, the frame
/// and the residual.
const BYTES_PER_SAMPLE: f64 = 160.0;
/// Planned length over the path-length lower bound, at most, on the samples
/// and random surfaces (iso-parametric's constant step is the longest).
const LENGTH_OVER_BOUND: f64 = 3.0;
/// Points a pass carries beyond its length over the point step: run-in,
/// run-out and the pivots at its ends.
const POINTS_PER_PASS: f64 = 40.0;
/// Cross-feed distance between belt paths, at least, over the belt width.
const BELT_STEP_SHARE: f64 = 0.25;

/// The estimate for `job`; errors are the ones planning would give (a tool
/// that gouges, a missing scallop), found before the work.
pub fn estimate(job: &Job) -> Result<Estimate> {
    crate::verification(job.strategy.family()).estimate(job)
}

/// Surface area by 3 x 3 Gauss points on 16 x 16 cells, mm^2.
fn area(surface: &NurbsSurface) -> f64 {
    const CELLS: usize = 16;
    const GAUSS3: [(f64, f64); 3] = [
        (0.112_701_665_379_258_3, 5.0 / 18.0),
        (0.5, 8.0 / 18.0),
        (0.887_298_334_620_741_7, 5.0 / 18.0),
    ];
    let ((u0, u1), (v0, v1)) = surface.domain();
    let (du, dv) = ((u1 - u0) / CELLS as f64, (v1 - v0) / CELLS as f64);
    let mut total = 0.0;
    for i in 0..CELLS {
        for j in 0..CELLS {
            for &(a, wa) in &GAUSS3 {
                for &(b, wb) in &GAUSS3 {
                    let (u, v) = (u0 + (i as f64 + a) * du, v0 + (j as f64 + b) * dv);
                    if let Some(g) = LocalGeometry::at(surface, u, v) {
                        total += wa * wb * du * dv * g.area_element();
                    }
                }
            }
        }
    }
    total
}

/// Memory of the scallop simulator's grid for a cutter of radius `r`, MB.
fn simulator_mb(job: &Job, area_mm2: f64, r: f64) -> f64 {
    use toolpath_simulation::scallop::{AUTO_MAX_SAMPLES, MAX_SAMPLES};
    let samples = match job.simulation_resolution {
        Some(res) => (area_mm2 / (res * res)).min(MAX_SAMPLES as f64),
        None => (area_mm2 / (r / 8.0).powi(2)).min(AUTO_MAX_SAMPLES as f64),
    };
    samples * BYTES_PER_SAMPLE / 1e6
}

pub(crate) fn strip_width(job: &Job) -> Result<Estimate> {
    use toolpath_planners::strip_width::{lower_bound, passes::PassSettings};
    let surface = job.surface()?;
    let settings = PassSettings::from_job(job)?;
    let bound = lower_bound::job_path_length_lower_bound(job, surface, &settings.cutter)?;
    let shortest_iso = surface
        .longest_iso_curve_length(true)
        .min(surface.longest_iso_curve_length(false))
        .max(1e-9);
    let length = LENGTH_OVER_BOUND * bound;
    let passes = length / shortest_iso;
    let points = length / settings.point_step + POINTS_PER_PASS * passes;
    // tensor_regions holds every candidate plan until it has chosen one.
    let plans = toolpath_planners::strategy(job.strategy).plans_held() as f64;
    let a = area(surface);
    let memory_mb =
        plans * points * BYTES_PER_POINT / 1e6 + simulator_mb(job, a, settings.cutter.radius);
    Ok(Estimate {
        passes,
        points,
        memory_mb,
        basis: format!(
            "path length at least {bound:.0} mm for scallop {} mm with a tool of radius {} mm on {a:.0} mm^2, points every {:.3} mm",
            job.scallop()?,
            settings.cutter.radius,
            settings.point_step
        ),
        remedy: "raise scallop, use a larger tool radius, or split the surface".into(),
    })
}

/// MPEC: strips at least as wide as a ball of the torus's corner radius
/// cuts at the tolerance band (the torus is flatter than that ball
/// everywhere), so the passes are at most the cross extent over that width.
pub(crate) fn mpec(job: &Job) -> Result<Estimate> {
    let surface = job.surface()?;
    let tool = job.tool()?;
    let r = match *tool {
        toolpath_kernel::tools::Tool::Torus { corner_radius, .. } => corner_radius,
        _ => tool.radius(),
    };
    let h = job.scallop.or(job.tolerance).unwrap_or(0.01).max(1e-12);
    let width = (8.0 * r * h).sqrt().max(1e-12);
    let (lu, lv) = (
        surface.longest_iso_curve_length(true),
        surface.longest_iso_curve_length(false),
    );
    let passes = lu.max(lv) / width;
    let step = (8.0 * 0.05 * h
        / toolpath_planners::strip_width::passes::max_curvature(surface).max(1e-9))
    .sqrt()
    .clamp(0.05, (2.0 * tool.radius()).max(1.0));
    let points = passes * (lu.max(lv) / step + POINTS_PER_PASS);
    let a = area(surface);
    Ok(Estimate {
        passes,
        points,
        memory_mb: points * BYTES_PER_POINT / 1e6 + simulator_mb(job, a, tool.radius()),
        basis: format!(
            "strips about {width:.4} mm wide across {:.0} mm, points every {step:.3} mm",
            lu.max(lv)
        ),
        remedy: "raise tolerance, use a larger corner radius, or split the surface".into(),
    })
}

pub(crate) fn belt(job: &Job) -> Result<Estimate> {
    use toolpath_planners::belt::contact::{point_spacing, BeltSpec};
    let surface = job.surface()?;
    let spec = BeltSpec::from_job(job)?;
    let (lu, lv) = (
        surface.longest_iso_curve_length(true),
        surface.longest_iso_curve_length(false),
    );
    // Section planes may run in any direction (iso-planar), so the extent
    // across them is at most the control net's diagonal (the surface lies
    // in its box), and so is the chord of one pass; a wavy pass is longer
    // than its chord by at most LENGTH_OVER_BOUND.
    let (lo, hi) = surface.bounding_box();
    let across = (hi - lo).norm().max(lu.max(lv));
    let passes = across / (BELT_STEP_SHARE * spec.width);
    let spacing = point_spacing(&spec);
    let points = passes * (LENGTH_OVER_BOUND * across / spacing + POINTS_PER_PASS);
    let a = area(surface);
    let removal_nodes = match job.simulation_resolution {
        Some(res) => (lu / res + 1.0) * (lv / res + 1.0),
        None => {
            let res = toolpath_simulation::removal::default_resolution(spec.width);
            (lu / res + 1.0) * (lv / res + 1.0)
        }
    };
    Ok(Estimate {
        passes,
        points,
        memory_mb: points * BYTES_PER_POINT / 1e6 + removal_nodes * 40.0 / 1e6,
        basis: format!(
            "a belt {} mm wide across {across:.0} mm of a {a:.0} mm^2 surface, points every {spacing:.3} mm",
            spec.width
        ),
        remedy: "use a wider belt or split the surface".into(),
    })
}

pub(crate) fn pocket(job: &Job) -> Result<Estimate> {
    use toolpath_planners::pocket::pocket_mat::{default_resolution, STEPOVER_FRACTION};
    let pocket = job.pocket()?;
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    let mut perimeter = 0.0;
    for l in std::iter::once(&pocket.outer).chain(pocket.holes.iter()) {
        for (k, p) in l.iter().enumerate() {
            for t in 0..2 {
                lo[t] = lo[t].min(p[t]);
                hi[t] = hi[t].max(p[t]);
            }
            let q = l[(k + 1) % l.len()];
            perimeter += (q[0] - p[0]).hypot(q[1] - p[1]);
        }
    }
    let (w, hgt) = (hi[0] - lo[0], hi[1] - lo[1]);
    let h = job
        .simulation_resolution
        .unwrap_or_else(|| default_resolution(pocket));
    let cells = (w / h).ceil().max(1.0) * (hgt / h).ceil().max(1.0);
    // The roughing tool: the largest catalogue tool no wider than the pocket.
    let narrow = w.min(hgt);
    let catalogue = &job.tool_catalogue;
    let d = catalogue
        .iter()
        .copied()
        .filter(|d| *d <= narrow)
        .fold(f64::NAN, f64::max);
    let d = if d.is_nan() {
        catalogue.iter().copied().fold(f64::INFINITY, f64::min)
    } else {
        d
    };
    let d_min = catalogue.iter().copied().fold(f64::INFINITY, f64::min);
    let contours = (0.5 * narrow / (STEPOVER_FRACTION * d)).ceil() + 1.0;
    // Each contour at most the outer perimeter long; corner and root tools
    // add at most one boundary offset each.
    let length = contours * perimeter + catalogue.len() as f64 * perimeter;
    // Flattened arcs and densified cleaning passes: a point every quarter
    // of the smallest tool radius (0.02 .. 1 mm).
    let spacing = (0.125 * d_min).clamp(0.02, 1.0);
    let points = length / spacing;
    // Medial-axis samples every 0.1 mm along about the perimeter.
    let axis_samples = perimeter / 0.1;
    // Contours split where the pocket narrows, and each smaller tool cleans
    // a few stretches of the medial axis the larger ones left: twice the
    // contours and four passes a tool cover the samples (the leaf's two
    // necks and tip need the most).
    let passes = 2.0 * contours * (1 + pocket.holes.len()) as f64 + 4.0 * catalogue.len() as f64;
    let memory_mb = cells * 2.0 / 1e6 + points * 16.0 * 4.0 / 1e6 + axis_samples * 48.0 / 1e6;
    Ok(Estimate {
        passes,
        points,
        memory_mb,
        basis: format!(
            "a {w:.0} x {hgt:.0} mm pocket, {perimeter:.0} mm of boundary, roughing tool {d} mm, coverage raster of {cells:.3e} cells at {h} mm"
        ),
        remedy: "use larger catalogue tools, a coarser simulation_resolution, or split the pocket".into(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{run, RunOptions};
    use toolpath_planners::NoProgress;

    /// The planned passes and points of `job` against its estimate: the
    /// estimate must not be below them (it decides refusals).
    fn planned_within_estimate(job: &Job) -> (f64, f64) {
        let e = estimate(job).unwrap();
        let r = run(job, &NoProgress, RunOptions::PLAN_ONLY).unwrap();
        let (passes, points) = (r.stats.passes as f64, r.stats.points.unwrap() as f64);
        eprintln!(
            "{} {}: passes {passes} / est {:.0} = {:.2}, points {points} / est {:.0} = {:.2}, mem est {:.1} MB",
            job.job_id,
            job.strategy.name(),
            e.passes,
            passes / e.passes,
            e.points,
            points / e.points,
            e.memory_mb
        );
        (passes / e.passes, points / e.points)
    }

    #[test]
    fn estimates_are_above_the_planned_counts_of_the_samples() {
        for s in toolpath_samples::list() {
            let job = toolpath_samples::job(s.name).unwrap();
            let (p, q) = planned_within_estimate(&job);
            assert!(p <= 1.0 && q <= 1.0, "{}: {p} {q}", s.name);
        }
    }
}
