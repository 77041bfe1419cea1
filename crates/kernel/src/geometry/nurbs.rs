//! Rational B-spline (NURBS) tensor-product surfaces: evaluation with all
//! partial derivatives up to second order.
//!
//! Written by hand (see docs/architecture.md): the planners evaluate surfaces
//! millions of times, so evaluation works on fixed-size stack arrays and never
//! allocates. The arrays' size is a const parameter: degree + 1 for the
//! bicubic surface most parts are, [`TABULATED_MAX_DEGREE`] + 1 for the other
//! common degrees, [`MAX_DEGREE`] + 1 for the high degrees CAD writes
//! (rational fillets of degree 11 to 14 and above), so a bicubic evaluation
//! never clears or walks arrays sized for degree 25. Algorithms follow Piegl & Tiller, *The NURBS Book*
//! (A2.1 span search, A2.3 basis derivatives, A4.4 rational derivatives).

use crate::error::{Error, Result};
use nalgebra::{Point3, Vector3};

/// Highest supported degree in either direction: above what CAD systems
/// write (OpenCASCADE's fillets and blends reach degree 14; the STEP files
/// of common CAD systems stay at or below 25).
pub const MAX_DEGREE: usize = 25;
const MAXP1: usize = MAX_DEGREE + 1;

/// Highest degree whose basis is tabulated per span ([`SpanBasis`]) and
/// evaluated on arrays of [`TABULATED_MAX_DEGREE`] + 1: above it the
/// power-basis coefficients of a span grow like binomials (cancellation
/// past 1e-12 relative), so The NURBS Book's A2.3 evaluates instead.
pub const TABULATED_MAX_DEGREE: usize = 9;
const TABP1: usize = TABULATED_MAX_DEGREE + 1;

/// Position and partial derivatives up to second order at one (u, v).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceDerivs {
    pub p: Point3<f64>,
    pub su: Vector3<f64>,
    pub sv: Vector3<f64>,
    pub suu: Vector3<f64>,
    pub suv: Vector3<f64>,
    pub svv: Vector3<f64>,
}

/// A NURBS tensor-product surface. Control points are stored row-major:
/// index `i * count_v + j`, `i` along u, `j` along v, in homogeneous form
/// `(w x, w y, w z, w)`.
#[derive(Clone, Debug, PartialEq)]
pub struct NurbsSurface {
    degree_u: usize,
    degree_v: usize,
    knots_u: Vec<f64>,
    knots_v: Vec<f64>,
    count_u: usize,
    count_v: usize,
    homogeneous: Vec<[f64; 4]>,
    rational: bool,
    /// The parameter domain [u0, u1, v0, v1] (from the knots; kept because
    /// every evaluation clamps into it).
    bounds: [f64; 4],
    /// The trimmed face, where only part of the domain is the surface
    /// (`None`: the whole domain).
    trim: Option<std::sync::Arc<super::trim::Trim>>,
    /// Which boundaries `[u0, u1, v0, v1]` are collapsed to a point (a pole
    /// or the apex of a triangular patch): S_v = 0 along u = u0 or u1,
    /// S_u = 0 along v = v0 or v1 (docs/methods.md, "Degenerate boundaries").
    collapsed: [bool; 4],
    /// The basis functions of each knot span as polynomials (see
    /// [`SpanBasis`]); `None` for a knot vector too long to tabulate.
    basis_u: Option<std::sync::Arc<SpanBasis>>,
    basis_v: Option<std::sync::Arc<SpanBasis>>,
}

/// Share of the parameter span next to a collapsed boundary inside which the
/// derivatives are taken at that distance from it: the limit of the
/// neighbouring tangent planes and curvatures (docs/methods.md, "Degenerate
/// boundaries"). The normal moves by about this share of the span's length
/// over the radius of curvature; rounding in S_vv (1e-16 relative) over
/// |S_v|^2 (this share squared) keeps curvatures to about 1e-8 relative.
pub const POLE_NUDGE: f64 = 1e-5;

/// A boundary whose points all lie within this share of the control net's
/// diagonal of each other is collapsed.
const COLLAPSE_TOLERANCE: f64 = 1e-9;

/// Weights whose largest value lies outside [2^-64, 2^64] are scaled by a
/// power of two (exact, the same surface: weights are homogeneous) so that
/// products with small basis values do not underflow.
const WEIGHT_RANGE: f64 = 18446744073709551616.0;

fn check_knots(name: &str, degree: usize, count: usize, knots: &[f64]) -> Result<()> {
    if degree == 0 {
        return Err(Error::invalid(
            format!("degree_{name}"),
            "degree must be at least 1",
        ));
    }
    if degree > MAX_DEGREE {
        return Err(Error::invalid(
            format!("degree_{name}"),
            format!("degree {degree} is higher than the supported maximum {MAX_DEGREE}"),
        ));
    }
    if count < degree + 1 {
        return Err(Error::invalid(
            "control_points",
            format!(
                "{count} control points along {name} are too few for degree {degree} (need at least {})",
                degree + 1
            ),
        ));
    }
    let field = format!("knots_{name}");
    if knots.len() != count + degree + 1 {
        return Err(Error::invalid(
            field,
            format!(
                "has {} knots; degree {degree} with {count} control points along {name} needs {}",
                knots.len(),
                count + degree + 1
            ),
        ));
    }
    for (k, &t) in knots.iter().enumerate() {
        if !t.is_finite() {
            return Err(Error::invalid(
                format!("{field}[{k}]"),
                "is not a finite number",
            ));
        }
    }
    for k in 1..knots.len() {
        if knots[k] < knots[k - 1] {
            return Err(Error::invalid(
                format!("{field}[{k}]"),
                format!(
                    "knot vector is not non-decreasing ({} after {})",
                    knots[k],
                    knots[k - 1]
                ),
            ));
        }
    }
    // A knot repeated more than the degree inside the domain would make the
    // surface discontinuous; more than degree + 1 anywhere is meaningless.
    let (lo, hi) = (knots[degree], knots[count]);
    let mut k = 0;
    while k < knots.len() {
        let mut run = 1;
        while k + run < knots.len() && knots[k + run] == knots[k] {
            run += 1;
        }
        let interior = knots[k] > lo && knots[k] < hi;
        if run > degree + 1 || (interior && run > degree) {
            return Err(Error::invalid(
                format!("{field}[{k}]"),
                format!(
                    "knot {} has multiplicity {run}, more than degree {degree} allows",
                    knots[k]
                ),
            ));
        }
        k += run;
    }
    if knots[count] <= knots[degree] {
        return Err(Error::invalid(
            field,
            "parameter domain is empty (all active knots equal)",
        ));
    }
    Ok(())
}

/// The grid size of `control_points` (rows along u), checked: not empty,
/// rectangular, finite coordinates.
fn check_control_points(control_points: &[Vec<[f64; 3]>]) -> Result<(usize, usize)> {
    let count_u = control_points.len();
    if count_u == 0 {
        return Err(Error::invalid("control_points", "is empty"));
    }
    let count_v = control_points[0].len();
    for (i, row) in control_points.iter().enumerate() {
        if row.len() != count_v {
            return Err(Error::invalid(
                format!("control_points[{i}]"),
                format!(
                    "has {} points, row 0 has {count_v}: the grid must be rectangular",
                    row.len()
                ),
            ));
        }
        for (j, p) in row.iter().enumerate() {
            if p.iter().any(|c| !c.is_finite()) {
                return Err(Error::invalid(
                    format!("control_points[{i}][{j}]"),
                    "has a coordinate that is not a finite number",
                ));
            }
        }
    }
    Ok((count_u, count_v))
}

/// The homogeneous control points (x w, y w, z w, w), row-major, weights
/// checked against the grid (positive, finite) and scaled by a power of two
/// when their largest lies outside [1 / WEIGHT_RANGE, WEIGHT_RANGE]; and
/// whether any weight differs from 1.
fn homogeneous_points(
    control_points: &[Vec<[f64; 3]>],
    weights: Option<&[Vec<f64>]>,
) -> Result<(Vec<[f64; 4]>, bool)> {
    let (count_u, count_v) = (control_points.len(), control_points[0].len());
    let mut homogeneous = Vec::with_capacity(count_u * count_v);
    let mut rational = false;
    let mut weight_scale = 1.0;
    if let Some(w) = weights {
        if w.len() != count_u {
            return Err(Error::invalid(
                "weights",
                format!("has {} rows, control_points has {count_u}", w.len()),
            ));
        }
        for (i, row) in w.iter().enumerate() {
            if row.len() != count_v {
                return Err(Error::invalid(
                    format!("weights[{i}]"),
                    format!(
                        "has {} values, control_points[{i}] has {count_v}",
                        row.len()
                    ),
                ));
            }
            for (j, &x) in row.iter().enumerate() {
                if !x.is_finite() || x <= 0.0 {
                    return Err(Error::invalid(
                        format!("weights[{i}][{j}]"),
                        format!("weight {x} must be a positive finite number"),
                    ));
                }
            }
        }
        let max = w.iter().flatten().fold(0.0f64, |a, &b| a.max(b));
        if !(1.0 / WEIGHT_RANGE..=WEIGHT_RANGE).contains(&max) {
            // 2^-e with max in [2^e, 2^(e+1)): the largest weight becomes [1, 2).
            weight_scale = 2f64.powi(-(max.log2().floor() as i32));
        }
    }
    for i in 0..count_u {
        for j in 0..count_v {
            let w = match weights {
                Some(w) => w[i][j],
                None => 1.0,
            };
            if w != 1.0 {
                rational = true;
            }
            let w = w * weight_scale;
            let p = control_points[i][j];
            homogeneous.push([p[0] * w, p[1] * w, p[2] * w, w]);
        }
    }
    Ok((homogeneous, rational))
}

impl NurbsSurface {
    /// Builds and validates a surface. `control_points[i][j]`, `i` along u.
    pub fn new(
        degree_u: usize,
        degree_v: usize,
        knots_u: Vec<f64>,
        knots_v: Vec<f64>,
        control_points: &[Vec<[f64; 3]>],
        weights: Option<&[Vec<f64>]>,
    ) -> Result<Self> {
        let (count_u, count_v) = check_control_points(control_points)?;
        check_knots("u", degree_u, count_u, &knots_u)?;
        check_knots("v", degree_v, count_v, &knots_v)?;
        let (homogeneous, rational) = homogeneous_points(control_points, weights)?;
        let mut surface = Self {
            degree_u,
            degree_v,
            knots_u,
            knots_v,
            count_u,
            count_v,
            homogeneous,
            rational,
            bounds: [0.0; 4],
            trim: None,
            collapsed: [false; 4],
            basis_u: None,
            basis_v: None,
        };
        surface.bounds = [
            surface.knots_u[degree_u],
            surface.knots_u[count_u],
            surface.knots_v[degree_v],
            surface.knots_v[count_v],
        ];
        surface.basis_u = SpanBasis::new(degree_u, count_u, &surface.knots_u).map(Into::into);
        surface.basis_v = SpanBasis::new(degree_v, count_v, &surface.knots_v).map(Into::into);
        surface.collapsed = surface.find_collapsed();
        Ok(surface)
    }

    /// Which boundaries are a single point: sampled at a few points per
    /// knot span (a non-constant spline of that degree cannot pass through
    /// them all at one point).
    fn find_collapsed(&self) -> [bool; 4] {
        let (lo, hi) = self.bounding_box();
        let tol = COLLAPSE_TOLERANCE * (hi - lo).norm();
        let ((u0, u1), (v0, v1)) = self.domain();
        let samples = |knots: &[f64], degree: usize, count: usize| -> Vec<f64> {
            let mut t = Vec::new();
            for k in degree..count {
                let (a, b) = (knots[k], knots[k + 1]);
                if b > a {
                    t.extend(
                        (0..=degree + 1).map(|i| a + (b - a) * i as f64 / (degree + 1) as f64),
                    );
                }
            }
            t
        };
        let along_v = samples(&self.knots_v, self.degree_v, self.count_v);
        let along_u = samples(&self.knots_u, self.degree_u, self.count_u);
        let is_point = |pts: Vec<Point3<f64>>| {
            pts.first()
                .is_some_and(|f| pts.iter().all(|p| (p - f).norm() <= tol))
        };
        [
            is_point(along_v.iter().map(|&v| self.point(u0, v)).collect()),
            is_point(along_v.iter().map(|&v| self.point(u1, v)).collect()),
            is_point(along_u.iter().map(|&u| self.point(u, v0)).collect()),
            is_point(along_u.iter().map(|&u| self.point(u, v1)).collect()),
        ]
    }

    /// Which boundaries `[u0, u1, v0, v1]` are collapsed to a point.
    pub fn collapsed_boundaries(&self) -> [bool; 4] {
        self.collapsed
    }

    /// `(u, v)` (clamped) moved off any collapsed boundary by
    /// [`POLE_NUDGE`] of the span: where the derivatives are taken.
    pub fn off_collapsed(&self, u: f64, v: f64) -> (f64, f64) {
        let (mut u, mut v) = self.clamp_uv(u, v);
        if self.collapsed == [false; 4] {
            return (u, v);
        }
        let ((u0, u1), (v0, v1)) = self.domain();
        let (du, dv) = (POLE_NUDGE * (u1 - u0), POLE_NUDGE * (v1 - v0));
        if self.collapsed[0] {
            u = u.max(u0 + du);
        }
        if self.collapsed[1] {
            u = u.min(u1 - du);
        }
        if self.collapsed[2] {
            v = v.max(v0 + dv);
        }
        if self.collapsed[3] {
            v = v.min(v1 - dv);
        }
        (u, v)
    }

    /// The surface trimmed to a face ([`Trim::new`](super::trim::Trim::new)
    /// builds one for this surface).
    pub fn with_trim(mut self, trim: super::trim::Trim) -> Self {
        self.trim = Some(std::sync::Arc::new(trim));
        self
    }

    /// The face's trim, `None` for the whole domain.
    pub fn trim(&self) -> Option<&super::trim::Trim> {
        self.trim.as_deref()
    }

    /// Is (u, v) on the face: inside the trim, or anywhere in the domain
    /// of an untrimmed surface? The one inside test every layer uses.
    pub fn in_face(&self, u: f64, v: f64) -> bool {
        match &self.trim {
            Some(t) => t.contains(u, v),
            None => true,
        }
    }

    pub fn degree_u(&self) -> usize {
        self.degree_u
    }
    pub fn degree_v(&self) -> usize {
        self.degree_v
    }
    pub fn knots_u(&self) -> &[f64] {
        &self.knots_u
    }
    pub fn knots_v(&self) -> &[f64] {
        &self.knots_v
    }
    pub fn count_u(&self) -> usize {
        self.count_u
    }
    pub fn count_v(&self) -> usize {
        self.count_v
    }
    pub fn is_rational(&self) -> bool {
        self.rational
    }
    /// Control point `(i, j)` in Cartesian form.
    pub fn control_point(&self, i: usize, j: usize) -> [f64; 3] {
        let h = self.homogeneous[i * self.count_v + j];
        [h[0] / h[3], h[1] / h[3], h[2] / h[3]]
    }
    pub fn weight(&self, i: usize, j: usize) -> f64 {
        self.homogeneous[i * self.count_v + j][3]
    }
    /// Control points as a grid `[i][j]`.
    pub fn control_grid(&self) -> Vec<Vec<[f64; 3]>> {
        (0..self.count_u)
            .map(|i| {
                (0..self.count_v)
                    .map(|j| self.control_point(i, j))
                    .collect()
            })
            .collect()
    }
    /// Weights as a grid, `None` for a non-rational surface.
    pub fn weight_grid(&self) -> Option<Vec<Vec<f64>>> {
        self.rational.then(|| {
            (0..self.count_u)
                .map(|i| (0..self.count_v).map(|j| self.weight(i, j)).collect())
                .collect()
        })
    }

    /// Parameter domain `((u0, u1), (v0, v1))`.
    pub fn domain(&self) -> ((f64, f64), (f64, f64)) {
        let [u0, u1, v0, v1] = self.bounds;
        ((u0, u1), (v0, v1))
    }

    /// Clamps `(u, v)` into the parameter domain.
    pub fn clamp_uv(&self, u: f64, v: f64) -> (f64, f64) {
        let ((u0, u1), (v0, v1)) = self.domain();
        (u.clamp(u0, u1), v.clamp(v0, v1))
    }

    /// Point on the surface.
    pub fn point(&self, u: f64, v: f64) -> Point3<f64> {
        self.derivs_order(u, v, 0).p
    }

    /// Position with first partial derivatives only (second ones are zero in the result).
    pub fn first_derivs(&self, u: f64, v: f64) -> SurfaceDerivs {
        self.derivs_order(u, v, 1)
    }

    /// Position with first and second partial derivatives.
    pub fn derivs(&self, u: f64, v: f64) -> SurfaceDerivs {
        self.derivs_order(u, v, 2)
    }

    /// [`Self::derivs_with`] with the degrees and order as constants for the
    /// common bicubic surface, so that the compiler unrolls its loops: the
    /// same operations in the same order, hence the same bits, only faster.
    ///
    /// Next to a collapsed boundary the derivatives are those at
    /// [`Self::off_collapsed`] and only the point is the exact one: on the
    /// boundary itself S_u x S_v = 0 and curvature from rounding noise
    /// (docs/methods.md, "Degenerate boundaries").
    fn derivs_order(&self, u: f64, v: f64, order: usize) -> SurfaceDerivs {
        if order > 0 && self.collapsed != [false; 4] {
            let (u, v) = self.clamp_uv(u, v);
            let (nu, nv) = self.off_collapsed(u, v);
            if (nu, nv) != (u, v) {
                let mut d = self.derivs_exact(nu, nv, order);
                d.p = self.derivs_exact(u, v, 0).p;
                return d;
            }
        }
        self.derivs_exact(u, v, order)
    }

    fn derivs_exact(&self, u: f64, v: f64, order: usize) -> SurfaceDerivs {
        match (self.degree_u, self.degree_v, order) {
            (3, 3, 2) => self.derivs_with::<4>(u, v, 3, 3, 2, false),
            (3, 3, 1) => self.derivs_with::<4>(u, v, 3, 3, 1, false),
            (3, 3, 0) => self.derivs_with::<4>(u, v, 3, 3, 0, false),
            (pu, pv, order) => self.derivs_any(u, v, pu, pv, order),
        }
    }

    /// [`Self::derivs_with`] for any degrees, as one out-of-line copy per
    /// array size.
    #[inline(never)]
    fn derivs_any(&self, u: f64, v: f64, pu: usize, pv: usize, order: usize) -> SurfaceDerivs {
        if pu.max(pv) <= TABULATED_MAX_DEGREE {
            self.derivs_with::<TABP1>(u, v, pu, pv, order, false)
        } else {
            self.derivs_with::<MAXP1>(u, v, pu, pv, order, false)
        }
    }

    /// Position and derivatives up to second order from the basis of The
    /// NURBS Book's A2.3 (with its divisions) instead of the tabulated span
    /// polynomials: the reference the tables are tested against.
    pub fn derivs_reference(&self, u: f64, v: f64) -> SurfaceDerivs {
        self.derivs_with::<MAXP1>(u, v, self.degree_u, self.degree_v, 2, true)
    }

    /// Position and derivatives up to `order` (<= 2) for degrees `pu`, `pv`
    /// (this surface's, both below `N`): the basis in each direction from
    /// the span polynomials ([`SpanBasis`]; A2.3 when `reference` or
    /// untabulated), then A4.4 when rational.
    // Index loops mirror The NURBS Book's algorithms; iterators would obscure them.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn derivs_with<const N: usize>(
        &self,
        u: f64,
        v: f64,
        pu: usize,
        pv: usize,
        order: usize,
        reference: bool,
    ) -> SurfaceDerivs {
        let (u, v) = self.clamp_uv(u, v);
        let su = find_span(pu, self.count_u, &self.knots_u, u);
        let sv = find_span(pv, self.count_v, &self.knots_v, v);
        let du = order.min(pu);
        let dv = order.min(pv);
        let nu = match &self.basis_u {
            Some(b) if !reference => b.ders::<N>(su, u, pu, du),
            _ => basis_ders::<N>(su, u, pu, du, &self.knots_u),
        };
        let nv = match &self.basis_v {
            Some(b) if !reference => b.ders::<N>(sv, v, pv, dv),
            _ => basis_ders::<N>(sv, v, pv, dv, &self.knots_v),
        };
        // a[k][l]: homogeneous derivative d^(k+l)/du^k dv^l, k + l <= order.
        let mut a = [[[0.0f64; 4]; 3]; 3];
        for l in 0..=pv {
            let col = sv - pv + l;
            // temp[k] = sum_i Nu^(k)_i P_{i, col}
            let mut temp = [[0.0f64; 4]; 3];
            for i in 0..=pu {
                let h = &self.homogeneous[(su - pu + i) * self.count_v + col];
                for (k, t) in temp.iter_mut().enumerate().take(du + 1) {
                    let n = nu[k][i];
                    t[0] += n * h[0];
                    t[1] += n * h[1];
                    t[2] += n * h[2];
                    t[3] += n * h[3];
                }
            }
            for k in 0..=du {
                for m in 0..=dv.min(order - k) {
                    let n = nv[m][l];
                    for c in 0..4 {
                        a[k][m][c] += n * temp[k][c];
                    }
                }
            }
        }
        let mut s = [[[0.0f64; 3]; 3]; 3];
        if !self.rational {
            for k in 0..=order {
                for m in 0..=(order - k) {
                    s[k][m] = [a[k][m][0], a[k][m][1], a[k][m][2]];
                }
            }
        } else {
            // A4.4: S^(k,l) = (A^(k,l) - sum binom w^(i,j) S^(k-i,l-j)) / w
            const BIN: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [1.0, 2.0, 1.0]];
            let w = a[0][0][3];
            for k in 0..=order {
                for l in 0..=(order - k) {
                    let mut v3 = [a[k][l][0], a[k][l][1], a[k][l][2]];
                    for j in 1..=l {
                        let c = BIN[l][j] * a[0][j][3];
                        for t in 0..3 {
                            v3[t] -= c * s[k][l - j][t];
                        }
                    }
                    for i in 1..=k {
                        let c = BIN[k][i] * a[i][0][3];
                        for t in 0..3 {
                            v3[t] -= c * s[k - i][l][t];
                        }
                        let mut v2 = [0.0; 3];
                        for j in 1..=l {
                            let c2 = BIN[l][j] * a[i][j][3];
                            for t in 0..3 {
                                v2[t] += c2 * s[k - i][l - j][t];
                            }
                        }
                        for t in 0..3 {
                            v3[t] -= BIN[k][i] * v2[t];
                        }
                    }
                    s[k][l] = [v3[0] / w, v3[1] / w, v3[2] / w];
                }
            }
        }
        let v3 = |x: [f64; 3]| Vector3::new(x[0], x[1], x[2]);
        SurfaceDerivs {
            p: Point3::new(s[0][0][0], s[0][0][1], s[0][0][2]),
            su: v3(s[1][0]),
            sv: v3(s[0][1]),
            suu: v3(s[2][0]),
            suv: v3(s[1][1]),
            svv: v3(s[0][2]),
        }
    }

    /// Unit normal `normalize(S_u x S_v)`, or `None` where the surface is degenerate.
    pub fn normal(&self, u: f64, v: f64) -> Option<Vector3<f64>> {
        let d = self.derivs_order(u, v, 1);
        d.su.cross(&d.sv).try_normalize(1e-300)
    }

    /// Length of the longest of five iso-curves (along u or v) from 32-segment
    /// polylines: a cheap size estimate for choosing grid resolutions.
    pub fn longest_iso_curve_length(&self, along_u: bool) -> f64 {
        let ((u0, u1), (v0, v1)) = self.domain();
        let mut best: f64 = 0.0;
        for k in 0..5 {
            let c = k as f64 / 4.0;
            let mut len = 0.0;
            let mut prev: Option<Point3<f64>> = None;
            for i in 0..=32 {
                let s = i as f64 / 32.0;
                let (u, v) = if along_u {
                    (u0 + (u1 - u0) * s, v0 + (v1 - v0) * c)
                } else {
                    (u0 + (u1 - u0) * c, v0 + (v1 - v0) * s)
                };
                let p = self.point(u, v);
                if let Some(q) = prev {
                    len += (p - q).norm();
                }
                prev = Some(p);
            }
            best = best.max(len);
        }
        best
    }

    /// Axis-aligned bounding box of the control net (contains the surface).
    pub fn bounding_box(&self) -> (Point3<f64>, Point3<f64>) {
        let mut lo = Point3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY);
        let mut hi = Point3::new(f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
        for i in 0..self.count_u {
            for j in 0..self.count_v {
                let p = self.control_point(i, j);
                for t in 0..3 {
                    lo[t] = lo[t].min(p[t]);
                    hi[t] = hi[t].max(p[t]);
                }
            }
        }
        (lo, hi)
    }
}

/// Knot spans beyond which a direction's basis is not tabulated (its table
/// would pass about 8 MB for a cubic): A2.3 evaluates it instead.
const SPAN_BASIS_MAX_SPANS: usize = 1 << 14;

/// The non-zero basis functions of one direction on each knot span, and their
/// first and second derivatives, as polynomials in the span's local
/// parameter x = (t - t_s) / (t_(s+1) - t_s) in [0, 1] (docs/methods.md,
/// "Surface evaluation"). On a span every basis function is one polynomial
/// of the degree whose coefficients depend only on the knots, so they are
/// computed once per surface (Cox-de Boor on polynomials) and an evaluation
/// is Horner's rule with no division; A2.3 divides by knot differences at
/// every call. The derivatives' coefficients hold the chain rule's powers of
/// 1 / (t_(s+1) - t_s).
#[derive(Clone, Debug, PartialEq)]
pub struct SpanBasis {
    degree: usize,
    /// t_s per span s = degree..count (index s - degree).
    start: Vec<f64>,
    /// 1 / (t_(s+1) - t_s), 0 for an empty span (never evaluated).
    inv_len: Vec<f64>,
    /// Per span, `[k][j][m]` (each index 0..=degree): the coefficient of x^m
    /// in the k-th derivative (k <= 2) of N_(s-degree+j).
    coef: Vec<f64>,
}

impl SpanBasis {
    /// The tables of a valid knot vector (as [`NurbsSurface::new`] checks);
    /// `None` beyond [`SPAN_BASIS_MAX_SPANS`] spans or
    /// [`TABULATED_MAX_DEGREE`].
    pub fn new(degree: usize, count: usize, knots: &[f64]) -> Option<Self> {
        let spans = count - degree;
        if spans > SPAN_BASIS_MAX_SPANS || degree > TABULATED_MAX_DEGREE {
            return None;
        }
        let p1 = degree + 1;
        let stride = 3 * p1 * p1;
        let mut start = Vec::with_capacity(spans);
        let mut inv_len = Vec::with_capacity(spans);
        let mut coef = vec![0.0; spans * stride];
        for s in degree..count {
            let (ts, len) = (knots[s], knots[s + 1] - knots[s]);
            start.push(ts);
            inv_len.push(if len > 0.0 { 1.0 / len } else { 0.0 });
            if len <= 0.0 {
                continue;
            }
            // n[r]: N_(s-d+r, d) as coefficients of x^0..x^d, degree d = 0..=p.
            let mut n = [[0.0f64; TABP1]; TABP1];
            n[0][0] = 1.0;
            for d in 1..=degree {
                let mut next = [[0.0f64; TABP1]; TABP1];
                for (r, out) in next.iter_mut().enumerate().take(d + 1) {
                    let i = s + r - d;
                    // (t - t_i) / (t_(i+d) - t_i) N_(i, d-1), N_(i, d-1) = n[r - 1].
                    if r >= 1 {
                        let den = knots[i + d] - knots[i];
                        if den > 0.0 {
                            let (a, b) = ((ts - knots[i]) / den, len / den);
                            for m in 0..d {
                                let c = n[r - 1][m];
                                out[m] += a * c;
                                out[m + 1] += b * c;
                            }
                        }
                    }
                    // (t_(i+d+1) - t) / (t_(i+d+1) - t_(i+1)) N_(i+1, d-1), = n[r].
                    if r < d {
                        let den = knots[i + d + 1] - knots[i + 1];
                        if den > 0.0 {
                            let (a, b) = ((knots[i + d + 1] - ts) / den, -len / den);
                            for m in 0..d {
                                let c = n[r][m];
                                out[m] += a * c;
                                out[m + 1] += b * c;
                            }
                        }
                    }
                }
                n = next;
            }
            let base = (s - degree) * stride;
            let inv = 1.0 / len;
            for (j, nj) in n.iter().enumerate().take(p1) {
                for m in 0..p1 {
                    coef[base + j * p1 + m] = nj[m];
                    if m < degree {
                        coef[base + p1 * p1 + j * p1 + m] = nj[m + 1] * (m + 1) as f64 * inv;
                    }
                    if m + 1 < degree {
                        coef[base + 2 * p1 * p1 + j * p1 + m] =
                            nj[m + 2] * ((m + 1) * (m + 2)) as f64 * (inv * inv);
                    }
                }
            }
        }
        Some(Self {
            degree,
            start,
            inv_len,
            coef,
        })
    }

    /// [`basis_ders`] from the tables: derivatives up to `nd` (<= 2) of the
    /// basis functions of span `span` at `t` (in that span; `p` is the
    /// degree, a constant where the caller's is; `N` > `p` the arrays' size).
    #[inline(always)]
    fn ders<const N: usize>(&self, span: usize, t: f64, p: usize, nd: usize) -> [[f64; N]; 3] {
        debug_assert_eq!(p, self.degree);
        let k = span - p;
        let x = ((t - self.start[k]) * self.inv_len[k]).clamp(0.0, 1.0);
        let p1 = p + 1;
        let table = &self.coef[k * 3 * p1 * p1..(k + 1) * 3 * p1 * p1];
        let mut ders = [[0.0f64; N]; 3];
        for (order, row) in ders.iter_mut().enumerate().take(nd.min(p) + 1) {
            let top = p - order;
            for (j, out) in row.iter_mut().enumerate().take(p1) {
                let c = &table[(order * p1 + j) * p1..(order * p1 + j + 1) * p1];
                let mut acc = c[top];
                for m in (0..top).rev() {
                    acc = acc * x + c[m];
                }
                *out = acc;
            }
        }
        ders
    }
}

/// Non-zero B-spline basis functions of degree `degree` at `t` (clamped into
/// the domain): returns the span `s` and `N_{s-degree+j}(t)` for `j = 0..=degree`.
/// `knots` must be a valid knot vector for some control-point count (as checked
/// by [`NurbsSurface::new`]); `degree <= MAX_DEGREE`.
pub fn basis_functions(degree: usize, knots: &[f64], t: f64) -> (usize, [f64; MAXP1]) {
    let count = knots.len() - degree - 1;
    let t = t.clamp(knots[degree], knots[count]);
    let span = find_span(degree, count, knots, t);
    (span, basis_ders::<MAXP1>(span, t, degree, 0, knots)[0])
}

/// A2.1: the knot span index `s` with `knots[s] <= t < knots[s+1]`
/// (the last non-empty span at the domain's upper end).
fn find_span(degree: usize, count: usize, knots: &[f64], t: f64) -> usize {
    let n = count - 1;
    if t >= knots[n + 1] {
        // Last non-empty span.
        let mut s = n;
        while s > degree && knots[s] >= knots[n + 1] {
            s -= 1;
        }
        return s;
    }
    if t <= knots[degree] {
        let mut s = degree;
        while s < n && knots[s + 1] <= t {
            s += 1;
        }
        return s;
    }
    let (mut lo, mut hi) = (degree, n + 1);
    let mut mid = (lo + hi) / 2;
    while t < knots[mid] || t >= knots[mid + 1] {
        if t < knots[mid] {
            hi = mid;
        } else {
            lo = mid;
        }
        mid = (lo + hi) / 2;
    }
    mid
}

/// A2.3: basis functions and their derivatives up to `nd` (<= 2) at `t`
/// in span `span`. Result `[k][j]`: k-th derivative of N_{span-p+j}; `N` >
/// `p` is the arrays' size. Inlined so that a constant degree unrolls it
/// (see `derivs_order`).
#[inline(always)]
fn basis_ders<const N: usize>(
    span: usize,
    t: f64,
    p: usize,
    nd: usize,
    knots: &[f64],
) -> [[f64; N]; 3] {
    let mut ndu = [[0.0f64; N]; N];
    let mut left = [0.0f64; N];
    let mut right = [0.0f64; N];
    ndu[0][0] = 1.0;
    for j in 1..=p {
        left[j] = t - knots[span + 1 - j];
        right[j] = knots[span + j] - t;
        let mut saved = 0.0;
        for r in 0..j {
            ndu[j][r] = right[r + 1] + left[j - r];
            let temp = ndu[r][j - 1] / ndu[j][r];
            ndu[r][j] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        ndu[j][j] = saved;
    }
    let mut ders = [[0.0f64; N]; 3];
    for j in 0..=p {
        ders[0][j] = ndu[j][p];
    }
    let mut a = [[0.0f64; N]; 2];
    for r in 0..=p {
        let (mut s1, mut s2) = (0usize, 1usize);
        a[0][0] = 1.0;
        for k in 1..=nd {
            let mut d = 0.0;
            let rk = r as isize - k as isize;
            let pk = p - k;
            if r >= k {
                a[s2][0] = a[s1][0] / ndu[pk + 1][rk as usize];
                d = a[s2][0] * ndu[rk as usize][pk];
            }
            let j1 = if rk >= -1 { 1 } else { (-rk) as usize };
            let j2 = if (r as isize) - 1 <= pk as isize {
                k - 1
            } else {
                p - r
            };
            for j in j1..=j2 {
                let idx = (rk + j as isize) as usize;
                a[s2][j] = (a[s1][j] - a[s1][j - 1]) / ndu[pk + 1][idx];
                d += a[s2][j] * ndu[idx][pk];
            }
            if r <= pk {
                a[s2][k] = -a[s1][k - 1] / ndu[pk + 1][r];
                d += a[s2][k] * ndu[r][pk];
            }
            ders[k][r] = d;
            std::mem::swap(&mut s1, &mut s2);
        }
    }
    let mut f = p as f64;
    for (k, row) in ders.iter_mut().enumerate().take(nd + 1).skip(1) {
        for x in row.iter_mut().take(p + 1) {
            *x *= f;
        }
        f *= (p - k) as f64;
    }
    ders
}

#[cfg(test)]
mod tests {
    use super::*;

    /// xorshift64* ([`crate::rng::XorShiftStar`]): a fixed, seeded sequence.
    struct Rng(u64);
    impl Rng {
        /// The next number in [0, 1).
        fn next(&mut self) -> f64 {
            let mut g = crate::rng::XorShiftStar(self.0);
            let x = g.unit();
            self.0 = g.0;
            x
        }
        fn below(&mut self, n: usize) -> usize {
            ((self.next() * n as f64) as usize).min(n - 1)
        }
    }

    /// A clamped knot vector of `degree` for `count` control points with
    /// random interior knots (some repeated up to the degree, spans from
    /// 1e-4 to 1 of each other) on a random domain.
    fn random_knots(rng: &mut Rng, degree: usize, count: usize) -> Vec<f64> {
        let (a, scale) = (
            rng.next() * 200.0 - 100.0,
            10f64.powf(rng.next() * 4.0 - 2.0),
        );
        let mut interior = Vec::new();
        let mut t = a;
        while interior.len() < count - degree - 1 {
            t += scale * 10f64.powf(-4.0 * rng.next() * rng.next());
            let run = 1 + rng
                .below(degree)
                .min(count - degree - 1 - interior.len() - 1);
            let run = if rng.next() < 0.7 { 1 } else { run };
            for _ in 0..run {
                interior.push(t);
            }
        }
        let end = t + scale * (0.1 + rng.next());
        let mut knots = vec![a; degree + 1];
        knots.extend(interior);
        knots.extend(std::iter::repeat_n(end, degree + 1));
        knots
    }

    #[test]
    fn span_polynomials_of_the_uniform_cubic_are_the_known_ones() {
        // Uniform cubic on an interior span: (1-x)^3/6, (3x^3-6x^2+4)/6,
        // (-3x^3+3x^2+3x+1)/6, x^3/6; knot spacing 2 halves the first
        // derivative and quarters the second.
        let knots: Vec<f64> = (0..12).map(|k| 2.0 * k as f64).collect();
        let b = SpanBasis::new(3, 8, &knots).unwrap();
        for x in [0.0, 0.25, 0.5, 0.9, 1.0] {
            let t = 8.0 + 2.0 * x;
            let d = b.ders::<4>(4, t, 3, 2);
            let n = [
                (1.0 - x).powi(3) / 6.0,
                (3.0 * x * x * x - 6.0 * x * x + 4.0) / 6.0,
                (-3.0 * x * x * x + 3.0 * x * x + 3.0 * x + 1.0) / 6.0,
                x * x * x / 6.0,
            ];
            let n1 = [
                -(1.0 - x).powi(2) / 2.0,
                (9.0 * x * x - 12.0 * x) / 6.0,
                (-9.0 * x * x + 6.0 * x + 3.0) / 6.0,
                x * x / 2.0,
            ];
            let n2 = [1.0 - x, 3.0 * x - 2.0, -3.0 * x + 1.0, x];
            for j in 0..4 {
                assert!((d[0][j] - n[j]).abs() < 1e-15, "x {x} N{j}");
                assert!((d[1][j] - n1[j] / 2.0).abs() < 1e-15, "x {x} N'{j}");
                assert!((d[2][j] - n2[j] / 4.0).abs() < 1e-15, "x {x} N''{j}");
            }
        }
    }

    #[test]
    fn span_polynomials_agree_with_a2_3_on_random_knot_vectors() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut worst = 0.0f64;
        for case in 0..400 {
            let degree = 1 + case % 5;
            let count = degree + 1 + rng.below(10);
            let knots = random_knots(&mut rng, degree, count);
            let b = SpanBasis::new(degree, count, &knots).unwrap();
            let (lo, hi) = (knots[degree], knots[count]);
            for k in 0..40 {
                // Knots themselves, the domain's ends and random points.
                let t = match k {
                    0 => lo,
                    1 => hi,
                    2..=9 => knots[degree + rng.below(count - degree + 1)],
                    _ => lo + (hi - lo) * rng.next(),
                };
                let span = find_span(degree, count, &knots, t);
                let nd = degree.min(2);
                let exact = basis_ders::<TABP1>(span, t, degree, nd, &knots);
                let got = b.ders::<TABP1>(span, t, degree, nd);
                for order in 0..=nd {
                    let scale: f64 = exact[order].iter().map(|x| x.abs()).sum();
                    for j in 0..=degree {
                        let err = (got[order][j] - exact[order][j]).abs() / scale;
                        worst = worst.max(err);
                        assert!(
                            err <= 1e-12,
                            "degree {degree} knots {knots:?} t {t} order {order} j {j}: {} vs {}",
                            got[order][j],
                            exact[order][j]
                        );
                    }
                }
            }
        }
        assert!(worst > 0.0, "the two evaluations never differed: no test");
    }

    #[test]
    fn surface_derivatives_agree_with_a2_3_on_random_surfaces() {
        let mut rng = Rng(0x1234_5678_9abc_def1);
        for case in 0..60 {
            // The last 20 bicubic (the constant-degree path), half of them rational.
            let (pu, pv) = if case >= 40 {
                (3, 3)
            } else {
                (1 + case % 4, 1 + (case / 4) % 4)
            };
            let (cu, cv) = (pu + 1 + rng.below(6), pv + 1 + rng.below(6));
            let ku = random_knots(&mut rng, pu, cu);
            let kv = random_knots(&mut rng, pv, cv);
            let cps: Vec<Vec<[f64; 3]>> = (0..cu)
                .map(|i| {
                    (0..cv)
                        .map(|j| {
                            [
                                10.0 * i as f64 + rng.next(),
                                10.0 * j as f64 + rng.next(),
                                20.0 * rng.next(),
                            ]
                        })
                        .collect()
                })
                .collect();
            let w: Vec<Vec<f64>> = (0..cu)
                .map(|_| (0..cv).map(|_| 0.3 + 2.0 * rng.next()).collect())
                .collect();
            let rational = case % 2 == 0;
            let s =
                NurbsSurface::new(pu, pv, ku, kv, &cps, rational.then_some(w.as_slice())).unwrap();
            let ((u0, u1), (v0, v1)) = s.domain();
            for _ in 0..50 {
                let (u, v) = (u0 + (u1 - u0) * rng.next(), v0 + (v1 - v0) * rng.next());
                let got = s.derivs_exact(u, v, 2);
                let exact = s.derivs_reference(u, v);
                let pairs = [
                    (got.p.coords, exact.p.coords),
                    (got.su, exact.su),
                    (got.sv, exact.sv),
                    (got.suu, exact.suu),
                    (got.suv, exact.suv),
                    (got.svv, exact.svv),
                ];
                // Relative to the size of the quantity's order: the
                // net's extent over the parameter lengths' powers.
                let size = 100.0;
                let (lu, lv) = (u1 - u0, v1 - v0);
                let scales = [
                    size,
                    size / lu,
                    size / lv,
                    size / (lu * lu),
                    size / (lu * lv),
                    size / (lv * lv),
                ];
                for (k, ((a, b), sc)) in pairs.iter().zip(scales).enumerate() {
                    let err = (a - b).norm() / sc.max(b.norm());
                    assert!(
                        err <= 1e-12,
                        "case {case} ({pu}, {pv}, rational {rational}) at ({u}, {v}) derivative {k}: {a:?} vs {b:?}"
                    );
                }
            }
        }
    }
}
