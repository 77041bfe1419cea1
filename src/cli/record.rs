use crate::error::{Error, Result};
use std::path::Path;

pub fn run(_job: &Path, _output: &Path) -> Result<()> {
    Err(Error::planning(
        "`toolpath record` is not available in this build yet",
    ))
}
