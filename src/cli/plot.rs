use crate::error::{Error, Result};
use std::path::Path;

pub fn run(_result: &Path, _job: Option<&Path>, _output: &Path) -> Result<()> {
    Err(Error::planning(
        "`toolpath plot` is not available in this build yet",
    ))
}
