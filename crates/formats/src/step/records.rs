//! The parsed file: ruststep's entity records by id, their typed
//! parameters (with errors naming the entity), and the points, directions
//! and placements every geometric entity is built from.

use super::{StepFile, MAX_STEP_BYTES, V3};
use ruststep::ast::{EntityInstance, Name, Parameter, Record};
use std::collections::BTreeMap;
use std::path::Path;
use toolpath_kernel::error::{Error, Result};

/// Digits a whole number (an integer, an entity id, the integral part or
/// exponent of a real) may have: an i64 holds every 18-digit number.
pub(super) const MAX_INTEGER_DIGITS: usize = 18;

/// Refuses a whole number too long for an i64 outside strings and comments,
/// naming its line: ruststep parses these with an `expect` that panics.
/// The fraction of a real (digits after its point) may be any length.
pub(super) fn check_number_lengths(text: &str) -> std::result::Result<(), String> {
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

/// An `AXIS2_PLACEMENT_3D`: origin and right-handed unit axes.
#[derive(Clone, Copy)]
pub(super) struct Frame {
    pub(super) o: V3,
    pub(super) x: V3,
    pub(super) y: V3,
    pub(super) z: V3,
}

pub(super) fn name_of(records: &[Record]) -> String {
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

/// The entity type an error names: a simple instance's, or a complex
/// one's rational B-spline part (the rest of its parts say no more), else
/// all its parts.
fn message_name(records: &[Record]) -> String {
    match records
        .iter()
        .find(|r| r.name.starts_with("RATIONAL_B_SPLINE_"))
    {
        Some(r) if records.len() > 1 => r.name.clone(),
        _ => name_of(records),
    }
}

pub(super) fn list(p: &Parameter) -> Option<&[Parameter]> {
    match p {
        Parameter::List(v) => Some(v),
        _ => None,
    }
}

impl StepFile {
    /// Reads and parses a STEP file.
    /// Errors name the file by its name (`mould.step #788 ...`), the
    /// entities by their ids.
    pub fn read(path: &Path) -> Result<Self> {
        let bytes = crate::read_file_limited(path, MAX_STEP_BYTES)?;
        let text = String::from_utf8_lossy(&bytes);
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "step".into());
        let label = path
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| path.display().to_string());
        Self::parse(&text, &label, &stem)
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

    pub(super) fn err(&self, id: u64, message: impl Into<String>) -> Error {
        let what = self
            .entities
            .get(&id)
            .map(|r| message_name(r))
            .unwrap_or_else(|| "(undefined)".into());
        Error::invalid(format!("{} #{id} {what}", self.label), message)
    }

    pub(super) fn records(&self, id: u64) -> Result<&[Record]> {
        self.entities.get(&id).map(|r| r.as_slice()).ok_or_else(|| {
            Error::invalid(&self.label, format!("#{id} is referenced but not defined"))
        })
    }

    /// Type name of a simple instance (or the complex one's parts).
    pub(super) fn kind(&self, id: u64) -> Result<String> {
        Ok(name_of(self.records(id)?))
    }

    /// The parameters of the record named `name` in instance `id`.
    pub(super) fn part(&self, id: u64, name: &str) -> Option<&[Parameter]> {
        self.entities
            .get(&id)?
            .iter()
            .find(|r| r.name == name)
            .and_then(|r| list(&r.parameter))
    }

    /// Parameters of `id`, which must be one of `names` (simple instances).
    pub(super) fn expect(&self, id: u64, names: &[&str]) -> Result<(&str, &[Parameter])> {
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

    pub(super) fn arg<'a>(&self, id: u64, p: &'a [Parameter], i: usize) -> Result<&'a Parameter> {
        p.get(i).ok_or_else(|| {
            self.err(
                id,
                format!("has too few parameters (no parameter {})", i + 1),
            )
        })
    }

    pub(super) fn reference(&self, id: u64, p: &[Parameter], i: usize) -> Result<u64> {
        match self.arg(id, p, i)? {
            Parameter::Ref(Name::Entity(r)) => Ok(*r),
            other => Err(self.err(
                id,
                format!("parameter {} should be a reference, found {other:?}", i + 1),
            )),
        }
    }

    pub(super) fn references(&self, id: u64, p: &[Parameter], i: usize) -> Result<Vec<u64>> {
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

    pub(super) fn real_of(&self, id: u64, x: &Parameter, i: usize) -> Result<f64> {
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

    pub(super) fn real(&self, id: u64, p: &[Parameter], i: usize) -> Result<f64> {
        self.real_of(id, self.arg(id, p, i)?, i)
    }

    pub(super) fn reals(&self, id: u64, p: &[Parameter], i: usize) -> Result<Vec<f64>> {
        let items = list(self.arg(id, p, i)?)
            .ok_or_else(|| self.err(id, format!("parameter {} should be a list", i + 1)))?;
        items.iter().map(|x| self.real_of(id, x, i)).collect()
    }

    pub(super) fn boolean(&self, id: u64, p: &[Parameter], i: usize) -> Result<bool> {
        match self.arg(id, p, i)? {
            Parameter::Enumeration(e) if e.trim_matches('.') == "T" => Ok(true),
            Parameter::Enumeration(e) if e.trim_matches('.') == "F" => Ok(false),
            other => Err(self.err(
                id,
                format!("parameter {} should be .T. or .F., found {other:?}", i + 1),
            )),
        }
    }

    pub(super) fn integer(&self, id: u64, p: &[Parameter], i: usize) -> Result<usize> {
        match self.arg(id, p, i)? {
            Parameter::Integer(v) if *v >= 0 => Ok(*v as usize),
            other => Err(self.err(
                id,
                format!("parameter {} should be a count, found {other:?}", i + 1),
            )),
        }
    }
}

impl StepFile {
    pub(super) fn point3(&self, id: u64) -> Result<V3> {
        let (_, p) = self.expect(id, &["CARTESIAN_POINT"])?;
        let c = self.reals(id, p, 1)?;
        match c.len() {
            3 => Ok(V3::new(c[0], c[1], c[2]) * self.mm_per_unit),
            _ => Err(self.err(id, format!("has {} coordinates, expected 3", c.len()))),
        }
    }

    /// A point of a 2-D (pcurve, in (u, v), unscaled) or 3-D (mm) curve.
    pub(super) fn point_in(&self, id: u64, in_uv: bool) -> Result<V3> {
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

    pub(super) fn direction(&self, id: u64, in_uv: bool) -> Result<V3> {
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

    pub(super) fn frame(&self, id: u64, in_uv: bool) -> Result<Frame> {
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
}
