//! Surface and pocket files (docs/formats.md).

use serde::{Deserialize, Serialize};
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::{NurbsSurface, Pocket, Trim, TrimCurve};

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
    /// The trimmed face: loops of pcurves in (u, v).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trim: Option<TrimFile>,
}

/// `"trim": {"outer": [curve, ...], "holes": [[curve, ...], ...], "tolerance": mm}`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrimFile {
    /// Sampling tolerance of the pcurves on the surface, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<f64>,
    pub outer: Vec<TrimCurveFile>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub holes: Vec<Vec<TrimCurveFile>>,
}

/// One pcurve of a loop: `{"polyline": [[u, v], ...]}` or `{"bspline": {...}}`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum TrimCurveFile {
    Polyline(Vec<[f64; 2]>),
    Bspline(BsplineCurveFile),
}

/// A 2-D B-spline pcurve (rational with `weights`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BsplineCurveFile {
    pub degree: usize,
    pub knots: Vec<f64>,
    pub control_points: Vec<[f64; 2]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weights: Option<Vec<f64>>,
}

impl TrimCurveFile {
    fn to_curve(&self) -> TrimCurve {
        match self {
            TrimCurveFile::Polyline(p) => TrimCurve::Polyline(p.clone()),
            TrimCurveFile::Bspline(b) => TrimCurve::Bspline {
                degree: b.degree,
                knots: b.knots.clone(),
                control_points: b.control_points.clone(),
                weights: b.weights.clone(),
            },
        }
    }
    fn from_curve(c: &TrimCurve) -> Self {
        match c {
            TrimCurve::Polyline(p) => TrimCurveFile::Polyline(p.clone()),
            TrimCurve::Bspline {
                degree,
                knots,
                control_points,
                weights,
            } => TrimCurveFile::Bspline(BsplineCurveFile {
                degree: *degree,
                knots: knots.clone(),
                control_points: control_points.clone(),
                weights: weights.clone(),
            }),
        }
    }
}

impl TrimFile {
    pub fn from_trim(t: &Trim) -> Self {
        let curves = |l: &[TrimCurve]| l.iter().map(TrimCurveFile::from_curve).collect();
        Self {
            tolerance: Some(t.tolerance_mm),
            outer: curves(&t.outer_curves),
            holes: t.hole_curves.iter().map(|h| curves(h)).collect(),
        }
    }
    /// Samples and validates the loops on `surface` (errors under `trim`).
    pub fn to_trim(&self, surface: &NurbsSurface) -> Result<Trim> {
        let curves = |l: &[TrimCurveFile]| l.iter().map(TrimCurveFile::to_curve).collect();
        Trim::new(
            surface,
            curves(&self.outer),
            self.holes.iter().map(|h| curves(h)).collect(),
            self.tolerance,
        )
    }
}

/// `{"kind": "pocket", "outer": [...], "holes": [...]}`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct PocketFile {
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
    pub(crate) fn from_surface(s: &NurbsSurface, name: Option<String>) -> Self {
        Self {
            kind: "nurbs".into(),
            name,
            degree_u: s.degree_u(),
            degree_v: s.degree_v(),
            knots_u: s.knots_u().to_vec(),
            knots_v: s.knots_v().to_vec(),
            control_points: s.control_grid(),
            weights: s.weight_grid(),
            trim: s.trim().map(TrimFile::from_trim),
        }
    }
    pub fn to_surface(&self) -> Result<NurbsSurface> {
        let surface = NurbsSurface::new(
            self.degree_u,
            self.degree_v,
            self.knots_u.clone(),
            self.knots_v.clone(),
            &self.control_points,
            self.weights.as_deref(),
        )?;
        match &self.trim {
            Some(t) => {
                let trim = t.to_trim(&surface)?;
                Ok(surface.with_trim(trim))
            }
            None => Ok(surface),
        }
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
    pub(crate) fn to_pocket(&self) -> Result<Pocket> {
        Pocket::new(&self.outer, &self.holes)
    }
}

/// Parses a shape object (`kind` nurbs or pocket) from JSON. Field paths in
/// errors are relative to the object.
pub(crate) fn shape_from_value(value: serde_json::Value) -> Result<Shape> {
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
