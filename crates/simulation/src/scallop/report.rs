//! What the simulator returns: the residual map over the grid, the refined
//! extrema, the covered and uncovered areas.

use serde::{Deserialize, Serialize};

/// Residual height over the surface grid. Sample `k = i * nv + j`, `i` along u
/// (cell centres). `residual[k]` is `None` where the tool never came within the
/// cap (uncovered).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResidualMap {
    pub nu: usize,
    pub nv: usize,
    pub uv: Vec<[f64; 2]>,
    pub xyz: Vec<[f64; 3]>,
    pub residual: Vec<Option<f64>>,
    /// Samples off a trimmed face (in a hole or outside the outer loop):
    /// not machined, not counted. Empty for an untrimmed surface.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub off_face: Vec<bool>,
}

impl ResidualMap {
    /// Whether sample `k` lies on the face (always, untrimmed).
    pub fn on_face(&self, k: usize) -> bool {
        !self.off_face.get(k).copied().unwrap_or(false)
    }
}

/// What the simulator found.
#[derive(Clone, Debug, PartialEq)]
pub struct ScallopReport {
    /// Highest residual over the machined (covered) area, mm (0 when nothing is covered).
    pub max_scallop_mm: f64,
    /// Deepest cut below the surface, mm, >= 0.
    pub max_gouge_mm: f64,
    /// Surface area the tool never reached, mm^2.
    pub uncovered_area_mm2: f64,
    /// Surface area the tool reached, mm^2.
    pub machined_area_mm2: f64,
    /// Grid spacing actually used, mm.
    pub resolution_mm: f64,
    pub map: ResidualMap,
    /// The residual maxima refined between grid samples, highest first
    /// (climbed from the highest grid maxima): a narrow peak above h that
    /// no grid sample shows is located here.
    pub peaks: Vec<RefinedPeak>,
}

/// A residual maximum refined between the grid samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefinedPeak {
    pub uv: [f64; 2],
    pub xyz: [f64; 3],
    pub residual: f64,
}
