use crate::error::{Error, Result};
use crate::formats;
use crate::samples;
use std::path::Path;

pub fn run(name: Option<&str>, list: bool, job: bool, output: &Path) -> Result<()> {
    if list {
        for s in samples::list() {
            println!("{:<16} {}", s.name, s.description);
        }
        return Ok(());
    }
    let name =
        name.ok_or_else(|| Error::invalid("NAME", "give a sample name, or --list to see them"))?;
    if job {
        formats::write_json(output, &samples::job(name)?.to_file())
    } else {
        formats::write_json(output, &samples::shape(name)?.to_json())
    }
}
