use crate::error::{Error, Result};
use std::path::Path;

pub fn run(_job: &Path, _result: &Path, _map: Option<&Path>) -> Result<()> {
    Err(Error::planning(
        "`toolpath simulate` is not available in this build yet",
    ))
}
