//! `toolpath compare JOB` for a milling job: plans the same surface and tool
//! with iso_parametric, iso_scallop and tensor_regions and prints the paper's
//! Table 1 side by side, with the simulator's max scallop and the path length
//! over the lower bound (integral of dA / w_max).

use super::table;
use toolpath_formats::{Job, Strategy};
use toolpath_kernel::error::Result;
use toolpath_pipeline::{self as pipeline, RunOptions};
use toolpath_planners::NoProgress;

pub const STRATEGIES: [Strategy; 3] = [
    Strategy::IsoParametric,
    Strategy::IsoScallop,
    Strategy::TensorRegions,
];

/// The comparison table as text.
pub fn table(job: &Job) -> Result<String> {
    let mut rows = Vec::new();
    for strategy in STRATEGIES {
        let mut j = job.clone();
        j.strategy = strategy;
        let r = pipeline::run(&j, &NoProgress, RunOptions::default())?;
        let s = &r.stats;
        let lb = s.path_length_lower_bound_mm.unwrap_or(f64::NAN);
        let fmt_opt = |v: Option<f64>, p: usize| v.map_or("-".to_string(), |x| format!("{x:.p$}"));
        rows.push(vec![
            strategy.name().to_string(),
            format!("{:.0}", s.compute_ms),
            format!("{:.1}", s.path_length_mm),
            format!("{}", s.passes),
            fmt_opt(s.machining_time_min.map(|m| m * 60.0), 1),
            fmt_opt(s.max_scallop_mm, 4),
            fmt_opt(s.max_gouge_mm, 4),
            fmt_opt(s.extra.get("uncovered_area_mm2").copied(), 2),
            format!("{:.3}", s.path_length_mm / lb),
            r.regions
                .as_ref()
                .map_or("1".into(), |x| x.len().to_string()),
        ]);
    }
    let tool = job.tool()?;
    let mut out = format!(
        "{}: {} R{} lead {} deg, scallop {} mm, feed {} mm/min\n",
        job.job_id,
        tool.kind(),
        tool.radius(),
        job.lead_angle_deg.unwrap_or(0.0),
        job.scallop.unwrap_or(f64::NAN),
        job.feed_rate
    );
    out.push_str(&table::render(
        &[
            "strategy",
            "compute ms",
            "length mm",
            "passes",
            "machining s",
            "max scallop mm",
            "max gouge mm",
            "uncovered mm2",
            "length / bound",
            "regions",
        ],
        &rows,
    ));
    Ok(out)
}

pub fn run(job: &Job) -> Result<()> {
    print!("{}", table(job)?);
    Ok(())
}
