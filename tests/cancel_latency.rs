//! A cancel stops every strategy promptly: each planner, the simulator and
//! the repair rounds check for it at their progress points
//! (docs/limits.md, "Cancel"). For one sample job per strategy, planned and
//! verified as the node plans it:
//! - an uncanceled run records the instant of every progress check; the
//!   longest stretch without one (from the start, between checks, and from
//!   the last check to the end) bounds how late a cancel can be seen;
//! - a second run is canceled from another thread half-way through its
//!   first run's time, and must end `Stopped { canceled: true }` soon after.
//!
//! The bounds are loose (this is the test profile on a shared 2-core
//! machine); the release figures are in docs/limits.md.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};
use toolpath_planner::error::{Error, Result};
use toolpath_planner::pipeline::{self, RunOptions};
use toolpath_planner::planners::Progress;
use toolpath_planner::samples;

/// The longest a strategy may go without a progress check here, s.
const MAX_GAP_S: f64 = 2.0;

/// Records when it is checked; once `cancel` is set, every check fails as
/// a canceled job's does.
struct Watch {
    checks: Mutex<Vec<Instant>>,
    cancel: AtomicBool,
}

impl Watch {
    fn new() -> Self {
        Self {
            checks: Mutex::new(Vec::new()),
            cancel: AtomicBool::new(false),
        }
    }
}

impl Progress for Watch {
    fn set(&self, _fraction: f32) {}

    fn check(&self) -> Result<()> {
        self.checks.lock().unwrap().push(Instant::now());
        if self.cancel.load(Ordering::SeqCst) {
            return Err(Error::canceled("canceled by the test"));
        }
        Ok(())
    }
}

fn options() -> RunOptions {
    RunOptions {
        skip_verify: false,
        ..RunOptions::PLAN_ONLY
    }
}

/// The longest stretch without a check in a run from `start` to `end`, s.
fn longest_gap(start: Instant, checks: &[Instant], end: Instant) -> f64 {
    std::iter::once(start)
        .chain(checks.iter().copied())
        .chain(std::iter::once(end))
        .collect::<Vec<_>>()
        .windows(2)
        .map(|w| w[1].duration_since(w[0]).as_secs_f64())
        .fold(0.0, f64::max)
}

#[test]
fn every_strategy_sees_a_cancel_soon() {
    let cases = [
        ("tensor_regions", "monkey_saddle"),
        ("iso_scallop", "concave_cylinder"),
        ("iso_parametric", "plane"),
        ("mpec", "die_saddle"),
        ("belt_iso_parametric", "turbine_blade"),
        ("belt_iso_planar", "sine_wave"),
        ("pocket_mat", "leaf_pocket"),
    ];
    let mut figures = Vec::new();
    for (strategy, sample) in cases {
        let mut job = samples::job(sample).unwrap();
        job.strategy = toolpath_planner::formats::Strategy::parse(strategy).unwrap();

        let watch = Watch::new();
        let start = Instant::now();
        let planned = pipeline::run(&job, &watch, options());
        let end = Instant::now();
        if let Err(e) = planned {
            panic!("{strategy} on {sample}: {e}");
        }
        let checks = watch.checks.into_inner().unwrap();
        let gap = longest_gap(start, &checks, end);
        let run_s = end.duration_since(start).as_secs_f64();
        assert!(
            checks.len() >= 3,
            "{strategy} on {sample}: {} progress checks in {run_s:.2} s",
            checks.len()
        );
        assert!(
            gap < MAX_GAP_S,
            "{strategy} on {sample}: {gap:.3} s without a progress check (run {run_s:.2} s)"
        );

        // Canceled half-way through: it ends canceled, about a gap later.
        let watch = Watch::new();
        let half = Duration::from_secs_f64(run_s / 2.0);
        let (outcome, late_s) = std::thread::scope(|scope| {
            let w = &watch;
            let canceled_at = scope.spawn(move || {
                std::thread::sleep(half);
                w.cancel.store(true, Ordering::SeqCst);
                Instant::now()
            });
            // As the node does: one more check once the pipeline returns,
            // so a cancel in its last stretch still stops the job.
            let outcome = pipeline::run(&job, w, options()).and_then(|r| w.check().map(|()| r));
            let ended = Instant::now();
            let at = canceled_at.join().unwrap();
            (outcome, ended.saturating_duration_since(at).as_secs_f64())
        });
        match outcome {
            Err(Error::Stopped { canceled: true, .. }) => {}
            // A run faster the second time may end before the cancel.
            Ok(_) if late_s == 0.0 => {}
            Ok(_) => panic!("{strategy} on {sample}: planned to the end though canceled"),
            Err(e) => panic!("{strategy} on {sample}: canceled run failed otherwise: {e}"),
        }
        assert!(
            late_s < MAX_GAP_S,
            "{strategy} on {sample}: ended {late_s:.3} s after the cancel"
        );
        figures.push(format!(
            "{strategy} on {sample}: run {run_s:.2} s, {} checks, longest gap {gap:.3} s, canceled run ended {late_s:.3} s after the cancel",
            checks.len()
        ));
    }
    for f in figures {
        eprintln!("{f}");
    }
}
