//! Built-in sample surfaces and pockets, each with a ready job for its planner.

use crate::error::{Error, Result};
use crate::formats::{Job, JobFile, Shape, Strategy};
use crate::geometry::NurbsSurface;
use crate::tools::Tool;

pub struct SampleInfo {
    pub name: &'static str,
    pub description: &'static str,
}

pub const SAMPLES: &[SampleInfo] = &[SampleInfo {
    name: "plane",
    description: "flat 100 x 100 mm square, z = 0",
}];

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

/// Bilinear patch through four corners, degree-elevated to bicubic.
pub fn plane() -> NurbsSurface {
    let knots = vec![0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0];
    let cps: Vec<Vec<[f64; 3]>> = (0..4)
        .map(|i| {
            (0..4)
                .map(|j| [100.0 * i as f64 / 3.0, 100.0 * j as f64 / 3.0, 0.0])
                .collect()
        })
        .collect();
    NurbsSurface::new(3, 3, knots.clone(), knots, &cps, None).expect("valid sample")
}

/// The sample's shape.
pub fn shape(name: &str) -> Result<Shape> {
    match name {
        "plane" => Ok(Shape::Surface(plane())),
        _ => Err(unknown(name)),
    }
}

/// The sample's ready job (shape embedded).
pub fn job(name: &str) -> Result<Job> {
    let shape = shape(name)?;
    let file = match name {
        "plane" => JobFile {
            job_id: format!("{name}_job"),
            surface: serde_json::Value::Null,
            strategy: Strategy::IsoParametric,
            tool: Tool::FlatEnd {
                radius: 2.5,
                length: None,
            },
            machine: None,
            scallop: Some(0.05),
            tolerance: None,
            lead_angle_deg: Some(5.0),
            side_tilt_deg: None,
            feed_direction: Some(crate::formats::FeedDirection::U),
            feed_rate: Some(1000.0),
            tool_catalogue: None,
            section_normal: None,
            simulation_resolution: None,
            grinding: None,
        },
        _ => return Err(unknown(name)),
    };
    Job::new(file, shape)
}
