//! Strategy `belt_iso_parametric`: not implemented yet.

use crate::error::{Error, Result};
use crate::formats::{Job, PlanResult};
use super::Progress;

pub fn plan(_job: &Job, _progress: &dyn Progress) -> Result<PlanResult> {
    Err(Error::planning("strategy belt_iso_parametric is not available in this build yet"))
}
