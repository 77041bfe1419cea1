//! Scallop simulator: the residual material height left on a surface by a
//! milling result (flat-end, ball or torus cutter), from the exact cutter
//! solid swept along the passes (docs/methods.md, "Swept cutter and residual").
//!
//! The surface is sampled on a uv grid (cell centres, each with its area).
//! At a sample `p` with tool-side unit normal `n`, the residual is the lowest
//! `t` such that `p + t n` lies in the swept tool volume: positive = material
//! left (scallop), negative = the tool cut below the surface (gouge). Between
//! consecutive points of a pass the tool moves linearly (tip interpolated,
//! axis interpolated and normalised). A sample the swept tool does not reach
//! within `cap` = the tool radius above it is uncovered.
//!
//! Per sample and pass segment, the drop of the exact cutter solid
//! ([`CutterShape::lowest_hit`]) is scanned at sub-positions no further apart
//! than R/8 along the motion, then the minimum is refined by golden-section
//! search around the best sub-position (the swept solid of a convex cutter
//! along a straight motion is convex, so the drop is unimodal in the motion
//! parameter); where the line leaves the tool between two sub-positions (the
//! sharp rim of a flat-end), the edge is located by bisection first. The
//! motion parameter is resolved to 1e-5 mm, far below the 0.002 mm the
//! planners are checked to. Reported maxima/minima are refined the same way
//! in (u, v) by a compass search from the grid's best local extrema, so the
//! max scallop is not limited by the grid spacing.
//!
//! Files, one concept each: `settings` and `resolution` (the grid), `report`
//! (what a run returns), `motion` (one straight tool motion) and
//! `motion_index` (the motions in a uniform grid), `reach` (which motions can
//! reach a sample's line), `drop` (the drop along one motion at one line),
//! `scan` (the scan along a motion and the refinement both simulators
//! share), `fast` (the cut-offs of the fast path), `residual` (the residual
//! of a sample and of the whole grid), `peaks` (the extrema refined between
//! the samples), `simulator` (the `Simulator` and its run), and, behind the
//! `reference` feature, `reference` (every motion scanned in full, for the
//! accuracy tests).

mod drop;
mod fast;
mod motion;
mod motion_index;
mod peaks;
mod reach;
#[cfg(feature = "reference")]
mod reference;
mod report;
mod residual;
mod resolution;
mod scan;
mod settings;
mod simulator;
#[cfg(test)]
mod test_support;

pub use report::{RefinedPeak, ResidualMap, ScallopReport};
pub use resolution::check_resolution;
pub use settings::{ScallopSettings, AUTO_MAX_SAMPLES, DEEP_PEAK_STARTS, MAX_SAMPLES, PEAK_STARTS};
pub use simulator::Simulator;

use residual::Method;
use toolpath_formats::PlanResult;
use toolpath_kernel::error::Result;
use toolpath_kernel::geometry::NurbsSurface;
use toolpath_kernel::progress::{NoProgress, Progress};
use toolpath_kernel::tools::Tool;

/// Simulates `result` (a milling result with `cl`/`axis` per point) on `surface`.
pub fn simulate(
    surface: &NurbsSurface,
    tool: &Tool,
    result: &PlanResult,
    settings: &ScallopSettings,
) -> Result<ScallopReport> {
    simulate_checked(surface, tool, result, settings, &NoProgress)
}

/// [`simulate`], checking `progress` for a stop about every thousand samples.
pub fn simulate_checked(
    surface: &NurbsSurface,
    tool: &Tool,
    result: &PlanResult,
    settings: &ScallopSettings,
    progress: &dyn Progress,
) -> Result<ScallopReport> {
    progress.check()?;
    let sim = Simulator::new(surface, tool, result)?;
    sim.run_with(settings, Method::Fast, progress)
}
