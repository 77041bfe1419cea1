//! Surface and pocket files (docs/formats.md).

use crate::error::{Error, Result};
use crate::geometry::{NurbsSurface, Pocket};
use serde::{Deserialize, Serialize};

/// `{"kind": "nurbs", ...}` as in the file format. Control points `[i][j]`, i along u.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SurfaceFile {
    pub kind: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    pub degree_u: usize,
    pub degree_v: usize,
    pub knots_u: Vec<f64>,
    pub knots_v: Vec<f64>,
    pub control_points: Vec<Vec<[f64; 3]>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weights: Option<Vec<Vec<f64>>>,
}

/// `{"kind": "pocket", "outer": [...], "holes": [...]}`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PocketFile {
    pub kind: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    pub outer: Vec<[f64; 2]>,
    #[serde(default)]
    pub holes: Vec<Vec<[f64; 2]>>,
}

/// What a job machines: a freeform surface or a 2.5-axis pocket.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    Surface(NurbsSurface),
    Pocket(Pocket),
}

impl Shape {
    pub fn as_surface(&self) -> Option<&NurbsSurface> {
        match self {
            Shape::Surface(s) => Some(s),
            Shape::Pocket(_) => None,
        }
    }
    pub fn as_pocket(&self) -> Option<&Pocket> {
        match self {
            Shape::Pocket(p) => Some(p),
            Shape::Surface(_) => None,
        }
    }
    /// A fingerprint of the geometry: FNV-1a (64 bit) of the file form's
    /// JSON, as `fnv1a64:` and 16 hex digits. Equal shapes give equal
    /// fingerprints; a name is not part of it.
    pub fn fingerprint(&self) -> String {
        let bytes = serde_json::to_vec(&self.to_json()).expect("serialisable");
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in bytes {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
        format!("fnv1a64:{h:016x}")
    }
    /// The file form, for writing samples and embedding in jobs.
    pub fn to_json(&self) -> serde_json::Value {
        match self {
            Shape::Surface(s) => {
                serde_json::to_value(SurfaceFile::from_surface(s, None)).expect("serialisable")
            }
            Shape::Pocket(p) => {
                serde_json::to_value(PocketFile::from_pocket(p, None)).expect("serialisable")
            }
        }
    }
}

impl SurfaceFile {
    pub fn from_surface(s: &NurbsSurface, name: Option<String>) -> Self {
        Self {
            kind: "nurbs".into(),
            name,
            degree_u: s.degree_u(),
            degree_v: s.degree_v(),
            knots_u: s.knots_u().to_vec(),
            knots_v: s.knots_v().to_vec(),
            control_points: s.control_grid(),
            weights: s.weight_grid(),
        }
    }
    pub fn to_surface(&self) -> Result<NurbsSurface> {
        NurbsSurface::new(
            self.degree_u,
            self.degree_v,
            self.knots_u.clone(),
            self.knots_v.clone(),
            &self.control_points,
            self.weights.as_deref(),
        )
    }
}

impl PocketFile {
    pub fn from_pocket(p: &Pocket, name: Option<String>) -> Self {
        Self {
            kind: "pocket".into(),
            name,
            outer: p.outer.clone(),
            holes: p.holes.clone(),
        }
    }
    pub fn to_pocket(&self) -> Result<Pocket> {
        Pocket::new(&self.outer, &self.holes)
    }
}

/// Parses a shape object (`kind` nurbs or pocket) from JSON. Field paths in
/// errors are relative to the object.
pub fn shape_from_value(value: serde_json::Value) -> Result<Shape> {
    let kind = match value.get("kind") {
        Some(serde_json::Value::String(k)) => k.clone(),
        Some(_) => {
            return Err(Error::invalid(
                "kind",
                "must be a string: \"nurbs\" or \"pocket\"",
            ))
        }
        None => {
            return Err(Error::invalid(
                "kind",
                "missing field: a surface needs \"kind\": \"nurbs\" (or \"pocket\")",
            ))
        }
    };
    match kind.as_str() {
        "nurbs" => {
            let f: SurfaceFile = super::from_value(value)?;
            Ok(Shape::Surface(f.to_surface()?))
        }
        "pocket" => {
            let f: PocketFile = super::from_value(value)?;
            Ok(Shape::Pocket(f.to_pocket()?))
        }
        other => Err(Error::invalid(
            "kind",
            format!("unknown kind \"{other}\": expected \"nurbs\" or \"pocket\""),
        )),
    }
}
