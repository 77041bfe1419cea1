//! `toolpath compare` on a pocket: the medial-axis tool sequence against the
//! root tool alone (contour-parallel at the same stepover), the paper's case.

use toolpath_formats::Job;
use toolpath_kernel::error::Result;
use toolpath_planners::pocket::offset_passes::rapid_length;
use toolpath_planners::pocket::pocket_mat::{plan_pocket, plan_single_tool, PocketPlan};
use toolpath_planners::NoProgress;

fn row(name: &str, tools: &str, plan: &PocketPlan, feed_rate: f64) -> String {
    let length = plan.path_length();
    let rapids: f64 = plan.stages.iter().map(|s| rapid_length(&s.passes)).sum();
    format!(
        "{name:<18} {tools:<26} {length:>12.1} {:>10.2} {rapids:>10.1} {:>10.3}\n",
        length / feed_rate,
        plan.uncut_area()
    )
}

/// The comparison table as text.
pub fn table(job: &Job) -> Result<String> {
    let pocket = job.pocket()?;
    let seq = plan_pocket(
        pocket,
        &job.tool_catalogue,
        job.simulation_resolution,
        &NoProgress,
    )?;
    let root = seq.stages.last().map_or(0.0, |s| s.diameter);
    let single = plan_single_tool(pocket, root, job.simulation_resolution)?;
    let tools: Vec<String> = seq
        .stages
        .iter()
        .map(|s| format!("{}", s.diameter))
        .collect();
    let mut out = format!(
        "pocket {}: Dmax {:.3} mm, min corner radius {:.3} mm, feed {} mm/min\n",
        job.job_id, seq.medial_axis.dmax, seq.medial_axis.min_corner_radius, job.feed_rate
    );
    out.push_str(&format!(
        "{:<18} {:<26} {:>12} {:>10} {:>10} {:>10}\n",
        "plan", "tool diameters (mm)", "cutting mm", "time min", "rapids mm", "uncut mm2"
    ));
    out.push_str(&row(
        "medial-axis tools",
        &tools.join(" > "),
        &seq,
        job.feed_rate,
    ));
    out.push_str(&row(
        "root tool alone",
        &format!("{root}"),
        &single,
        job.feed_rate,
    ));
    let ratio = single.path_length() / seq.path_length().max(1e-12);
    out.push_str(&format!(
        "root tool alone / sequence: {ratio:.2} x the cutting path length\n"
    ));
    Ok(out)
}

pub fn run(job: &Job) -> Result<()> {
    print!("{}", table(job)?);
    Ok(())
}
