//! The file's length and plane angle units, from its representation
//! contexts.

use super::records::list;
use super::StepFile;
use ruststep::ast::{Name, Parameter};
use toolpath_kernel::error::Result;

impl StepFile {
    /// The length unit named by the representation contexts, in mm: an
    /// `SI_UNIT` on metres with its prefix, or a `CONVERSION_BASED_UNIT`
    /// (inch, foot, ...) through its measure. Files naming none are in mm.
    pub(super) fn length_unit(&self) -> Result<f64> {
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
    pub(super) fn angle_unit(&self) -> Result<f64> {
        for u in self.context_units()? {
            if self.part(u, "PLANE_ANGLE_UNIT").is_some() {
                return self.unit_rad(u, 0);
            }
        }
        Ok(1.0)
    }

    /// The unit entities every `GLOBAL_UNIT_ASSIGNED_CONTEXT` lists, in
    /// entity order.
    pub(super) fn context_units(&self) -> Result<Vec<u64>> {
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

    pub(super) fn unit_rad(&self, id: u64, depth: usize) -> Result<f64> {
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
            let (factor, base) = self.conversion(id, p, "PLANE_ANGLE_MEASURE_WITH_UNIT")?;
            return Ok(factor * self.unit_rad(base, depth + 1)?);
        }
        Err(self.err(id, "is a plane angle unit of an unsupported kind"))
    }

    pub(super) fn unit_mm(&self, id: u64, depth: usize) -> Result<f64> {
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
            let (factor, base) = self.conversion(id, p, "LENGTH_MEASURE_WITH_UNIT")?;
            return Ok(factor * self.unit_mm(base, depth + 1)?);
        }
        Err(self.err(id, "is a length unit of an unsupported kind"))
    }

    /// A `CONVERSION_BASED_UNIT` (`p`: its parameters): the factor of its
    /// measure (a `measure`, e.g. `LENGTH_MEASURE_WITH_UNIT`) and the unit
    /// that measure is in.
    fn conversion(&self, id: u64, p: &[Parameter], measure: &str) -> Result<(f64, u64)> {
        let m = self.reference(id, p, 1)?;
        let records = self.records(m)?;
        let mp = records
            .iter()
            .find(|r| r.name.ends_with("MEASURE_WITH_UNIT"))
            .and_then(|r| list(&r.parameter))
            .ok_or_else(|| self.err(m, format!("should be a {measure}")))?;
        Ok((self.real(m, mp, 0)?, self.reference(m, mp, 1)?))
    }
}
