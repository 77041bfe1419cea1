//! Rational B-spline (NURBS) tensor-product surfaces: evaluation with all
//! partial derivatives up to second order.
//!
//! Written by hand (see docs/architecture.md): the planners evaluate surfaces
//! millions of times, so evaluation works on fixed-size stack arrays and never
//! allocates. Algorithms follow Piegl & Tiller, *The NURBS Book*
//! (A2.1 span search, A2.3 basis derivatives, A4.4 rational derivatives).

use crate::error::{Error, Result};
use nalgebra::{Point3, Vector3};

/// Highest supported degree in either direction.
pub const MAX_DEGREE: usize = 9;
const MAXP1: usize = MAX_DEGREE + 1;

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
    /// The trimmed face, where only part of the domain is the surface
    /// (`None`: the whole domain).
    trim: Option<std::sync::Arc<super::trim::Trim>>,
    /// Which boundaries `[u0, u1, v0, v1]` are collapsed to a point (a pole
    /// or the apex of a triangular patch): S_v = 0 along u = u0 or u1,
    /// S_u = 0 along v = v0 or v1 (docs/methods.md, "Degenerate boundaries").
    collapsed: [bool; 4],
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
        check_knots("u", degree_u, count_u, &knots_u)?;
        check_knots("v", degree_v, count_v, &knots_v)?;
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
        let mut surface = Self {
            degree_u,
            degree_v,
            knots_u,
            knots_v,
            count_u,
            count_v,
            homogeneous,
            rational,
            trim: None,
            collapsed: [false; 4],
        };
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
        (
            (self.knots_u[self.degree_u], self.knots_u[self.count_u]),
            (self.knots_v[self.degree_v], self.knots_v[self.count_v]),
        )
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
            (3, 3, 2) => self.derivs_with(u, v, 3, 3, 2),
            (3, 3, 1) => self.derivs_with(u, v, 3, 3, 1),
            (3, 3, 0) => self.derivs_with(u, v, 3, 3, 0),
            (pu, pv, order) => self.derivs_any(u, v, pu, pv, order),
        }
    }

    /// [`Self::derivs_with`] for any degrees, as one out-of-line copy.
    #[inline(never)]
    fn derivs_any(&self, u: f64, v: f64, pu: usize, pv: usize, order: usize) -> SurfaceDerivs {
        self.derivs_with(u, v, pu, pv, order)
    }

    /// Position and derivatives up to `order` (<= 2) for degrees `pu`, `pv`
    /// (this surface's): A2.3 in each direction, then A4.4 when rational.
    // Index loops mirror The NURBS Book's algorithms; iterators would obscure them.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn derivs_with(&self, u: f64, v: f64, pu: usize, pv: usize, order: usize) -> SurfaceDerivs {
        let (u, v) = self.clamp_uv(u, v);
        let su = find_span(pu, self.count_u, &self.knots_u, u);
        let sv = find_span(pv, self.count_v, &self.knots_v, v);
        let du = order.min(pu);
        let dv = order.min(pv);
        let nu = basis_ders(su, u, pu, du, &self.knots_u);
        let nv = basis_ders(sv, v, pv, dv, &self.knots_v);
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

/// Non-zero B-spline basis functions of degree `degree` at `t` (clamped into
/// the domain): returns the span `s` and `N_{s-degree+j}(t)` for `j = 0..=degree`.
/// `knots` must be a valid knot vector for some control-point count (as checked
/// by [`NurbsSurface::new`]); `degree <= MAX_DEGREE`.
pub fn basis_functions(degree: usize, knots: &[f64], t: f64) -> (usize, [f64; MAXP1]) {
    let count = knots.len() - degree - 1;
    let t = t.clamp(knots[degree], knots[count]);
    let span = find_span(degree, count, knots, t);
    (span, basis_ders(span, t, degree, 0, knots)[0])
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
/// in span `span`. Result `[k][j]`: k-th derivative of N_{span-p+j}.
/// Inlined so that a constant degree unrolls it (see `derivs_order`).
#[inline(always)]
fn basis_ders(span: usize, t: f64, p: usize, nd: usize, knots: &[f64]) -> [[f64; MAXP1]; 3] {
    let mut ndu = [[0.0f64; MAXP1]; MAXP1];
    let mut left = [0.0f64; MAXP1];
    let mut right = [0.0f64; MAXP1];
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
    let mut ders = [[0.0f64; MAXP1]; 3];
    for j in 0..=p {
        ders[0][j] = ndu[j][p];
    }
    let mut a = [[0.0f64; MAXP1]; 2];
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
