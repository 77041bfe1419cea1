use crate::error::Result;
use crate::pipeline::{self, RunOptions};
use crate::planners::NoProgress;
use crate::samples;

/// Plans every sample job and prints one row each.
pub fn run(_out: &std::path::Path) -> Result<()> {
    println!(
        "{:<16} {:<20} {:>7} {:>12} {:>10} {:>12} {:>10}",
        "sample", "strategy", "passes", "length_mm", "time_min", "scallop_mm", "ms"
    );
    for s in samples::list() {
        let job = samples::job(s.name)?;
        match pipeline::run(&job, &NoProgress, RunOptions::default()) {
            Ok(r) => println!(
                "{:<16} {:<20} {:>7} {:>12.1} {:>10.2} {:>12} {:>10.1}",
                s.name,
                r.strategy,
                r.stats.passes,
                r.stats.path_length_mm,
                r.stats.machining_time_min.unwrap_or(0.0),
                r.stats
                    .max_scallop_mm
                    .map_or("-".to_string(), |x| format!("{x:.4}")),
                r.stats.compute_ms
            ),
            Err(e) => println!("{:<16} {:<20} {e}", s.name, job.strategy.name()),
        }
    }
    Ok(())
}
