//! Partitioning a surface into machining regions (docs/methods.md, "Partition
//! at trisectors"; Xu, Li, Liu 2016, section 2.2): trace the separatrices of
//! each trisector along the optimal feed field to the boundary or another
//! degenerate point, then split the parameter domain into the faces of the
//! planar graph formed by the separatrices and the domain boundary. Also the field-line tracing the initial passes use (on
//! the shared tracer in geometry::field_trace).

use super::degenerate_points::{DegeneratePoint, Kind};
use crate::strip_width::field::feed_at;
use nalgebra::{Point3, Vector2, Vector3};
use toolpath_kernel::geometry::field_trace::{trace_field_until, TraceOptions, TraceStop};
use toolpath_kernel::geometry::{LocalGeometry, NurbsSurface};

/// How a traced field line ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum TraceEnd {
    /// Reached the domain boundary (the last point is on it).
    Boundary,
    /// Ran into degenerate point `index` (the last point is that point).
    Degenerate(usize),
    /// `stop` said so (left the region); the last point is the first outside.
    Stopped,
    /// Field undefined (isotropic point, singular surface) or too long.
    Lost,
}

#[derive(Clone, Debug)]
pub struct Trace {
    pub uv: Vec<Vector2<f64>>,
    pub end: TraceEnd,
}

fn inside_domain(surface: &NurbsSurface, uv: Vector2<f64>) -> bool {
    let ((u0, u1), (v0, v1)) = surface.domain();
    uv.x >= u0 && uv.x <= u1 && uv.y >= v0 && uv.y <= v1
}

/// Feed field lines: traced with steps of at most `step` mm until the domain
/// boundary, a degenerate point (within `snap` mm; not the one the line
/// starts from), `stop(uv)`, or `max_len` mm.
pub(crate) struct Tracer<'a> {
    pub surface: &'a NurbsSurface,
    pub k_b: f64,
    pub step: f64,
    pub max_len: f64,
    /// Degenerate points to end at (xyz) and the distance that counts as reaching one.
    pub degenerate: &'a [Point3<f64>],
    pub snap: f64,
}

impl Tracer<'_> {
    /// Traces the feed field line from `start` heading along the 3-D tangent
    /// `dir`, with the shared field tracer (Dormand-Prince, error control in
    /// mm on the surface, exact stop on the domain boundary).
    pub fn trace(
        &self,
        start: Vector2<f64>,
        dir: Vector3<f64>,
        stop: &dyn Fn(Vector2<f64>) -> bool,
    ) -> Trace {
        let s = self.surface;
        let k_b = self.k_b;
        let field = |x: Vector2<f64>| {
            let g = LocalGeometry::at(s, x.x, x.y)?;
            feed_at(&g, k_b).map(|f| f.feed_uv)
        };
        let Some(g0) = LocalGeometry::at(s, start.x, start.y) else {
            return Trace {
                uv: vec![start],
                end: TraceEnd::Lost,
            };
        };
        let direction = g0.tangent_to_uv(dir);
        let start_xyz = s.point(start.x, start.y);
        let hit = std::cell::Cell::new(None);
        // A degenerate point within `snap` ends the line there (not the one
        // it starts from: it leaves that one radially).
        let near_degenerate = |p: &Point3<f64>, within: f64| -> Option<usize> {
            self.degenerate.iter().position(|d| {
                let from_start =
                    (d - start_xyz).norm() < self.snap && (p - start_xyz).norm() < 4.0 * self.snap;
                !from_start && (p - d).norm() < within
            })
        };
        let until = |uv: Vector2<f64>, p: &Point3<f64>| {
            if let Some(k) = near_degenerate(p, self.snap) {
                hit.set(Some(k));
                return true;
            }
            stop(uv)
        };
        let options = TraceOptions {
            max_length: self.max_len,
            tolerance: 1e-5,
            initial_step: self.step,
            max_step: self.step,
            min_step: 1e-7,
            oriented: false,
            max_points: 1_000_000,
        };
        let tr = trace_field_until(s, field, start, direction, &options, &until);
        let mut uv: Vec<Vector2<f64>> = tr.uv.iter().map(|p| Vector2::new(p[0], p[1])).collect();
        let end = match tr.stop {
            TraceStop::Boundary => TraceEnd::Boundary,
            TraceStop::Stopped => match hit.get() {
                Some(k) => {
                    uv.pop();
                    TraceEnd::Degenerate(k)
                }
                None => TraceEnd::Stopped,
            },
            // The field turns too fast or vanishes right at an umbilic.
            TraceStop::FieldUndefined | TraceStop::StepTooSmall => {
                let last = tr.xyz.last().map(|p| Point3::new(p[0], p[1], p[2]));
                match last.and_then(|p| near_degenerate(&p, 4.0 * self.snap)) {
                    Some(k) => TraceEnd::Degenerate(k),
                    None => TraceEnd::Lost,
                }
            }
            TraceStop::MaxLength | TraceStop::MaxPoints => TraceEnd::Lost,
        };
        if uv.is_empty() {
            uv.push(start);
        }
        Trace { uv, end }
    }
}

/// One machining region: a face of the partition.
#[derive(Clone, Debug)]
pub struct Region {
    pub id: usize,
    /// Closed polygon in parameter space, counter-clockwise, first point not repeated.
    pub boundary_uv: Vec<Vector2<f64>>,
    pub area_mm2: f64,
}

impl Region {
    /// Even-odd point-in-polygon in parameter space.
    pub fn contains(&self, uv: Vector2<f64>) -> bool {
        polygon_contains(&self.boundary_uv, uv)
    }
}

/// The x at which the edges of `poly` cross the horizontal line at `y`: a
/// point (x', y) is inside where an odd number of them lie beyond x'.
fn crossings(poly: &[Vector2<f64>], y: f64) -> impl Iterator<Item = f64> + '_ {
    let last = poly.len().wrapping_sub(1);
    (0..poly.len()).filter_map(move |i| {
        let (a, b) = (poly[i], poly[if i == 0 { last } else { i - 1 }]);
        ((a.y > y) != (b.y > y)).then(|| a.x + (y - a.y) / (b.y - a.y) * (b.x - a.x))
    })
}

/// The [`crossings`] of the row at `y`, into `out`, for testing many points
/// of one row with [`inside_of_row`] (the same answers as
/// [`polygon_contains`]).
pub(crate) fn row_crossings(poly: &[Vector2<f64>], y: f64, out: &mut Vec<f64>) {
    out.clear();
    out.extend(crossings(poly, y));
}

/// [`polygon_contains`] for a point at `x` on the row whose
/// [`row_crossings`] are `crossings`.
pub(crate) fn inside_of_row(crossings: &[f64], x: f64) -> bool {
    crossings.iter().filter(|&&c| x < c).count() % 2 == 1
}

/// Even-odd point-in-polygon test.
pub(crate) fn polygon_contains(poly: &[Vector2<f64>], p: Vector2<f64>) -> bool {
    crossings(poly, p.y).filter(|&x| p.x < x).count() % 2 == 1
}

/// The partition of a surface.
#[derive(Clone, Debug)]
pub(crate) struct Partition {
    pub regions: Vec<Region>,
    /// Separatrices in parameter space, each from its trisector.
    pub separatrices_uv: Vec<Vec<Vector2<f64>>>,
    /// The planar graph the regions are the faces of.
    pub graph: FaceGraph,
}

/// The planar graph of the separatrices and the domain boundary: its
/// bounded faces are the regions. The first `separatrices` edges are the
/// separatrices (each once), the rest the boundary ring.
#[derive(Clone, Debug)]
pub(crate) struct FaceGraph {
    nodes: Vec<Vector2<f64>>,
    edges: Vec<(usize, usize, Vec<Vector2<f64>>)>,
    separatrices: usize,
    scale: (f64, f64),
}

impl FaceGraph {
    /// How many separatrix edges the graph has (the ones [`Self::regions_without`] may drop).
    pub(crate) fn separatrix_count(&self) -> usize {
        self.separatrices
    }

    /// The regions of the graph with the separatrix edges marked in
    /// `removed` taken out: the faces they separated merge into one. A
    /// separatrix the removal leaves ending at a point no other kept edge
    /// reaches goes too (it would bound nothing; removed iteratively; spurs
    /// of the whole graph, such as a separatrix ending at a wedge, stay).
    /// Returns the faces (counter-clockwise polygons) and which separatrices
    /// were left out in the end.
    pub(crate) fn faces_without(&self, removed: &[bool]) -> (Vec<Vec<Vector2<f64>>>, Vec<bool>) {
        let mut out: Vec<bool> = (0..self.edges.len())
            .map(|e| e < self.separatrices && removed.get(e).copied().unwrap_or(false))
            .collect();
        let degrees = |out: &[bool]| {
            let mut degree = vec![0usize; self.nodes.len()];
            for (e, (a, b, _)) in self.edges.iter().enumerate() {
                if !out[e] {
                    degree[*a] += 1;
                    degree[*b] += 1;
                }
            }
            degree
        };
        let whole = degrees(&vec![false; self.edges.len()]);
        loop {
            let degree = degrees(&out);
            let left_alone = |n: usize| degree[n] == 1 && whole[n] > 1;
            let dangling: Vec<usize> = (0..self.separatrices)
                .filter(|&e| {
                    let (a, b, _) = &self.edges[e];
                    !out[e] && a != b && (left_alone(*a) || left_alone(*b))
                })
                .collect();
            if dangling.is_empty() {
                break;
            }
            for e in dangling {
                out[e] = true;
            }
        }
        let kept: Vec<(usize, usize, Vec<Vector2<f64>>)> = self
            .edges
            .iter()
            .zip(&out)
            .filter(|(_, &o)| !o)
            .map(|(e, _)| e.clone())
            .collect();
        let faces = faces(&self.nodes, &kept, self.scale);
        out.truncate(self.separatrices);
        (faces, out)
    }

    /// [`Self::faces_without`] as regions with their areas (ids by centroid).
    pub(crate) fn regions_without(
        &self,
        surface: &NurbsSurface,
        removed: &[bool],
    ) -> (Vec<Region>, Vec<bool>) {
        let (faces, out) = self.faces_without(removed);
        (regions_of_faces(surface, faces), out)
    }
}

/// A point strictly inside `poly` (even-odd): the middle of the widest
/// inside interval on the rows at 1/4, 1/2 and 3/4 of its v range.
pub(crate) fn interior_point(poly: &[Vector2<f64>]) -> Option<Vector2<f64>> {
    let (lo, hi) = poly
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.y), b.max(p.y))
        });
    let mut best: Option<(f64, Vector2<f64>)> = None;
    for t in [0.5, 0.25, 0.75] {
        let y = lo + t * (hi - lo);
        let mut xs: Vec<f64> = crossings(poly, y).collect();
        xs.sort_by(f64::total_cmp);
        for pair in xs.chunks_exact(2) {
            let w = pair[1] - pair[0];
            if w > 0.0 && best.is_none_or(|(bw, _)| w > bw) {
                best = Some((w, Vector2::new(0.5 * (pair[0] + pair[1]), y)));
            }
        }
    }
    best.map(|(_, p)| p)
}

/// The faces as regions with their areas, ids by centroid (u, then v) so
/// that they do not depend on the order the faces were found in.
fn regions_of_faces(surface: &NurbsSurface, faces: Vec<Vec<Vector2<f64>>>) -> Vec<Region> {
    let mut regions: Vec<Region> = faces
        .into_iter()
        .map(|poly| Region {
            id: 0,
            area_mm2: polygon_area(surface, &poly, 48),
            boundary_uv: poly,
        })
        .collect();
    let centroid = |r: &Region| {
        let n = r.boundary_uv.len() as f64;
        r.boundary_uv.iter().fold(Vector2::zeros(), |a, p| a + p) / n
    };
    regions.sort_by(|a, b| {
        let (ca, cb) = (centroid(a), centroid(b));
        ca.x.total_cmp(&cb.x).then(ca.y.total_cmp(&cb.y))
    });
    for (k, r) in regions.iter_mut().enumerate() {
        r.id = k;
    }
    regions
}

/// Gauss-Legendre on [0, 1], 3 points.
const GAUSS3: [(f64, f64); 3] = [
    (0.112_701_665_379_258_3, 5.0 / 18.0),
    (0.5, 8.0 / 18.0),
    (0.887_298_334_620_741_7, 5.0 / 18.0),
];

/// Surface area of a parameter-space polygon: scanlines in v at Gauss
/// points, each crossing interval integrated in u with Gauss points.
pub(crate) fn polygon_area(surface: &NurbsSurface, poly: &[Vector2<f64>], strips: usize) -> f64 {
    integrate_polygon(surface, poly, strips, false)
}

/// [`polygon_area`] of the part on a trimmed face (each scanline's
/// intervals cut to the face's): the region's area a result reports.
pub(crate) fn polygon_face_area(
    surface: &NurbsSurface,
    poly: &[Vector2<f64>],
    strips: usize,
) -> f64 {
    integrate_polygon(surface, poly, strips, surface.trim().is_some())
}

fn integrate_polygon(
    surface: &NurbsSurface,
    poly: &[Vector2<f64>],
    strips: usize,
    face_only: bool,
) -> f64 {
    let (vmin, vmax) = poly
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.y), b.max(p.y))
        });
    if vmax.is_nan() || vmin.is_nan() || vmax <= vmin {
        return 0.0;
    }
    let dv = (vmax - vmin) / strips as f64;
    let area_element =
        |u: f64, v: f64| LocalGeometry::at(surface, u, v).map_or(0.0, |g| g.area_element());
    let mut total = 0.0;
    let mut xs = Vec::new();
    for k in 0..strips {
        for &(gv, wv) in &GAUSS3 {
            let v = vmin + (k as f64 + gv) * dv;
            xs.clear();
            let n = poly.len();
            for i in 0..n {
                let (a, b) = (poly[i], poly[(i + 1) % n]);
                if (a.y > v) != (b.y > v) {
                    xs.push(a.x + (v - a.y) / (b.y - a.y) * (b.x - a.x));
                }
            }
            xs.sort_by(f64::total_cmp);
            // On a trimmed face, each interval is cut to the face's own
            // intervals on the scanline, so the rule integrates a smooth
            // integrand.
            let face = match (face_only, surface.trim()) {
                (true, Some(trim)) => Some(trim.intervals_at_v(v)),
                _ => None,
            };
            let mut intervals = Vec::new();
            for pair in xs.chunks_exact(2) {
                match &face {
                    Some(face) => intervals.extend(
                        face.iter()
                            .map(|&(fa, fb)| (pair[0].max(fa), pair[1].min(fb)))
                            .filter(|(a, b)| a < b),
                    ),
                    None => intervals.push((pair[0], pair[1])),
                }
            }
            let mut row = 0.0;
            for (ua, ub) in intervals {
                let sub = 8;
                let du = (ub - ua) / sub as f64;
                for m in 0..sub {
                    for &(gu, wu) in &GAUSS3 {
                        row += wu * du * area_element(ua + (m as f64 + gu) * du, v);
                    }
                }
            }
            total += wv * dv * row;
        }
    }
    total
}

/// Perimeter coordinate of a boundary point, counter-clockwise from (u0, v0).
fn perimeter_s(surface: &NurbsSurface, p: Vector2<f64>) -> f64 {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let (w, h) = (u1 - u0, v1 - v0);
    let tol = 1e-9 * (w + h);
    if (p.y - v0).abs() <= tol {
        (p.x - u0) / w
    } else if (p.x - u1).abs() <= tol {
        1.0 + (p.y - v0) / h
    } else if (p.y - v1).abs() <= tol {
        2.0 + (u1 - p.x) / w
    } else {
        3.0 + (v1 - p.y) / h
    }
}

fn on_boundary(surface: &NurbsSurface, p: Vector2<f64>) -> bool {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let tol = 1e-9 * ((u1 - u0) + (v1 - v0));
    (p.x - u0).abs() <= tol
        || (p.x - u1).abs() <= tol
        || (p.y - v0).abs() <= tol
        || (p.y - v1).abs() <= tol
}

/// Traces the separatrices of the trisectors and splits the domain.
/// `step` mm for tracing.
pub(crate) fn partition(
    surface: &NurbsSurface,
    k_b: f64,
    points: &[DegeneratePoint],
    step: f64,
) -> Partition {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let (w, h) = (u1 - u0, v1 - v0);
    let xyz: Vec<Point3<f64>> = points.iter().map(|p| p.xyz).collect();
    let (lo, hi) = surface.bounding_box();
    let tracer = Tracer {
        surface,
        k_b,
        step,
        max_len: 20.0 * (hi - lo).norm(),
        degenerate: &xyz,
        snap: 1.5 * step,
    };
    let Separatrices {
        mut nodes,
        mut edges,
        lines: separatrices_uv,
    } = trace_separatrices(&tracer, points);
    let ring_edges = close_boundary(surface, &mut nodes, &mut edges);
    let separatrices = edges.len() - ring_edges;
    let graph = FaceGraph {
        nodes,
        edges,
        separatrices,
        scale: (w, h),
    };
    let (regions, _) = graph.regions_without(surface, &[]);
    Partition {
        regions,
        separatrices_uv,
        graph,
    }
}

/// The traced separatrices as graph nodes (the degenerate points, index =
/// point index, then the places where separatrices leave the domain) and
/// edges (one copy of a separatrix traced from both ends), with every
/// traced line.
struct Separatrices {
    nodes: Vec<Vector2<f64>>,
    edges: Vec<(usize, usize, Vec<Vector2<f64>>)>,
    lines: Vec<Vec<Vector2<f64>>>,
}

/// Traces every separatrix of the trisectors among `points`, starting one
/// step out along its direction.
fn trace_separatrices(tracer: &Tracer, points: &[DegeneratePoint]) -> Separatrices {
    let (surface, step) = (tracer.surface, tracer.step);
    let ((u0, u1), (v0, v1)) = surface.domain();
    let (w, h) = (u1 - u0, v1 - v0);
    let mut nodes: Vec<Vector2<f64>> = points.iter().map(|p| p.uv).collect();
    let mut edges: Vec<(usize, usize, Vec<Vector2<f64>>)> = Vec::new();
    let mut separatrices_uv = Vec::new();
    for (pi, p) in points.iter().enumerate() {
        if p.kind != Kind::Trisector {
            continue;
        }
        for (t3, t_uv) in &p.separatrices {
            // Start one step out along the separatrix direction.
            let start = p.uv + t_uv * step;
            if !inside_domain(surface, start) {
                continue; // a trisector on the boundary: this separatrix leaves at once
            }
            let tr = tracer.trace(start, *t3, &|_| false);
            let mut line = vec![p.uv];
            line.extend(tr.uv.iter().copied());
            let end = match tr.end {
                TraceEnd::Degenerate(k) => {
                    line.push(points[k].uv);
                    Some(k)
                }
                TraceEnd::Boundary => {
                    nodes.push(*line.last().unwrap_or(&p.uv));
                    Some(nodes.len() - 1)
                }
                _ => {
                    nodes.push(*line.last().unwrap_or(&p.uv));
                    Some(nodes.len() - 1)
                }
            };
            if let Some(b) = end {
                // The same separatrix traced from its other end: keep one copy.
                let dup = b < points.len()
                    && edges.iter().any(|(a0, b0, l)| {
                        *a0 == b
                            && *b0 == pi
                            && l.len() > 1
                            && (l[1] - line[line.len() - 2]).norm() < 2.0 * step / (w + h)
                    });
                separatrices_uv.push(line.clone());
                if !dup {
                    edges.push((pi, b, line));
                }
            }
        }
    }
    Separatrices {
        nodes,
        edges,
        lines: separatrices_uv,
    }
}

/// Adds the boundary cycle to the graph: the corners, the boundary nodes
/// and the degenerate points on the boundary, in order round the
/// perimeter, joined by straight edges. Returns how many edges it added.
fn close_boundary(
    surface: &NurbsSurface,
    nodes: &mut Vec<Vector2<f64>>,
    edges: &mut Vec<(usize, usize, Vec<Vector2<f64>>)>,
) -> usize {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let (w, h) = (u1 - u0, v1 - v0);
    let corners = [
        Vector2::new(u0, v0),
        Vector2::new(u1, v0),
        Vector2::new(u1, v1),
        Vector2::new(u0, v1),
    ];
    let mut ring: Vec<usize> = Vec::new();
    for c in corners {
        nodes.push(c);
        ring.push(nodes.len() - 1);
    }
    for (k, n) in nodes.iter().enumerate() {
        if on_boundary(surface, *n) && !ring.contains(&k) {
            ring.push(k);
        }
    }
    ring.sort_by(|&a, &b| {
        perimeter_s(surface, nodes[a]).total_cmp(&perimeter_s(surface, nodes[b]))
    });
    ring.dedup_by(|a, b| (nodes[*a] - nodes[*b]).norm() <= 1e-12 * (w + h));
    let mut ring_edges = 0;
    for k in 0..ring.len() {
        let (a, b) = (ring[k], ring[(k + 1) % ring.len()]);
        if (nodes[a] - nodes[b]).norm() > 0.0 {
            edges.push((a, b, vec![nodes[a], nodes[b]]));
            ring_edges += 1;
        }
    }
    ring_edges
}

fn signed_area(poly: &[Vector2<f64>]) -> f64 {
    let n = poly.len();
    (0..n)
        .map(|i| poly[i].perp(&poly[(i + 1) % n]))
        .sum::<f64>()
        * 0.5
}

/// Bounded faces of the planar graph (counter-clockwise polygons).
fn faces(
    nodes: &[Vector2<f64>],
    edges: &[(usize, usize, Vec<Vector2<f64>>)],
    scale: (f64, f64),
) -> Vec<Vec<Vector2<f64>>> {
    // Half-edge 2k runs a -> b along the polyline, 2k + 1 back.
    let norm = |d: Vector2<f64>| Vector2::new(d.x / scale.0, d.y / scale.1);
    let half = |h: usize| -> (usize, usize, Vec<Vector2<f64>>) {
        let (a, b, l) = &edges[h / 2];
        if h.is_multiple_of(2) {
            (*a, *b, l.clone())
        } else {
            (*b, *a, l.iter().rev().copied().collect())
        }
    };
    let angle = |line: &[Vector2<f64>]| {
        let o = line[0];
        let p = line
            .iter()
            .skip(1)
            .find(|p| (**p - o).norm() > 0.0)
            .copied()
            .unwrap_or(o);
        let d = norm(p - o);
        d.y.atan2(d.x)
    };
    let count = edges.len() * 2;
    let mut outgoing: Vec<Vec<(f64, usize)>> = vec![Vec::new(); nodes.len()];
    for h in 0..count {
        let (a, _, l) = half(h);
        outgoing[a].push((angle(&l), h));
    }
    for o in &mut outgoing {
        o.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    }
    let mut used = vec![false; count];
    let mut out = Vec::new();
    for h0 in 0..count {
        if used[h0] {
            continue;
        }
        let mut poly: Vec<Vector2<f64>> = Vec::new();
        let mut h = h0;
        let mut guard = 0;
        while !used[h] && guard <= count {
            used[h] = true;
            guard += 1;
            let (_, b, l) = half(h);
            poly.extend(l.iter().take(l.len().saturating_sub(1)).copied());
            // Next: the outgoing edge at b just clockwise of the twin.
            let twin = h ^ 1;
            let list = &outgoing[b];
            let Some(pos) = list.iter().position(|&(_, x)| x == twin) else {
                break;
            };
            let prev = if pos == 0 { list.len() - 1 } else { pos - 1 };
            h = list[prev].1;
        }
        if poly.len() >= 3 && signed_area(&poly) > 0.0 {
            out.push(poly);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::strip_width::regions::degenerate_points;
    use crate::test_surfaces;

    #[test]
    fn row_crossings_answer_as_the_point_test() {
        // A star with 11 spikes (concave, rows through its vertices), and
        // a grid of points including those on its vertices' rows.
        let poly: Vec<Vector2<f64>> = (0..22)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / 22.0;
                let r = if k % 2 == 0 { 1.0 } else { 0.45 };
                Vector2::new(r * a.cos(), r * a.sin())
            })
            .collect();
        let mut rows: Vec<f64> = (0..=60).map(|j| -1.1 + 2.2 * j as f64 / 60.0).collect();
        rows.extend(poly.iter().map(|p| p.y));
        let mut crossings = Vec::new();
        let (mut inside, mut outside) = (0, 0);
        for &y in &rows {
            row_crossings(&poly, y, &mut crossings);
            let mut xs: Vec<f64> = (0..=80).map(|i| -1.1 + 2.2 * i as f64 / 80.0).collect();
            xs.extend(poly.iter().map(|p| p.x));
            for x in xs {
                let want = polygon_contains(&poly, Vector2::new(x, y));
                assert_eq!(inside_of_row(&crossings, x), want, "({x}, {y})");
                if want {
                    inside += 1;
                } else {
                    outside += 1;
                }
            }
        }
        assert!(
            inside > 500 && outside > 500,
            "{inside} inside, {outside} outside"
        );
    }

    /// Independent region areas: the exact rays at 60, 180 and 300 deg
    /// bound the three sectors of the square; the surface area of each is
    /// integrated on a fine grid of the closed-form monkey saddle.
    fn reference_areas() -> Vec<(f64, f64)> {
        let n = 800;
        let mut sums = [0.0f64; 3];
        let mut proj = [0.0f64; 3];
        let d = 100.0 / n as f64;
        for i in 0..n {
            for j in 0..n {
                let (x, y) = (-50.0 + (i as f64 + 0.5) * d, -50.0 + (j as f64 + 0.5) * d);
                let (zx, zy) = (3e-5 * (x * x - y * y), -6e-5 * x * y);
                let da = (1.0 + zx * zx + zy * zy).sqrt() * d * d;
                let a = y.atan2(x).to_degrees().rem_euclid(360.0);
                let k = if !(60.0..300.0).contains(&a) {
                    0
                } else if a < 180.0 {
                    1
                } else {
                    2
                };
                sums[k] += da;
                proj[k] += d * d;
            }
        }
        (0..3).map(|k| (sums[k], proj[k])).collect()
    }

    #[test]
    fn monkey_saddle_splits_into_three_regions_of_the_exact_areas() {
        let reference = reference_areas();
        assert!((reference[0].0 - 3563.7).abs() < 1.0 && (reference[0].1 - 3556.6).abs() < 1.0);
        for (offset, warp) in [([0.0, 0.0], 0.0), ([137.0, -41.0], 0.35)] {
            let s = test_surfaces::monkey_saddle(offset, warp);
            let a = degenerate_points::find(&s, 32).unwrap();
            let k_b = 5f64.to_radians().sin() / 2.5;
            let p = partition(&s, k_b, &a.points, 1.0);
            assert_eq!(p.separatrices_uv.len(), 3);
            // Separatrices are straight rays at 60, 180, 300 deg (within 1 deg).
            for line in &p.separatrices_uv {
                let mut ang = Vec::new();
                for uv in line {
                    let q = s.point(uv.x, uv.y);
                    let (x, y) = (q.x - offset[0], q.y - offset[1]);
                    if x.hypot(y) > 3.0 {
                        ang.push(y.atan2(x).to_degrees().rem_euclid(360.0));
                    }
                }
                let want = [60.0, 180.0, 300.0]
                    .into_iter()
                    .min_by(|a: &f64, b: &f64| (a - ang[0]).abs().total_cmp(&(b - ang[0]).abs()))
                    .unwrap();
                assert!(ang.iter().all(|a| (a - want).abs() < 1.0), "{ang:?}");
                let end = line.last().unwrap();
                assert!(on_boundary(&s, *end));
            }
            assert_eq!(p.regions.len(), 3);
            let mut got: Vec<f64> = p.regions.iter().map(|r| r.area_mm2).collect();
            got.sort_by(f64::total_cmp);
            let mut want: Vec<f64> = reference.iter().map(|r| r.0).collect();
            want.sort_by(f64::total_cmp);
            for (g, w) in got.iter().zip(&want) {
                assert!((g - w).abs() / w < 0.01, "{got:?} vs {want:?}");
            }
            // Projected on xy (shoelace of the mapped boundary).
            let mut proj: Vec<f64> = p
                .regions
                .iter()
                .map(|r| {
                    let xy: Vec<Vector2<f64>> = r
                        .boundary_uv
                        .iter()
                        .map(|uv| {
                            let q = s.point(uv.x, uv.y);
                            Vector2::new(q.x, q.y)
                        })
                        .collect();
                    signed_area(&xy).abs()
                })
                .collect();
            proj.sort_by(f64::total_cmp);
            for (g, w) in proj.iter().zip([3221.7, 3221.7, 3556.6]) {
                assert!((g - w).abs() / w < 0.01, "{proj:?}");
            }
        }
    }

    #[test]
    fn removing_a_separatrix_merges_the_regions_it_separated() {
        // Monkey saddle: three rays from the trisector. Without one of them
        // the two sectors it separated are one region of their joint exact
        // area; without two, the third ray dangles and goes too.
        let reference = reference_areas();
        let total: f64 = reference.iter().map(|r| r.0).sum();
        let s = test_surfaces::monkey_saddle([0.0, 0.0], 0.0);
        let a = degenerate_points::find(&s, 32).unwrap();
        let p = partition(&s, 5f64.to_radians().sin() / 2.5, &a.points, 1.0);
        let g = &p.graph;
        assert_eq!(g.separatrix_count(), 3);
        for e in 0..3 {
            let mut removed = vec![false; 3];
            removed[e] = true;
            let (regions, out) = g.regions_without(&s, &removed);
            assert_eq!(out, removed);
            assert_eq!(regions.len(), 2);
            let mut got: Vec<f64> = regions.iter().map(|r| r.area_mm2).collect();
            got.sort_by(f64::total_cmp);
            // The kept sector is one of the reference's; the merged region
            // the sum of the other two.
            let kept = reference
                .iter()
                .map(|r| r.0)
                .min_by(|a, b| (a - got[0]).abs().total_cmp(&(b - got[0]).abs()))
                .unwrap();
            assert!((got[0] - kept).abs() / kept < 0.01, "{got:?}");
            assert!((got[1] - (total - kept)).abs() / total < 0.01, "{got:?}");
            // Every point of the domain lies in exactly one region.
            for i in 0..20 {
                for j in 0..20 {
                    let uv = Vector2::new((i as f64 + 0.37) / 20.0, (j as f64 + 0.61) / 20.0);
                    let ((u0, u1), (v0, v1)) = s.domain();
                    let uv = Vector2::new(u0 + (u1 - u0) * uv.x, v0 + (v1 - v0) * uv.y);
                    assert_eq!(regions.iter().filter(|r| r.contains(uv)).count(), 1);
                }
            }
            let mut two = removed.clone();
            two[(e + 1) % 3] = true;
            let (regions, out) = g.regions_without(&s, &two);
            assert_eq!(out, vec![true; 3], "the last ray dangles");
            assert_eq!(regions.len(), 1);
            assert!((regions[0].area_mm2 - total).abs() / total < 0.005);
        }
        // Nothing removed: the partition as traced.
        let (regions, out) = g.regions_without(&s, &[]);
        assert_eq!(out, vec![false; 3]);
        assert_eq!(regions.len(), 3);
        for (r, t) in regions.iter().zip(&p.regions) {
            assert_eq!(r.boundary_uv, t.boundary_uv);
        }
    }

    #[test]
    fn any_separatrices_removed_the_regions_still_tile_the_domain() {
        // Random surfaces outside the suite (seeds 40-45, 200 x 150 mm),
        // partitions of several regions; for 12 subsets of separatrices
        // removed each: every point of a 30 x 30 grid lies in exactly one
        // region, the areas add up to the surface's, and fewer separatrices
        // never give more regions.
        let mut partitions = 0;
        for seed in 40..46u64 {
            let params = toolpath_samples::random::RandomSurface {
                seed,
                anisotropy: (seed % 3) as f64,
                ..Default::default()
            };
            let s = params.surface().unwrap();
            let a = degenerate_points::find(&s, 48).unwrap();
            let p = partition(&s, 5f64.to_radians().sin() / 2.5, &a.points, 2.5);
            let whole: f64 = p.regions.iter().map(|r| r.area_mm2).sum();
            let total = polygon_area(
                &s,
                &crate::strip_width::regions::whole_domain(&s).boundary_uv,
                48,
            );
            if p.regions.len() < 3 || (whole - total).abs() > 0.005 * total {
                continue; // too few regions, or a partition planned as one region
            }
            partitions += 1;
            let n = p.graph.separatrix_count();
            let mut bits = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15);
            for _ in 0..12 {
                bits = bits.rotate_left(7) ^ 0x2545_F491_4F6C_DD1D;
                let removed: Vec<bool> = (0..n).map(|e| (bits >> (e % 64)) & 1 == 1).collect();
                let (regions, out) = p.graph.regions_without(&s, &removed);
                assert!(out.iter().zip(&removed).all(|(o, r)| *o || !*r), "{seed}");
                assert!(
                    !regions.is_empty() && regions.len() <= p.regions.len(),
                    "{seed}"
                );
                let sum: f64 = regions.iter().map(|r| r.area_mm2).sum();
                assert!(
                    (sum - total).abs() < 0.005 * total,
                    "{seed}: {sum} of {total}"
                );
                let ((u0, u1), (v0, v1)) = s.domain();
                for i in 0..30 {
                    for j in 0..30 {
                        let uv = Vector2::new(
                            u0 + (u1 - u0) * (i as f64 + 0.43) / 30.0,
                            v0 + (v1 - v0) * (j as f64 + 0.57) / 30.0,
                        );
                        let holding = regions.iter().filter(|r| r.contains(uv)).count();
                        assert_eq!(holding, 1, "seed {seed}, uv {uv:?}, removed {removed:?}");
                    }
                }
            }
        }
        assert!(partitions >= 3, "only {partitions} partitions to test");
    }

    #[test]
    fn an_interior_point_lies_inside() {
        // A U shape: the middle of its bounding box is outside.
        let poly = [
            (0.0, 0.0),
            (3.0, 0.0),
            (3.0, 3.0),
            (2.0, 3.0),
            (2.0, 1.0),
            (1.0, 1.0),
            (1.0, 3.0),
            (0.0, 3.0),
        ]
        .map(|(x, y)| Vector2::new(x, y));
        let p = interior_point(&poly).unwrap();
        assert!(polygon_contains(&poly, p), "{p:?}");
        assert!(interior_point(&poly[..2]).is_none());
    }

    #[test]
    fn no_trisector_means_one_region_of_the_whole_surface() {
        let s = test_surfaces::concave_cylinder(100.0, 100.0);
        let p = partition(&s, 0.03, &[], 1.0);
        assert_eq!(p.regions.len(), 1);
        let want = 100.0 * std::f64::consts::PI * 100.0;
        assert!(
            (p.regions[0].area_mm2 - want).abs() / want < 1e-3,
            "{}",
            p.regions[0].area_mm2
        );
    }

    #[test]
    fn trisector_on_the_boundary_still_partitions() {
        // Monkey saddle cut at x = 0: the trisector sits on the edge u = 0.
        let s = test_surfaces::fit(
            3,
            3,
            test_surfaces::clamped(3, &[]),
            test_surfaces::clamped(3, &[]),
            |u, v| {
                let (x, y) = (50.0 * u, 100.0 * v - 50.0);
                [x, y, 1e-5 * (x * x * x - 3.0 * x * y * y)]
            },
        );
        let a = degenerate_points::find(&s, 32).unwrap();
        let p = partition(&s, 0.03, &a.points, 1.0);
        let total: f64 = p.regions.iter().map(|r| r.area_mm2).sum();
        let whole = polygon_area(
            &s,
            &[
                Vector2::new(0.0, 0.0),
                Vector2::new(1.0, 0.0),
                Vector2::new(1.0, 1.0),
                Vector2::new(0.0, 1.0),
            ],
            48,
        );
        assert!(
            !p.regions.is_empty() && (total - whole).abs() / whole < 1e-3,
            "{total} {whole}"
        );
    }
}
