//! Strategy `belt_iso_planar`: not implemented yet.

use super::Progress;
use crate::error::{Error, Result};
use crate::formats::{Job, PlanResult};

pub fn plan(_job: &Job, _progress: &dyn Progress) -> Result<PlanResult> {
    Err(Error::planning(
        "strategy belt_iso_planar is not available in this build yet",
    ))
}
