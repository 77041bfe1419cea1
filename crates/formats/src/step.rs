//! STEP import (docs/formats.md, "STEP import"): the faces of a Part 21 file
//! (AP203/AP214/AP242) as trimmed NURBS surfaces in mm.
//!
//! ruststep parses the exchange structure into its generic records; the
//! mapping of the few entities a face needs onto our shapes is written here:
//! `ADVANCED_FACE` (or `FACE_SURFACE`) on `B_SPLINE_SURFACE_WITH_KNOTS`
//! (rational or not), `PLANE`, or a surface of revolution (`CYLINDRICAL_`,
//! `CONICAL_`, `SPHERICAL_`, `TOROIDAL_SURFACE`, `SURFACE_OF_REVOLUTION`),
//! or `SURFACE_OF_LINEAR_EXTRUSION`, all converted to exact NURBS, bounded by `EDGE_LOOP`s of `EDGE_CURVE`s on `LINE`,
//! `CIRCLE`, `ELLIPSE` and B-spline curves. On a B-spline surface an edge
//! uses its pcurve on that surface when the file gives one; every other edge
//! (and every edge of a plane, revolved or extruded surface, whose own parametrisation differs
//! from the NURBS written) is its 3-D curve projected onto the surface. Each
//! loop is written as one closed polyline in (u, v), sampled so that the
//! surface image of every chord stays within the trim tolerance of the edge.
//! Lengths are converted to mm from the file's length unit. The face's
//! orientation is honoured: a face whose `same_sense` is false gets its u
//! direction reversed, so the surface normal is the face's.

use super::shape::{SurfaceFile, TrimCurveFile, TrimFile};
use nalgebra::{Point3, Vector2, Vector3};
use ruststep::ast::{EntityInstance, Name, Parameter, Record};
use std::collections::BTreeMap;
use std::f64::consts::{PI, TAU};
use std::path::Path;
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::inversion::{closest_point, closest_point_near};
use toolpath_kernel::geometry::trim::DEFAULT_TOLERANCE_MM;
use toolpath_kernel::geometry::NurbsSurface;

/// Largest STEP file read, bytes.
pub const MAX_STEP_BYTES: u64 = 512 << 20;

/// Surface types a face may lie on.
pub const SUPPORTED_SURFACES: &str = "B_SPLINE_SURFACE_WITH_KNOTS, PLANE, CYLINDRICAL_SURFACE, CONICAL_SURFACE, SPHERICAL_SURFACE, TOROIDAL_SURFACE, SURFACE_OF_REVOLUTION, SURFACE_OF_LINEAR_EXTRUSION";

/// Grid cells per direction of the area integration of `--list`.
pub const LIST_CELLS: usize = 128;

/// Deepest bisection of an edge's parameter range when sampling it.
const MAX_DEPTH: u32 = 18;

/// Pieces per edge of the samples that bound a plane's or revolved
/// surface's patch: fine enough that a curved edge's bulge between two of
/// them stays far below the trim tolerance (a boundary point outside the
/// patch would be clamped onto it and never meet the tolerance).
const COARSE: usize = 256;

/// Uniform pieces an edge starts from before bisection.
const START_PIECES: usize = 8;

/// Bisection steps one trim loop may take to follow its edges within the
/// tolerance: hundreds of times what the test parts need. An edge that
/// would need more (a degenerate curve or map that bisection never
/// resolves) ends the sampling there and the face is refused, instead of
/// bisecting every piece to [`MAX_DEPTH`] (millions of point inversions).
const MAX_LOOP_STEPS: usize = 100_000;

type V3 = Vector3<f64>;

/// One face of a STEP file, as `toolpath import --list` shows it.
#[derive(Clone, Debug)]
pub struct FaceSummary {
    pub id: u64,
    /// The surface entity's type, e.g. `B_SPLINE_SURFACE_WITH_KNOTS`.
    pub surface_type: String,
    /// Area of the trimmed face (mm²) and its bounding box (mm), or why the
    /// face cannot be imported.
    pub imported: std::result::Result<(f64, [f64; 3], [f64; 3]), String>,
}

/// A parsed STEP file: its entity instances by id and its length unit.
pub struct StepFile {
    label: String,
    stem: String,
    entities: BTreeMap<u64, Vec<Record>>,
    mm_per_unit: f64,
    radians_per_unit: f64,
}

/// A curve in the file's space (3-D, mm) or in a surface's (u, v) (z = 0).
#[derive(Clone, Debug)]
enum Curve {
    /// `p + t d`.
    Line { p: V3, d: V3 },
    /// `c + a cos t x + b sin t y` (a circle when a = b).
    Conic { c: V3, x: V3, y: V3, a: f64, b: f64 },
    /// Homogeneous control points `(w x, w y, w z, w)`, full knot vector.
    Bspline {
        degree: usize,
        knots: Vec<f64>,
        points: Vec<[f64; 4]>,
    },
}

impl Curve {
    fn point(&self, t: f64) -> V3 {
        match self {
            Curve::Line { p, d } => p + d * t,
            Curve::Conic { c, x, y, a, b } => c + x * (a * t.cos()) + y * (b * t.sin()),
            Curve::Bspline {
                degree,
                knots,
                points,
            } => de_boor(*degree, knots, points, t),
        }
    }

    fn periodic(&self) -> bool {
        matches!(self, Curve::Conic { .. })
    }

    /// The parameter of the curve's point nearest `q`.
    fn locate(&self, q: &V3) -> f64 {
        match self {
            Curve::Line { p, d } => (q - p).dot(d) / d.norm_squared(),
            Curve::Conic { c, x, y, a, b } => {
                let r = q - c;
                (r.dot(y) / b).atan2(r.dot(x) / a)
            }
            Curve::Bspline { degree, knots, .. } => {
                let (t0, t1) = (knots[*degree], knots[knots.len() - degree - 1]);
                let n = 400;
                let at = |k: usize| t0 + (t1 - t0) * k as f64 / n as f64;
                let dist = |t: f64| (self.point(t) - q).norm_squared();
                let best = (0..=n)
                    .min_by(|&i, &j| dist(at(i)).total_cmp(&dist(at(j))))
                    .unwrap_or(0);
                // Golden-section search on the samples' neighbourhood.
                let (mut lo, mut hi) = (at(best.saturating_sub(1)), at((best + 1).min(n)));
                let g = 0.5 * (5f64.sqrt() - 1.0);
                for _ in 0..80 {
                    let (m1, m2) = (hi - g * (hi - lo), lo + g * (hi - lo));
                    if dist(m1) <= dist(m2) {
                        hi = m2;
                    } else {
                        lo = m1;
                    }
                }
                0.5 * (lo + hi)
            }
        }
    }

    /// The parameter range of a bounded curve.
    fn range(&self) -> Option<(f64, f64)> {
        match self {
            Curve::Bspline { degree, knots, .. } => {
                Some((knots[*degree], knots[knots.len() - degree - 1]))
            }
            Curve::Conic { .. } => Some((0.0, TAU)),
            Curve::Line { .. } => None,
        }
    }
}

/// A 3-D curve in the plane through `o` spanned by `e1` and `e2` (unit,
/// orthogonal), as a 2-D meridian: each point (or direction) replaced by its
/// two coordinates along them. A curve in that plane keeps its shape and
/// parameter; any other is projected onto it, still a line, conic or
/// B-spline of the same parameter.
fn plane_curve(curve: &Curve, o: V3, e1: V3, e2: V3) -> Meridian {
    let m2 = |q: &V3| [(q - o).dot(&e1), (q - o).dot(&e2)];
    let v2 = |d: &V3| [d.dot(&e1), d.dot(&e2)];
    match curve {
        Curve::Line { p, d } => Meridian::Line { p: m2(p), d: v2(d) },
        Curve::Conic { c, x, y, a, b } => Meridian::Conic {
            c: m2(c),
            a: v2(&(x * *a)),
            b: v2(&(y * *b)),
        },
        Curve::Bspline {
            degree,
            knots,
            points,
        } => Meridian::Bspline(Curve::Bspline {
            degree: *degree,
            knots: knots.clone(),
            points: points
                .iter()
                .map(|h| {
                    let q = m2(&V3::new(h[0] / h[3], h[1] / h[3], h[2] / h[3]));
                    [q[0] * h[3], q[1] * h[3], 0.0, h[3]]
                })
                .collect(),
        }),
    }
}

/// Digits a whole number (an integer, an entity id, the integral part or
/// exponent of a real) may have: an i64 holds every 18-digit number.
const MAX_INTEGER_DIGITS: usize = 18;

/// Refuses a whole number too long for an i64 outside strings and comments,
/// naming its line: ruststep parses these with an `expect` that panics.
/// The fraction of a real (digits after its point) may be any length.
fn check_number_lengths(text: &str) -> std::result::Result<(), String> {
    let bytes = text.as_bytes();
    let (mut i, mut line) = (0, 1);
    while i < bytes.len() {
        match bytes[i] {
            b'\n' => line += 1,
            // A string ends at the next quote ('' inside is two strings
            // back to back, which skips the same way).
            b'\'' => {
                i += 1;
                while i < bytes.len() && bytes[i] != b'\'' {
                    line += usize::from(bytes[i] == b'\n');
                    i += 1;
                }
            }
            b'/' if bytes.get(i + 1) == Some(&b'*') => {
                i += 2;
                while i < bytes.len() && !(bytes[i] == b'*' && bytes.get(i + 1) == Some(&b'/')) {
                    line += usize::from(bytes[i] == b'\n');
                    i += 1;
                }
                i += 1;
            }
            c if c.is_ascii_digit() => {
                let start = i;
                while i < bytes.len() && bytes[i].is_ascii_digit() {
                    i += 1;
                }
                let fraction = start > 0 && bytes[start - 1] == b'.';
                let digits = bytes[start..i].iter().skip_while(|&&d| d == b'0').count();
                if !fraction && digits > MAX_INTEGER_DIGITS {
                    return Err(format!(
                        "line {line}: the number {} has more than {MAX_INTEGER_DIGITS} digits",
                        &text[start..i]
                    ));
                }
                continue;
            }
            _ => {}
        }
        i += 1;
    }
    Ok(())
}

/// Point of a rational B-spline curve at `t` (de Boor on homogeneous points).
fn de_boor(p: usize, knots: &[f64], pts: &[[f64; 4]], t: f64) -> V3 {
    let n = pts.len();
    let t = t.clamp(knots[p], knots[n]);
    let mut k = p;
    while k + 1 < n && knots[k + 1] <= t {
        k += 1;
    }
    let mut d: Vec<[f64; 4]> = (0..=p).map(|j| pts[j + k - p]).collect();
    for r in 1..=p {
        for j in (r..=p).rev() {
            let i = j + k - p;
            let den = knots[i + p + 1 - r] - knots[i];
            let a = if den > 0.0 { (t - knots[i]) / den } else { 0.0 };
            let prev = d[j - 1];
            for (c, x) in d[j].iter_mut().enumerate() {
                *x = (1.0 - a) * prev[c] + a * *x;
            }
        }
    }
    let h = d[p];
    V3::new(h[0] / h[3], h[1] / h[3], h[2] / h[3])
}

/// The surface a face lies on, as read.
enum Basis {
    Bspline(SurfaceFile),
    Plane(Frame),
    /// A surface of revolution about the frame's z axis (cylinder, cone,
    /// sphere, torus, `SURFACE_OF_REVOLUTION`), named for messages.
    Revolved(Frame, Meridian, &'static str),
    /// A `SURFACE_OF_LINEAR_EXTRUSION` along the frame's z: its swept
    /// curve projected along z onto the frame's (x, y) plane (the section).
    Extruded(Frame, Meridian),
}

/// The meridian of a surface of revolution in the frame's (rho, h) half
/// plane: rho along the frame's x (distance from the axis), h along its z.
#[derive(Clone)]
enum Meridian {
    /// `p + s d`: a cylinder (d = (0, 1)), a cone (d = (tan a, 1)) or a
    /// swept line.
    Line { p: [f64; 2], d: [f64; 2] },
    /// `c + a cos s + b sin s`: a sphere, a torus or a swept circle or
    /// ellipse.
    Conic {
        c: [f64; 2],
        a: [f64; 2],
        b: [f64; 2],
    },
    /// A swept B-spline curve: homogeneous (w rho, w h, 0, w) points.
    Bspline(Curve),
}

impl Meridian {
    /// The parameter of the meridian point nearest `m` = (rho, h); a conic's
    /// angle is taken within half a turn of `seed`.
    fn locate(&self, m: [f64; 2], seed: Option<f64>) -> f64 {
        match self {
            Meridian::Line { p, d } => {
                ((m[0] - p[0]) * d[0] + (m[1] - p[1]) * d[1]) / (d[0] * d[0] + d[1] * d[1])
            }
            Meridian::Conic { c, a, b } => {
                // Solve m - c = a cos s + b sin s for (cos s, sin s).
                let (x, y) = (m[0] - c[0], m[1] - c[1]);
                let det = a[0] * b[1] - a[1] * b[0];
                let cs = (x * b[1] - y * b[0]) / det;
                let sn = (a[0] * y - a[1] * x) / det;
                let s = sn.atan2(cs);
                match seed {
                    Some(sd) => s + TAU * ((sd - s) / TAU).round(),
                    None => s,
                }
            }
            Meridian::Bspline(c) => c.locate(&V3::new(m[0], m[1], 0.0)),
        }
    }
}

/// How a meridian parameter s maps to the patch's v: itself (lines and
/// B-splines), or through the conic's rational arcs.
#[derive(Clone, Copy)]
enum VMap {
    Same,
    Arcs(Arcs),
}

impl VMap {
    fn v_of(&self, s: f64) -> f64 {
        match self {
            VMap::Same => s,
            VMap::Arcs(a) => a.u_of(s),
        }
    }

    fn s_of(&self, v: f64) -> f64 {
        match self {
            VMap::Same => v,
            VMap::Arcs(a) => a.theta_of(v),
        }
    }
}

/// Knots of `n` rational quadratic arcs over [0, 1].
fn arc_knots(n: usize) -> Vec<f64> {
    let mut k = vec![0.0; 3];
    for i in 1..n {
        let u = i as f64 / n as f64;
        k.extend([u, u]);
    }
    k.extend([1.0; 3]);
    k
}

/// An `AXIS2_PLACEMENT_3D`: origin and right-handed unit axes.
#[derive(Clone, Copy)]
struct Frame {
    o: V3,
    x: V3,
    y: V3,
    z: V3,
}

/// One edge of a loop: a curve (3-D, or a pcurve in (u, v)) run from `ta` to `tb`.
struct EdgeUse {
    id: u64,
    curve: Curve,
    in_uv: bool,
    ta: f64,
    tb: f64,
}

/// The angle parametrisation of a revolved NURBS: `n` rational quadratic
/// arcs of `delta` radians each from `theta0`, u in [0, 1].
#[derive(Clone, Copy)]
struct Arcs {
    theta0: f64,
    delta: f64,
    n: usize,
}

impl Arcs {
    fn new(theta0: f64, theta1: f64) -> Self {
        let span = (theta1 - theta0).max(1e-9);
        let n = (span / (0.5 * PI) - 1e-9).ceil().max(1.0) as usize;
        Arcs {
            theta0,
            delta: span / n as f64,
            n,
        }
    }

    /// u of angle `theta`: on the arc from -a to a with weights 1, cos a, 1,
    /// the point at parameter s in [0, 1] has angle psi with
    /// tan(psi / 2) = tan(a / 2) (2 s - 1) (docs/formats.md, "STEP import").
    fn u_of(&self, theta: f64) -> f64 {
        let s = (theta - self.theta0) / self.delta;
        let k = (s.floor().max(0.0) as usize).min(self.n - 1);
        let psi = theta - self.theta0 - (k as f64 + 0.5) * self.delta;
        let t = 0.5 * (1.0 + (0.5 * psi).tan() / (0.25 * self.delta).tan());
        ((k as f64 + t) / self.n as f64).clamp(0.0, 1.0)
    }

    fn theta_of(&self, u: f64) -> f64 {
        let s = u.clamp(0.0, 1.0) * self.n as f64;
        let k = (s.floor() as usize).min(self.n - 1);
        let t = s - k as f64;
        let psi = 2.0 * ((0.25 * self.delta).tan() * (2.0 * t - 1.0)).atan();
        self.theta0 + (k as f64 + 0.5) * self.delta + psi
    }
}

fn name_of(records: &[Record]) -> String {
    if records.len() == 1 {
        records[0].name.clone()
    } else {
        format!(
            "({})",
            records
                .iter()
                .map(|r| r.name.as_str())
                .collect::<Vec<_>>()
                .join(" ")
        )
    }
}

fn list(p: &Parameter) -> Option<&[Parameter]> {
    match p {
        Parameter::List(v) => Some(v),
        _ => None,
    }
}

impl StepFile {
    /// Reads and parses a STEP file.
    pub fn read(path: &Path) -> Result<Self> {
        let bytes = super::read_file_limited(path, MAX_STEP_BYTES)?;
        let text = String::from_utf8_lossy(&bytes);
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "step".into());
        Self::parse(&text, &path.display().to_string(), &stem)
    }

    /// Parses Part 21 text; `label` names the file in errors.
    pub fn parse(text: &str, label: &str, stem: &str) -> Result<Self> {
        let bad = |m: String| Error::invalid(label, m);
        let trimmed = text.trim_end();
        if !trimmed.starts_with("ISO-10303-21;") {
            return Err(bad(
                "is not a STEP file (it does not start with ISO-10303-21;)".into(),
            ));
        }
        if !trimmed.ends_with("END-ISO-10303-21;") {
            return Err(bad(
                "is truncated: it does not end with END-ISO-10303-21;".into()
            ));
        }
        check_number_lengths(text).map_err(bad)?;
        let exchange = ruststep::parser::parse(text).map_err(|e| {
            let first = e.to_string();
            let first = first.lines().take(6).collect::<Vec<_>>().join(" | ");
            bad(format!("is not valid STEP (Part 21): {first}"))
        })?;
        let mut entities = BTreeMap::new();
        for section in exchange.data {
            for e in section.entities {
                let (id, records) = match e {
                    EntityInstance::Simple { id, record } => (id, vec![record]),
                    EntityInstance::Complex { id, subsuper } => (id, subsuper.0),
                };
                if entities.insert(id, records).is_some() {
                    return Err(bad(format!("#{id} is defined twice")));
                }
            }
        }
        let mut file = StepFile {
            label: label.to_string(),
            stem: stem.to_string(),
            entities,
            mm_per_unit: 1.0,
            radians_per_unit: 1.0,
        };
        file.mm_per_unit = file.length_unit()?;
        file.radians_per_unit = file.angle_unit()?;
        Ok(file)
    }

    /// Millimetres per length unit of the file.
    pub fn mm_per_unit(&self) -> f64 {
        self.mm_per_unit
    }

    fn err(&self, id: u64, message: impl Into<String>) -> Error {
        let what = self
            .entities
            .get(&id)
            .map(|r| name_of(r))
            .unwrap_or_else(|| "(undefined)".into());
        Error::invalid(format!("{}: #{id} {what}", self.label), message)
    }

    fn records(&self, id: u64) -> Result<&[Record]> {
        self.entities.get(&id).map(|r| r.as_slice()).ok_or_else(|| {
            Error::invalid(&self.label, format!("#{id} is referenced but not defined"))
        })
    }

    /// Type name of a simple instance (or the complex one's parts).
    fn kind(&self, id: u64) -> Result<String> {
        Ok(name_of(self.records(id)?))
    }

    /// The parameters of the record named `name` in instance `id`.
    fn part(&self, id: u64, name: &str) -> Option<&[Parameter]> {
        self.entities
            .get(&id)?
            .iter()
            .find(|r| r.name == name)
            .and_then(|r| list(&r.parameter))
    }

    /// Parameters of `id`, which must be one of `names` (simple instances).
    fn expect(&self, id: u64, names: &[&str]) -> Result<(&str, &[Parameter])> {
        let records = self.records(id)?;
        if records.len() == 1 && names.contains(&records[0].name.as_str()) {
            if let Some(p) = list(&records[0].parameter) {
                return Ok((records[0].name.as_str(), p));
            }
        }
        Err(self.err(
            id,
            format!("is not supported here (expected {})", names.join(" or ")),
        ))
    }

    fn arg<'a>(&self, id: u64, p: &'a [Parameter], i: usize) -> Result<&'a Parameter> {
        p.get(i).ok_or_else(|| {
            self.err(
                id,
                format!("has too few parameters (no parameter {})", i + 1),
            )
        })
    }

    fn reference(&self, id: u64, p: &[Parameter], i: usize) -> Result<u64> {
        match self.arg(id, p, i)? {
            Parameter::Ref(Name::Entity(r)) => Ok(*r),
            other => Err(self.err(
                id,
                format!("parameter {} should be a reference, found {other:?}", i + 1),
            )),
        }
    }

    fn references(&self, id: u64, p: &[Parameter], i: usize) -> Result<Vec<u64>> {
        let items = list(self.arg(id, p, i)?)
            .ok_or_else(|| self.err(id, format!("parameter {} should be a list", i + 1)))?;
        items
            .iter()
            .map(|x| match x {
                Parameter::Ref(Name::Entity(r)) => Ok(*r),
                other => Err(self.err(
                    id,
                    format!(
                        "parameter {} should list references, found {other:?}",
                        i + 1
                    ),
                )),
            })
            .collect()
    }

    fn real_of(&self, id: u64, x: &Parameter, i: usize) -> Result<f64> {
        let v = match x {
            Parameter::Real(v) => *v,
            Parameter::Integer(v) => *v as f64,
            Parameter::Typed { parameter, .. } => return self.real_of(id, parameter, i),
            other => {
                return Err(self.err(
                    id,
                    format!("parameter {} should be a number, found {other:?}", i + 1),
                ))
            }
        };
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(id, format!("parameter {} is not finite", i + 1)))
        }
    }

    fn real(&self, id: u64, p: &[Parameter], i: usize) -> Result<f64> {
        self.real_of(id, self.arg(id, p, i)?, i)
    }

    fn reals(&self, id: u64, p: &[Parameter], i: usize) -> Result<Vec<f64>> {
        let items = list(self.arg(id, p, i)?)
            .ok_or_else(|| self.err(id, format!("parameter {} should be a list", i + 1)))?;
        items.iter().map(|x| self.real_of(id, x, i)).collect()
    }

    fn boolean(&self, id: u64, p: &[Parameter], i: usize) -> Result<bool> {
        match self.arg(id, p, i)? {
            Parameter::Enumeration(e) if e.trim_matches('.') == "T" => Ok(true),
            Parameter::Enumeration(e) if e.trim_matches('.') == "F" => Ok(false),
            other => Err(self.err(
                id,
                format!("parameter {} should be .T. or .F., found {other:?}", i + 1),
            )),
        }
    }

    fn integer(&self, id: u64, p: &[Parameter], i: usize) -> Result<usize> {
        match self.arg(id, p, i)? {
            Parameter::Integer(v) if *v >= 0 => Ok(*v as usize),
            other => Err(self.err(
                id,
                format!("parameter {} should be a count, found {other:?}", i + 1),
            )),
        }
    }

    /// The length unit named by the representation contexts, in mm: an
    /// `SI_UNIT` on metres with its prefix, or a `CONVERSION_BASED_UNIT`
    /// (inch, foot, ...) through its measure. Files naming none are in mm.
    fn length_unit(&self) -> Result<f64> {
        let mut found: Option<(u64, f64)> = None;
        for u in self.context_units()? {
            if self.part(u, "LENGTH_UNIT").is_none() {
                continue;
            }
            let mm = self.unit_mm(u, 0)?;
            match found {
                Some((other, f)) if (f - mm).abs() > 1e-12 * f => {
                    return Err(self.err(
                        u,
                        format!("disagrees with the length unit #{other} ({f} mm): one length unit per file is supported"),
                    ))
                }
                _ => found = Some((u, mm)),
            }
        }
        Ok(found.map(|(_, f)| f).unwrap_or(1.0))
    }

    /// The plane angle unit in radians: an `SI_UNIT` radian, or a
    /// `CONVERSION_BASED_UNIT` (degree) through its measure. Files naming
    /// none are in radians.
    fn angle_unit(&self) -> Result<f64> {
        for u in self.context_units()? {
            if self.part(u, "PLANE_ANGLE_UNIT").is_some() {
                return self.unit_rad(u, 0);
            }
        }
        Ok(1.0)
    }

    /// The unit entities every `GLOBAL_UNIT_ASSIGNED_CONTEXT` lists, in
    /// entity order.
    fn context_units(&self) -> Result<Vec<u64>> {
        let mut out = Vec::new();
        for (&id, records) in &self.entities {
            let Some(r) = records
                .iter()
                .find(|r| r.name == "GLOBAL_UNIT_ASSIGNED_CONTEXT")
            else {
                continue;
            };
            let units = list(&r.parameter)
                .and_then(|p| p.first())
                .and_then(list)
                .ok_or_else(|| {
                    self.err(id, "GLOBAL_UNIT_ASSIGNED_CONTEXT should list its units")
                })?;
            out.extend(units.iter().filter_map(|u| match u {
                Parameter::Ref(Name::Entity(u)) => Some(*u),
                _ => None,
            }));
        }
        Ok(out)
    }

    fn unit_rad(&self, id: u64, depth: usize) -> Result<f64> {
        if depth > 8 {
            return Err(self.err(id, "unit conversions nest too deeply"));
        }
        if let Some(p) = self.part(id, "SI_UNIT") {
            return match self.arg(id, p, 1)? {
                Parameter::Enumeration(e) if e.trim_matches('.') == "RADIAN" => Ok(1.0),
                other => Err(self.err(id, format!("is not a plane angle unit ({other:?})"))),
            };
        }
        if let Some(p) = self.part(id, "CONVERSION_BASED_UNIT") {
            let m = self.reference(id, p, 1)?;
            let records = self.records(m)?;
            let mp = records
                .iter()
                .find(|r| r.name.ends_with("MEASURE_WITH_UNIT"))
                .and_then(|r| list(&r.parameter))
                .ok_or_else(|| self.err(m, "should be a PLANE_ANGLE_MEASURE_WITH_UNIT"))?;
            let factor = self.real(m, mp, 0)?;
            let base = self.unit_rad(self.reference(m, mp, 1)?, depth + 1)?;
            return Ok(factor * base);
        }
        Err(self.err(id, "is a plane angle unit of an unsupported kind"))
    }

    fn unit_mm(&self, id: u64, depth: usize) -> Result<f64> {
        if depth > 8 {
            return Err(self.err(id, "unit conversions nest too deeply"));
        }
        if let Some(p) = self.part(id, "SI_UNIT") {
            let prefix = match self.arg(id, p, 0)? {
                Parameter::Enumeration(e) => e.trim_matches('.').to_string(),
                _ => String::new(),
            };
            match self.arg(id, p, 1)? {
                Parameter::Enumeration(e) if e.trim_matches('.') == "METRE" => {}
                other => return Err(self.err(id, format!("is not a length unit ({other:?})"))),
            }
            let scale = match prefix.as_str() {
                "" => 1e3,
                "MILLI" => 1.0,
                "CENTI" => 10.0,
                "DECI" => 100.0,
                "MICRO" => 1e-3,
                "NANO" => 1e-6,
                "KILO" => 1e6,
                other => return Err(self.err(id, format!("has an unsupported prefix .{other}."))),
            };
            return Ok(scale);
        }
        if let Some(p) = self.part(id, "CONVERSION_BASED_UNIT") {
            let m = self.reference(id, p, 1)?;
            let records = self.records(m)?;
            let mp = records
                .iter()
                .find(|r| r.name.ends_with("MEASURE_WITH_UNIT"))
                .and_then(|r| list(&r.parameter))
                .ok_or_else(|| self.err(m, "should be a LENGTH_MEASURE_WITH_UNIT"))?;
            let factor = self.real(m, mp, 0)?;
            let base = self.unit_mm(self.reference(m, mp, 1)?, depth + 1)?;
            return Ok(factor * base);
        }
        Err(self.err(id, "is a length unit of an unsupported kind"))
    }

    /// Ids of the faces (`ADVANCED_FACE`, `FACE_SURFACE`), ascending.
    pub fn face_ids(&self) -> Vec<u64> {
        self.entities
            .iter()
            .filter(|(_, r)| {
                r.len() == 1 && (r[0].name == "ADVANCED_FACE" || r[0].name == "FACE_SURFACE")
            })
            .map(|(&id, _)| id)
            .collect()
    }

    /// Every face with its surface type, area and bounding box.
    pub fn summaries(&self) -> Vec<FaceSummary> {
        self.face_ids()
            .into_iter()
            .map(|id| {
                let surface_type = self
                    .face_surface(id)
                    .map(|s| self.surface_type(s))
                    .unwrap_or_else(|_| "?".into());
                let imported = self
                    .face(id)
                    .and_then(|f| {
                        let s = f.to_surface()?;
                        let area = s.trim().map(|t| t.face_area(&s, LIST_CELLS)).unwrap_or(0.0);
                        let (lo, hi) = face_box(&s);
                        Ok((area, lo, hi))
                    })
                    .map_err(|e| e.to_string());
                FaceSummary {
                    id,
                    surface_type,
                    imported,
                }
            })
            .collect()
    }

    /// The surface's entity type; a complex B-spline surface is named by
    /// its most specific part.
    fn surface_type(&self, id: u64) -> String {
        if self.part(id, "RATIONAL_B_SPLINE_SURFACE").is_some() {
            return "RATIONAL_B_SPLINE_SURFACE".into();
        }
        self.kind(id).unwrap_or_else(|_| "?".into())
    }

    fn face_surface(&self, id: u64) -> Result<u64> {
        let (_, p) = self.expect(id, &["ADVANCED_FACE", "FACE_SURFACE"])?;
        self.reference(id, p, 2)
    }

    /// Face `id` as a trimmed surface in mm (named `STEM_ID`).
    pub fn face(&self, id: u64) -> Result<SurfaceFile> {
        if !self.entities.contains_key(&id) {
            return Err(Error::invalid(
                &self.label,
                format!("has no entity #{id} (faces: {})", self.face_list()),
            ));
        }
        let (_, p) = match self.expect(id, &["ADVANCED_FACE", "FACE_SURFACE"]) {
            Ok(x) => x,
            Err(_) => {
                return Err(self.err(id, format!("is not a face (faces: {})", self.face_list())))
            }
        };
        let bounds = self.references(id, p, 1)?;
        let surface_id = self.reference(id, p, 2)?;
        let same_sense = self.boolean(id, p, 3)?;
        let basis = self.basis(surface_id)?;
        let mut loops = Vec::new();
        for b in &bounds {
            let (kind, bp) = self.expect(*b, &["FACE_OUTER_BOUND", "FACE_BOUND"])?;
            let loop_id = self.reference(*b, bp, 1)?;
            let orientation = self.boolean(*b, bp, 2)?;
            let edges = self.edge_loop(loop_id, surface_id, &basis)?;
            loops.push((*b, kind == "FACE_OUTER_BOUND", orientation, edges));
        }
        if loops.is_empty() {
            return Err(self.err(id, "has no bounds"));
        }
        let (mut surface, sampled) = self.sample_loops(id, basis, &loops)?;
        let mut polylines: Vec<(u64, bool, Vec<[f64; 2]>)> = sampled;
        if !same_sense {
            let (u0, u1) = (surface.knots_u[0], *surface.knots_u.last().unwrap_or(&1.0));
            surface.control_points.reverse();
            if let Some(w) = &mut surface.weights {
                w.reverse();
            }
            surface.knots_u = surface.knots_u.iter().rev().map(|k| u0 + u1 - k).collect();
            for (_, _, l) in &mut polylines {
                for q in l.iter_mut() {
                    q[0] = u0 + u1 - q[0];
                }
            }
        }
        let outer = self.outer_index(id, &polylines)?;
        let mut holes = Vec::new();
        let mut outer_loop = Vec::new();
        for (k, (_, _, l)) in polylines.into_iter().enumerate() {
            if k == outer {
                outer_loop = vec![TrimCurveFile::Polyline(l)];
            } else {
                holes.push(vec![TrimCurveFile::Polyline(l)]);
            }
        }
        surface.name = Some(format!("{}_{id}", self.stem));
        surface.trim = Some(TrimFile {
            tolerance: None,
            outer: outer_loop,
            holes,
        });
        surface
            .to_surface()
            .map_err(|e| self.err(id, format!("gives an invalid trimmed surface: {e}")))?;
        Ok(surface)
    }

    fn face_list(&self) -> String {
        let ids: Vec<String> = self.face_ids().iter().map(|i| format!("#{i}")).collect();
        if ids.is_empty() {
            "none".into()
        } else {
            ids.join(", ")
        }
    }

    /// The outer loop: the `FACE_OUTER_BOUND`, else the one loop running
    /// counter-clockwise in (u, v) with the face normal towards the viewer
    /// (material on its left, as STEP orients bounds), else the largest.
    fn outer_index(&self, face: u64, loops: &[(u64, bool, Vec<[f64; 2]>)]) -> Result<usize> {
        let declared: Vec<usize> = (0..loops.len()).filter(|&k| loops[k].1).collect();
        match declared.len() {
            1 => return Ok(declared[0]),
            0 => {}
            _ => return Err(self.err(face, "has more than one FACE_OUTER_BOUND")),
        }
        let areas: Vec<f64> = loops.iter().map(|l| shoelace(&l.2)).collect();
        let ccw: Vec<usize> = (0..loops.len()).filter(|&k| areas[k] > 0.0).collect();
        if ccw.len() == 1 {
            return Ok(ccw[0]);
        }
        if ccw.len() > 1 && loops.len() > 1 {
            return Err(self.err(
                face,
                format!(
                    "has {} outer loops (bounds {}): one outer loop per face is supported",
                    ccw.len(),
                    ccw.iter()
                        .map(|&k| format!("#{}", loops[k].0))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        }
        Ok((0..loops.len())
            .max_by(|&a, &b| areas[a].abs().total_cmp(&areas[b].abs()))
            .unwrap_or(0))
    }

    fn point3(&self, id: u64) -> Result<V3> {
        let (_, p) = self.expect(id, &["CARTESIAN_POINT"])?;
        let c = self.reals(id, p, 1)?;
        match c.len() {
            3 => Ok(V3::new(c[0], c[1], c[2]) * self.mm_per_unit),
            _ => Err(self.err(id, format!("has {} coordinates, expected 3", c.len()))),
        }
    }

    /// A point of a 2-D (pcurve, in (u, v), unscaled) or 3-D (mm) curve.
    fn point_in(&self, id: u64, in_uv: bool) -> Result<V3> {
        if !in_uv {
            return self.point3(id);
        }
        let (_, p) = self.expect(id, &["CARTESIAN_POINT"])?;
        let c = self.reals(id, p, 1)?;
        match c.len() {
            2 => Ok(V3::new(c[0], c[1], 0.0)),
            _ => Err(self.err(id, format!("has {} coordinates, expected 2", c.len()))),
        }
    }

    fn direction(&self, id: u64, in_uv: bool) -> Result<V3> {
        let (_, p) = self.expect(id, &["DIRECTION"])?;
        let c = self.reals(id, p, 1)?;
        let v = match (c.len(), in_uv) {
            (3, false) => V3::new(c[0], c[1], c[2]),
            (2, true) => V3::new(c[0], c[1], 0.0),
            (n, _) => return Err(self.err(id, format!("has {n} components"))),
        };
        let n = v.norm();
        if n > 0.0 {
            Ok(v / n)
        } else {
            Err(self.err(id, "is the zero vector"))
        }
    }

    fn frame(&self, id: u64, in_uv: bool) -> Result<Frame> {
        if in_uv {
            let (_, p) = self.expect(id, &["AXIS2_PLACEMENT_2D"])?;
            let o = self.point_in(self.reference(id, p, 1)?, true)?;
            let x = match self.arg(id, p, 2)? {
                Parameter::Ref(Name::Entity(r)) => self.direction(*r, true)?,
                _ => V3::x(),
            };
            let z = V3::z();
            return Ok(Frame {
                o,
                x,
                y: z.cross(&x),
                z,
            });
        }
        let (_, p) = self.expect(id, &["AXIS2_PLACEMENT_3D"])?;
        let o = self.point3(self.reference(id, p, 1)?)?;
        let z = match self.arg(id, p, 2)? {
            Parameter::Ref(Name::Entity(r)) => self.direction(*r, false)?,
            _ => V3::z(),
        };
        let xr = match self.arg(id, p, 3)? {
            Parameter::Ref(Name::Entity(r)) => self.direction(*r, false)?,
            _ => {
                if z.x.abs() < 0.9 {
                    V3::x()
                } else {
                    V3::y()
                }
            }
        };
        let x = xr - z * xr.dot(&z);
        if x.norm() < 1e-12 {
            return Err(self.err(id, "has its reference direction along its axis"));
        }
        let x = x.normalize();
        Ok(Frame {
            o,
            x,
            y: z.cross(&x),
            z,
        })
    }

    fn basis(&self, id: u64) -> Result<Basis> {
        let records = self.records(id)?;
        let name = name_of(records);
        if records.len() == 1 && name == "PLANE" {
            let (_, p) = self.expect(id, &["PLANE"])?;
            return Ok(Basis::Plane(self.frame(self.reference(id, p, 1)?, false)?));
        }
        if records.len() == 1 && name == "SURFACE_OF_LINEAR_EXTRUSION" {
            return self.linear_extrusion(id);
        }
        if records.len() == 1 {
            if let Some(b) = self.revolved(id, &name)? {
                return Ok(b);
            }
        }
        // B_SPLINE_SURFACE_WITH_KNOTS alone carries the name first; in a
        // complex instance the B_SPLINE_SURFACE part holds degrees and points.
        let (core, knots, offset) = if records.len() == 1 && name == "B_SPLINE_SURFACE_WITH_KNOTS" {
            let p = list(&records[0].parameter).unwrap_or(&[]);
            (p, p.get(8..).unwrap_or(&[]), 1)
        } else if let (Some(core), Some(knots)) = (
            self.part(id, "B_SPLINE_SURFACE"),
            self.part(id, "B_SPLINE_SURFACE_WITH_KNOTS"),
        ) {
            (core, knots, 0)
        } else {
            return Err(self.err(
                id,
                format!("is not a supported surface (supported: {SUPPORTED_SURFACES})"),
            ));
        };
        let degree_u = self.integer(id, core, offset)?;
        let degree_v = self.integer(id, core, offset + 1)?;
        let rows = list(self.arg(id, core, offset + 2)?)
            .ok_or_else(|| self.err(id, "control points should be a list of lists"))?;
        let mut control_points = Vec::new();
        for row in rows {
            let ids = self.references(id, std::slice::from_ref(row), 0)?;
            control_points.push(
                ids.iter()
                    .map(|&c| self.point3(c).map(|v| [v.x, v.y, v.z]))
                    .collect::<Result<Vec<_>>>()?,
            );
        }
        let expand = |mi: usize, ki: usize| -> Result<Vec<f64>> {
            let m = self.reals(id, knots, mi)?;
            let k = self.reals(id, knots, ki)?;
            if m.len() != k.len() {
                return Err(self.err(id, "has knot and multiplicity lists of different lengths"));
            }
            let mut out = Vec::new();
            for (&m, &k) in m.iter().zip(&k) {
                if !(1.0..=64.0).contains(&m) {
                    return Err(self.err(id, format!("has a knot multiplicity {m}")));
                }
                out.extend(std::iter::repeat_n(k, m as usize));
            }
            Ok(out)
        };
        let knots_u = expand(0, 2)?;
        let knots_v = expand(1, 3)?;
        let weights = match self.part(id, "RATIONAL_B_SPLINE_SURFACE") {
            Some(w) => {
                let rows = list(self.arg(id, w, 0)?)
                    .ok_or_else(|| self.err(id, "weights should be a list of lists"))?;
                Some(
                    rows.iter()
                        .map(|r| self.reals(id, std::slice::from_ref(r), 0))
                        .collect::<Result<Vec<_>>>()?,
                )
            }
            None => None,
        };
        let s = SurfaceFile {
            kind: "nurbs".into(),
            name: None,
            degree_u,
            degree_v,
            knots_u,
            knots_v,
            control_points,
            weights,
            trim: None,
        };
        s.to_surface()
            .map_err(|e| self.err(id, format!("is not a valid B-spline surface: {e}")))?;
        Ok(Basis::Bspline(s))
    }

    /// A cylinder, cone, sphere, torus or surface of revolution as its
    /// frame and meridian (docs/formats.md, "STEP import"); None for other
    /// entities.
    fn revolved(&self, id: u64, name: &str) -> Result<Option<Basis>> {
        let kinds = [
            "CYLINDRICAL_SURFACE",
            "CONICAL_SURFACE",
            "SPHERICAL_SURFACE",
            "TOROIDAL_SURFACE",
            "SURFACE_OF_REVOLUTION",
        ];
        if !kinds.contains(&name) {
            return Ok(None);
        }
        let (_, p) = self.expect(id, &kinds)?;
        let length = |i: usize| -> Result<f64> {
            let r = self.real(id, p, i)? * self.mm_per_unit;
            if r > 0.0 {
                Ok(r)
            } else {
                Err(self.err(
                    id,
                    format!("has parameter {} (a length) not positive", i + 1),
                ))
            }
        };
        if name == "SURFACE_OF_REVOLUTION" {
            return self.surface_of_revolution(id, p).map(Some);
        }
        let frame = self.frame(self.reference(id, p, 1)?, false)?;
        let (meridian, what) = match name {
            "CYLINDRICAL_SURFACE" => (
                Meridian::Line {
                    p: [length(2)?, 0.0],
                    d: [0.0, 1.0],
                },
                "cylinder",
            ),
            "CONICAL_SURFACE" => {
                // The radius may be 0 (the placement at the apex).
                let r = self.real(id, p, 2)? * self.mm_per_unit;
                let a = self.real(id, p, 3)? * self.radians_per_unit;
                if r < 0.0 || !(a > 0.0 && a < 0.5 * PI) {
                    return Err(self.err(
                        id,
                        format!("has radius {r} mm and semi-angle {a} rad: expected radius >= 0 and 0 < semi-angle < pi/2"),
                    ));
                }
                (
                    Meridian::Line {
                        p: [r, 0.0],
                        d: [a.tan(), 1.0],
                    },
                    "cone",
                )
            }
            "SPHERICAL_SURFACE" => {
                let r = length(2)?;
                (
                    Meridian::Conic {
                        c: [0.0, 0.0],
                        a: [r, 0.0],
                        b: [0.0, r],
                    },
                    "sphere",
                )
            }
            _ => {
                let (major, minor) = (length(2)?, length(3)?);
                (
                    Meridian::Conic {
                        c: [major, 0.0],
                        a: [minor, 0.0],
                        b: [0.0, minor],
                    },
                    "torus",
                )
            }
        };
        Ok(Some(Basis::Revolved(frame, meridian, what)))
    }

    /// A `SURFACE_OF_REVOLUTION`: its swept curve (a line, circle, ellipse
    /// or B-spline) must lie in a plane through its axis, the frame's x
    /// pointing from the axis to the curve.
    fn surface_of_revolution(&self, id: u64, p: &[Parameter]) -> Result<Basis> {
        let curve = self.curve(self.reference(id, p, 1)?, false)?;
        let axis = self.reference(id, p, 2)?;
        let (_, ap) = self.expect(axis, &["AXIS1_PLACEMENT"])?;
        let o = self.point3(self.reference(axis, ap, 1)?)?;
        let z = match self.arg(axis, ap, 2)? {
            Parameter::Ref(Name::Entity(r)) => self.direction(*r, false)?,
            _ => V3::z(),
        };
        // Points that fix the curve's plane.
        let defining: Vec<V3> = match &curve {
            Curve::Line { p, d } => vec![*p, p + d],
            Curve::Conic { c, x, y, a, b } => vec![*c, c + x * *a, c + y * *b],
            Curve::Bspline { points, .. } => points
                .iter()
                .map(|h| V3::new(h[0] / h[3], h[1] / h[3], h[2] / h[3]))
                .collect(),
        };
        let radial = |q: &V3| {
            let d = q - o;
            d - z * d.dot(&z)
        };
        let far = defining
            .iter()
            .map(radial)
            .max_by(|a, b| a.norm().total_cmp(&b.norm()))
            .unwrap_or_else(V3::zeros);
        let size = defining.iter().map(|q| (q - o).norm()).fold(1.0, f64::max);
        if far.norm() <= 1e-9 * size {
            return Err(self.err(id, "has its swept curve on its axis"));
        }
        let x = far.normalize();
        let y = z.cross(&x);
        if defining.iter().any(|q| (q - o).dot(&y).abs() > 1e-7 * size) {
            return Err(self.err(
                id,
                "has a swept curve that does not lie in a plane through its axis: not supported",
            ));
        }
        let meridian = plane_curve(&curve, o, x, z);
        Ok(Basis::Revolved(
            Frame { o, x, y, z },
            meridian,
            "surface of revolution",
        ))
    }

    /// A `SURFACE_OF_LINEAR_EXTRUSION`: its swept curve (a line, circle,
    /// ellipse or B-spline) in any plane, moved along its axis vector. The
    /// surface is the cylinder over the curve's projection along the axis
    /// (the section), so the section's parameter and the height along the
    /// axis parametrise it exactly.
    fn linear_extrusion(&self, id: u64) -> Result<Basis> {
        let (_, p) = self.expect(id, &["SURFACE_OF_LINEAR_EXTRUSION"])?;
        let curve = self.curve(self.reference(id, p, 1)?, false)?;
        let vid = self.reference(id, p, 2)?;
        let (_, vp) = self.expect(vid, &["VECTOR"])?;
        let z = self.direction(self.reference(vid, vp, 1)?, false)?;
        let magnitude = self.real(vid, vp, 2)?;
        if magnitude.is_nan() || magnitude <= 0.0 {
            return Err(self.err(vid, "has a magnitude that is not positive"));
        }
        let o = match &curve {
            Curve::Line { p, .. } => *p,
            Curve::Conic { c, .. } => *c,
            Curve::Bspline { points, .. } => points
                .first()
                .map(|h| V3::new(h[0] / h[3], h[1] / h[3], h[2] / h[3]))
                .unwrap_or_else(V3::zeros),
        };
        let xr = if z.x.abs() < 0.9 { V3::x() } else { V3::y() };
        let x = (xr - z * xr.dot(&z)).normalize();
        let y = z.cross(&x);
        if let Curve::Line { d, .. } = &curve {
            if d.cross(&z).norm() <= 1e-9 * d.norm() {
                return Err(self.err(id, "has a swept line along its extrusion direction"));
            }
        }
        let section = plane_curve(&curve, o, x, y);
        match &section {
            Meridian::Conic { a, b, .. }
                if (a[0] * b[1] - a[1] * b[0]).abs()
                    <= 1e-9 * a[0].hypot(a[1]) * b[0].hypot(b[1]) =>
            {
                return Err(self.err(
                    id,
                    "has a swept circle or ellipse whose plane contains the extrusion direction: the face is a plane, not supported as an extrusion",
                ));
            }
            _ => {}
        }
        Ok(Basis::Extruded(Frame { o, x, y, z }, section))
    }

    fn curve(&self, id: u64, in_uv: bool) -> Result<Curve> {
        let records = self.records(id)?;
        let name = name_of(records);
        let scale = if in_uv { 1.0 } else { self.mm_per_unit };
        if records.len() == 1 {
            let p = list(&records[0].parameter).unwrap_or(&[]);
            match name.as_str() {
                "LINE" => {
                    let o = self.point_in(self.reference(id, p, 1)?, in_uv)?;
                    let vid = self.reference(id, p, 2)?;
                    let (_, vp) = self.expect(vid, &["VECTOR"])?;
                    let d = self.direction(self.reference(vid, vp, 1)?, in_uv)?
                        * self.real(vid, vp, 2)?
                        * scale;
                    if d.norm() == 0.0 {
                        return Err(self.err(vid, "has zero magnitude"));
                    }
                    return Ok(Curve::Line { p: o, d });
                }
                "CIRCLE" | "ELLIPSE" => {
                    let f = self.frame(self.reference(id, p, 1)?, in_uv)?;
                    let a = self.real(id, p, 2)? * scale;
                    let b = if name == "ELLIPSE" {
                        self.real(id, p, 3)? * scale
                    } else {
                        a
                    };
                    if !(a > 0.0 && b > 0.0) {
                        return Err(self.err(id, "has a radius that is not positive"));
                    }
                    return Ok(Curve::Conic {
                        c: f.o,
                        x: f.x,
                        y: f.y,
                        a,
                        b,
                    });
                }
                "B_SPLINE_CURVE_WITH_KNOTS" => {
                    return self.bspline_curve(id, p, p.get(6..).unwrap_or(&[]), 1, None, in_uv);
                }
                _ => {}
            }
        } else if let (Some(core), Some(knots)) = (
            self.part(id, "B_SPLINE_CURVE"),
            self.part(id, "B_SPLINE_CURVE_WITH_KNOTS"),
        ) {
            let w = match self.part(id, "RATIONAL_B_SPLINE_CURVE") {
                Some(w) => Some(self.reals(id, w, 0)?),
                None => None,
            };
            return self.bspline_curve(id, core, knots, 0, w, in_uv);
        }
        Err(self.err(
            id,
            "is not a supported curve (supported: LINE, CIRCLE, ELLIPSE, B_SPLINE_CURVE_WITH_KNOTS)",
        ))
    }

    fn bspline_curve(
        &self,
        id: u64,
        core: &[Parameter],
        knots: &[Parameter],
        offset: usize,
        weights: Option<Vec<f64>>,
        in_uv: bool,
    ) -> Result<Curve> {
        let degree = self.integer(id, core, offset)?;
        let pts = self
            .references(id, core, offset + 1)?
            .iter()
            .map(|&c| self.point_in(c, in_uv))
            .collect::<Result<Vec<_>>>()?;
        let m = self.reals(id, knots, 0)?;
        let k = self.reals(id, knots, 1)?;
        let mut full = Vec::new();
        for (&m, &k) in m.iter().zip(&k) {
            if !(1.0..=64.0).contains(&m) {
                return Err(self.err(id, format!("has a knot multiplicity {m}")));
            }
            full.extend(std::iter::repeat_n(k, m as usize));
        }
        if degree == 0 || m.len() != k.len() || full.len() != pts.len() + degree + 1 {
            return Err(self.err(
                id,
                format!(
                    "has {} knots for {} points of degree {degree}",
                    full.len(),
                    pts.len()
                ),
            ));
        }
        if full.windows(2).any(|w| w[1] < w[0]) || full[degree] >= full[pts.len()] {
            return Err(self.err(id, "has knots that are not non-decreasing"));
        }
        let w = weights.unwrap_or_else(|| vec![1.0; pts.len()]);
        if w.len() != pts.len() || w.iter().any(|&x| x.is_nan() || x <= 0.0) {
            return Err(self.err(id, "has weights that are not one positive number per point"));
        }
        Ok(Curve::Bspline {
            degree,
            knots: full,
            points: pts
                .iter()
                .zip(&w)
                .map(|(p, &w)| [p.x * w, p.y * w, p.z * w, w])
                .collect(),
        })
    }

    /// The edges of an `EDGE_LOOP` in loop order, each with the curve to
    /// sample (the pcurve on `surface_id` when there is one and the basis is
    /// a B-spline) and the parameter range its vertices bound.
    fn edge_loop(&self, id: u64, surface_id: u64, basis: &Basis) -> Result<Vec<EdgeUse>> {
        let (_, p) = self.expect(id, &["EDGE_LOOP"])?;
        let mut out = Vec::new();
        let nurbs = match basis {
            Basis::Bspline(s) => Some(s.to_surface()?),
            _ => None,
        };
        for oe in self.references(id, p, 1)? {
            let (_, op) = self.expect(oe, &["ORIENTED_EDGE"])?;
            let edge = self.reference(oe, op, 3)?;
            let forward = self.boolean(oe, op, 4)?;
            let (_, ep) = self.expect(edge, &["EDGE_CURVE"])?;
            let (v1, v2) = (self.reference(edge, ep, 1)?, self.reference(edge, ep, 2)?);
            let geometry = self.reference(edge, ep, 3)?;
            let same_sense = self.boolean(edge, ep, 4)?;
            let vertex = |v: u64| -> Result<V3> {
                let (_, vp) = self.expect(v, &["VERTEX_POINT"])?;
                self.point3(self.reference(v, vp, 1)?)
            };
            let (p1, p2) = (vertex(v1)?, vertex(v2)?);
            let (mut curve_id, mut pcurve) = (geometry, None);
            if let Ok((_, sp)) = self.expect(geometry, &["SURFACE_CURVE", "SEAM_CURVE"]) {
                curve_id = self.reference(geometry, sp, 1)?;
                if nurbs.is_some() {
                    for pc in self.references(geometry, sp, 2)? {
                        if let Some(pp) = self.part(pc, "PCURVE") {
                            if self.reference(pc, pp, 1)? == surface_id {
                                let rep = self.reference(pc, pp, 2)?;
                                let (_, rp) = self.expect(rep, &["DEFINITIONAL_REPRESENTATION"])?;
                                pcurve = self.references(rep, rp, 1)?.first().copied();
                                break;
                            }
                        }
                    }
                }
            }
            let (curve, in_uv, q1, q2) = match (pcurve, &nurbs) {
                (Some(pc), Some(s)) => {
                    let uv = |q: &V3| {
                        let c = closest_point(s, &Point3::from(*q));
                        V3::new(c.uv.x, c.uv.y, 0.0)
                    };
                    (self.curve(pc, true)?, true, uv(&p1), uv(&p2))
                }
                _ => (self.curve(curve_id, false)?, false, p1, p2),
            };
            let closed = v1 == v2 || (p1 - p2).norm() <= 1e-9 * (1.0 + p1.norm());
            let (ta, tb) = if closed {
                match curve.range() {
                    Some((a, b)) if curve.periodic() => {
                        let t = curve.locate(&q1);
                        if same_sense {
                            (t, t + (b - a))
                        } else {
                            (t, t - (b - a))
                        }
                    }
                    Some((a, b)) => {
                        if same_sense {
                            (a, b)
                        } else {
                            (b, a)
                        }
                    }
                    None => return Err(self.err(edge, "is a closed edge on a line")),
                }
            } else {
                let (ta, mut tb) = (curve.locate(&q1), curve.locate(&q2));
                if curve.periodic() {
                    if same_sense {
                        while tb <= ta {
                            tb += TAU;
                        }
                        while tb - ta > TAU {
                            tb -= TAU;
                        }
                    } else {
                        while tb >= ta {
                            tb -= TAU;
                        }
                        while ta - tb > TAU {
                            tb += TAU;
                        }
                    }
                }
                (ta, tb)
            };
            let (ta, tb) = if forward { (ta, tb) } else { (tb, ta) };
            out.push(EdgeUse {
                id: edge,
                curve,
                in_uv,
                ta,
                tb,
            });
        }
        if out.is_empty() {
            return Err(self.err(id, "has no edges"));
        }
        Ok(out)
    }

    /// Builds the NURBS of the basis and samples every loop into (u, v).
    #[allow(clippy::type_complexity)]
    fn sample_loops(
        &self,
        face: u64,
        basis: Basis,
        loops: &[(u64, bool, bool, Vec<EdgeUse>)],
    ) -> Result<(SurfaceFile, Vec<(u64, bool, Vec<[f64; 2]>)>)> {
        // Coarse 3-D samples of every loop: the extent of a plane or
        // cylinder patch, and each loop's unwrapped start angle.
        let coarse: Vec<Vec<V3>> = loops
            .iter()
            .map(|(_, _, _, edges)| {
                edges
                    .iter()
                    .filter(|e| !e.in_uv)
                    .flat_map(|e| {
                        (0..=COARSE).map(move |k| {
                            e.curve
                                .point(e.ta + (e.tb - e.ta) * k as f64 / COARSE as f64)
                        })
                    })
                    .collect()
            })
            .collect();
        let (surface, map) = self.patch(face, basis, &coarse)?;
        let nurbs = surface.to_surface()?;
        let mut out = Vec::new();
        for (bound, declared_outer, orientation, edges) in loops {
            let mut pts: Vec<[f64; 2]> = Vec::new();
            let mut steps = MAX_LOOP_STEPS;
            for e in edges {
                let seed = pts.last().copied();
                let eval = |t: f64, seed: Option<[f64; 2]>| -> ([f64; 2], V3) {
                    let c = e.curve.point(t);
                    if e.in_uv {
                        let p = nurbs.point(c.x, c.y);
                        ([c.x, c.y], p.coords)
                    } else {
                        (map(&c, seed), c)
                    }
                };
                sample_edge(&nurbs, e, &eval, seed, &mut steps, &mut pts);
                if steps == 0 {
                    return Err(self.err(
                        e.id,
                        format!(
                            "cannot be followed within the trim tolerance in {MAX_LOOP_STEPS} bisection steps: its curve or the face's surface is degenerate along it"
                        ),
                    ));
                }
            }
            let (Some(&first), Some(&last)) = (pts.first(), pts.last()) else {
                return Err(self.err(*bound, "has an empty loop"));
            };
            let gap = (nurbs.point(first[0], first[1]) - nurbs.point(last[0], last[1])).norm();
            let size = {
                let (lo, hi) = nurbs.bounding_box();
                (hi - lo).norm()
            };
            if gap > 1e-4 * size.max(1.0) {
                let e = edges.last().map(|e| e.id).unwrap_or(*bound);
                return Err(self.err(
                    *bound,
                    format!("is not closed: its last edge #{e} ends {gap:.3e} mm from its start"),
                ));
            }
            *pts.last_mut().unwrap_or(&mut [0.0; 2]) = first;
            if !orientation {
                pts.reverse();
            }
            out.push((*bound, *declared_outer, pts));
        }
        Ok((surface, out))
    }

    /// The NURBS of a face's basis (planes and cylinders over the extent of
    /// the boundary's coarse samples) and the map of 3-D boundary points to
    /// its (u, v), seeded by the previous point of the loop.
    #[allow(clippy::type_complexity)]
    /// The face's surface as a NURBS patch covering its boundary (`coarse`:
    /// the boundary's sampled loops), and the map from a 3-D boundary point
    /// (with an optional nearby (u, v) seed) to the patch's (u, v).
    fn patch(&self, face: u64, basis: Basis, coarse: &[Vec<V3>]) -> Result<Patch> {
        match basis {
            Basis::Bspline(s) => bspline_patch(s),
            Basis::Plane(f) => self.plane_patch(face, f, coarse),
            Basis::Revolved(f, m, what) => self.revolved_patch(face, f, m, what, coarse),
            Basis::Extruded(f, m) => self.extruded_patch(face, f, m, coarse),
        }
    }

    /// A surface of linear extrusion as the exact patch over the section
    /// range and the heights its boundary spans: the section's NURBS in u
    /// (as a meridian's, [`Self::meridian_profile`]) times a line along the
    /// axis in v, so u runs along the swept curve and v along the axis
    /// vector, the orientation STEP gives the surface.
    fn extruded_patch(
        &self,
        face: u64,
        f: Frame,
        m: Meridian,
        coarse: &[Vec<V3>],
    ) -> Result<Patch> {
        const WHAT: &str = "surface of linear extrusion";
        let section = move |q: &V3| [(q - f.o).dot(&f.x), (q - f.o).dot(&f.y)];
        let height = move |q: &V3| (q - f.o).dot(&f.z);
        let (mut s0, mut s1) = (f64::INFINITY, f64::NEG_INFINITY);
        let (mut h0, mut h1) = (f64::INFINITY, f64::NEG_INFINITY);
        let mut s_reference = None;
        for l in coarse {
            let mut s_prev: Option<f64> = None;
            for q in l {
                let s = m.locate(section(q), s_prev.or(s_reference));
                s_reference.get_or_insert(s);
                s_prev = Some(s);
                (s0, s1) = (s0.min(s), s1.max(s));
                (h0, h1) = (h0.min(height(q)), h1.max(height(q)));
            }
        }
        if !(s1 > s0 && h1 > h0) {
            return Err(self.err(face, format!("has a boundary of no extent on its {WHAT}")));
        }
        let (degree_u, knots_u, profile, umap, (s0, s1)) =
            self.meridian_profile(face, &m, WHAT, (s0, s1))?;
        let rational = profile.iter().any(|(_, w)| *w != 1.0);
        let at = |q: [f64; 2], h: f64| {
            let p = f.o + f.x * q[0] + f.y * q[1] + f.z * h;
            [p.x, p.y, p.z]
        };
        let (u_lo, u_hi) = (umap.v_of(s0), umap.v_of(s1));
        Ok((
            SurfaceFile {
                kind: "nurbs".into(),
                name: None,
                degree_u,
                degree_v: 1,
                knots_u,
                knots_v: vec![h0, h0, h1, h1],
                control_points: profile
                    .iter()
                    .map(|(q, _)| vec![at(*q, h0), at(*q, h1)])
                    .collect(),
                weights: rational.then(|| profile.iter().map(|(_, w)| vec![*w, *w]).collect()),
                trim: None,
            },
            Box::new(move |q: &V3, seed: Option<[f64; 2]>| {
                let s_near = seed.map(|sd| umap.s_of(sd[0])).or(s_reference);
                let s = m.locate(section(q), s_near).clamp(s0, s1);
                [umap.v_of(s).clamp(u_lo, u_hi), height(q).clamp(h0, h1)]
            }),
        ))
    }

    /// A plane as the bilinear patch over its boundary's box.
    fn plane_patch(&self, face: u64, f: Frame, coarse: &[Vec<V3>]) -> Result<Patch> {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for q in coarse.iter().flatten() {
            let r = q - f.o;
            for (k, a) in [f.x, f.y].iter().enumerate() {
                lo[k] = lo[k].min(r.dot(a));
                hi[k] = hi[k].max(r.dot(a));
            }
        }
        if !(hi[0] > lo[0] && hi[1] > lo[1]) {
            return Err(self.err(face, "has a boundary of no extent on its plane"));
        }

        // The patch is the boundary's box: a loop on the domain's
        // edges is on the face (the face is closed).
        let at = |x: f64, y: f64| {
            let p = f.o + f.x * x + f.y * y;
            [p.x, p.y, p.z]
        };
        Ok((
            SurfaceFile {
                kind: "nurbs".into(),
                name: None,
                degree_u: 1,
                degree_v: 1,
                knots_u: vec![lo[0], lo[0], hi[0], hi[0]],
                knots_v: vec![lo[1], lo[1], hi[1], hi[1]],
                control_points: vec![
                    vec![at(lo[0], lo[1]), at(lo[0], hi[1])],
                    vec![at(hi[0], lo[1]), at(hi[0], hi[1])],
                ],
                weights: None,
                trim: None,
            },
            Box::new(move |q: &V3, _| {
                let r = q - f.o;
                [
                    r.dot(&f.x).clamp(lo[0], hi[0]),
                    r.dot(&f.y).clamp(lo[1], hi[1]),
                ]
            }),
        ))
    }

    /// The meridian of a surface of revolution as a NURBS over [s0, s1]:
    /// degree, knots, (rho, h) points with weights, the map between its
    /// parameter and the meridian's, and the s range it spans (a B-spline
    /// meridian spans its whole curve).
    fn meridian_profile(
        &self,
        face: u64,
        m: &Meridian,
        what: &str,
        (s0, s1): (f64, f64),
    ) -> Result<MeridianProfile> {
        Ok(match m {
            Meridian::Line { p, d } => {
                let at = |s: f64| ([p[0] + d[0] * s, p[1] + d[1] * s], 1.0);
                (
                    1,
                    vec![s0, s0, s1, s1],
                    vec![at(s0), at(s1)],
                    VMap::Same,
                    (s0, s1),
                )
            }
            Meridian::Conic { c, a, b } => {
                if s1 - s0 > TAU + 1e-6 {
                    return Err(self.err(
                        face,
                        format!(
                            "winds round the meridian of its {what} more than once: not supported"
                        ),
                    ));
                }
                let va = Arcs::new(s0, s1.min(s0 + TAU));
                let w = (0.5 * va.delta).cos();
                let pts = (0..=2 * va.n)
                    .map(|i| {
                        let phi = va.theta0 + va.delta * i as f64 / 2.0;
                        let (k, wt) = if i % 2 == 1 { (1.0 / w, w) } else { (1.0, 1.0) };
                        let (cs, sn) = (phi.cos() * k, phi.sin() * k);
                        (
                            [c[0] + a[0] * cs + b[0] * sn, c[1] + a[1] * cs + b[1] * sn],
                            wt,
                        )
                    })
                    .collect();
                (2, arc_knots(va.n), pts, VMap::Arcs(va), (s0, s1))
            }
            Meridian::Bspline(Curve::Bspline {
                degree,
                knots,
                points,
            }) => {
                // The whole curve; its range bounds s.
                let range = (knots[*degree], knots[knots.len() - degree - 1]);
                let pts = points
                    .iter()
                    .map(|h| ([h[0] / h[3], h[1] / h[3]], h[3]))
                    .collect();
                (*degree, knots.clone(), pts, VMap::Same, range)
            }
            Meridian::Bspline(_) => return Err(self.err(face, "has a malformed meridian")),
        })
    }

    /// A surface of revolution as the exact rational patch over the angles
    /// and the meridian range its boundary spans (at most one turn): the
    /// circle's rational quadratic arcs of at most 90 degrees in u times the
    /// meridian's NURBS in v, control point (i, j) at the meridian's point j
    /// turned to the arc's point i, weight the product of theirs
    /// (docs/formats.md, "STEP import").
    /// A boundary point on the axis (a pole, an apex) takes the angle of
    /// the loop's previous point, so a loop through a pole runs along the
    /// patch's collapsed edge there.
    fn revolved_patch(
        &self,
        face: u64,
        f: Frame,
        m: Meridian,
        what: &str,
        coarse: &[Vec<V3>],
    ) -> Result<Patch> {
        let size = coarse
            .iter()
            .flatten()
            .map(|q| (q - f.o).norm())
            .fold(1.0, f64::max);
        let on_axis = 1e-9 * size;
        let meridian = move |q: &V3| -> [f64; 2] {
            let d = q - f.o;
            let h = d.dot(&f.z);
            [(d - f.z * h).norm(), h]
        };
        let angle = move |q: &V3| -> Option<f64> {
            let d = q - f.o;
            let (x, y) = (d.dot(&f.x), d.dot(&f.y));
            (x.hypot(y) > on_axis).then(|| y.atan2(x))
        };
        let (mut t0, mut t1) = (f64::INFINITY, f64::NEG_INFINITY);
        let (mut s0, mut s1) = (f64::INFINITY, f64::NEG_INFINITY);
        let (mut reference, mut s_reference) = (None, None);
        for l in coarse {
            let (mut prev, mut s_prev): (Option<f64>, Option<f64>) = (None, None);
            let mut first = None;
            for q in l {
                if let Some(mut t) = angle(q) {
                    if let Some(p) = prev.or(reference) {
                        t += TAU * ((p - t) / TAU).round();
                    }
                    reference.get_or_insert(t);
                    first.get_or_insert(t);
                    prev = Some(t);
                    t0 = t0.min(t);
                    t1 = t1.max(t);
                }
                let s = m.locate(meridian(q), s_prev.or(s_reference));
                s_reference.get_or_insert(s);
                s_prev = Some(s);
                s0 = s0.min(s);
                s1 = s1.max(s);
            }
            if let (Some(a), Some(b)) = (first, prev) {
                if (b - a).abs() > PI {
                    return Err(self.err(
                        face,
                        format!("has a loop that winds round the axis of its {what} (a face closed round a pole or a band without a seam edge): not supported"),
                    ));
                }
            }
        }
        if !(t1 > t0 && s1 > s0) {
            return Err(self.err(face, format!("has a boundary of no extent on its {what}")));
        }
        if t1 - t0 > TAU + 1e-6 {
            return Err(self.err(
                face,
                format!("winds round its {what} more than once: not supported"),
            ));
        }
        let t1 = t1.min(t0 + TAU);
        let arcs = Arcs::new(t0, t1);
        let (degree_v, knots_v, profile, vmap, (s0, s1)) =
            self.meridian_profile(face, &m, what, (s0, s1))?;
        if profile.iter().any(|(q, _)| q[0] < -on_axis) {
            return Err(self.err(
                face,
                format!("lies on a part of its {what} that crosses its axis: not supported"),
            ));
        }
        let w = (0.5 * arcs.delta).cos();
        let mut rows = Vec::new();
        let mut wrows = Vec::new();
        for i in 0..=2 * arcs.n {
            let th = t0 + arcs.delta * i as f64 / 2.0;
            let (k, wa) = if i % 2 == 1 { (1.0 / w, w) } else { (1.0, 1.0) };
            let dir = (f.x * th.cos() + f.y * th.sin()) * k;
            rows.push(
                profile
                    .iter()
                    .map(|(q, _)| {
                        let p = f.o + dir * q[0] + f.z * q[1];
                        [p.x, p.y, p.z]
                    })
                    .collect(),
            );
            wrows.push(profile.iter().map(|(_, wp)| wa * wp).collect());
        }
        let (v_lo, v_hi) = (vmap.v_of(s0), vmap.v_of(s1));
        Ok((
            SurfaceFile {
                kind: "nurbs".into(),
                name: None,
                degree_u: 2,
                degree_v,
                knots_u: arc_knots(arcs.n),
                knots_v,
                control_points: rows,
                weights: Some(wrows),
                trim: None,
            },
            Box::new(move |q: &V3, seed: Option<[f64; 2]>| {
                let near = seed
                    .map(|s| arcs.theta_of(s[0]))
                    .or(reference)
                    .unwrap_or(t0);
                let t = angle(q).map_or(near, |t| t + TAU * ((near - t) / TAU).round());
                let s_near = seed.map(|s| vmap.s_of(s[1])).or(s_reference);
                let s = m.locate(meridian(q), s_near).clamp(s0, s1);
                [arcs.u_of(t.clamp(t0, t1)), vmap.v_of(s).clamp(v_lo, v_hi)]
            }),
        ))
    }
}

/// A meridian as [`StepFile::meridian_profile`] gives it: degree, knots,
/// (rho, h) points with weights, parameter map, s range.
type MeridianProfile = (usize, Vec<f64>, Vec<([f64; 2], f64)>, VMap, (f64, f64));

/// A face's NURBS patch and the map from a 3-D point near it (with an
/// optional (u, v) seed) to its (u, v).
type Patch = (SurfaceFile, Box<dyn Fn(&V3, Option<[f64; 2]>) -> [f64; 2]>);

/// A B-spline surface is its own patch; points map by closest-point inversion.
fn bspline_patch(s: SurfaceFile) -> Result<Patch> {
    let n = s.to_surface()?;
    Ok((
        s,
        Box::new(move |q: &V3, seed: Option<[f64; 2]>| {
            let c = match seed {
                Some(sd) => closest_point_near(&n, &Point3::from(*q), Vector2::new(sd[0], sd[1])),
                None => closest_point(&n, &Point3::from(*q)),
            };
            [c.uv.x, c.uv.y]
        }),
    ))
}

/// Samples one edge into `pts`: the (u, v) images of parameters from `ta`
/// to `tb`, bisected until the surface image of each chord's midpoint lies
/// within the trim tolerance of the edge's point there.
fn sample_edge(
    nurbs: &NurbsSurface,
    e: &EdgeUse,
    eval: &dyn Fn(f64, Option<[f64; 2]>) -> ([f64; 2], V3),
    seed: Option<[f64; 2]>,
    steps: &mut usize,
    pts: &mut Vec<[f64; 2]>,
) {
    let tol = DEFAULT_TOLERANCE_MM * 0.5;
    let (mut t, (mut uv, mut p)) = (e.ta, eval(e.ta, seed));
    push(pts, uv);
    for k in 1..=START_PIECES {
        let t1 = e.ta + (e.tb - e.ta) * k as f64 / START_PIECES as f64;
        let (uv1, p1) = eval(t1, Some(uv));
        bisect(nurbs, eval, (t, uv, p), (t1, uv1, p1), tol, 0, steps, pts);
        (t, uv, p) = (t1, uv1, p1);
    }
}

#[allow(clippy::too_many_arguments)]
fn bisect(
    nurbs: &NurbsSurface,
    eval: &dyn Fn(f64, Option<[f64; 2]>) -> ([f64; 2], V3),
    a: (f64, [f64; 2], V3),
    b: (f64, [f64; 2], V3),
    tol: f64,
    depth: u32,
    steps: &mut usize,
    pts: &mut Vec<[f64; 2]>,
) {
    if *steps == 0 {
        push(pts, b.1);
        return;
    }
    *steps -= 1;
    let tm = 0.5 * (a.0 + b.0);
    let (uvm, pm) = eval(tm, Some(a.1));
    let chord = nurbs.point(0.5 * (a.1[0] + b.1[0]), 0.5 * (a.1[1] + b.1[1]));
    if depth < MAX_DEPTH && (chord.coords - pm).norm() > tol {
        bisect(nurbs, eval, a, (tm, uvm, pm), tol, depth + 1, steps, pts);
        bisect(nurbs, eval, (tm, uvm, pm), b, tol, depth + 1, steps, pts);
    } else {
        push(pts, b.1);
    }
}

/// Appends q unless it repeats the last point: two edges' images of their
/// shared vertex differ by rounding (about 1e-12), and keeping both would
/// make the loop turn back on itself there.
fn push(pts: &mut Vec<[f64; 2]>, q: [f64; 2]) {
    if pts
        .last()
        .is_none_or(|l| (l[0] - q[0]).abs() > 1e-9 || (l[1] - q[1]).abs() > 1e-9)
    {
        pts.push(q);
    }
}

/// Twice the signed area... halved: the shoelace area of a closed polyline.
fn shoelace(l: &[[f64; 2]]) -> f64 {
    0.5 * l
        .windows(2)
        .map(|w| w[0][0] * w[1][1] - w[1][0] * w[0][1])
        .sum::<f64>()
}

/// Bounding box of a trimmed face: its loops' points and the face's points
/// of a 64 x 64 grid of the domain.
fn face_box(s: &NurbsSurface) -> ([f64; 3], [f64; 3]) {
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    let mut add = |p: Point3<f64>| {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    };
    if let Some(t) = s.trim() {
        for l in t.loops() {
            for q in l {
                add(s.point(q[0], q[1]));
            }
        }
    }
    let ((u0, u1), (v0, v1)) = s.domain();
    let n = 64;
    for i in 0..=n {
        for j in 0..=n {
            let u = u0 + (u1 - u0) * i as f64 / n as f64;
            let v = v0 + (v1 - v0) * j as f64 / n as f64;
            if s.in_face(u, v) {
                add(s.point(u, v));
            }
        }
    }
    (lo, hi)
}
