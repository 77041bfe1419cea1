//! Progress reporting from long work (planners, simulators) to its caller:
//! the CLI shows a bar, the node a `RUNNING` status.

use crate::error::Result;

/// Progress reporting from a planner to its caller (CLI bar, node status).
pub trait Progress: Sync {
    /// `fraction` in 0..=1.
    fn set(&self, fraction: f32);
    /// Why the work must stop now (`Error::Stopped`: a cancel, a time
    /// limit), checked by long loops at their progress points; `Ok` to go on.
    fn check(&self) -> Result<()> {
        Ok(())
    }
}

/// Discards progress.
pub struct NoProgress;

impl Progress for NoProgress {
    fn set(&self, _fraction: f32) {}
}

/// Checks through to `0` but reports no fractions: for work run beside other
/// work (candidate plans in parallel), whose own fractions would make the
/// caller's progress jump back and forth.
pub struct CheckOnly<'a>(pub &'a dyn Progress);

impl Progress for CheckOnly<'_> {
    fn set(&self, _fraction: f32) {}
    fn check(&self) -> Result<()> {
        self.0.check()
    }
}
