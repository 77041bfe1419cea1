//! B-spline curves and surfaces in every form STEP gives them: simple
//! instances (`B_SPLINE_SURFACE_WITH_KNOTS`, `BEZIER_SURFACE`,
//! `UNIFORM_SURFACE`, `QUASI_UNIFORM_SURFACE` and their curve forms) and
//! complex ones (`B_SPLINE_SURFACE` with one of those parts, rational with
//! `RATIONAL_B_SPLINE_SURFACE`), of any degree the evaluator takes
//! (`nurbs::MAX_DEGREE`), clamped or not (a periodic B-spline is written unclamped: its
//! domain is [t_p, t_n] of its knots).

use super::curves::Curve;
use super::records::list;
use super::{StepFile, SurfaceFile};
use ruststep::ast::Parameter;
use toolpath_kernel::error::Result;

/// How a B-spline entity gives its knots (ISO 10303-42, 4.3.4).
#[derive(Clone, Copy)]
enum KnotForm<'a> {
    /// `..._WITH_KNOTS`: multiplicities and knots listed, from this
    /// parameter list (multiplicities first, one list per direction).
    Explicit(&'a [Parameter]),
    /// `UNIFORM_...`: knots -p, -p + 1, ... one apart, all simple.
    Uniform,
    /// `QUASI_UNIFORM_...`: knots 0, 1, ... one apart, the ends of
    /// multiplicity p + 1.
    QuasiUniform,
    /// `BEZIER_...`: piecewise Bezier, knots 0, 1, ... of multiplicity p
    /// (p + 1 at the ends).
    Bezier,
}

/// The subtypes that fix the knots, by their entity name's prefix.
const FORMS: [(&str, KnotForm<'static>); 3] = [
    ("UNIFORM_", KnotForm::Uniform),
    ("QUASI_UNIFORM_", KnotForm::QuasiUniform),
    ("BEZIER_", KnotForm::Bezier),
];

/// Largest knot multiplicity read: a bound on the file's numbers before
/// any knot vector is built (the surface's own checks then hold it to its
/// degree + 1).
const MAX_MULTIPLICITY: f64 = 64.0;

/// The knots of an implicit form for `count` control points of `degree`.
fn implicit_knots(
    form: KnotForm,
    degree: usize,
    count: usize,
) -> std::result::Result<Vec<f64>, String> {
    let p = degree;
    if p == 0 {
        return Err("has degree 0".into());
    }
    if count < p + 1 {
        return Err(format!(
            "has {count} control points, too few for degree {p}"
        ));
    }
    Ok(match form {
        KnotForm::Explicit(_) => unreachable!("explicit knots are read, not made"),
        KnotForm::Uniform => (0..count + p + 1).map(|i| i as f64 - p as f64).collect(),
        KnotForm::QuasiUniform => {
            let spans = count - p;
            let mut k = vec![0.0; p];
            k.extend((0..=spans).map(|i| i as f64));
            k.extend(std::iter::repeat_n(spans as f64, p));
            k
        }
        KnotForm::Bezier => {
            if !(count - 1).is_multiple_of(p) {
                return Err(format!(
                    "is a piecewise Bezier form with {count} control points, which degree {p} does not divide into segments (count - 1 must be a multiple of the degree)"
                ));
            }
            let segments = (count - 1) / p;
            // 0 and the last knot p + 1 times, the joints p times.
            let mut k = vec![0.0];
            for s in 0..=segments {
                k.extend(std::iter::repeat_n(s as f64, p));
            }
            k.push(segments as f64);
            k
        }
    })
}

/// Where a B-spline instance keeps its parameters.
struct BsplineParts<'a> {
    /// The `B_SPLINE_CURVE` / `B_SPLINE_SURFACE` parameters.
    core: &'a [Parameter],
    /// Index of the degree in `core` (1 in a simple instance, after the
    /// name; 0 in a complex one).
    offset: usize,
    form: KnotForm<'a>,
    /// The `RATIONAL_B_SPLINE_...` part's parameters, if rational.
    weights: Option<&'a [Parameter]>,
}

impl StepFile {
    /// The parts of B-spline instance `id` of `kind` (`CURVE` or
    /// `SURFACE`); None when `id` is not one. `core_len`: the number of
    /// `B_SPLINE_<kind>` parameters after the name (5 for a curve, 7 for a
    /// surface), after which a simple `..._WITH_KNOTS` instance lists its
    /// knots.
    fn bspline_parts(&self, id: u64, kind: &str, core_len: usize) -> Option<BsplineParts<'_>> {
        let records = self.entities.get(&id)?;
        let with_knots = format!("B_SPLINE_{kind}_WITH_KNOTS");
        if records.len() == 1 {
            let name = records[0].name.as_str();
            let p = list(&records[0].parameter)?;
            let form = if name == with_knots {
                KnotForm::Explicit(p.get(core_len + 1..).unwrap_or(&[]))
            } else {
                FORMS
                    .iter()
                    .find(|(prefix, _)| name == format!("{prefix}{kind}"))?
                    .1
            };
            return Some(BsplineParts {
                core: p,
                offset: 1,
                form,
                weights: None,
            });
        }
        let core = self.part(id, &format!("B_SPLINE_{kind}"))?;
        let form = match self.part(id, &with_knots) {
            Some(k) => KnotForm::Explicit(k),
            None => {
                FORMS
                    .iter()
                    .find(|(prefix, _)| self.part(id, &format!("{prefix}{kind}")).is_some())?
                    .1
            }
        };
        Some(BsplineParts {
            core,
            offset: 0,
            form,
            weights: self.part(id, &format!("RATIONAL_B_SPLINE_{kind}")),
        })
    }

    /// The full knot vector of one direction: listed (`mult`, `knots`: the
    /// parameter indices of its multiplicities and knots) or implicit.
    fn knot_vector(
        &self,
        id: u64,
        form: KnotForm,
        (mult, knots): (usize, usize),
        degree: usize,
        count: usize,
    ) -> Result<Vec<f64>> {
        let KnotForm::Explicit(p) = form else {
            return implicit_knots(form, degree, count).map_err(|m| self.err(id, m));
        };
        let m = self.reals(id, p, mult)?;
        let k = self.reals(id, p, knots)?;
        if m.len() != k.len() {
            return Err(self.err(id, "has knot and multiplicity lists of different lengths"));
        }
        let mut out = Vec::new();
        for (&m, &k) in m.iter().zip(&k) {
            if !(1.0..=MAX_MULTIPLICITY).contains(&m) || m.fract() != 0.0 {
                return Err(self.err(id, format!("has a knot multiplicity {m}")));
            }
            out.extend(std::iter::repeat_n(k, m as usize));
        }
        Ok(out)
    }

    /// A B-spline surface in any of its forms as a surface file (mm,
    /// (u, v) as in the file); None when `id` is no B-spline surface.
    pub(super) fn bspline_surface(&self, id: u64) -> Result<Option<SurfaceFile>> {
        let Some(b) = self.bspline_parts(id, "SURFACE", 7) else {
            return Ok(None);
        };
        let degree_u = self.integer(id, b.core, b.offset)?;
        let degree_v = self.integer(id, b.core, b.offset + 1)?;
        let rows = list(self.arg(id, b.core, b.offset + 2)?)
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
        let count_u = control_points.len();
        let count_v = control_points.first().map_or(0, Vec::len);
        let knots_u = self.knot_vector(id, b.form, (0, 2), degree_u, count_u)?;
        let knots_v = self.knot_vector(id, b.form, (1, 3), degree_v, count_v)?;
        let weights = match b.weights {
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
        Ok(Some(s))
    }

    /// A B-spline curve in any of its forms (3-D in mm, or a pcurve in
    /// (u, v)); None when `id` is no B-spline curve.
    pub(super) fn bspline_curve(&self, id: u64, in_uv: bool) -> Result<Option<Curve>> {
        let Some(b) = self.bspline_parts(id, "CURVE", 5) else {
            return Ok(None);
        };
        let degree = self.integer(id, b.core, b.offset)?;
        let pts = self
            .references(id, b.core, b.offset + 1)?
            .iter()
            .map(|&c| self.point_in(c, in_uv))
            .collect::<Result<Vec<_>>>()?;
        if degree == 0 {
            return Err(self.err(id, "has degree 0"));
        }
        let full = self.knot_vector(id, b.form, (0, 1), degree, pts.len())?;
        if full.len() != pts.len() + degree + 1 {
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
        let w = match b.weights {
            Some(w) => self.reals(id, w, 0)?,
            None => vec![1.0; pts.len()],
        };
        if w.len() != pts.len() || w.iter().any(|&x| x.is_nan() || x <= 0.0) {
            return Err(self.err(id, "has weights that are not one positive number per point"));
        }
        Ok(Some(Curve::Bspline {
            degree,
            knots: full,
            points: pts
                .iter()
                .zip(&w)
                .map(|(p, &w)| [p.x * w, p.y * w, p.z * w, w])
                .collect(),
        }))
    }
}
