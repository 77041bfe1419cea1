//! Builds chosen candidate plans of `tensor_regions` exactly, at the job's
//! settings, on every surface of the flat-end suite (docs/results.md,
//! "Flat-end strategy suite") and prints each one's cl path length and pass
//! count: the candidates the delivered plan did not keep, which `compare
//! --suite` does not show.
//!
//!     cargo run --release --example suite_candidates -- partitioned,whole_field,edge_offset_u
//!
//! (`partitioned_as_traced`: the partition before merging.)

use toolpath_planner::planners::strip_width::tensor_regions;
use toolpath_planner::planners::NoProgress;
use toolpath_planner::samples::{self, random};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let labels = std::env::args()
        .nth(1)
        .ok_or("usage: suite_candidates LABEL[,LABEL...] (partitioned, partitioned_as_traced, whole_field, mean_feed, edge_offset_u, ...)")?;
    let mut jobs = Vec::new();
    for p in random::suite() {
        jobs.push((p.name(), samples::random_job(&p)?));
    }
    for name in ["plane", "concave_cylinder", "monkey_saddle", "wing_mould"] {
        jobs.push((name.to_string(), samples::job(name)?));
    }
    for (name, job) in jobs {
        let mut line = format!("{name:28}");
        for label in labels.split(',') {
            match tensor_regions::candidate(&job, label, &NoProgress)? {
                Some(r) => {
                    line += &format!(
                        " {label} {:7.0} mm ({:3} passes)",
                        r.cl_path_length(),
                        r.passes.len()
                    )
                }
                None => line += &format!(" {label} -"),
            }
        }
        println!("{line}");
    }
    Ok(())
}
