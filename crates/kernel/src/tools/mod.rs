//! Cutting tools and the belt-grinder contact wheel. Sizes in mm.

pub mod cutter_shape;
pub mod lead_cutter;
pub mod strip_width;

pub use cutter_shape::CutterShape;
pub use lead_cutter::{LeadCutter, LeadCutterError};
pub use strip_width::{Curvatures, WidthError};

/// Belt gouge depths below this (mm) are round-off, reported as no gouge; the
/// belt planners and the removal simulation share it.
pub const BELT_GOUGE_EPS: f64 = 1e-6;

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};

/// A tool as the job names it. `radius` is always D/2.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Tool {
    FlatEnd {
        radius: f64,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        length: Option<f64>,
    },
    Ball {
        radius: f64,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        length: Option<f64>,
    },
    Torus {
        radius: f64,
        corner_radius: f64,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        length: Option<f64>,
    },
    Belt {
        width: f64,
        wheel_radius: f64,
    },
}

fn positive(field: &str, value: f64) -> Result<()> {
    if !value.is_finite() {
        return Err(Error::invalid(
            field,
            format!("{value} is not a finite number"),
        ));
    }
    if value <= 0.0 {
        return Err(Error::invalid(
            field,
            format!("must be positive, got {value}"),
        ));
    }
    Ok(())
}

impl Tool {
    pub fn kind(&self) -> &'static str {
        match self {
            Tool::FlatEnd { .. } => "flat_end",
            Tool::Ball { .. } => "ball",
            Tool::Torus { .. } => "torus",
            Tool::Belt { .. } => "belt",
        }
    }

    /// Checks sizes; field names are relative to the tool object.
    pub fn validate(&self) -> Result<()> {
        let check_length = |length: &Option<f64>| match length {
            Some(l) => positive("length", *l),
            None => Ok(()),
        };
        match self {
            Tool::FlatEnd { radius, length } | Tool::Ball { radius, length } => {
                positive("radius", *radius)?;
                check_length(length)
            }
            Tool::Torus {
                radius,
                corner_radius,
                length,
            } => {
                positive("radius", *radius)?;
                positive("corner_radius", *corner_radius)?;
                if corner_radius >= radius {
                    return Err(Error::invalid(
                        "corner_radius",
                        format!(
                            "corner radius {corner_radius} must be smaller than the cutter radius {radius} (use a ball tool when they are equal)"
                        ),
                    ));
                }
                check_length(length)
            }
            Tool::Belt {
                width,
                wheel_radius,
            } => {
                positive("width", *width)?;
                positive("wheel_radius", *wheel_radius)
            }
        }
    }

    /// Cutter radius (D/2), or the contact-wheel radius for the belt.
    pub fn radius(&self) -> f64 {
        match *self {
            Tool::FlatEnd { radius, .. }
            | Tool::Ball { radius, .. }
            | Tool::Torus { radius, .. } => radius,
            Tool::Belt { wheel_radius, .. } => wheel_radius,
        }
    }

    /// Corner radius: 0 for flat-end, R for ball, r for torus.
    pub fn corner_radius(&self) -> f64 {
        match *self {
            Tool::FlatEnd { .. } | Tool::Belt { .. } => 0.0,
            Tool::Ball { radius, .. } => radius,
            Tool::Torus { corner_radius, .. } => corner_radius,
        }
    }

    /// Flute length, with a default of 4 D when the job gives none.
    pub fn length(&self) -> f64 {
        match *self {
            Tool::FlatEnd { length, radius }
            | Tool::Ball { length, radius }
            | Tool::Torus { length, radius, .. } => length.unwrap_or(8.0 * radius),
            Tool::Belt { width, .. } => width,
        }
    }
}
