//! The surface a face lies on, as the file gives it: a B-spline surface,
//! a plane, a surface of revolution (cylinder, cone, sphere, torus,
//! `SURFACE_OF_REVOLUTION`) as its axis frame and meridian, or a
//! `SURFACE_OF_LINEAR_EXTRUSION` as its section; offset surfaces
//! (`offset`) and B-splines (`bspline`) have their own modules.

use super::curves::{plane_curve, Curve, MAX_NESTING};
use super::records::{name_of, Frame};
use super::{StepFile, SurfaceFile, SUPPORTED_SURFACES, V3};
use ruststep::ast::{Name, Parameter};
use std::f64::consts::{PI, TAU};
use toolpath_kernel::error::Result;

/// The surface a face lies on, as read.
pub(super) enum Basis {
    Bspline(SurfaceFile),
    Plane(Frame),
    /// A surface of revolution about the frame's z axis (cylinder, cone,
    /// sphere, torus, `SURFACE_OF_REVOLUTION`), named for messages.
    Revolved(Frame, Meridian, &'static str),
    /// A `SURFACE_OF_LINEAR_EXTRUSION` along the frame's z: its swept
    /// curve projected along z onto the frame's (x, y) plane (the section).
    Extruded(Frame, Meridian),
    /// An `OFFSET_SURFACE` (entity `id`) that is no elementary surface:
    /// `basis` moved by `distance` mm along its normal, fitted
    /// ([`StepFile::offset_patch`]).
    Offset {
        basis: Box<Basis>,
        distance: f64,
        id: u64,
    },
}

/// The meridian of a surface of revolution in the frame's (rho, h) half
/// plane: rho along the frame's x (distance from the axis), h along its z.
#[derive(Clone)]
pub(super) enum Meridian {
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
    pub(super) fn locate(&self, m: [f64; 2], seed: Option<f64>) -> f64 {
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

impl StepFile {
    /// The surface `id` a face lies on.
    pub(super) fn basis(&self, id: u64) -> Result<Basis> {
        self.basis_nested(id, 0)
    }

    /// [`Self::basis`] inside `depth` wrapping entities (offset or trimmed
    /// surfaces).
    pub(super) fn basis_nested(&self, id: u64, depth: usize) -> Result<Basis> {
        let records = self.records(id)?;
        let name = name_of(records);
        if records.len() == 1 {
            match name.as_str() {
                "PLANE" => {
                    let (_, p) = self.expect(id, &["PLANE"])?;
                    return Ok(Basis::Plane(self.frame(self.reference(id, p, 1)?, false)?));
                }
                "SURFACE_OF_LINEAR_EXTRUSION" => return self.linear_extrusion(id),
                "OFFSET_SURFACE" => return self.offset_surface(id, depth),
                "RECTANGULAR_TRIMMED_SURFACE" => return self.rectangular_trimmed(id, depth),
                _ => {
                    if let Some(b) = self.revolved(id, &name)? {
                        return Ok(b);
                    }
                }
            }
        }
        match self.bspline_surface(id)? {
            Some(s) => Ok(Basis::Bspline(s)),
            None => Err(self.err(
                id,
                format!("is not a supported surface (supported: {SUPPORTED_SURFACES})"),
            )),
        }
    }

    /// A `RECTANGULAR_TRIMMED_SURFACE`: its basis surface (the face's
    /// bounds trim it). Only the form whose parameters run as the basis's
    /// (both senses .T.) is read, so the basis's pcurves and normal are the
    /// face's.
    fn rectangular_trimmed(&self, id: u64, depth: usize) -> Result<Basis> {
        if depth >= MAX_NESTING {
            return Err(self.err(id, "nests surfaces too deeply (a cycle?)"));
        }
        let (_, p) = self.expect(id, &["RECTANGULAR_TRIMMED_SURFACE"])?;
        if !(self.boolean(id, p, 6)? && self.boolean(id, p, 7)?) {
            return Err(self.err(
                id,
                "runs against its basis surface's parameters (usense or vsense .F.): not supported",
            ));
        }
        self.basis_nested(self.reference(id, p, 1)?, depth + 1)
    }

    /// A cylinder, cone, sphere, torus or surface of revolution as its
    /// frame and meridian (docs/formats.md, "STEP import"); None for other
    /// entities.
    pub(super) fn revolved(&self, id: u64, name: &str) -> Result<Option<Basis>> {
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
    pub(super) fn surface_of_revolution(&self, id: u64, p: &[Parameter]) -> Result<Basis> {
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
    pub(super) fn linear_extrusion(&self, id: u64) -> Result<Basis> {
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
}
