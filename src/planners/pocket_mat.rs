//! Strategy `pocket_mat`: not implemented yet.

use super::Progress;
use crate::error::{Error, Result};
use crate::formats::{Job, PlanResult};

pub fn plan(_job: &Job, _progress: &dyn Progress) -> Result<PlanResult> {
    Err(Error::planning(
        "strategy pocket_mat is not available in this build yet",
    ))
}
