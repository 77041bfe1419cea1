//! `toolpath import`: the faces of a STEP file (docs/formats.md, "STEP import").

use std::path::Path;
use toolpath_formats as formats;
use toolpath_formats::step::{FaceExtent, StepFile};
use toolpath_kernel::error::{Error, Result};

pub fn run(step: &Path, list: bool, faces: &[u64], output: &Path) -> Result<()> {
    if list != faces.is_empty() {
        return Err(Error::invalid(
            "import",
            "give either --list or at least one --face ID",
        ));
    }
    let t0 = std::time::Instant::now();
    let file = StepFile::read(step)?;
    if list {
        let summaries = file.summaries();
        if summaries.is_empty() {
            return Err(Error::invalid(
                step.display().to_string(),
                "has no faces (ADVANCED_FACE or FACE_SURFACE)",
            ));
        }
        println!(
            "{:>8}  {:<28} {:>12}  bounding box (mm)",
            "face", "surface", "area (mm²)"
        );
        for s in &summaries {
            match &s.imported {
                Ok(FaceExtent { area_mm2, lo, hi }) => println!(
                    "{:>8}  {:<28} {:>12.3}  [{:.3}, {:.3}, {:.3}] .. [{:.3}, {:.3}, {:.3}]",
                    format!("#{}", s.id),
                    s.surface_type,
                    area_mm2,
                    lo[0],
                    lo[1],
                    lo[2],
                    hi[0],
                    hi[1],
                    hi[2]
                ),
                Err(e) => println!(
                    "{:>8}  {:<28} {:>12}  not importable: {e}",
                    format!("#{}", s.id),
                    s.surface_type,
                    "-"
                ),
            }
        }
        eprintln!(
            "{} face(s), length unit {} mm, read in {:.0} ms",
            summaries.len(),
            file.mm_per_unit(),
            t0.elapsed().as_secs_f64() * 1e3
        );
        return Ok(());
    }
    let mut shapes = Vec::new();
    for &id in faces {
        shapes.push(
            serde_json::to_value(file.face(id)?)
                .map_err(|e| Error::invalid("import", e.to_string()))?,
        );
    }
    let value = if shapes.len() == 1 {
        shapes.remove(0)
    } else {
        serde_json::Value::Array(shapes)
    };
    formats::write_json(output, &value)
}
