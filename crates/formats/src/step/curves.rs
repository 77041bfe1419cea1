//! Edge curves (`LINE`, `CIRCLE`, `ELLIPSE`, B-splines, rational too) in
//! the file's space or in a surface's (u, v), and their evaluation.

use super::records::{list, name_of};
use super::surfaces::Meridian;
use super::{StepFile, V3};
use ruststep::ast::Parameter;
use std::f64::consts::TAU;
use toolpath_kernel::error::Result;

/// A curve in the file's space (3-D, mm) or in a surface's (u, v) (z = 0).
#[derive(Clone, Debug)]
pub(super) enum Curve {
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
    pub(super) fn point(&self, t: f64) -> V3 {
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

    pub(super) fn periodic(&self) -> bool {
        matches!(self, Curve::Conic { .. })
    }

    /// The parameter of the curve's point nearest `q`.
    pub(super) fn locate(&self, q: &V3) -> f64 {
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
    pub(super) fn range(&self) -> Option<(f64, f64)> {
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
pub(super) fn plane_curve(curve: &Curve, o: V3, e1: V3, e2: V3) -> Meridian {
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

/// Point of a rational B-spline curve at `t` (de Boor on homogeneous points).
pub(super) fn de_boor(p: usize, knots: &[f64], pts: &[[f64; 4]], t: f64) -> V3 {
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

/// Deepest chain of entities wrapping one another (a trimmed curve of a
/// trimmed curve, an offset of an offset surface) that is followed.
pub(super) const MAX_NESTING: usize = 8;

/// Curve types an edge may lie on.
pub const SUPPORTED_CURVES: &str = "LINE, CIRCLE, ELLIPSE, POLYLINE, TRIMMED_CURVE, B_SPLINE_CURVE_WITH_KNOTS, BEZIER_CURVE, UNIFORM_CURVE, QUASI_UNIFORM_CURVE (rational too)";

impl StepFile {
    pub(super) fn curve(&self, id: u64, in_uv: bool) -> Result<Curve> {
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
                // The edge's vertices bound it; its basis curve is the
                // geometry.
                "TRIMMED_CURVE" => return self.curve(self.trimmed_basis(id, p)?, in_uv),
                "POLYLINE" => return self.polyline(id, p, in_uv),
                _ => {}
            }
        }
        if let Some(c) = self.bspline_curve(id, in_uv)? {
            return Ok(c);
        }
        Err(self.err(
            id,
            format!("is not a supported curve (supported: {SUPPORTED_CURVES})"),
        ))
    }

    /// The basis curve of a `TRIMMED_CURVE` (`p`: its parameters), through
    /// trimmed curves of trimmed curves; a chain deeper than
    /// [`MAX_NESTING`] (a cycle in the file) is refused.
    fn trimmed_basis(&self, id: u64, p: &[Parameter]) -> Result<u64> {
        let mut basis = self.reference(id, p, 1)?;
        for _ in 0..MAX_NESTING {
            match self.expect(basis, &["TRIMMED_CURVE"]) {
                Ok((_, bp)) => basis = self.reference(basis, bp, 1)?,
                Err(_) => return Ok(basis),
            }
        }
        Err(self.err(id, "nests trimmed curves too deeply (a cycle?)"))
    }

    /// A `POLYLINE` as the degree 1 B-spline through its points, one knot
    /// per point.
    fn polyline(&self, id: u64, p: &[Parameter], in_uv: bool) -> Result<Curve> {
        let pts = self
            .references(id, p, 1)?
            .iter()
            .map(|&c| self.point_in(c, in_uv))
            .collect::<Result<Vec<_>>>()?;
        if pts.len() < 2 {
            return Err(self.err(id, "has fewer than 2 points"));
        }
        let n = pts.len();
        let mut knots = vec![0.0];
        knots.extend((0..n).map(|i| i as f64));
        knots.push((n - 1) as f64);
        Ok(Curve::Bspline {
            degree: 1,
            knots,
            points: pts.iter().map(|q| [q.x, q.y, q.z, 1.0]).collect(),
        })
    }
}
