//! Trimmed faces: the part of a surface's (u, v) domain inside an outer loop
//! and outside its holes (docs/formats.md, "Trimmed surfaces").
//!
//! A loop is a chain of pcurves in (u, v): polylines and 2-D B-spline/NURBS
//! curves, joined end to end and closed. Each curve is sampled to a polyline
//! whose chords stay within the stated tolerance of the curve on the
//! surface (in mm), then the loops are validated as a pocket outline is
//! (closed, not self-intersecting, holes inside the outer loop and disjoint,
//! outer counter-clockwise, holes clockwise) and checked to lie in the
//! domain. The one inside test ([`Trim::contains`]) counts the loop edges a
//! ray crosses, over the edges of the point's horizontal band only, so it
//! costs a few dozen edge tests however fine the loops are.

use super::nurbs::{basis_functions, MAX_DEGREE};
use super::pocket::Point2;
use super::{NurbsSurface, Pocket};
use crate::error::{Error, Result};

/// A pcurve in the (u, v) domain, as given.
#[derive(Clone, Debug, PartialEq)]
pub enum TrimCurve {
    /// Points joined by straight segments in (u, v).
    Polyline(Vec<Point2>),
    /// A 2-D B-spline (rational with `weights`): control points in (u, v).
    Bspline {
        degree: usize,
        knots: Vec<f64>,
        control_points: Vec<Point2>,
        weights: Option<Vec<f64>>,
    },
}

/// Default sampling tolerance of pcurves, mm on the surface.
pub const DEFAULT_TOLERANCE_MM: f64 = 1e-3;

/// Largest gap between consecutive curves of a loop, as a share of the
/// domain's diagonal in (u, v): ends closer than this are joined.
pub(crate) const JOIN_GAP: f64 = 1e-6;

/// Subcells per direction of a grid cell the trim boundary crosses, in
/// [`Trim::cell_nodes`].
pub(crate) const BOUNDARY_SUBCELLS: usize = 16;

/// Gauss-Legendre nodes and weights on [0, 1], 3 points.
const GAUSS3: [(f64, f64); 3] = [
    (0.112_701_665_379_258_3, 5.0 / 18.0),
    (0.5, 8.0 / 18.0),
    (0.887_298_334_620_741_7, 5.0 / 18.0),
];

/// Bands of the inside test per loop vertex (square root), at most.
const MAX_BANDS: usize = 1024;

/// A validated trim: the loops as given and their sampled polylines.
#[derive(Clone, Debug)]
pub struct Trim {
    /// The curves as given, for writing the trim back out.
    pub outer_curves: Vec<TrimCurve>,
    pub hole_curves: Vec<Vec<TrimCurve>>,
    pub tolerance_mm: f64,
    /// Sampled outer loop, counter-clockwise, and holes, clockwise (no
    /// repeated closing vertex).
    pub outer: Vec<Point2>,
    pub holes: Vec<Vec<Point2>>,
    bands: Bands,
}

impl PartialEq for Trim {
    fn eq(&self, other: &Self) -> bool {
        self.outer_curves == other.outer_curves
            && self.hole_curves == other.hole_curves
            && self.tolerance_mm.to_bits() == other.tolerance_mm.to_bits()
    }
}

/// Edges of all loops bucketed by horizontal bands of v.
#[derive(Clone, Debug)]
struct Bands {
    v0: f64,
    height: f64,
    /// Points this close to a loop (in (u, v)) are on the face.
    on_loop: f64,
    /// Edge (a, b) lists per band.
    edges: Vec<Vec<(Point2, Point2)>>,
}

impl Bands {
    fn new(loops: &[&[Point2]]) -> Self {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        let (mut left, mut right) = (f64::INFINITY, f64::NEG_INFINITY);
        let mut count = 0;
        for l in loops {
            for p in l.iter() {
                lo = lo.min(p[1]);
                hi = hi.max(p[1]);
                left = left.min(p[0]);
                right = right.max(p[0]);
            }
            count += l.len();
        }
        let n = ((count as f64).sqrt().ceil() as usize).clamp(1, MAX_BANDS);
        let height = ((hi - lo) / n as f64).max(1e-300);
        let mut edges = vec![Vec::new(); n];
        for l in loops {
            for i in 0..l.len() {
                let (a, b) = (l[i], l[(i + 1) % l.len()]);
                let (b0, b1) = (
                    Self::band(lo, height, n, a[1].min(b[1])),
                    Self::band(lo, height, n, a[1].max(b[1])),
                );
                for e in &mut edges[b0..=b1] {
                    e.push((a, b));
                }
            }
        }
        Self {
            v0: lo,
            height,
            on_loop: 1e-9 * (right - left).hypot(hi - lo),
            edges,
        }
    }

    fn band(v0: f64, height: f64, n: usize, v: f64) -> usize {
        (((v - v0) / height).floor().max(0.0) as usize).min(n - 1)
    }

    /// Even-odd crossing count of the ray from `p` towards +u: inside the
    /// outer loop and outside every hole (the holes lie inside the outer loop
    /// and apart, so the parity over all loops is the answer). The face is
    /// closed: a point on a loop (within `on_loop`) is on it, so a pass
    /// along an outer loop on the domain's edge is kept whole.
    fn contains(&self, p: Point2) -> bool {
        let n = self.edges.len();
        let top = self.v0 + self.height * n as f64;
        if !(p[1] >= self.v0 - self.on_loop && p[1] <= top + self.on_loop) {
            return false;
        }
        let edges = &self.edges[Self::band(self.v0, self.height, n, p[1])];
        if edges
            .iter()
            .any(|&(a, b)| segment_dist2(p, a, b) <= self.on_loop * self.on_loop)
        {
            return true;
        }
        let mut inside = false;
        for (a, b) in edges {
            if (a[1] > p[1]) != (b[1] > p[1]) {
                let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
                if p[0] < x {
                    inside = !inside;
                }
            }
        }
        inside
    }

    /// Edges of the bands the v-range [lo, hi] meets (with repeats).
    fn edges_between(&self, lo: f64, hi: f64) -> impl Iterator<Item = &(Point2, Point2)> {
        let n = self.edges.len();
        let (b0, b1) = (
            Self::band(self.v0, self.height, n, lo),
            Self::band(self.v0, self.height, n, hi),
        );
        self.edges[b0..=b1].iter().flatten()
    }
}

/// Squared distance from `p` to the segment [a, b].
fn segment_dist2(p: Point2, a: Point2, b: Point2) -> f64 {
    let ab = [b[0] - a[0], b[1] - a[1]];
    let len2 = ab[0] * ab[0] + ab[1] * ab[1];
    let t = if len2 > 0.0 {
        (((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    dist2(p, [a[0] + t * ab[0], a[1] + t * ab[1]])
}

fn dist2(a: Point2, b: Point2) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}

/// Checks a pcurve's numbers; `field` names it.
fn check_curve(field: &str, c: &TrimCurve) -> Result<()> {
    let finite = |name: String, p: &Point2| {
        if p[0].is_finite() && p[1].is_finite() {
            Ok(())
        } else {
            Err(Error::invalid(
                name,
                "has a coordinate that is not a finite number",
            ))
        }
    };
    match c {
        TrimCurve::Polyline(pts) => {
            if pts.len() < 2 {
                return Err(Error::invalid(
                    format!("{field}.polyline"),
                    format!("needs at least 2 points, got {}", pts.len()),
                ));
            }
            for (i, p) in pts.iter().enumerate() {
                finite(format!("{field}.polyline[{i}]"), p)?;
            }
        }
        TrimCurve::Bspline {
            degree,
            knots,
            control_points,
            weights,
        } => {
            let f = |s: &str| format!("{field}.bspline.{s}");
            if *degree == 0 || *degree > MAX_DEGREE {
                return Err(Error::invalid(
                    f("degree"),
                    format!("must be 1 to {MAX_DEGREE}, got {degree}"),
                ));
            }
            let n = control_points.len();
            if n < degree + 1 {
                return Err(Error::invalid(
                    f("control_points"),
                    format!("{n} points are too few for degree {degree}"),
                ));
            }
            for (i, p) in control_points.iter().enumerate() {
                finite(format!("{}[{i}]", f("control_points")), p)?;
            }
            if knots.len() != n + degree + 1 {
                return Err(Error::invalid(
                    f("knots"),
                    format!(
                        "has {} knots; degree {degree} with {n} control points needs {}",
                        knots.len(),
                        n + degree + 1
                    ),
                ));
            }
            for (k, t) in knots.iter().enumerate() {
                if !t.is_finite() {
                    return Err(Error::invalid(
                        format!("{}[{k}]", f("knots")),
                        "is not a finite number",
                    ));
                }
                if k > 0 && *t < knots[k - 1] {
                    return Err(Error::invalid(
                        format!("{}[{k}]", f("knots")),
                        "knot vector is not non-decreasing",
                    ));
                }
            }
            if knots[n] <= knots[*degree] {
                return Err(Error::invalid(f("knots"), "parameter range is empty"));
            }
            if let Some(w) = weights {
                if w.len() != n {
                    return Err(Error::invalid(
                        f("weights"),
                        format!("has {} weights for {n} control points", w.len()),
                    ));
                }
                for (i, x) in w.iter().enumerate() {
                    if !(x.is_finite() && *x > 0.0) {
                        return Err(Error::invalid(
                            format!("{}[{i}]", f("weights")),
                            "must be a finite positive number",
                        ));
                    }
                }
            }
        }
    }
    Ok(())
}

/// Point of a B-spline pcurve at `t` (de Boor's sum over the non-zero basis).
fn bspline_point(
    degree: usize,
    knots: &[f64],
    ctrl: &[Point2],
    weights: Option<&[f64]>,
    t: f64,
) -> Point2 {
    let (span, n) = basis_functions(degree, knots, t);
    let (mut x, mut y, mut w) = (0.0, 0.0, 0.0);
    for (j, nj) in n.iter().enumerate().take(degree + 1) {
        let i = span - degree + j;
        let wi = weights.map_or(1.0, |ws| ws[i]);
        x += nj * wi * ctrl[i][0];
        y += nj * wi * ctrl[i][1];
        w += nj * wi;
    }
    [x / w, y / w]
}

/// Samples a pcurve to a polyline (first point included, last included)
/// whose chords stay within `tol` mm of the curve on the surface: a chord's
/// midpoint mapped onto the surface against the curve's midpoint, and its
/// quarter point, recursively.
fn sample_curve(surface: &NurbsSurface, c: &TrimCurve, tol: f64) -> Vec<Point2> {
    let TrimCurve::Bspline {
        degree,
        knots,
        control_points,
        weights,
    } = c
    else {
        let TrimCurve::Polyline(pts) = c else {
            unreachable!()
        };
        return pts.clone();
    };
    let n = control_points.len();
    let (t0, t1) = (knots[*degree], knots[n]);
    let at = |t: f64| bspline_point(*degree, knots, control_points, weights.as_deref(), t);
    let on = |p: Point2| surface.point(p[0], p[1]);
    // Start with a few points per knot span, so no span is skipped.
    let spans = knots.windows(2).filter(|w| w[1] > w[0]).count().max(1);
    let n0 = (spans * (degree + 1)).clamp(4, 4096);
    let mut out = vec![at(t0)];
    let mut stack: Vec<(f64, f64, u32)> = (0..n0)
        .rev()
        .map(|k| {
            (
                t0 + (t1 - t0) * k as f64 / n0 as f64,
                t0 + (t1 - t0) * (k + 1) as f64 / n0 as f64,
                0,
            )
        })
        .collect();
    while let Some((a, b, depth)) = stack.pop() {
        let (pa, pb) = (at(a), at(b));
        let dev = |f: f64| {
            let q = at(a + (b - a) * f);
            let l = [pa[0] + (pb[0] - pa[0]) * f, pa[1] + (pb[1] - pa[1]) * f];
            (on(q) - on(l)).norm()
        };
        if depth < 30 && (dev(0.5) > tol || dev(0.25) > tol || dev(0.75) > tol) {
            let m = 0.5 * (a + b);
            stack.push((m, b, depth + 1));
            stack.push((a, m, depth + 1));
        } else {
            out.push(pb);
        }
    }
    out
}

/// Joins a loop's curves into one closed polyline (no repeated closing
/// vertex). Consecutive curves must meet, and the last must end where the
/// first begins, within `gap`.
fn join_loop(
    surface: &NurbsSurface,
    field: &str,
    curves: &[TrimCurve],
    tol: f64,
    gap: f64,
) -> Result<Vec<Point2>> {
    if curves.is_empty() {
        return Err(Error::invalid(field, "a loop needs at least one curve"));
    }
    let mut out: Vec<Point2> = Vec::new();
    for (k, c) in curves.iter().enumerate() {
        let name = format!("{field}[{k}]");
        check_curve(&name, c)?;
        let pts = sample_curve(surface, c, tol);
        if let (Some(last), Some(first)) = (out.last(), pts.first()) {
            if dist2(*last, *first) > gap * gap {
                return Err(Error::invalid(
                    name,
                    format!(
                        "starts at ({}, {}) but the curve before ends at ({}, {}): the loop is open",
                        first[0], first[1], last[0], last[1]
                    ),
                ));
            }
            out.pop();
        }
        out.extend(pts);
    }
    let (first, last) = (out[0], out[out.len() - 1]);
    if dist2(first, last) > gap * gap {
        return Err(Error::invalid(
            field,
            format!(
                "is not closed: it ends at ({}, {}) but starts at ({}, {})",
                last[0], last[1], first[0], first[1]
            ),
        ));
    }
    out.pop();
    Ok(out)
}

/// Renames a pocket validation error's loop (`outer`, `holes[k]`) to the
/// trim's field (`trim.outer`, `trim.holes[k]`).
fn in_trim(e: Error) -> Error {
    match e {
        Error::Invalid { field, message } => Error::Invalid {
            field: format!("trim.{field}"),
            message: message.replace("crosses outer", "crosses trim.outer"),
        },
        other => other,
    }
}

impl Trim {
    /// Samples, validates and orients the loops on `surface`. Errors name
    /// the field under `trim` (`trim.outer[1].bspline.knots`, `trim.holes[0]`).
    pub fn new(
        surface: &NurbsSurface,
        outer_curves: Vec<TrimCurve>,
        hole_curves: Vec<Vec<TrimCurve>>,
        tolerance_mm: Option<f64>,
    ) -> Result<Self> {
        let tol = tolerance_mm.unwrap_or(DEFAULT_TOLERANCE_MM);
        if !(tol.is_finite() && tol > 0.0) {
            return Err(Error::invalid(
                "trim.tolerance",
                format!("must be a positive number (mm), got {tol}"),
            ));
        }
        let ((u0, u1), (v0, v1)) = surface.domain();
        let gap = JOIN_GAP * (u1 - u0).hypot(v1 - v0);
        let outer = join_loop(surface, "trim.outer", &outer_curves, tol, gap)?;
        let holes = hole_curves
            .iter()
            .enumerate()
            .map(|(k, h)| join_loop(surface, &format!("trim.holes[{k}]"), h, tol, gap))
            .collect::<Result<Vec<_>>>()?;
        let slack = 1e-9 * (u1 - u0).hypot(v1 - v0);
        for (name, l) in std::iter::once(("trim.outer".to_string(), &outer)).chain(
            holes
                .iter()
                .enumerate()
                .map(|(k, h)| (format!("trim.holes[{k}]"), h)),
        ) {
            if let Some(p) = l.iter().find(|p| {
                p[0] < u0 - slack || p[0] > u1 + slack || p[1] < v0 - slack || p[1] > v1 + slack
            }) {
                return Err(Error::invalid(
                    name,
                    format!(
                        "leaves the surface's domain [{u0}, {u1}] x [{v0}, {v1}] at ({}, {})",
                        p[0], p[1]
                    ),
                ));
            }
        }
        // The pocket outline's checks: closed loops of non-zero area, no
        // crossings within or between loops, holes inside the outer loop and
        // apart; and its orientation (outer CCW, holes CW).
        let pocket = Pocket::new(&outer, &holes).map_err(in_trim)?;
        let mut loops: Vec<&[Point2]> = vec![&pocket.outer];
        loops.extend(pocket.holes.iter().map(|h| h.as_slice()));
        let bands = Bands::new(&loops);
        Ok(Self {
            outer_curves,
            hole_curves,
            tolerance_mm: tol,
            outer: pocket.outer.clone(),
            holes: pocket.holes.clone(),
            bands,
        })
    }

    /// Is (u, v) on the trimmed face (inside the outer loop, outside every hole)?
    pub fn contains(&self, u: f64, v: f64) -> bool {
        self.bands.contains([u, v])
    }

    /// Area of the trimmed domain in (u, v) (outer minus holes).
    #[cfg(test)]
    fn uv_area(&self) -> f64 {
        use super::pocket::signed_area;
        signed_area(&self.outer) + self.holes.iter().map(|h| signed_area(h)).sum::<f64>()
    }

    /// Quadrature nodes of the grid cell [u, u + du] x [v, v + dv] over
    /// the face: (u, v, weight in (u, v) area). A cell whose 4 x 4 probe
    /// points all lie on the face gets the 3 x 3 Gauss-Legendre rule; one
    /// with none gets nothing; a cell the boundary crosses gets the
    /// midpoint rule on [`BOUNDARY_SUBCELLS`]² subcells, each kept if its
    /// centre is on the face (an area error of about one subcell per
    /// subcell the boundary crosses).
    pub fn cell_nodes(
        &self,
        (u, v): (f64, f64),
        (du, dv): (f64, f64),
        out: &mut Vec<(f64, f64, f64)>,
    ) {
        let probes = (0..4)
            .flat_map(|a| (0..4).map(move |b| (a, b)))
            .filter(|&(a, b)| {
                self.contains(
                    u + (a as f64 + 0.5) / 4.0 * du,
                    v + (b as f64 + 0.5) / 4.0 * dv,
                )
            })
            .count();
        if probes == 16 {
            for &(a, wa) in &GAUSS3 {
                for &(b, wb) in &GAUSS3 {
                    out.push((u + a * du, v + b * dv, wa * wb * du * dv));
                }
            }
        } else if probes > 0 || self.meets_cell((u, v), (du, dv)) {
            let n = BOUNDARY_SUBCELLS;
            let (su, sv) = (du / n as f64, dv / n as f64);
            for a in 0..n {
                for b in 0..n {
                    let (x, y) = (u + (a as f64 + 0.5) * su, v + (b as f64 + 0.5) * sv);
                    if self.contains(x, y) {
                        out.push((x, y, su * sv));
                    }
                }
            }
        }
    }

    /// Whether a loop vertex lies in the cell (a small loop between probes).
    fn meets_cell(&self, (u, v): (f64, f64), (du, dv): (f64, f64)) -> bool {
        self.loops()
            .flatten()
            .any(|p| p[0] >= u && p[0] <= u + du && p[1] >= v && p[1] <= v + dv)
    }

    /// Area of the face on `surface`, mm²: the area element integrated
    /// with [`Self::cell_nodes`] over a `cells` x `cells` grid of the domain.
    pub fn face_area(&self, surface: &NurbsSurface, cells: usize) -> f64 {
        let ((u0, u1), (v0, v1)) = surface.domain();
        let (du, dv) = ((u1 - u0) / cells as f64, (v1 - v0) / cells as f64);
        let mut nodes = Vec::new();
        let mut total = 0.0;
        for i in 0..cells {
            for j in 0..cells {
                nodes.clear();
                self.cell_nodes(
                    (u0 + i as f64 * du, v0 + j as f64 * dv),
                    (du, dv),
                    &mut nodes,
                );
                for &(u, v, w) in &nodes {
                    let d = surface.first_derivs(u, v);
                    total += w * d.su.cross(&d.sv).norm();
                }
            }
        }
        total
    }

    /// The intervals of the line v = const on the face, sorted by u: the
    /// loop crossings of the line, paired (even-odd).
    pub fn intervals_at_v(&self, v: f64) -> Vec<(f64, f64)> {
        let mut xs: Vec<f64> = self
            .bands
            .edges_between(v, v)
            .filter(|(a, b)| (a[1] > v) != (b[1] > v))
            .map(|(a, b)| a[0] + (v - a[1]) / (b[1] - a[1]) * (b[0] - a[0]))
            .collect();
        xs.sort_by(f64::total_cmp);
        xs.chunks_exact(2).map(|p| (p[0], p[1])).collect()
    }

    /// All loops, outer first.
    pub fn loops(&self) -> impl Iterator<Item = &Vec<Point2>> {
        std::iter::once(&self.outer).chain(self.holes.iter())
    }

    /// Distance in (u, v) from `p` to the nearest loop, in the metric of the
    /// surface at `p` (the first fundamental form, so about mm): how far
    /// the face is from a point off it.
    pub fn distance_mm(&self, surface: &NurbsSurface, p: Point2) -> f64 {
        let d = surface.first_derivs(p[0], p[1]);
        let (e, f, g) = (d.su.dot(&d.su), d.su.dot(&d.sv), d.sv.dot(&d.sv));
        let norm2 = |x: Point2| e * x[0] * x[0] + 2.0 * f * x[0] * x[1] + g * x[1] * x[1];
        let dot = |x: Point2, y: Point2| {
            e * x[0] * y[0] + f * (x[0] * y[1] + x[1] * y[0]) + g * x[1] * y[1]
        };
        let mut best = f64::INFINITY;
        for l in self.loops() {
            for i in 0..l.len() {
                let (a, b) = (l[i], l[(i + 1) % l.len()]);
                let ab = [b[0] - a[0], b[1] - a[1]];
                let ap = [p[0] - a[0], p[1] - a[1]];
                let len2 = norm2(ab);
                let t = if len2 > 0.0 {
                    (dot(ap, ab) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let r = [ap[0] - ab[0] * t, ap[1] - ab[1] * t];
                best = best.min(norm2(r));
            }
        }
        best.max(0.0).sqrt()
    }
}

/// A circle in (u, v) as one exact rational quadratic B-spline (four
/// quarter arcs: nine control points, weights 1 and sqrt(2)/2), from
/// (c + (r, 0)), counter-clockwise or clockwise.
pub fn circle(c: Point2, r: f64, ccw: bool) -> TrimCurve {
    let w = std::f64::consts::FRAC_1_SQRT_2;
    let mut pts = vec![
        [1.0, 0.0],
        [1.0, 1.0],
        [0.0, 1.0],
        [-1.0, 1.0],
        [-1.0, 0.0],
        [-1.0, -1.0],
        [0.0, -1.0],
        [1.0, -1.0],
        [1.0, 0.0],
    ];
    if !ccw {
        for p in &mut pts {
            p[1] = -p[1];
        }
    }
    TrimCurve::Bspline {
        degree: 2,
        knots: vec![
            0.0, 0.0, 0.0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1.0, 1.0, 1.0,
        ],
        control_points: pts
            .iter()
            .map(|p| [c[0] + r * p[0], c[1] + r * p[1]])
            .collect(),
        weights: Some(vec![1.0, w, 1.0, w, 1.0, w, 1.0, w, 1.0]),
    }
}

#[cfg(test)]
mod tests {
    use super::super::pocket::signed_area;
    use super::*;

    fn unit_plane() -> NurbsSurface {
        NurbsSurface::new(
            1,
            1,
            vec![0.0, 0.0, 1.0, 1.0],
            vec![0.0, 0.0, 1.0, 1.0],
            &[
                vec![[0.0, 0.0, 0.0], [0.0, 100.0, 0.0]],
                vec![[100.0, 0.0, 0.0], [100.0, 100.0, 0.0]],
            ],
            None,
        )
        .unwrap()
    }

    #[test]
    fn a_sampled_circle_hole_has_the_circle_area_and_orientation() {
        let s = unit_plane();
        let square = TrimCurve::Polyline(vec![
            [0.1, 0.1],
            [0.9, 0.1],
            [0.9, 0.9],
            [0.1, 0.9],
            [0.1, 0.1],
        ]);
        // The hole given counter-clockwise: reversed to clockwise.
        let t = Trim::new(
            &s,
            vec![square],
            vec![vec![circle([0.5, 0.5], 0.2, true)]],
            None,
        )
        .unwrap();
        assert!(signed_area(&t.holes[0]) < 0.0 && signed_area(&t.outer) > 0.0);
        let exact = 0.64 - std::f64::consts::PI * 0.04;
        // Chords within 1e-3 mm of a 20 mm circle: the area within 2 tol / r.
        assert!(
            (t.uv_area() - exact).abs() < exact * 1e-4,
            "{}",
            t.uv_area()
        );
        assert!(t.contains(0.15, 0.5) && !t.contains(0.5, 0.5) && !t.contains(0.05, 0.5));
        assert!(!t.contains(0.5, 0.95) && t.contains(0.5, 0.25));
        // Every sampled hole vertex lies on the circle.
        for p in &t.holes[0] {
            assert!(((p[0] - 0.5).hypot(p[1] - 0.5) - 0.2).abs() < 1e-12);
        }
    }

    #[test]
    fn the_banded_inside_test_agrees_with_the_plain_one() {
        let s = unit_plane();
        let t = Trim::new(
            &s,
            vec![circle([0.5, 0.5], 0.45, false)],
            vec![
                vec![circle([0.4, 0.5], 0.1, true)],
                vec![TrimCurve::Polyline(vec![
                    [0.6, 0.6],
                    [0.7, 0.6],
                    [0.65, 0.7],
                    [0.6, 0.6],
                ])],
            ],
            Some(1e-4),
        )
        .unwrap();
        let p = Pocket::new(&t.outer, &t.holes).unwrap();
        for i in 0..200 {
            for j in 0..200 {
                let q = [i as f64 / 199.0, j as f64 / 199.0 + 1e-7];
                assert_eq!(t.contains(q[0], q[1]), p.contains(q), "{q:?}");
            }
        }
    }

    #[test]
    fn the_face_is_closed_its_loops_belong_to_it() {
        let s = unit_plane();
        let square = TrimCurve::Polyline(vec![
            [0.0, 0.0],
            [1.0, 0.0],
            [1.0, 1.0],
            [0.0, 1.0],
            [0.0, 0.0],
        ]);
        let t = Trim::new(
            &s,
            vec![square],
            vec![vec![circle([0.5, 0.5], 0.2, false)]],
            None,
        )
        .unwrap();
        for k in 0..=100 {
            let f = k as f64 / 100.0;
            for p in [[f, 0.0], [f, 1.0], [0.0, f], [1.0, f]] {
                assert!(t.contains(p[0], p[1]), "{p:?} on the outer loop");
            }
        }
        for p in &t.holes[0] {
            assert!(t.contains(p[0], p[1]), "{p:?} on the hole's loop");
        }
        for p in [
            [1.0 + 1e-6, 0.5],
            [0.5, -1e-6],
            [0.5, 0.5],
            [0.5, 0.7 - 1e-3],
        ] {
            assert!(!t.contains(p[0], p[1]), "{p:?} off the face");
        }
    }

    #[test]
    fn bad_loops_name_the_field() {
        let s = unit_plane();
        let open = TrimCurve::Polyline(vec![[0.1, 0.1], [0.9, 0.1], [0.9, 0.9]]);
        let e = Trim::new(&s, vec![open], vec![], None).unwrap_err();
        assert!(
            matches!(&e, Error::Invalid { field, .. } if field == "trim.outer"),
            "{e}"
        );
        let bow = TrimCurve::Polyline(vec![
            [0.1, 0.1],
            [0.9, 0.9],
            [0.9, 0.1],
            [0.1, 0.6],
            [0.1, 0.1],
        ]);
        let e = Trim::new(&s, vec![bow], vec![], None).unwrap_err();
        assert!(
            e.to_string().contains("trim.outer") && e.to_string().contains("intersects itself"),
            "{e}"
        );
        let big = TrimCurve::Polyline(vec![[-0.1, 0.1], [0.9, 0.1], [0.9, 0.9], [-0.1, 0.1]]);
        let e = Trim::new(&s, vec![big], vec![], None).unwrap_err();
        assert!(e.to_string().contains("leaves the surface's domain"), "{e}");
    }
}
