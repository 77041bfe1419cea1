use std::path::Path;
use toolpath_formats::{self as formats, Shape};
use toolpath_kernel::error::{Error, Result};
use toolpath_samples::{self as samples, random::RandomSurface};

/// The options of `toolpath sample random`.
pub struct RandomArgs {
    pub seed: Option<u64>,
    pub size: [f64; 2],
    pub amplitude: f64,
    pub anisotropy: f64,
}

pub fn run(
    name: Option<&str>,
    random: RandomArgs,
    list: bool,
    job: bool,
    output: &Path,
) -> Result<()> {
    if list {
        for s in samples::list() {
            println!("{:<16} {}", s.name, s.description);
        }
        println!(
            "{:<16} seeded random bicubic surface: --seed N [--size X Y] [--amplitude A] [--anisotropy K] (tensor_regions, flat end R2.5)",
            "random"
        );
        return Ok(());
    }
    let name =
        name.ok_or_else(|| Error::invalid("NAME", "give a sample name, or --list to see them"))?;
    if name == "random" {
        let seed = random
            .seed
            .ok_or_else(|| Error::invalid("--seed", "sample random needs --seed N"))?;
        let params = RandomSurface {
            seed,
            size: random.size,
            amplitude: random.amplitude,
            anisotropy: random.anisotropy,
        };
        return if job {
            formats::write_json(output, &samples::random_job(&params)?.to_file())
        } else {
            formats::write_json(output, &Shape::Surface(params.surface()?).to_json())
        };
    }
    if random.seed.is_some() {
        return Err(Error::invalid(
            "--seed",
            format!("only the random sample takes a seed, not \"{name}\""),
        ));
    }
    if job {
        formats::write_json(output, &samples::job(name)?.to_file())
    } else if let Some(text) = samples::step_text(name) {
        // A STEP sample's shape is its STEP part.
        if output == Path::new("-") {
            print!("{text}");
            Ok(())
        } else {
            std::fs::write(output, text).map_err(|e| Error::io(output.display().to_string(), e))
        }
    } else {
        formats::write_json(output, &samples::shape(name)?.to_json())
    }
}
