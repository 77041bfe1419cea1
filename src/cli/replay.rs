use crate::error::{Error, Result};
use crate::machines::Machines;
use crate::recording::runs;
use std::path::Path;

/// `toolpath replay BAG [--check]`: re-plans every job of the bag; with
/// `--check`, prints what differs from the recording and fails on a difference.
pub fn run(bag: &Path, check: bool, publish: bool) -> Result<()> {
    if publish {
        return Err(Error::planning(
            "`toolpath replay --publish` (republishing to a running node) is not available in this build yet",
        ));
    }
    let report = runs::replay(bag, &Machines::default())?;
    if let Some(t) = &report.truncated {
        eprintln!("warning: {t}");
    }
    for j in &report.jobs {
        let verdict = if j.differences.is_empty() {
            "same"
        } else {
            "DIFFERENT"
        };
        println!(
            "{:<28} {:<20} {:<6} {:>8} points  {verdict}",
            j.job_id, j.strategy, j.machine, j.points
        );
        if check {
            for d in &j.differences {
                println!("    {d}");
            }
        }
    }
    let n = report.differences();
    if check && n > 0 {
        return Err(Error::planning(format!(
            "{n} difference(s) from the recording in {}",
            bag.display()
        )));
    }
    Ok(())
}
