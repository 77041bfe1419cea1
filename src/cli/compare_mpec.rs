use crate::error::{Error, Result};
use crate::formats::Job;

pub fn run(_job: &Job) -> Result<()> {
    Err(Error::planning(
        "`toolpath compare` (compare_mpec) is not available in this build yet",
    ))
}
