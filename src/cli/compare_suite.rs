//! `toolpath compare --suite`: the three flat-end strategies on the fixed
//! suite of seeded random surfaces (`samples::random::suite`) and the
//! built-in milling samples, each plan verified by the simulator. One
//! Markdown row per surface, then the median and worst of the ratios.

use std::time::Instant;
use toolpath_formats::{Job, PlanResult};
use toolpath_kernel::error::{Error, Result};
use toolpath_pipeline::{self as pipeline, RunOptions};
use toolpath_planners::strip_width::{crossings, lower_bound};
use toolpath_planners::NoProgress;
use toolpath_samples as samples;

/// The built-in samples planned with the flat end.
pub const BUILT_IN: [&str; 4] = ["plane", "concave_cylinder", "monkey_saddle", "wing_mould"];

/// Where the shorter baseline leaves room (>= this x the lower bound),
/// tensor_regions is held to [`ROOM_TARGET`] x the shorter baseline.
pub const ROOM: f64 = 1.15;
pub const ROOM_TARGET: f64 = 0.90;

/// The suite's jobs, named: random surfaces first, then the samples.
pub fn jobs() -> Result<Vec<(String, Job)>> {
    let mut out = Vec::new();
    for params in samples::random::suite() {
        out.push((params.name(), samples::random_job(&params)?));
    }
    for name in BUILT_IN {
        out.push((name.to_string(), samples::job(name)?));
    }
    Ok(out)
}

/// One surface: the three results (or the error text) and the wall time.
pub struct Row {
    pub results: Vec<std::result::Result<PlanResult, String>>,
    pub seconds: f64,
}

pub fn plan_surface(job: &Job) -> Row {
    let start = Instant::now();
    let results = super::compare_milling::STRATEGIES
        .iter()
        .map(|&strategy| {
            let mut j = job.clone();
            j.strategy = strategy;
            pipeline::run(&j, &NoProgress, RunOptions::default()).map_err(|e| e.to_string())
        })
        .collect();
    Row {
        results,
        seconds: start.elapsed().as_secs_f64(),
    }
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The simulator's figures of one surface's plans.
struct Checks {
    /// Max scallop of each strategy's plan, as printed ("error" if it failed).
    scallops: Vec<String>,
    worst_scallop: f64,
    gouge: f64,
    uncovered: f64,
    /// Pairs of the planner's passes (repair passes left out) that cross
    /// each other, per strategy, as printed.
    crossings: Vec<String>,
    crossing_total: usize,
}

/// Pairs of a plan's own passes that cross each other (`None` without a
/// surface to take the domain from).
fn plan_crossings(job: &Job, r: &PlanResult) -> Option<usize> {
    Some(crossings::plan_crossing_pairs(
        r,
        job.surface().ok()?.domain(),
    ))
}

/// Reads the simulator's figures off a row's plans; plans above `h` are
/// named in `over_h`, failed ones reported on stderr.
fn checks(name: &str, job: &Job, row: &Row, over_h: &mut Vec<String>) -> Checks {
    let h = job.scallop.unwrap_or(f64::NAN);
    let mut c = Checks {
        scallops: Vec::new(),
        worst_scallop: 0.0,
        gouge: 0.0,
        uncovered: 0.0,
        crossings: Vec::new(),
        crossing_total: 0,
    };
    for (k, r) in row.results.iter().enumerate() {
        let strategy = super::compare_milling::STRATEGIES[k].name();
        match r {
            Ok(r) => {
                let s = r.stats.max_scallop_mm.unwrap_or(f64::NAN);
                c.worst_scallop = c.worst_scallop.max(s);
                if s > h {
                    over_h.push(format!("{name} {strategy}"));
                }
                c.scallops.push(format!("{s:.4}"));
                c.gouge = c.gouge.max(r.stats.max_gouge_mm.unwrap_or(0.0));
                let uncovered = r.stats.extra.get("uncovered_area_mm2");
                c.uncovered = c.uncovered.max(uncovered.copied().unwrap_or(0.0));
                let n = plan_crossings(job, r);
                c.crossing_total += n.unwrap_or(0);
                c.crossings.push(n.map_or("-".into(), |n| n.to_string()));
            }
            Err(e) => {
                c.scallops.push("error".into());
                c.crossings.push("error".into());
                eprintln!("{name} {strategy}: {e}");
            }
        }
    }
    c
}

/// The suite's figures summed over its rows.
#[derive(Default)]
struct Totals {
    to_shorter: Vec<f64>,
    to_bound: Vec<f64>,
    /// Surfaces whose shorter baseline is at least [`ROOM`] x the bound, and
    /// of them those where tensor_regions meets [`ROOM_TARGET`].
    room: (usize, usize),
    /// Of the surfaces with room: those where the target lies above the
    /// spacing bound (reachable at all by passes spaced for 0.9 h), and met.
    reachable: (usize, usize),
    worst_scallop: f64,
    worst_gouge: f64,
    over_h: Vec<String>,
    crossing_pairs: usize,
    plans: usize,
}

/// Prints the suite's table; `scallop` (mm) replaces every job's height.
pub fn run(only: Option<&str>, scallop: Option<f64>) -> Result<()> {
    if let Some(h) = scallop {
        if !(h.is_finite() && h > 0.0) {
            return Err(Error::invalid(
                "--scallop",
                format!("must be a positive number of mm, got {h}"),
            ));
        }
    }
    println!(
        "| surface | umbilics | lower bound mm | iso_parametric mm | iso_scallop mm | tensor_regions mm | tensor / shorter | shorter / bound | shorter / bound at 0.9 h | tensor / bound | max scallop mm (ip, is, tr) | max gouge mm | uncovered mm2 | crossing pairs (ip, is, tr) | regions | plan | repair mm | s |"
    );
    println!("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- | ---: | ---: | --- | ---: | --- | ---: | ---: |");
    let mut totals = Totals::default();
    for (name, mut job) in jobs()? {
        if only.is_some_and(|o| !name.contains(o)) {
            continue;
        }
        if scallop.is_some() {
            job.scallop = scallop;
        }
        suite_row(&name, &job, &mut totals);
    }
    print_totals(&mut totals);
    Ok(())
}

/// Plans one surface of the suite, prints its row and adds it to `t`.
fn suite_row(name: &str, job: &Job, t: &mut Totals) {
    let row = plan_surface(job);
    let len = |k: usize| row.results[k].as_ref().ok().map(|r| r.stats.path_length_mm);
    let fmt = |x: Option<f64>, p: usize| x.map_or("error".to_string(), |x| format!("{x:.p$}"));
    let tr = row.results[2].as_ref().ok();
    let bound = row
        .results
        .iter()
        .flatten()
        .find_map(|r| r.stats.path_length_lower_bound_mm);
    let shorter = match (len(0), len(1)) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    };
    let ratio = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(a), Some(b)) => Some(a / b),
        _ => None,
    };
    let r_short = ratio(len(2), shorter);
    let r_bound = ratio(len(2), bound);
    let s_bound = ratio(shorter, bound);
    let spacing_bound = lower_bound::job_spacing_lower_bound(job).ok();
    let s_spacing = ratio(shorter, spacing_bound);
    if let Some(x) = r_short {
        t.to_shorter.push(x);
        if s_bound.is_some_and(|s| s >= ROOM) {
            t.room.0 += 1;
            if x <= ROOM_TARGET {
                t.room.1 += 1;
            }
            if s_spacing.is_some_and(|s| s * ROOM_TARGET >= 1.0) {
                t.reachable.0 += 1;
                if x <= ROOM_TARGET {
                    t.reachable.1 += 1;
                }
            }
        }
    }
    if let Some(x) = r_bound {
        t.to_bound.push(x);
    }
    let Checks {
        scallops,
        worst_scallop: row_scallop,
        gouge,
        uncovered,
        crossings,
        crossing_total,
    } = checks(name, job, &row, &mut t.over_h);
    t.crossing_pairs += crossing_total;
    t.plans += row.results.iter().flatten().count();
    t.worst_scallop = t.worst_scallop.max(row_scallop);
    t.worst_gouge = t.worst_gouge.max(gouge);
    println!(
        "| {name} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {gouge:.4} | {uncovered:.2} | {} | {} | {} | {} | {:.1} |",
        tr.and_then(|r| r.degenerate_points.as_ref())
            .map_or("-".into(), |d| d.len().to_string()),
        fmt(bound, 0),
        fmt(len(0), 0),
        fmt(len(1), 0),
        fmt(len(2), 0),
        fmt(r_short, 3),
        fmt(s_bound, 3),
        fmt(s_spacing, 3),
        fmt(r_bound, 3),
        scallops.join(", "),
        crossings.join(", "),
        tr.and_then(|r| r.regions.as_ref())
            .map_or("-".into(), |x| x.len().to_string()),
        tr.and_then(|r| r.plan_choice.as_deref())
            .and_then(|c| c.split(':').next())
            .unwrap_or("-"),
        tr.and_then(|r| r.stats.extra.get("repair_length_mm"))
            .map_or("-".into(), |x| format!("{x:.0}")),
        row.seconds,
    );
}

/// Prints the lines under the table.
fn print_totals(t: &mut Totals) {
    let worst = |v: &[f64]| v.iter().copied().fold(f64::NAN, f64::max);
    println!();
    println!(
        "tensor / shorter baseline: median {:.3}, worst {:.3} over {} surfaces",
        median(&mut t.to_shorter.clone()),
        worst(&t.to_shorter),
        t.to_shorter.len()
    );
    println!(
        "tensor / lower bound: median {:.3}, worst {:.3}",
        median(&mut t.to_bound.clone()),
        worst(&t.to_bound)
    );
    println!(
        "surfaces with shorter baseline >= {ROOM} x bound: {}, of them tensor <= {ROOM_TARGET} x shorter: {}",
        t.room.0, t.room.1
    );
    println!(
        "of those, reachable by passes spaced for 0.9 h ({ROOM_TARGET} x shorter >= bound at 0.9 h): {}, met: {}",
        t.reachable.0, t.reachable.1
    );
    println!(
        "max scallop over all plans {:.4} mm, max gouge {:.4} mm",
        t.worst_scallop, t.worst_gouge
    );
    println!(
        "pairs of passes crossing each other (in uv, off the domain edge, repair passes left out): {} over {} plans",
        t.crossing_pairs, t.plans
    );
    if !t.over_h.is_empty() {
        println!("above h: {}", t.over_h.join("; "));
    }
}
