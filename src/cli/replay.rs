use crate::error::{Error, Result};
use std::path::Path;

pub fn run(_bag: &Path, _check: bool, _publish: bool) -> Result<()> {
    Err(Error::planning(
        "`toolpath replay` is not available in this build yet",
    ))
}
