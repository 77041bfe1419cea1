use crate::error::{Error, Result};
use std::path::Path;

pub fn run(_config: Option<&Path>) -> Result<()> {
    Err(Error::planning(
        "`toolpath node` is not available in this build yet",
    ))
}
