//! Built-in sample surfaces and pockets, each with a ready job for its planner
//! (`toolpath sample NAME [--job]`). They are the embedded default the demo
//! plans, and the reference cases of docs/methods.md (see the tests in
//! tests/samples.rs for the checked properties).

pub mod pockets;
pub mod random;
pub mod step_parts;
pub mod surfaces;

use toolpath_formats::{FeedDirection, Job, JobFile, Shape, Strategy};
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::NurbsSurface;
use toolpath_kernel::tools::Tool;

pub struct SampleInfo {
    pub name: &'static str,
    pub description: &'static str,
}

pub(crate) const SAMPLES: &[SampleInfo] = &[
    SampleInfo {
        name: "plane",
        description: "flat 100 x 100 mm square, z = 0 (tensor_regions, flat end R2.5)",
    },
    SampleInfo {
        name: "concave_cylinder",
        description: "trough of a radius-100 cylinder about x, 100 x 100 mm, exact rational (tensor_regions)",
    },
    SampleInfo {
        name: "monkey_saddle",
        description: "z = 1e-5 (x^3 - 3 x y^2) on [-50,50]^2, exact bicubic; trisector umbilic at 0 (tensor_regions)",
    },
    SampleInfo {
        name: "wing_mould",
        description: "blended-wing-like mould 200 x 150 mm with one trisector umbilic inside (tensor_regions)",
    },
    SampleInfo {
        name: "trimmed_saddle",
        description: "monkey saddle trimmed to a round face with an off-centre round hole (tensor_regions)",
    },
    SampleInfo {
        name: "step_freeform",
        description: "STEP part: bicubic face 120 x 90 mm trimmed by an ellipse with a round hole; `-o part.step` writes the STEP file (tensor_regions)",
    },
    SampleInfo {
        name: "step_multi_face",
        description: "STEP part: a bicubic face joined to two planes and a quarter cylinder; `-o part.step` writes the STEP file (tensor_regions on the bicubic face)",
    },
    SampleInfo {
        name: "die_saddle",
        description: "shallow hyperbolic paraboloid die 600 x 400 mm, radii 1198 / 19000 mm (mpec, torus D63R6)",
    },
    SampleInfo {
        name: "sine_wave",
        description: "z = 5 sin(2 pi x/100) on [0,100]^2, cubic in x, straight in y (belt_iso_planar)",
    },
    SampleInfo {
        name: "egg_crate",
        description: "z = 2 sin(2 pi x/50) sin(2 pi y/50) on [0,100]^2 (belt_iso_planar)",
    },
    SampleInfo {
        name: "turbine_blade",
        description: "developable (conical) cambered ruled blade, chord 70 -> 55 mm over 130 mm span, about 9 900 mm^2 (belt_iso_planar)",
    },
    SampleInfo {
        name: "rect_pocket",
        description: "rectangular pocket 100 x 60 mm (pocket_mat, flat end R5)",
    },
    SampleInfo {
        name: "pocket_with_hole",
        description: "pocket 120 x 80 mm with a round hole of radius 15 (pocket_mat)",
    },
    SampleInfo {
        name: "leaf_pocket",
        description: "leaf outline 180 mm long, two narrow necks, tip radius 1.5, two holes (pocket_mat)",
    },
];

pub fn list() -> &'static [SampleInfo] {
    SAMPLES
}

fn unknown(name: &str) -> Error {
    let names: Vec<_> = SAMPLES.iter().map(|s| s.name).collect();
    Error::invalid(
        "sample",
        format!(
            "unknown sample \"{name}\": expected one of {}",
            names.join(", ")
        ),
    )
}

/// The sample surface `name`, or an error for pockets and unknown names.
pub fn surface(name: &str) -> Result<NurbsSurface> {
    use surfaces::*;
    Ok(match name {
        "plane" => plane(),
        "concave_cylinder" => concave_cylinder(),
        "monkey_saddle" => monkey_saddle(),
        "trimmed_saddle" => trimmed_saddle(),
        "wing_mould" => wing_mould(),
        "die_saddle" => die_saddle(),
        "sine_wave" => sine_wave(),
        "egg_crate" => egg_crate(),
        "turbine_blade" => turbine_blade(),
        _ => return step_face(name),
    })
}

/// The face a STEP sample's job plans (its first face), imported from the
/// sample's own STEP text as `toolpath import --face` would.
fn step_face(name: &str) -> Result<NurbsSurface> {
    let part = step_parts::part(name).ok_or_else(|| unknown(name))?;
    let file = toolpath_formats::step::StepFile::parse(&part.text, &format!("{name}.step"), name)?;
    file.face(part.faces[0])?.to_surface()
}

/// The STEP text of a STEP sample (`toolpath sample NAME -o part.step`).
pub fn step_text(name: &str) -> Option<String> {
    step_parts::part(name).map(|p| p.text)
}

/// The sample's shape (surface or pocket).
pub fn shape(name: &str) -> Result<Shape> {
    Ok(match name {
        "rect_pocket" => Shape::Pocket(pockets::rect_pocket()),
        "pocket_with_hole" => Shape::Pocket(pockets::pocket_with_hole()),
        "leaf_pocket" => Shape::Pocket(pockets::leaf_pocket()),
        _ => Shape::Surface(surface(name)?),
    })
}

fn base_job(name: &str, strategy: Strategy, tool: Tool) -> JobFile {
    JobFile {
        feed_rate: Some(2000.0),
        ..JobFile::new(&format!("{name}_job"), strategy, Some(tool))
    }
}

/// The flat-end finishing job of the milling samples: tensor_regions, flat
/// end R 2.5, lead 5 deg, scallop 0.05 mm.
fn flat_end_job(name: &str) -> JobFile {
    JobFile {
        scallop: Some(0.05),
        lead_angle_deg: Some(5.0),
        ..base_job(
            name,
            Strategy::TensorRegions,
            Tool::FlatEnd {
                radius: 2.5,
                length: None,
            },
        )
    }
}

/// The flat-end finishing job (as for wing_mould) of a seeded random surface.
pub fn random_job(params: &random::RandomSurface) -> Result<Job> {
    let surface = params.surface()?;
    Job::new(flat_end_job(&params.name()), Shape::Surface(surface))
}

/// The sample's ready job (shape embedded).
pub fn job(name: &str) -> Result<Job> {
    let shape = shape(name)?;
    let file = match name {
        "plane" | "concave_cylinder" | "monkey_saddle" | "trimmed_saddle" | "wing_mould"
        | "step_freeform" | "step_multi_face" => flat_end_job(name),
        "die_saddle" => JobFile {
            tolerance: Some(0.01),
            feed_direction: Some(FeedDirection::U),
            ..base_job(
                name,
                Strategy::Mpec,
                Tool::Torus {
                    radius: 31.5,
                    corner_radius: 6.0,
                    length: None,
                },
            )
        },
        "sine_wave" | "egg_crate" | "turbine_blade" => JobFile {
            scallop: Some(0.01),
            ..base_job(
                name,
                Strategy::BeltIsoPlanar,
                Tool::Belt {
                    width: 10.0,
                    // The wheel must fit the egg crate's concave dips (radius
                    // about 32 mm along the feed) without gouging.
                    wheel_radius: if name == "egg_crate" { 25.0 } else { 50.0 },
                },
            )
        },
        "rect_pocket" | "pocket_with_hole" | "leaf_pocket" => base_job(
            name,
            Strategy::PocketMat,
            Tool::FlatEnd {
                radius: 5.0,
                length: None,
            },
        ),
        _ => return Err(unknown(name)),
    };
    Job::new(file, shape)
}
