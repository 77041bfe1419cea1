//! What a simulation is asked for: the grid spacing and how many extrema
//! are refined, and the limits on the number of samples.

/// Simulation settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScallopSettings {
    /// Grid spacing on the surface, mm. `<= 0` (the default) means automatic:
    /// R/8 for cutter radius R (0.3125 mm for R = 2.5), made coarser if the
    /// surface would need more than [`AUTO_MAX_SAMPLES`] samples.
    pub resolution_mm: f64,
    /// How many of the grid's highest local maxima (and lowest minima) are
    /// climbed to the extremum between the samples.
    pub peak_starts: usize,
}

/// Grid extrema refined by a plain verification ([`ScallopSettings::peak_starts`]).
pub const PEAK_STARTS: usize = 24;
/// Grid extrema refined while repair passes are added: a plan with narrow
/// peaks above h (pass defects on strongly anisotropic surfaces) can hide
/// one among hundreds of ridge maxima only just below h.
pub const DEEP_PEAK_STARTS: usize = 240;

impl Default for ScallopSettings {
    fn default() -> Self {
        Self {
            resolution_mm: 0.0,
            peak_starts: PEAK_STARTS,
        }
    }
}

impl ScallopSettings {
    /// Settings with a given spacing, or automatic for `None` (a job's `simulation_resolution`).
    pub fn with_resolution(resolution_mm: Option<f64>) -> Self {
        Self {
            resolution_mm: resolution_mm.unwrap_or(0.0),
            ..Self::default()
        }
    }
}

/// Automatic resolution never asks for more samples than this.
pub const AUTO_MAX_SAMPLES: usize = 1_000_000;
/// An explicit resolution may ask for at most this many samples.
pub const MAX_SAMPLES: usize = 16_000_000;
