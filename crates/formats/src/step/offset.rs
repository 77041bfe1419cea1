//! `OFFSET_SURFACE`: the basis surface moved by a distance along its unit
//! normal, S(u, v) + d N(u, v) (ISO 10303-42). Offsets of planes,
//! cylinders, cones, spheres and tori are again such surfaces and are read
//! exactly (the plane moved, the meridian line moved along its normal, the
//! meridian circle's radius grown by d). Any other offset is no NURBS: it
//! is fitted by a bicubic B-spline interpolating the exact offset over the
//! face's extent in the basis's (u, v), on the basis's own knots (with the
//! continuity its offset keeps there) subdivided until the fit is within
//! [`OFFSET_FIT_TOLERANCE_MM`] of the exact offset at 3 x 3 points in every
//! cell of the fit (docs/formats.md, "STEP import").

use super::curves::MAX_NESTING;
use super::patches::{bspline_patch, Patch};
use super::surfaces::{Basis, Meridian};
use super::{StepFile, SurfaceFile, V3};
use nalgebra::Point3;
use toolpath_kernel::error::Result;
use toolpath_kernel::geometry::interpolation::interpolate_surface;
use toolpath_kernel::geometry::NurbsSurface;

/// Largest distance, mm, of a fitted offset surface from the exact offset
/// at the points it is checked at (the trim's default tolerance is 1e-3 mm:
/// the fit stays ten times inside it).
pub const OFFSET_FIT_TOLERANCE_MM: f64 = 1e-4;

/// Degree of the fit in each direction.
const FIT_DEGREE: usize = 3;

/// Most knot spans of a fit in one direction; an offset that needs more
/// (one folding over itself, where the distance passes a radius of
/// curvature) is refused.
const MAX_FIT_SPANS: usize = 512;

/// Subdivisions of the basis's spans from which a fit whose error stops
/// falling is given up (before, the basis's own features may still be
/// resolving).
const MIN_PIECES_BEFORE_STALL: usize = 8;

/// Points per cell side at which a fit is checked (at 1/4, 1/2 and 3/4).
const CHECKS_PER_CELL: usize = 3;

/// Share of the face's (u, v) extent added on each side of the fitted
/// patch, so that the boundary's points map inside it.
const FIT_MARGIN: f64 = 0.01;

impl StepFile {
    /// An `OFFSET_SURFACE` at nesting depth `depth`: exact where the basis
    /// is an elementary surface, else [`Basis::Offset`] for the fit.
    pub(super) fn offset_surface(&self, id: u64, depth: usize) -> Result<Basis> {
        if depth >= MAX_NESTING {
            return Err(self.err(id, "nests surfaces too deeply (a cycle?)"));
        }
        let (_, p) = self.expect(id, &["OFFSET_SURFACE"])?;
        let basis = self.basis_nested(self.reference(id, p, 1)?, depth + 1)?;
        let distance = self.real(id, p, 2)? * self.mm_per_unit;
        self.offset_of(id, basis, distance)
    }

    /// `basis` offset by `distance` mm along its normal.
    fn offset_of(&self, id: u64, basis: Basis, distance: f64) -> Result<Basis> {
        Ok(match basis {
            Basis::Plane(mut f) => {
                f.o += f.z * distance;
                Basis::Plane(f)
            }
            Basis::Revolved(f, Meridian::Line { p, d }, what) => {
                // The patch's normal in the (rho, h) plane is (h', -rho').
                let len = d[0].hypot(d[1]);
                let n = [d[1] / len, -d[0] / len];
                let p = [p[0] + distance * n[0], p[1] + distance * n[1]];
                Basis::Revolved(f, Meridian::Line { p, d }, what)
            }
            Basis::Revolved(f, Meridian::Conic { c, a, b }, what) if is_circle(a, b) => {
                // The normal is radial, outward where (a, b) turn
                // counter-clockwise.
                let r = a[0].hypot(a[1]);
                let sense = (a[0] * b[1] - a[1] * b[0]).signum();
                let k = 1.0 + sense * distance / r;
                if k <= 0.0 {
                    return Err(self.err(
                        id,
                        format!("offsets its {what} of radius {r} mm by {distance} mm: the offset collapses"),
                    ));
                }
                let (a, b) = ([a[0] * k, a[1] * k], [b[0] * k, b[1] * k]);
                Basis::Revolved(f, Meridian::Conic { c, a, b }, what)
            }
            Basis::Offset {
                basis,
                distance: inner,
                ..
            } => Basis::Offset {
                basis,
                distance: inner + distance,
                id,
            },
            other => Basis::Offset {
                basis: Box::new(other),
                distance,
                id,
            },
        })
    }

    /// The fitted patch of `basis` offset by `distance` mm (entity `id`)
    /// over the extent of the face's boundary (`coarse`, points on the
    /// offset surface, which map to the basis point they lie over).
    pub(super) fn offset_patch(
        &self,
        face: u64,
        basis: Basis,
        distance: f64,
        id: u64,
        coarse: &[Vec<V3>],
    ) -> Result<Patch> {
        let base = self.patch(face, basis, coarse)?;
        let n = base.surface.to_surface()?;
        let (lo, hi) = uv_box(&base, &n, coarse);
        let exact = |u: f64, v: f64| -> [f64; 3] {
            let p = n.point(u, v);
            let q = match n.normal(u, v) {
                Some(nn) => p + nn * distance,
                None => Point3::new(f64::NAN, f64::NAN, f64::NAN),
            };
            [q.x, q.y, q.z]
        };
        let breaks_u = breakpoints(n.knots_u(), n.degree_u(), lo[0], hi[0]);
        let breaks_v = breakpoints(n.knots_v(), n.degree_v(), lo[1], hi[1]);
        let mut pieces = 1;
        let mut worst = f64::INFINITY;
        loop {
            let (ku, kv) = (fit_knots(&breaks_u, pieces), fit_knots(&breaks_v, pieces));
            let spans = (ku.len() - 2 * FIT_DEGREE - 1).max(kv.len() - 2 * FIT_DEGREE - 1);
            let fit = interpolate_surface(exact, FIT_DEGREE, ku, FIT_DEGREE, kv).map_err(|e| {
                self.err(
                    id,
                    format!(
                        "cannot be fitted: {e} (its basis has no normal somewhere on the face)"
                    ),
                )
            })?;
            let previous = worst;
            worst = deviation(&fit, &exact);
            if worst <= OFFSET_FIT_TOLERANCE_MM {
                return bspline_patch(surface_file(&fit));
            }
            // A smooth offset's error falls about 16 times a doubling; one
            // that no longer halves is not smooth (it folds over itself).
            let stalled = pieces >= MIN_PIECES_BEFORE_STALL && worst > 0.5 * previous;
            if stalled || 2 * spans > MAX_FIT_SPANS {
                return Err(self.err(
                    id,
                    format!(
                        "cannot be fitted within {OFFSET_FIT_TOLERANCE_MM} mm: {spans} knot spans a direction leave {worst:.2e} mm{}; an offset of {distance} mm may fold over itself",
                        if stalled { " and more do not converge" } else { "" }
                    ),
                ));
            }
            pieces *= 2;
        }
    }
}

/// Whether `c + a cos s + b sin s` is a circle.
fn is_circle(a: [f64; 2], b: [f64; 2]) -> bool {
    let (ra, rb) = (a[0].hypot(a[1]), b[0].hypot(b[1]));
    (ra - rb).abs() <= 1e-12 * ra && (a[0] * b[0] + a[1] * b[1]).abs() <= 1e-12 * ra * rb
}

/// The box in the basis patch's (u, v) of the face's boundary points (each
/// loop mapped with its previous point as the seed), widened by
/// [`FIT_MARGIN`] and kept inside the domain.
fn uv_box(base: &Patch, n: &NurbsSurface, coarse: &[Vec<V3>]) -> ([f64; 2], [f64; 2]) {
    let ((u0, u1), (v0, v1)) = n.domain();
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for l in coarse {
        let mut seed = None;
        for q in l {
            let uv = (base.to_uv)(q, seed);
            seed = Some(uv);
            for k in 0..2 {
                lo[k] = lo[k].min(uv[k]);
                hi[k] = hi[k].max(uv[k]);
            }
        }
    }
    if !(hi[0] > lo[0] && hi[1] > lo[1]) {
        return ([u0, v0], [u1, v1]);
    }
    let (du, dv) = (FIT_MARGIN * (hi[0] - lo[0]), FIT_MARGIN * (hi[1] - lo[1]));
    (
        [(lo[0] - du).max(u0), (lo[1] - dv).max(v0)],
        [(hi[0] + du).min(u1), (hi[1] + dv).min(v1)],
    )
}

/// The basis's distinct knots strictly inside (lo, hi), each with the
/// multiplicity a cubic needs to follow the offset there: the basis is
/// C^(p - m) at a knot of multiplicity m, its normal and so its offset one
/// order less, C^(p - m - 1); a cubic knot of multiplicity 3 - (p - m - 1)
/// (1 to 3) allows that much. The ends lo and hi come first and last.
fn breakpoints(knots: &[f64], degree: usize, lo: f64, hi: f64) -> Vec<(f64, usize)> {
    let mut out = vec![(lo, 0)];
    let mut k = 0;
    while k < knots.len() {
        let mut m = 1;
        while k + m < knots.len() && knots[k + m] == knots[k] {
            m += 1;
        }
        if knots[k] > lo && knots[k] < hi {
            let continuity = degree as isize - m as isize - 1;
            let mult = (FIT_DEGREE as isize - continuity).clamp(1, FIT_DEGREE as isize);
            out.push((knots[k], mult as usize));
        }
        k += m;
    }
    out.push((hi, 0));
    out
}

/// The clamped cubic knot vector with the breakpoints' knots and every
/// interval between two breakpoints split into `pieces` equal spans.
fn fit_knots(breaks: &[(f64, usize)], pieces: usize) -> Vec<f64> {
    let mut k = vec![breaks[0].0; FIT_DEGREE + 1];
    for w in breaks.windows(2) {
        let ((a, _), (b, mult)) = (w[0], w[1]);
        for i in 1..pieces {
            k.push(a + (b - a) * i as f64 / pieces as f64);
        }
        let m = if mult == 0 { FIT_DEGREE + 1 } else { mult };
        k.extend(std::iter::repeat_n(b, m));
    }
    k
}

/// Largest distance between the fit and the exact offset at
/// [`CHECKS_PER_CELL`]^2 interior points of every cell of the fit.
fn deviation(fit: &NurbsSurface, exact: &dyn Fn(f64, f64) -> [f64; 3]) -> f64 {
    let cells = |knots: &[f64]| -> Vec<f64> {
        let mut t = Vec::new();
        for w in knots.windows(2) {
            if w[1] > w[0] {
                t.extend(
                    (1..=CHECKS_PER_CELL)
                        .map(|i| w[0] + (w[1] - w[0]) * i as f64 / (CHECKS_PER_CELL + 1) as f64),
                );
            }
        }
        t
    };
    let (us, vs) = (cells(fit.knots_u()), cells(fit.knots_v()));
    let mut worst = 0.0f64;
    for &u in &us {
        for &v in &vs {
            let e = exact(u, v);
            let d = (fit.point(u, v).coords - V3::new(e[0], e[1], e[2])).norm();
            // NaN (no normal there) counts as a failure.
            worst = if d.is_nan() {
                f64::INFINITY
            } else {
                worst.max(d)
            };
        }
    }
    worst
}

/// A fitted surface as a surface file.
fn surface_file(s: &NurbsSurface) -> SurfaceFile {
    SurfaceFile {
        kind: "nurbs".into(),
        name: None,
        degree_u: s.degree_u(),
        degree_v: s.degree_v(),
        knots_u: s.knots_u().to_vec(),
        knots_v: s.knots_v().to_vec(),
        control_points: s.control_grid(),
        weights: s.weight_grid(),
        trim: None,
    }
}
