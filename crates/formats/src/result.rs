//! Result files: passes of tool positions plus per-strategy extras.
//! Optional fields are omitted when a strategy does not produce them.

use crate::job::Job;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use toolpath_kernel::error::{Error, Result};

/// One tool position. `cc` contact point on the surface; `cl` tool tip (or, for
/// the belt, the contact-wheel centre); `axis` unit tool axis from the tip
/// towards the spindle (for the belt, the wheel axis along the belt width).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PathPoint {
    pub cc: [f64; 3],
    pub cl: [f64; 3],
    pub axis: [f64; 3],
    pub uv: [f64; 2],
    /// Machining strip width at this point, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strip_width: Option<f64>,
    /// Unit feed direction.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub feed: Option<[f64; 3]>,
    /// MPEC: lead angle at this point, degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lead_deg: Option<f64>,
    /// MPEC: "ok" | "not_applicable" | "lifted".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mpec: Option<String>,
    /// Belt: contact-wheel centre (= cl).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wheel_center: Option<[f64; 3]>,
    /// Belt: wheel axis (= axis).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wheel_axis: Option<[f64; 3]>,
    /// Surface unit normal at cc (tool side).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normal: Option<[f64; 3]>,
    /// Belt: rigid-belt gouge depth at this point, mm (reported, never hidden).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gouge: Option<f64>,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pass {
    pub region: usize,
    pub points: Vec<PathPoint>,
    /// MPEC: usable width of the pass (its narrowest strip), mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_strip_width: Option<f64>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DegeneratePoint {
    pub uv: [f64; 2],
    pub xyz: [f64; 3],
    /// "trisector" | "wedge".
    pub kind: String,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Region {
    pub id: usize,
    pub area_mm2: f64,
    pub boundary_uv: Vec<[f64; 2]>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MedialBranch {
    /// (x, y, r) samples along the branch.
    pub points: Vec<[f64; 3]>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PocketTool {
    /// "roughing" | "corner" | "root".
    pub stage: String,
    pub diameter: f64,
    /// Tool-centre paths.
    pub passes: Vec<Vec<[f64; 2]>>,
    /// Path length of this tool's passes, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path_length_mm: Option<f64>,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    pub path_length_mm: f64,
    pub passes: usize,
    /// From the simulator, never from the planner's own estimate. `None` when not simulated.
    pub max_scallop_mm: Option<f64>,
    /// Wall-clock planning time; the only field that varies between identical runs.
    pub compute_ms: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path_length_lower_bound_mm: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub points: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub machining_time_min: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_gouge_mm: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uncut_area_mm2: Option<f64>,
    /// Pockets: path length per tool stage, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path_length_per_tool_mm: Option<Vec<f64>>,
    /// Further named figures a planner reports (deterministic order).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub extra: BTreeMap<String, f64>,
}

/// A planning result.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PlanResult {
    pub job_id: String,
    pub strategy: String,
    /// [`crate::Shape::fingerprint`] of the shape planned on:
    /// `verify` and `simulate` refuse a result checked against another shape.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shape_fingerprint: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub machine: Option<String>,
    pub passes: Vec<Pass>,
    pub stats: Stats,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub degenerate_points: Option<Vec<DegeneratePoint>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub separatrices: Option<Vec<Vec<[f64; 3]>>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub regions: Option<Vec<Region>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub medial_axis: Option<Vec<MedialBranch>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dmax: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_corner_radius: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tools: Option<Vec<PocketTool>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub section_normal: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub section_normal_eigen_ratio: Option<f64>,
    /// Flat-end strategies: which candidate plan was kept and why (tensor_regions).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plan_choice: Option<String>,
    /// Milling: whether the simulator found the verified plan within the
    /// job's scallop height everywhere (`None` when not simulated).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub within_scallop: Option<bool>,
    /// A job on several faces: the face (index into the job's face list)
    /// of each pass, in pass order; the passes are grouped by face.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pass_faces: Option<Vec<usize>>,
    /// Human-readable notes (fallbacks taken, regions skipped, ...).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

impl PlanResult {
    pub fn new(job_id: &str, strategy: &str) -> Self {
        Self {
            job_id: job_id.to_string(),
            strategy: strategy.to_string(),
            ..Default::default()
        }
    }

    /// Total length of the cl polylines, mm.
    pub fn cl_path_length(&self) -> f64 {
        self.passes
            .iter()
            .map(|p| polyline_length(p.points.iter().map(|q| q.cl)))
            .sum()
    }

    /// Total number of points.
    pub fn point_count(&self) -> usize {
        self.passes.iter().map(|p| p.points.len()).sum()
    }
}

/// Refuses to check, simulate or post `result` against `job` when it was
/// planned for another job: another job_id or strategy, or (when the result
/// records it) another shape.
pub fn check_belongs(job: &Job, result: &PlanResult) -> Result<()> {
    if result.job_id != job.job_id {
        return Err(Error::invalid(
            "result.job_id",
            format!(
                "\"{}\" is not the job's \"{}\": the result belongs to another job",
                result.job_id, job.job_id
            ),
        ));
    }
    if result.strategy != job.strategy.name() {
        return Err(Error::invalid(
            "result.strategy",
            format!(
                "{} is not the job's {}: the result belongs to another job",
                result.strategy,
                job.strategy.name()
            ),
        ));
    }
    if let Some(f) = &result.shape_fingerprint {
        let own = job.shape.fingerprint();
        if *f != own {
            return Err(Error::invalid(
                "result.shape_fingerprint",
                format!(
                    "{f} is not the job's shape ({own}): the result was planned on another shape"
                ),
            ));
        }
    }
    Ok(())
}

/// Length of a 3-D polyline.
pub fn polyline_length(points: impl IntoIterator<Item = [f64; 3]>) -> f64 {
    let mut it = points.into_iter();
    let Some(mut prev) = it.next() else {
        return 0.0;
    };
    let mut len = 0.0;
    for p in it {
        len +=
            ((p[0] - prev[0]).powi(2) + (p[1] - prev[1]).powi(2) + (p[2] - prev[2]).powi(2)).sqrt();
        prev = p;
    }
    len
}

/// Length of a 2-D polyline.
pub fn polyline_length_2d(points: &[[f64; 2]]) -> f64 {
    points
        .windows(2)
        .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
        .sum()
}
