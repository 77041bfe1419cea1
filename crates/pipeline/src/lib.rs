//! The application layer: plan a job, verify it with the simulator, fill the
//! common statistics. The CLI and the ROS node both call this.

use std::time::Instant;
use toolpath_formats::result::polyline_length;
use toolpath_formats::{Job, PlanResult, Strategy};
use toolpath_kernel::error::{Error, Result};
use toolpath_planners::{self as planners, Progress};
use toolpath_simulation::scallop::{self, ScallopReport, ScallopSettings};

pub mod budget;
pub mod limits;

pub use budget::{Budget, Estimate};
pub use limits::{Limited, TimeLimit};
pub use toolpath_formats::result::check_belongs;

/// Options that do not change the toolpath.
#[derive(Clone, Copy, Debug, Default)]
pub struct RunOptions {
    /// Skip the simulator (max_scallop_mm stays `None`).
    pub skip_verify: bool,
    /// Report compute_ms as 0 so that repeated runs give identical bytes.
    pub no_timing: bool,
    /// Stop the job once it has run this long (besides the job's own
    /// `time_limit_s`: the shorter one stops it).
    pub time_limit: Option<TimeLimit>,
    /// Refuse a job whose estimate exceeds these before planning.
    pub budget: Budget,
}

impl RunOptions {
    /// Plan only: no simulator, compute_ms 0 (benches, tests, edges that verify elsewhere).
    pub const PLAN_ONLY: RunOptions = RunOptions {
        skip_verify: true,
        no_timing: true,
        time_limit: None,
        budget: Budget::DEFAULT,
    };
}

/// Plans the jobs of several faces ([`toolpath_formats::read_jobs`]) one after
/// another, each within its own face's trim, into one result: the passes
/// grouped by face in the order given (`pass_faces` gives each pass's
/// face), the statistics summed (lengths, passes, points, times, lower
/// bounds, areas in `extra`) or the worst taken (scallop, gouge), the
/// shape fingerprint left out (no single shape verifies it). Passes are not
/// stitched across faces (docs/formats.md, "Several faces").
pub fn run_faces(jobs: &[Job], progress: &dyn Progress, options: RunOptions) -> Result<PlanResult> {
    let [first, ..] = jobs else {
        return Err(toolpath_kernel::error::Error::invalid(
            "surface.faces",
            "is empty",
        ));
    };
    if jobs.len() == 1 {
        return run(first, progress, options);
    }
    let mut out = PlanResult::new(&first.job_id, first.strategy.name());
    let mut faces = Vec::new();
    let mut within = Some(true);
    let add = |x: Option<f64>, y: Option<f64>| match (x, y) {
        (Some(x), Some(y)) => Some(x + y),
        (x, y) => x.or(y),
    };
    let max = |x: Option<f64>, y: Option<f64>| match (x, y) {
        (Some(x), Some(y)) => Some(x.max(y)),
        (x, y) => x.or(y),
    };
    for (k, job) in jobs.iter().enumerate() {
        let r = run(job, progress, options)?;
        faces.extend(std::iter::repeat_n(k, r.passes.len()));
        out.machine = r.machine.clone();
        let (a, b) = (&mut out.stats, &r.stats);
        a.path_length_mm += b.path_length_mm;
        a.passes += b.passes;
        a.compute_ms += b.compute_ms;
        a.max_scallop_mm = max(a.max_scallop_mm, b.max_scallop_mm);
        a.max_gouge_mm = max(a.max_gouge_mm, b.max_gouge_mm);
        a.path_length_lower_bound_mm =
            add(a.path_length_lower_bound_mm, b.path_length_lower_bound_mm);
        a.machining_time_min = add(a.machining_time_min, b.machining_time_min);
        a.uncut_area_mm2 = add(a.uncut_area_mm2, b.uncut_area_mm2);
        a.points = Some(a.points.unwrap_or(0) + b.points.unwrap_or(0));
        for (key, v) in &b.extra {
            if key.ends_with("_mm2") || key.ends_with("_mm") || key.ends_with("_s") {
                *a.extra.entry(key.clone()).or_insert(0.0) += v;
            } else {
                a.extra.insert(format!("face{k}_{key}"), *v);
            }
        }
        within = match (within, r.within_scallop) {
            (Some(x), Some(y)) => Some(x && y),
            _ => None,
        };
        out.warnings
            .extend(r.warnings.iter().map(|w| format!("face {k}: {w}")));
        out.passes.extend(r.passes);
    }
    out.within_scallop = within;
    out.pass_faces = Some(faces);
    Ok(out)
}

/// Plans `job` and fills the statistics every result carries. Flat-end
/// milling plans are verified by the simulator and repaired (see
/// [`verify_and_repair`]); of several candidate plans (tensor_regions) the
/// shortest after repair is kept, preferring one within the scallop height.
///
/// Before any of that the job's estimate is checked against
/// `options.budget`; the job's `time_limit_s` and `options.time_limit` stop
/// it through `progress` checks (`Error::Stopped`), as a cancel does.
pub fn run(job: &Job, progress: &dyn Progress, options: RunOptions) -> Result<PlanResult> {
    let own = job.time_limit_s.map(|seconds| TimeLimit {
        seconds,
        parameter: "the job's time_limit_s",
    });
    let own = Limited::new(progress, own);
    let limited = Limited::new(&own, options.time_limit);
    let progress: &dyn Progress = &limited;
    progress.check()?;
    options.budget.check(job)?;
    let verify = !options.skip_verify && is_milling(job.strategy);
    if verify {
        // A grid the simulator would refuse is refused before planning.
        scallop::check_resolution(job.surface()?, job.simulation_resolution)?;
    }
    let start = Instant::now();
    let candidates = planners::plan_candidates(job, progress)?;
    progress.check()?;
    let mut planning_s = start.elapsed().as_secs_f64();
    let verify_belt = !options.skip_verify && is_belt(job.strategy);
    let mut result = if verify {
        let (result, repair_s) = verify_candidates(job, candidates, progress)?;
        planning_s += repair_s;
        result
    } else if verify_belt {
        let first = candidates.into_iter().next().ok_or_else(|| {
            toolpath_kernel::error::Error::planning("the planner returned no plan")
        })?;
        let (result, refine_s) = verify_and_refine_belt(job, first, progress)?;
        planning_s += refine_s;
        result
    } else {
        candidates.into_iter().next().ok_or_else(|| {
            toolpath_kernel::error::Error::planning("the planner returned no plan")
        })?
    };
    result.job_id = job.job_id.clone();
    result.shape_fingerprint = Some(job.shape.fingerprint());
    result.strategy = job.strategy.name().to_string();
    result.machine = Some(job.machine.name().to_string());
    fill_path_stats(&mut result, job.feed_rate);
    result.stats.compute_ms = if options.no_timing {
        0.0
    } else {
        (planning_s * 1e6).round() / 1000.0
    };
    progress.set(1.0);
    Ok(result)
}

/// At most this many candidate plans are verified (shortest first).
pub const MAX_VERIFIED_CANDIDATES: usize = 3;

/// Verifies (and, for flat ends, repairs) the candidates shortest first and
/// keeps the best: within the scallop height before not, then shorter. A
/// candidate already longer before repair than the best after repair is not
/// verified (repair only adds passes). Returns the kept result with its
/// simulator figures and the seconds spent making repair passes.
fn verify_candidates(
    job: &Job,
    candidates: Vec<PlanResult>,
    progress: &dyn Progress,
) -> Result<(PlanResult, f64)> {
    let total = candidates.len();
    let mut best: Option<(PlanResult, ScallopReport)> = None;
    let mut repair_s = 0.0;
    let mut verified = 0;
    for (rank, candidate) in candidates.into_iter().enumerate() {
        let raw = candidate.cl_path_length();
        if let Some((b, rb)) = &best {
            let within = b.within_scallop != Some(false) && rb.uncovered_area_mm2 <= 0.0;
            if (within && raw >= b.cl_path_length()) || verified >= MAX_VERIFIED_CANDIDATES {
                break;
            }
        }
        verified += 1;
        progress.check()?;
        let started = Instant::now();
        let (mut result, report, sim_s) = verify_and_repair_checked(job, candidate, progress)?;
        repair_s += (started.elapsed().as_secs_f64() - sim_s).max(0.0);
        if rank > 0 {
            if let Some(choice) = &mut result.plan_choice {
                *choice = format!(
                    "{choice}; kept after verification and repair (shorter, or within h where the shorter ones are not)"
                );
            }
        }
        let better = match &best {
            None => true,
            Some((b, _)) => {
                let (wa, wb) = (
                    result.within_scallop != Some(false),
                    b.within_scallop != Some(false),
                );
                (wa && !wb) || (wa == wb && result.cl_path_length() < b.cl_path_length())
            }
        };
        if better {
            best = Some((result, report));
        }
    }
    let (mut result, report) = best
        .ok_or_else(|| toolpath_kernel::error::Error::planning("the planner returned no plan"))?;
    if total > 1 {
        result
            .stats
            .extra
            .insert("candidates_verified".into(), verified as f64);
    }
    fill_scallop_stats(&mut result, &report);
    Ok((result, repair_s))
}

/// Rounds of repair passes after the first verification.
pub const REPAIR_ROUNDS: usize = 3;

/// Flat-end strategies: the plans the repair passes apply to.
pub fn is_flat_end(strategy: Strategy) -> bool {
    matches!(
        strategy,
        Strategy::TensorRegions | Strategy::IsoScallop | Strategy::IsoParametric
    )
}

/// Simulates `result`; for a flat-end plan, turns the islands above the
/// job's scallop height h (and the samples the tool never reached) into
/// repair passes (`planners::strip_width::repair`) and simulates again, at
/// most [`REPAIR_ROUNDS`] times (MPEC: passes added, `planners::refine`).
/// Sets `within_scallop` (h, or both sides of the MPEC tolerance band) and,
/// where the limit is not held, a warning naming the area and where it is. Returns the final report and the seconds the
/// simulations took.
pub fn verify_and_repair(
    job: &Job,
    result: PlanResult,
) -> Result<(PlanResult, ScallopReport, f64)> {
    verify_and_repair_checked(job, result, &planners::NoProgress)
}

/// [`verify_and_repair`], checking `progress` for a stop in the simulator
/// and between repair rounds.
pub fn verify_and_repair_checked(
    job: &Job,
    mut result: PlanResult,
    progress: &dyn Progress,
) -> Result<(PlanResult, ScallopReport, f64)> {
    let mut sim_s = 0.0;
    let mut simulate = |r: &PlanResult, peak_starts: usize| -> Result<ScallopReport> {
        let t = Instant::now();
        let report = verify_milling_with(job, r, progress, peak_starts)?;
        sim_s += t.elapsed().as_secs_f64();
        Ok(report)
    };
    let mut report = simulate(&result, scallop::PEAK_STARTS)?;
    let limit = job.scallop.or(job.tolerance);
    let raw_length = result.cl_path_length();
    let raw_passes = result.passes.len();
    if let (Some(h), true) = (job.scallop, is_flat_end(job.strategy)) {
        let region = result
            .passes
            .iter()
            .map(|p| p.region + 1)
            .max()
            .unwrap_or(0);
        for _ in 0..REPAIR_ROUNDS {
            progress.check()?;
            let islands = islands(&report, h, job.tool()?.radius());
            if islands.is_empty() {
                break;
            }
            let passes = planners::strip_width::repair::repair_passes(job, &islands, region)?;
            if passes.is_empty() {
                break;
            }
            result.passes.extend(passes);
            // A plan with peaks above h may hide more among the ridges just
            // below it: the repaired plan's check climbs from more of them.
            report = simulate(&result, scallop::DEEP_PEAK_STARTS)?;
        }
    }
    if let (Some(delta), Strategy::Mpec) = (job.tolerance, job.strategy) {
        // Passes added at the middle of the gaps left above the band
        // (`planners::refine`; MPEC has no scallop to aim its steps at).
        let mut refinement = planners::refine::Refinement::default();
        for _ in 0..REPAIR_ROUNDS {
            if report.max_scallop_mm <= delta {
                break;
            }
            let map = &report.map;
            // The grid peak may sit well below a refined maximum between
            // samples (a part edge): the band below the grid maximum as wide
            // as the refinement's gain counts, down to delta / 2.
            let threshold = residual_threshold(&report, delta, 0.5);
            // Where the tool is lifted (no lead holds the band) more passes
            // do not help: those places are reported, not refined.
            let reach = job.tool()?.radius();
            let lifted: Vec<nalgebra::Point3<f64>> = result
                .passes
                .iter()
                .flat_map(|p| &p.points)
                .filter(|q| q.mpec.as_deref() == Some("lifted"))
                .map(|q| nalgebra::Point3::from(q.cc))
                .collect();
            let by_lifted = |xyz: [f64; 3]| {
                let p = nalgebra::Point3::from(xyz);
                lifted.iter().any(|q| (p - q).norm() <= reach)
            };
            let residuals: Vec<planners::refine::Residual> = (0..map.uv.len())
                .filter(|&k| map.on_face(k))
                .filter_map(|k| {
                    map.residual[k]
                        .filter(|r| *r > threshold && !by_lifted(map.xyz[k]))
                        .map(|height| planners::refine::Residual {
                            uv: map.uv[k],
                            point: map.xyz[k],
                            height,
                        })
                })
                .collect();
            let mode = planners::refine::Mode::Split;
            let changed = planners::refine::refine(
                job,
                &result,
                &residuals,
                threshold,
                mode,
                &mut refinement,
            )?;
            if !changed {
                break;
            }
            progress.check()?;
            result = planners::mpec::positioning::plan_refined(job, progress, &refinement.added)?;
            report = simulate(&result, scallop::PEAK_STARTS)?;
        }
    }
    record_repair(&mut result, raw_passes, raw_length);
    if let Some(h) = limit {
        let above = report.max_scallop_mm > h || report.uncovered_area_mm2 > 0.0;
        // MPEC's band has a gouge side too: -delta.
        let below =
            job.strategy == Strategy::Mpec && report.max_gouge_mm > h + CONFORMANCE_SLACK_MM;
        result.within_scallop = Some(!above && !below);
        if above {
            result
                .warnings
                .push(above_limit_warning(&report, h, job.tool()?.radius()));
        }
        if below {
            result.warnings.push(format!(
                "{BELOW_BAND} -{h} mm: the simulator finds a gouge of {:.4} mm",
                report.max_gouge_mm
            ));
        }
    }
    Ok((result, report, sim_s))
}

/// Puts into `extra` what repair passes (or refinement paths) added to a
/// plan that had `raw_passes` passes of `raw_length` mm: `repair_passes`
/// and `repair_length_mm`, nothing when none were added.
fn record_repair(result: &mut PlanResult, raw_passes: usize, raw_length: f64) {
    if result.passes.len() > raw_passes {
        result.stats.extra.insert(
            "repair_passes".into(),
            (result.passes.len() - raw_passes) as f64,
        );
        result.stats.extra.insert(
            "repair_length_mm".into(),
            result.cl_path_length() - raw_length,
        );
    }
}

/// How the warning of a plan above its scallop height (or tolerance) begins.
pub const ABOVE_LIMIT: &str = "not within the scallop height";
/// How the warning of an MPEC plan that cuts below its band begins.
pub const BELOW_BAND: &str = "not within the tolerance band: it cuts below";

/// The warning for a plan the simulator finds above `h` (or not reaching
/// part of the surface): the largest islands, their area and where they are.
fn above_limit_warning(report: &ScallopReport, h: f64, radius: f64) -> String {
    const LISTED: usize = 5;
    let mut found = map_islands(report, h, radius);
    let cell = report.resolution_mm * report.resolution_mm;
    found.sort_by_key(|island| std::cmp::Reverse(island.uv.len()));
    let mut parts = Vec::new();
    for island in found.iter().take(LISTED) {
        let n = island.uv.len() as f64;
        let centre = island.xyz.iter().fold([0.0; 3], |acc, p| {
            [acc[0] + p[0] / n, acc[1] + p[1] / n, acc[2] + p[2] / n]
        });
        parts.push(format!(
            "{:.2} mm^2 around ({:.1}, {:.1}, {:.1}) mm",
            n * cell,
            centre[0],
            centre[1],
            centre[2]
        ));
    }
    if found.len() > LISTED {
        parts.push(format!("and {} more", found.len() - LISTED));
    }
    format!(
        "{ABOVE_LIMIT} {h} mm: the simulator finds {:.4} mm at most and {:.2} mm^2 the tool never reached; {}",
        report.max_scallop_mm,
        report.uncovered_area_mm2,
        if parts.is_empty() {
            "between grid samples".to_string()
        } else {
            parts.join("; ")
        }
    )
}

/// One island of the residual map: samples above the threshold (or not
/// reached), grouped.
pub struct MapIsland {
    pub uv: Vec<nalgebra::Vector2<f64>>,
    pub xyz: Vec<[f64; 3]>,
}

/// Groups the map's samples above h, or not reached, into islands:
/// samples closer than half the tool radius are one island (a pass over
/// one covers the other). A refined peak above h between the samples
/// joins the island within that reach, or is an island of its own.
pub fn islands(
    report: &ScallopReport,
    h: f64,
    radius: f64,
) -> Vec<planners::strip_width::repair::Island> {
    map_islands(report, h, radius)
        .iter()
        .map(|m| planners::strip_width::repair::Island {
            uv: m.uv.clone(),
            spacing_mm: report.resolution_mm,
        })
        .collect()
}

/// The residual above which MPEC's grid samples count as above the band
/// `h`: `h`, or, where the simulator's refined maximum exceeds h but no
/// grid sample does, h lowered by the refinement's gain (at least `floor`
/// h), so the peak's samples are found.
fn residual_threshold(report: &ScallopReport, h: f64, floor: f64) -> f64 {
    let grid_max = report
        .map
        .residual
        .iter()
        .flatten()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    if report.max_scallop_mm > h && grid_max <= h {
        (h - (report.max_scallop_mm - grid_max)).max(floor * h)
    } else {
        h
    }
}

fn map_islands(report: &ScallopReport, h: f64, radius: f64) -> Vec<MapIsland> {
    let map = &report.map;
    let (nu, nv) = (map.nu, map.nv);
    let flagged: Vec<bool> = map
        .residual
        .iter()
        .enumerate()
        .map(|(k, r)| map.on_face(k) && r.is_none_or(|r| r > h))
        .collect();
    let reach = ((0.5 * radius / report.resolution_mm.max(1e-9)).round() as i64).max(1);
    let mut seen = vec![false; flagged.len()];
    let mut out = Vec::new();
    for start in 0..flagged.len() {
        if !flagged[start] || seen[start] {
            continue;
        }
        seen[start] = true;
        let mut stack = vec![start];
        let mut island = MapIsland {
            uv: Vec::new(),
            xyz: Vec::new(),
        };
        while let Some(k) = stack.pop() {
            island
                .uv
                .push(nalgebra::Vector2::new(map.uv[k][0], map.uv[k][1]));
            island.xyz.push(map.xyz[k]);
            let (i, j) = ((k / nv) as i64, (k % nv) as i64);
            for a in (i - reach).max(0)..=(i + reach).min(nu as i64 - 1) {
                for b in (j - reach).max(0)..=(j + reach).min(nv as i64 - 1) {
                    let q = a as usize * nv + b as usize;
                    if flagged[q] && !seen[q] {
                        seen[q] = true;
                        stack.push(q);
                    }
                }
            }
        }
        out.push(island);
    }
    // Peaks between the samples: only where the refined residual itself is
    // above h (lowering the grid threshold instead flags every sample
    // near that level, on a whole surface spaced for 0.9 h).
    let reach_mm = 0.5 * radius;
    for peak in report.peaks.iter().filter(|p| p.residual > h) {
        let at = nalgebra::Point3::from(peak.xyz);
        let near = out.iter_mut().find(|island| {
            island
                .xyz
                .iter()
                .any(|q| (nalgebra::Point3::from(*q) - at).norm() <= reach_mm)
        });
        match near {
            Some(island) => {
                island
                    .uv
                    .push(nalgebra::Vector2::new(peak.uv[0], peak.uv[1]));
                island.xyz.push(peak.xyz);
            }
            None => out.push(MapIsland {
                uv: vec![nalgebra::Vector2::new(peak.uv[0], peak.uv[1])],
                xyz: vec![peak.xyz],
            }),
        }
    }
    out
}

/// Belt strategies, checked by the material-removal simulation.
pub fn is_belt(strategy: Strategy) -> bool {
    matches!(
        strategy,
        Strategy::BeltIsoParametric | Strategy::BeltIsoPlanar
    )
}

/// Rounds of belt refinement after the first removal simulation.
pub const BELT_REFINE_ROUNDS: usize = 4;
/// The first rounds re-step the gaps left above h; the later ones split them.
pub const BELT_TIGHTEN_ROUNDS: usize = 2;

/// Belt results: simulates the removal; where nodes are left above h,
/// re-steps the gaps holding them, later adds paths at their middle
/// (`planners::refine`), and simulates again, at most [`BELT_REFINE_ROUNDS`] times. The result
/// carries the simulation's figures (`max_scallop_mm`; in `extra` the
/// removal figures, `simulated_gouge_mm` and, when paths were added,
/// `repair_passes` and `repair_length_mm`; the planner's rigid-belt
/// `max_gouge_mm` stays as planned), `within_scallop` and, where h is not
/// held, a warning saying where. Returns the result and the seconds spent
/// planning the added paths.
pub fn verify_and_refine_belt(
    job: &Job,
    mut result: PlanResult,
    progress: &dyn Progress,
) -> Result<(PlanResult, f64)> {
    use toolpath_planners::{belt, refine};
    let h = job.scallop()?;
    let surface = job.surface()?;
    let (raw_passes, raw_length) = (result.passes.len(), result.cl_path_length());
    let mut refinement = refine::Refinement::default();
    let mut planning_s = 0.0;
    progress.check()?;
    let mut sim = toolpath_simulation::removal::simulate_job(job, &result)?;
    for round in 0..BELT_REFINE_ROUNDS {
        if sim.stats.max_scallop_mm <= h {
            break;
        }
        let residuals: Vec<refine::Residual> = sim
            .nodes_above(h)
            .into_iter()
            .map(|(uv, height)| {
                let p = surface.point(uv[0], uv[1]);
                refine::Residual {
                    uv,
                    point: [p.x, p.y, p.z],
                    height,
                }
            })
            .collect();
        // Re-step first; what that leaves above h is split.
        let mode = if round < BELT_TIGHTEN_ROUNDS {
            refine::Mode::Tighten
        } else {
            refine::Mode::Split
        };
        if !refine::refine(job, &result, &residuals, h, mode, &mut refinement)? {
            break;
        }
        progress.check()?;
        let started = Instant::now();
        result = belt::plan_with(job, progress, &refinement)?;
        planning_s += started.elapsed().as_secs_f64();
        progress.check()?;
        sim = toolpath_simulation::removal::simulate_job(job, &result)?;
    }
    let s = &sim.stats;
    result.stats.max_scallop_mm = Some(s.max_scallop_mm);
    for (key, value) in [
        ("removal_mean_mm", s.mean_mm),
        ("removal_min_mm", s.min_mm),
        ("removal_max_mm", s.max_mm),
        ("removal_uniformity", s.uniformity),
        ("simulated_gouge_mm", s.max_gouge_mm),
    ] {
        result.stats.extra.insert(key.into(), value);
    }
    record_repair(&mut result, raw_passes, raw_length);
    let within = s.max_scallop_mm <= h;
    result.within_scallop = Some(within);
    if !within {
        let above = sim.nodes_above(h);
        let cell = s.resolution_mm * s.resolution_mm;
        let worst = above
            .iter()
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(uv, _)| surface.point(uv[0], uv[1]));
        result.warnings.push(format!(
            "{ABOVE_LIMIT} {h} mm: the removal simulation finds {:.4} mm at most, {:.2} mm^2 above h{}",
            s.max_scallop_mm,
            above.len() as f64 * cell,
            worst.map_or(String::new(), |p| format!(
                ", the highest at ({:.1}, {:.1}, {:.1}) mm",
                p.x, p.y, p.z
            ))
        ));
    }
    Ok((result, planning_s))
}

/// Path length, pass and point counts and machining time at `feed_rate` (mm/min).
pub fn fill_path_stats(result: &mut PlanResult, feed_rate: f64) {
    let length = match &result.tools {
        // Pockets: the tool-centre paths of every tool.
        Some(tools) => tools
            .iter()
            .flat_map(|t| t.passes.iter())
            .map(|p| polyline_length(p.iter().map(|q| [q[0], q[1], 0.0])))
            .sum(),
        None => result.cl_path_length(),
    };
    result.stats.path_length_mm = length;
    result.stats.passes = match &result.tools {
        Some(tools) => tools.iter().map(|t| t.passes.len()).sum(),
        None => result.passes.len(),
    };
    result.stats.points = Some(match &result.tools {
        // Pockets: the tool-centre points of every tool.
        Some(tools) => tools
            .iter()
            .flat_map(|t| t.passes.iter())
            .map(Vec::len)
            .sum(),
        None => result.point_count(),
    });
    result.stats.machining_time_min = Some(length / feed_rate);
}

/// Strategies whose results the scallop simulator checks (pocket and belt results have their own).
pub fn is_milling(strategy: Strategy) -> bool {
    matches!(
        strategy,
        Strategy::TensorRegions | Strategy::IsoScallop | Strategy::IsoParametric | Strategy::Mpec
    )
}

/// Runs the scallop simulator on a milling result of `job` at the job's `simulation_resolution`.
pub fn verify_milling(job: &Job, result: &PlanResult) -> Result<ScallopReport> {
    verify_milling_checked(job, result, &planners::NoProgress)
}

/// [`verify_milling`], checking `progress` for a stop about every thousand samples.
pub fn verify_milling_checked(
    job: &Job,
    result: &PlanResult,
    progress: &dyn Progress,
) -> Result<ScallopReport> {
    verify_milling_with(job, result, progress, scallop::PEAK_STARTS)
}

/// [`verify_milling_checked`] with `peak_starts` grid extrema refined.
fn verify_milling_with(
    job: &Job,
    result: &PlanResult,
    progress: &dyn Progress,
    peak_starts: usize,
) -> Result<ScallopReport> {
    let surface = job.surface()?;
    let settings = ScallopSettings {
        peak_starts,
        ..ScallopSettings::with_resolution(job.simulation_resolution)
    };
    scallop::simulate_checked(surface, job.tool()?, result, &settings, progress)
}

/// Puts the simulator's figures into the result's stats: max_scallop_mm,
/// max_gouge_mm and, in `extra`, uncovered/machined area and the grid spacing.
pub fn fill_scallop_stats(result: &mut PlanResult, report: &ScallopReport) {
    result.stats.max_scallop_mm = Some(report.max_scallop_mm);
    result.stats.max_gouge_mm = Some(report.max_gouge_mm);
    let extra = &mut result.stats.extra;
    extra.insert("uncovered_area_mm2".into(), report.uncovered_area_mm2);
    extra.insert("machined_area_mm2".into(), report.machined_area_mm2);
    extra.insert("simulation_resolution_mm".into(), report.resolution_mm);
}

/// Simulated figures within this much of a tolerance count as within it, mm
/// (0.1 micrometre, far below what a machine holds): the simulator's refined
/// extrema carry numerical error of that order, and a plan built to touch its
/// band (MPEC's -delta, docs/methods.md) lands on it: die_saddle's plan gives
/// a gouge of 0.0100136 mm against its 0.01 mm band.
pub const CONFORMANCE_SLACK_MM: f64 = 1e-4;

/// Where a simulated milling result breaks the job's tolerances, read from
/// the figures [`fill_scallop_stats`] put into its stats. Nothing is out of
/// spec in a result that was not simulated. Belt results are held to h only
/// (by `toolpath simulate`): their `max_gouge_mm` is the rigid-belt planning
/// figure, and the elastic removal model's depth below the part is not
/// comparable with a cutter's gouge tolerance.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Conformance {
    /// The simulated gouge beyond the job's gouge tolerance.
    pub gouge: Option<String>,
    /// The simulated residual above the job's scallop height h.
    pub scallop: Option<String>,
}

impl Conformance {
    /// Checks the simulator's `max_gouge_mm` against [`Job::gouge_tolerance`]
    /// and `max_scallop_mm` against h.
    pub fn of(job: &Job, result: &PlanResult) -> Self {
        if !is_milling(job.strategy) {
            return Self::default();
        }
        Self::of_figures(job, result.stats.max_gouge_mm, result.stats.max_scallop_mm)
    }

    /// The same check on given simulated figures (mm).
    pub fn of_figures(job: &Job, max_gouge_mm: Option<f64>, max_scallop_mm: Option<f64>) -> Self {
        let tolerance = job.gouge_tolerance();
        let gouge = max_gouge_mm.filter(|g| *g > tolerance + CONFORMANCE_SLACK_MM).map(|g| {
            format!("the simulator finds a gouge of {g:.4} mm, beyond the job's gouge tolerance of {tolerance} mm")
        });
        let scallop = match (max_scallop_mm, job.scallop) {
            (Some(s), Some(h)) if s > h + CONFORMANCE_SLACK_MM => Some(format!(
                "the simulator finds a residual of {s:.4} mm, above the job's scallop height h = {h} mm"
            )),
            _ => None,
        };
        Conformance { gouge, scallop }
    }

    /// The error for the worse breach (a gouge before a residual), if any.
    pub fn error(&self) -> Option<Error> {
        if let Some(m) = &self.gouge {
            return Some(Error::OutOfSpec {
                message: m.clone(),
                gouge: true,
            });
        }
        self.scallop.as_ref().map(|m| Error::OutOfSpec {
            message: m.clone(),
            gouge: false,
        })
    }
}

/// A plan whose simulated gouge is beyond the job's gouge tolerance is an
/// error (the node's job FAILED): no toolpath that cuts into the part is
/// handed out.
pub fn refuse_gouge(job: &Job, result: &PlanResult) -> Result<()> {
    match Conformance::of(job, result).gouge {
        Some(message) => Err(Error::OutOfSpec {
            message,
            gouge: true,
        }),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use toolpath_simulation::scallop::ResidualMap;

    /// A 10 x 10 map with 1 mm cells at (i, j, 0), residual 0.01 mm except
    /// where `set` says.
    fn report(set: &[((usize, usize), Option<f64>)], max_scallop: f64) -> ScallopReport {
        let (nu, nv) = (10, 10);
        let mut map = ResidualMap {
            nu,
            nv,
            uv: Vec::new(),
            xyz: Vec::new(),
            residual: Vec::new(),
            off_face: Vec::new(),
        };
        for i in 0..nu {
            for j in 0..nv {
                map.uv
                    .push([(i as f64 + 0.5) / 10.0, (j as f64 + 0.5) / 10.0]);
                map.xyz.push([i as f64, j as f64, 0.0]);
                let r = set
                    .iter()
                    .find(|(k, _)| *k == (i, j))
                    .map_or(Some(0.01), |(_, r)| *r);
                map.residual.push(r);
            }
        }
        ScallopReport {
            max_scallop_mm: max_scallop,
            max_gouge_mm: 0.0,
            uncovered_area_mm2: 1.0,
            machined_area_mm2: 99.0,
            resolution_mm: 1.0,
            map,
            peaks: Vec::new(),
        }
    }

    #[test]
    fn islands_group_near_samples_and_the_warning_says_where() {
        let high = Some(0.08);
        let r = report(
            &[
                ((2, 2), high),
                ((2, 3), high),
                ((3, 2), high),
                ((3, 3), high),
                ((8, 8), None),
            ],
            0.08,
        );
        // Reach: half the 2.5 mm radius = 1 cell; the block and the unreached
        // sample are 5 cells apart.
        let found = islands(&r, 0.05, 2.5);
        let mut sizes: Vec<usize> = found.iter().map(|i| i.uv.len()).collect();
        sizes.sort();
        assert_eq!(sizes, [1, 4]);
        let w = above_limit_warning(&r, 0.05, 2.5);
        assert!(w.starts_with(ABOVE_LIMIT), "{w}");
        assert!(
            w.contains("4.00 mm^2 around (2.5, 2.5, 0.0) mm; 1.00 mm^2 around (8.0, 8.0, 0.0) mm"),
            "{w}"
        );
        assert!(w.contains("0.0800 mm at most and 1.00 mm^2"), "{w}");
    }

    #[test]
    fn a_peak_above_h_between_samples_is_an_island_of_its_own() {
        use toolpath_simulation::scallop::RefinedPeak;
        let peak = |xyz: [f64; 3], residual| RefinedPeak {
            uv: [(xyz[0] + 0.5) / 10.0, (xyz[1] + 0.5) / 10.0],
            xyz,
            residual,
        };
        // Grid samples just below h near the peak and far from it: only
        // the refined peak's own place is repaired, not every sample near
        // the grid maximum.
        let mut r = report(
            &[
                ((5, 5), Some(0.049)),
                ((5, 6), Some(0.048)),
                ((1, 1), Some(0.0485)),
            ],
            0.052,
        );
        r.peaks = vec![peak([5.3, 5.4, 0.0], 0.052), peak([1.0, 1.0, 0.0], 0.0485)];
        let found = islands(&r, 0.05, 2.5);
        assert_eq!(found.len(), 1);
        assert_eq!(found[0].uv.len(), 1);
        assert!((found[0].uv[0].x - 0.58).abs() < 1e-12);
        assert!((found[0].uv[0].y - 0.59).abs() < 1e-12);
        // A peak within half the radius of a grid island joins it.
        let mut r = report(&[((2, 2), Some(0.08))], 0.09);
        r.peaks = vec![peak([2.6, 2.7, 0.0], 0.09)];
        let found = islands(&r, 0.05, 2.5);
        assert_eq!(found.len(), 1);
        assert_eq!(found[0].uv.len(), 2);
        // Within h on the grid and refined: no island.
        let mut r = report(&[((5, 5), Some(0.049))], 0.0495);
        r.peaks = vec![peak([5.2, 5.0, 0.0], 0.0495)];
        assert!(islands(&r, 0.05, 2.5).is_empty());
    }
}
