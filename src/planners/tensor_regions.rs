//! Strategy `tensor_regions`: not implemented yet.

use super::Progress;
use crate::error::{Error, Result};
use crate::formats::{Job, PlanResult};

pub fn plan(_job: &Job, _progress: &dyn Progress) -> Result<PlanResult> {
    Err(Error::planning(
        "strategy tensor_regions is not available in this build yet",
    ))
}
