//! The exact reference of the fast residual: every candidate motion scanned
//! at every position and refined in full by golden section, no cut-offs.
//! Slow; built with the `reference` feature for the accuracy tests
//! (`tests/scallop_accuracy.rs`).

use super::motion::Motion;
use super::reach::ReachLine;
use super::report::ScallopReport;
use super::residual::Method;
use super::scan::scan;
use super::settings::ScallopSettings;
use super::simulator::Simulator;
use nalgebra::Vector3;
use toolpath_kernel::error::Result;
use toolpath_kernel::progress::NoProgress;

impl Simulator<'_> {
    /// [`Self::run`] with the exact reference residual everywhere. Slow; for
    /// the accuracy tests.
    pub fn run_reference(&self, settings: &ScallopSettings) -> Result<ScallopReport> {
        self.run_with(settings, Method::Reference, &NoProgress)
    }

    /// Lowest drop of the tool swept along `seg` at the line p + t n: the
    /// whole scan, then the refinement around its best position (the exact
    /// reference the fast [`Self::sweep_min`] is tested against).
    fn sweep_min_reference(&self, seg: &Motion, p: &Vector3<f64>, n: &Vector3<f64>) -> f64 {
        // Near the edge of a tool's reach the line meets the moving tool only
        // over a short stretch centred where it passes closest to the axis
        // (at the corner height): scan that position too so it is not missed.
        let s_close = self.closest_position(seg, p, n);
        let drop = |s| self.drop_at(seg, s, p, n);
        match scan(drop, self.scan_steps(seg), s_close, None) {
            Some(scanned) => Self::refine_bracket(seg, drop, scanned),
            None => f64::INFINITY,
        }
    }

    /// The exact reference of [`Self::residual`]: every candidate motion
    /// scanned and refined in full.
    pub(super) fn residual_reference(
        &self,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        scratch: &mut Vec<u32>,
    ) -> Option<f64> {
        self.candidates_sorted(p, n, scratch);
        let line = ReachLine::new(p, n, self.depth, self.cap);
        let mut best = f64::INFINITY;
        for &id in scratch.iter() {
            let Some(seg) = self.motions.get(id as usize) else {
                continue;
            };
            if !self.may_reach(seg, &line, p, n, best) {
                continue;
            }
            best = best.min(self.sweep_min_reference(seg, p, n));
        }
        (best <= self.cap).then_some(best)
    }
}
