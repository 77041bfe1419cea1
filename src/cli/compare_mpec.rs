//! `toolpath compare JOB` for an mpec job: the torus with MPEC against a
//! ball-end tool of the same diameter leaving the same scallop, both with
//! iso-parametric drive curves along the job's feed direction.
//!
//! The ball's stepover at a drive point comes from the exact scallop of two
//! neighbouring ball positions on the circle of the part's normal curvature
//! across the feed; a pass is as wide as its narrowest stepover, and passes
//! are placed with the same gap measure as the MPEC planner's.

use toolpath_formats::Job;
use toolpath_kernel::error::Result;
use toolpath_kernel::geometry::LocalGeometry;
use toolpath_pipeline::{self as pipeline, RunOptions};
use toolpath_planners::mpec::Planner;
use toolpath_planners::NoProgress;

/// Exact stepover (arc length on the part) of a ball of radius `rb` leaving a
/// scallop `h` on a part whose normal curvature across the feed is `kappa`
/// (> 0 concave towards the tool). Flat: 2 sqrt(2 rb h - h^2).
pub fn ball_stepover(rb: f64, kappa: f64, h: f64) -> f64 {
    if kappa.abs() < 1e-9 {
        return 2.0 * (2.0 * rb * h - h * h).max(0.0).sqrt();
    }
    // Part circle of radius rho about O; ball centres at |OC| = rho -+ rb,
    // the cusp on the bisector at |OQ| = rho -+ h, |QC| = rb.
    let rho = 1.0 / kappa.abs();
    let (oc, oq) = if kappa > 0.0 {
        (rho - rb, rho - h)
    } else {
        (rho + rb, rho + h)
    };
    let cos_a = ((oc * oc + oq * oq - rb * rb) / (2.0 * oc * oq)).clamp(-1.0, 1.0);
    2.0 * rho * cos_a.acos()
}

/// Ball-end passes: (pass count, total drive-curve length in mm).
pub fn ball_passes(planner: &Planner, rb: f64, scallop: f64) -> Result<(usize, f64)> {
    let samples = planner.feed_samples();
    let inside: Vec<f64> = samples.iter().filter(|s| s.1).map(|s| s.0).collect();
    let (_, (t0, t1)) = planner.ranges();
    let step_at = |t: f64| -> f64 {
        inside
            .iter()
            .map(|&s| {
                let (u, v) = planner.uv(s, t);
                let kappa = LocalGeometry::at(planner.surface, u, v)
                    .map(|g| {
                        let su = match planner.feed {
                            toolpath_formats::FeedDirection::U => g.forms.derivs.su,
                            toolpath_formats::FeedDirection::V => g.forms.derivs.sv,
                        };
                        let across = g.forms.n.cross(&su.normalize());
                        g.normal_curvature(across)
                    })
                    .unwrap_or(0.0);
                ball_stepover(rb, kappa, scallop)
            })
            .fold(f64::INFINITY, f64::min)
    };
    let length_at = |t: f64| -> f64 {
        inside
            .windows(2)
            .map(|w| (planner.point(w[1], t) - planner.point(w[0], t)).norm())
            .sum()
    };
    // First pass half a stepover in from the edge, then one stepover apart.
    let mut t = planner.advance(&samples, t0, t1, 0.5 * step_at(t0));
    let mut passes = 1;
    let mut length = length_at(t);
    while planner.gap(&samples, t, t1) > 0.5 * step_at(t) {
        let next = planner.advance(&samples, t, t1, step_at(t));
        if next <= t || passes > 100_000 {
            break;
        }
        t = next;
        passes += 1;
        length += length_at(t);
    }
    Ok((passes, length))
}

pub fn run(job: &Job) -> Result<()> {
    let planner = Planner::from_job(job)?;
    let delta = planner.delta;
    let rb = planner.tool.tube_radius() + planner.tool.corner_radius;
    let start = std::time::Instant::now();
    let result = pipeline::run(
        job,
        &NoProgress,
        RunOptions {
            skip_verify: true,
            no_timing: false,
            ..RunOptions::default()
        },
    )?;
    let mpec_ms = start.elapsed().as_secs_f64() * 1e3;
    let mean = result
        .stats
        .extra
        .get("mean_strip_width_mm")
        .copied()
        .unwrap_or(f64::NAN);
    println!(
        "job {}: torus R {rb} r {} with MPEC, tolerance +-{delta} mm, feed along {:?}",
        job.job_id, planner.tool.corner_radius, planner.feed
    );
    println!(
        "{:<34} {:>7} {:>16} {:>16} {:>10}",
        "strategy", "passes", "path_length_mm", "mean_width_mm", "time_ms"
    );
    println!(
        "{:<34} {:>7} {:>16.1} {:>16.2} {:>10.1}",
        "mpec (torus, band +-delta)",
        result.passes.len(),
        result.stats.path_length_mm,
        mean,
        mpec_ms
    );
    for (label, h) in [
        ("ball, scallop delta", delta),
        ("ball, scallop 2 delta (same band)", 2.0 * delta),
    ] {
        let start = std::time::Instant::now();
        let (passes, length) = ball_passes(&planner, rb, h)?;
        let ms = start.elapsed().as_secs_f64() * 1e3;
        println!(
            "{:<34} {:>7} {:>16.1} {:>16} {:>10.1}",
            label, passes, length, "-", ms
        );
        println!(
            "  ball / mpec: {:.1} x the passes, {:.1} x the path length",
            passes as f64 / result.passes.len().max(1) as f64,
            length / result.stats.path_length_mm.max(1e-9)
        );
    }
    Ok(())
}
