//! Medial axis of a polygonal pocket (outer loop plus holes) as 3-D branches
//! (x, y, r), split at branch points and end points (docs/methods.md, "Medial
//! axis of a pocket").
//!
//! The segment Voronoi diagram comes from `boostvoronoi` (robust integer
//! predicates); this module turns it into the interior medial axis:
//! - edges outside the pocket (beyond the outer loop, inside holes) are dropped,
//! - secondary edges (the perpendiculars from a reflex vertex to its own
//!   segments) are dropped, they are not part of the medial axis,
//! - edges whose object angle (the angle at the medial point between its two
//!   foot points) stays below [`MIN_OBJECT_ANGLE`] are dropped: they are the
//!   artefacts of polygonising a smooth curve (every vertex of a discretised
//!   ellipse is a tiny convex corner whose bisector runs towards the evolute).
//!   True corners (interior angle alpha) have object angle pi - alpha and stay.
//!
//! Parabolic edges (reflex vertex against a segment) are sampled exactly on
//! the parabola; r is the exact distance to the edge's site.

use crate::error::{Error, Result};
use crate::geometry::pocket::{Pocket, Point2};
use boostvoronoi::prelude::{Builder, Diagram, Line, SourceCategory};

/// Medial-axis edges whose object angle never reaches this are discretisation
/// artefacts of smooth boundaries (radians; 10 degrees). A polygon corner with
/// an interior angle above 170 degrees is treated as smooth.
pub(crate) const MIN_OBJECT_ANGLE: f64 = 10.0 * std::f64::consts::PI / 180.0;

/// A polygon vertex turning by less than this (radians; 30 degrees) is read as
/// one sample of a rounded corner: its corner radius is the radius where its
/// medial-axis branch meets the others (the fan centre of the arc's vertices),
/// not 0. Vertices turning more are sharp corners (radius 0).
pub(crate) const SHARP_CORNER_TURN: f64 = 30.0 * std::f64::consts::PI / 180.0;

/// Largest spacing of the samples along curved medial-axis edges, mm.
const SAMPLE_STEP_MM: f64 = 0.25;

/// Integer resolution of the Voronoi input: 1e-4 mm.
const UNITS_PER_MM: f64 = 1e4;

/// Where the pocket's centre goes in boostvoronoi's integer frame (fast path).
/// The library accepts a circle event computed in floating point when its
/// error bound is within 64 ulps of the event's coordinates, else recomputes
/// it with big integers. Far from 0 the coordinates' ulps are larger while the
/// (patched, locally framed) predicates' absolute error is not, so the lazy
/// values pass on a finely sampled outline too: 2^30, with the pocket within
/// +-2^29 of it, keeps every coordinate inside i32 and every product the
/// library forms inside i64. The diagram is the same, translated.
const VORONOI_ORIGIN: i32 = 1 << 30;

/// Simplification tolerance of the fast path, in integer units (one unit,
/// 1e-4 mm): consecutive segments that a single segment replaces within the
/// integer resolution are merged before the Voronoi diagram. A finely sampled
/// smooth curve loses many of its vertices there (each is a site of the
/// diagram, whose cost grows with the sites), corners and anything coarser
/// than the resolution stay. The given vertices are kept for the lobe ends
/// (`lobe_centre`).
const SIMPLIFY_TOLERANCE_UNITS: f64 = 1.0;

/// How the Voronoi diagram is computed. Both give the exact diagram of the
/// same integer input; `Upstream` (boostvoronoi's unpatched predicates, input
/// centred on 0) is the slow reference the fast path is tested against.
#[doc(hidden)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VoronoiPath {
    Fast,
    Upstream,
}

/// Sets boostvoronoi's predicate mode for this thread and restores the fast
/// mode when dropped (also on early return).
struct PredicateMode;

impl PredicateMode {
    fn set(path: VoronoiPath) -> Self {
        boostvoronoi::set_upstream_predicates(path == VoronoiPath::Upstream);
        PredicateMode
    }
}

impl Drop for PredicateMode {
    fn drop(&mut self) {
        boostvoronoi::set_upstream_predicates(false);
    }
}

/// One medial-axis branch: a chain of (x, y, r) between two nodes (branch
/// points or end points), or a closed loop (`start == end`, no branch point).
#[derive(Clone, Debug, PartialEq)]
pub struct Branch {
    pub points: Vec<[f64; 3]>,
    /// Node indices of the first and last point.
    pub start: usize,
    pub end: usize,
    /// Object angle (between the directions to the two nearest boundary
    /// points) of the first and last edge, radians. At a polygon corner it is
    /// the corner's turning angle.
    pub end_angles: [f64; 2],
}

/// A branch point (degree >= 3) or an end point (degree 1) of the medial axis.
#[derive(Clone, Debug, PartialEq)]
pub struct Node {
    pub x: f64,
    pub y: f64,
    pub r: f64,
    pub degree: usize,
}

#[derive(Clone, Debug, PartialEq)]
pub struct MedialAxis {
    pub branches: Vec<Branch>,
    pub nodes: Vec<Node>,
    /// Diameter of the largest inscribed circle, mm.
    pub dmax: f64,
    /// Centre of that circle.
    pub dmax_center: Point2,
    /// Smallest radius at a medial-axis end point: 0 at sharp convex corners of
    /// the pocket (concave for the tool), the curvature radius at the tip of a
    /// smooth lobe.
    pub min_corner_radius: f64,
}

impl MedialAxis {
    pub fn branch_points(&self) -> impl Iterator<Item = &Node> {
        self.nodes.iter().filter(|n| n.degree >= 3)
    }
    pub fn end_points(&self) -> impl Iterator<Item = &Node> {
        self.nodes.iter().filter(|n| n.degree == 1)
    }
}

#[derive(Clone, Copy, Debug)]
enum Site {
    Point(Point2),
    Segment(Point2, Point2),
}

fn sub(a: Point2, b: Point2) -> Point2 {
    [a[0] - b[0], a[1] - b[1]]
}
fn dot(a: Point2, b: Point2) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}
fn cross(a: Point2, b: Point2) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}
fn norm(a: Point2) -> f64 {
    // No overflow to guard against at these magnitudes (below 2^31): sqrt, not hypot.
    (a[0] * a[0] + a[1] * a[1]).sqrt()
}

impl Site {
    /// Nearest point of the site to `p`.
    fn foot(&self, p: Point2) -> Point2 {
        match *self {
            Site::Point(q) => q,
            Site::Segment(a, b) => {
                let d = sub(b, a);
                let l2 = dot(d, d);
                let t = if l2 > 0.0 {
                    (dot(sub(p, a), d) / l2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                [a[0] + t * d[0], a[1] + t * d[1]]
            }
        }
    }
    fn distance(&self, p: Point2) -> f64 {
        norm(sub(p, self.foot(p)))
    }
}

/// Longest run of given segments one simplified segment may replace (bounds
/// the work of `simplify_loop` on long straight runs).
const SIMPLIFY_MAX_RUN: usize = 64;

/// Indices of the vertices of the closed loop `pts` kept by simplification
/// with tolerance `tol`, in order: from each kept vertex the segment reaches as
/// far along the loop as every vertex in between stays within `tol` of it (at
/// most `SIMPLIFY_MAX_RUN` segments). Greedy furthest reach keeps fewer
/// vertices than Douglas-Peucker on a finely sampled curve, with the same
/// bound (`greedy_reach_keeps_fewer_vertices_than_douglas_peucker`). All
/// vertices if fewer than 3 would remain.
fn simplify_loop(pts: &[Point2], tol: f64) -> Vec<usize> {
    let n = pts.len();
    if n < 4 {
        return (0..n).collect();
    }
    let within = |a: usize, b: usize| {
        let chord = Site::Segment(pts[a], pts[b % n]);
        (a + 1..b).all(|k| chord.distance(pts[k]) <= tol)
    };
    let mut kept = vec![0];
    let mut a = 0;
    loop {
        let mut b = a + 1;
        while b < n && b < a + SIMPLIFY_MAX_RUN && within(a, b + 1) {
            b += 1;
        }
        if b >= n {
            break;
        }
        kept.push(b);
        a = b;
    }
    if kept.len() < 3 {
        (0..n).collect()
    } else {
        kept
    }
}

/// Boundary segments of all loops, in the scaled integer frame.
struct Boundary {
    /// Per segment: (a, b, vertex before a, vertex after b) in scaled coordinates.
    segs: Vec<(Point2, Point2, Point2, Point2)>,
    ints: Vec<[i32; 4]>,
    /// Per loop: its vertices in mm as given (unrounded, not simplified; only
    /// repeats at the integer resolution dropped).
    loops_mm: Vec<Vec<Point2>>,
    /// Per segment: its loop and the indices in `loops_mm` of its start and
    /// end vertex (more than one apart where the simplification merged).
    seg_loop: Vec<(usize, usize, usize)>,
    center: Point2,
    scale: f64,
    /// Added to the integer coordinates handed to boostvoronoi.
    origin: i32,
}

impl Boundary {
    fn new(pocket: &Pocket, path: VoronoiPath) -> Result<Self> {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in pocket.outer.iter() {
            for t in 0..2 {
                lo[t] = lo[t].min(p[t]);
                hi[t] = hi[t].max(p[t]);
            }
        }
        let center = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
        let half = 0.5 * (hi[0] - lo[0]).max(hi[1] - lo[1]);
        // Keep |coordinates| within 2^29 of the centre: with VORONOI_ORIGIN added they
        // stay inside i32 and boostvoronoi's i64 products cannot overflow.
        let scale = UNITS_PER_MM.min((1u64 << 29) as f64 / half.max(1e-9));
        let mut segs = Vec::new();
        let mut ints = Vec::new();
        let mut loops_mm = Vec::new();
        let mut seg_loop = Vec::new();
        let loops = std::iter::once(&pocket.outer).chain(pocket.holes.iter());
        for (l, poly) in loops.enumerate() {
            let mut q: Vec<[i32; 2]> = Vec::with_capacity(poly.len());
            let mut qmm: Vec<Point2> = Vec::with_capacity(poly.len());
            for p in poly {
                let x = ((p[0] - center[0]) * scale).round() as i32;
                let y = ((p[1] - center[1]) * scale).round() as i32;
                if q.last() != Some(&[x, y]) {
                    q.push([x, y]);
                    qmm.push(*p);
                }
            }
            while q.len() > 1 && q.first() == q.last() {
                q.pop();
                qmm.pop();
            }
            if q.len() < 3 {
                let field = if l == 0 {
                    "outer".to_string()
                } else {
                    format!("holes[{}]", l - 1)
                };
                return Err(Error::invalid(
                    field,
                    "loop collapses below 1e-4 mm resolution",
                ));
            }
            let keep: Vec<usize> = match path {
                VoronoiPath::Fast => {
                    let scaled: Vec<Point2> = qmm
                        .iter()
                        .map(|p| [(p[0] - center[0]) * scale, (p[1] - center[1]) * scale])
                        .collect();
                    simplify_loop(&scaled, SIMPLIFY_TOLERANCE_UNITS)
                }
                VoronoiPath::Upstream => (0..q.len()).collect(),
            };
            let n = keep.len();
            let f = |v: [i32; 2]| [v[0] as f64, v[1] as f64];
            let vertex = |i: usize| q[keep[i % n]];
            for i in 0..n {
                let (a, b, prev, next) =
                    (vertex(i), vertex(i + 1), vertex(i + n - 1), vertex(i + 2));
                segs.push((f(a), f(b), f(prev), f(next)));
                ints.push([a[0], a[1], b[0], b[1]]);
                seg_loop.push((l, keep[i], keep[(i + 1) % n]));
            }
            loops_mm.push(qmm);
        }
        Ok(Self {
            segs,
            ints,
            loops_mm,
            seg_loop,
            center,
            scale,
            origin: match path {
                VoronoiPath::Fast => VORONOI_ORIGIN,
                VoronoiPath::Upstream => 0,
            },
        })
    }

    fn to_mm(&self, p: Point2) -> Point2 {
        [
            p[0] / self.scale + self.center[0],
            p[1] / self.scale + self.center[1],
        ]
    }

    fn site(&self, index: usize, cat: SourceCategory) -> Option<Site> {
        let &(a, b, _, _) = self.segs.get(index)?;
        Some(match cat {
            SourceCategory::Segment => Site::Segment(a, b),
            SourceCategory::SegmentEnd => Site::Point(b),
            _ => Site::Point(a),
        })
    }

    /// Is a point of the cell of `site` inside the pocket? For a segment the
    /// pocket is on its left (outer CCW, holes CW); a vertex cell lies inside
    /// exactly when the vertex is reflex.
    fn inside(&self, index: usize, cat: SourceCategory, p: Point2) -> bool {
        let Some(&(a, b, prev, next)) = self.segs.get(index) else {
            return false;
        };
        match cat {
            SourceCategory::Segment => cross(sub(b, a), sub(p, a)) > 0.0,
            SourceCategory::SegmentEnd => cross(sub(b, a), sub(next, b)) < 0.0,
            _ => cross(sub(a, prev), sub(b, a)) < 0.0,
        }
    }
}

/// A kept Voronoi edge, sampled.
struct KeptEdge {
    v0: usize,
    v1: usize,
    points: Vec<[f64; 3]>,
    angle: f64,
    /// The two boundary segments it separates (None unless both sites are segments).
    segments: Option<[usize; 2]>,
}

/// Samples the edge between two Voronoi vertices separated by sites s1 and s2.
fn sample_edge(p0: Point2, p1: Point2, curved: bool, s1: Site, s2: Site, step: f64) -> Vec<Point2> {
    if curved {
        let (pt, a, b) = match (s1, s2) {
            (Site::Point(p), Site::Segment(a, b)) | (Site::Segment(a, b), Site::Point(p)) => {
                (p, a, b)
            }
            _ => return vec![p0, p1],
        };
        let len = norm(sub(b, a));
        if len <= 0.0 {
            return vec![p0, p1];
        }
        let d = [(b[0] - a[0]) / len, (b[1] - a[1]) / len];
        let mut n = [-d[1], d[0]];
        let mut hp = dot(sub(pt, a), n);
        if hp < 0.0 {
            n = [-n[0], -n[1]];
            hp = -hp;
        }
        if hp < 1e-9 {
            return vec![p0, p1];
        }
        let up = dot(sub(pt, a), d);
        let (u0, u1) = (dot(sub(p0, a), d), dot(sub(p1, a), d));
        let count = ((u1 - u0).abs() / step).ceil().clamp(1.0, 256.0) as usize;
        let mut out = Vec::with_capacity(count + 1);
        out.push(p0);
        for k in 1..count {
            let u = u0 + (u1 - u0) * k as f64 / count as f64;
            let h = ((u - up).powi(2) + hp * hp) / (2.0 * hp);
            out.push([a[0] + u * d[0] + h * n[0], a[1] + u * d[1] + h * n[1]]);
        }
        out.push(p1);
        out
    } else {
        let count = (norm(sub(p1, p0)) / step).ceil().clamp(1.0, 256.0) as usize;
        // Linear edges between two segments have linear r: two points suffice.
        let count = if matches!((s1, s2), (Site::Segment(..), Site::Segment(..))) {
            1
        } else {
            count
        };
        (0..=count)
            .map(|k| {
                let t = k as f64 / count as f64;
                [p0[0] + t * (p1[0] - p0[0]), p0[1] + t * (p1[1] - p0[1])]
            })
            .collect()
    }
}

/// Cosine of the object angle at p (the angle between the directions to the
/// two foot points); 1 where a foot is at p. The largest angle along an edge
/// is the acos of the smallest cosine: one acos per edge.
fn object_angle_cos(p: Point2, s1: Site, s2: Site) -> f64 {
    let (f1, f2) = (sub(s1.foot(p), p), sub(s2.foot(p), p));
    let (n1, n2) = (norm(f1), norm(f2));
    if n1 <= 1e-9 * (1.0 + n2) || n2 <= 1e-9 * (1.0 + n1) {
        return 1.0;
    }
    (dot(f1, f2) / (n1 * n2)).clamp(-1.0, 1.0)
}

fn voronoi_error(e: impl std::fmt::Display) -> Error {
    Error::planning(format!(
        "medial axis: the Voronoi diagram failed ({e}); is the outline self-intersecting?"
    ))
}

/// Computes the interior medial axis of `pocket`.
pub fn medial_axis(pocket: &Pocket) -> Result<MedialAxis> {
    medial_axis_with(pocket, VoronoiPath::Fast)
}

/// [`medial_axis`] with the Voronoi diagram computed the given way.
#[doc(hidden)]
pub fn medial_axis_with(pocket: &Pocket, path: VoronoiPath) -> Result<MedialAxis> {
    let bd = Boundary::new(pocket, path)?;
    let o = bd.origin;
    let diagram = voronoi_diagram(&bd, path)?;
    let step = SAMPLE_STEP_MM * bd.scale;
    let cells = diagram.cells();
    let vertices = diagram.vertices();
    let edges = diagram.edges();
    let site_of = |cell: usize| -> Option<(usize, SourceCategory, Site)> {
        let c = cells.get(cell)?;
        let (idx, cat) = c.source_index_2();
        Some((idx.usize(), cat, bd.site(idx.usize(), cat)?))
    };
    // Back to the centred frame: exact, the difference is a multiple of the coordinates' ulp.
    let (ox, oy) = (f64::from(o), f64::from(o));
    let vpos = |v: usize| -> Option<Point2> { vertices.get(v).map(|v| [v.x() - ox, v.y() - oy]) };

    let mut kept: Vec<KeptEdge> = Vec::new();
    // Largest inscribed circle over every interior Voronoi vertex (pruning-independent).
    let mut best: (f64, Point2) = (0.0, [0.0, 0.0]);
    for (i, e) in edges.iter().enumerate() {
        let Ok(twin) = e.twin() else { continue };
        if twin.usize() < i {
            continue;
        }
        let (Some(v0), Some(tw)) = (e.vertex0(), edges.get(twin.usize())) else {
            continue;
        };
        let Some(v1) = tw.vertex0() else { continue };
        let (Ok(c1), Ok(c2)) = (e.cell(), tw.cell()) else {
            continue;
        };
        let (Some((i1, k1, s1)), Some((i2, k2, s2))) = (site_of(c1.usize()), site_of(c2.usize()))
        else {
            continue;
        };
        let (Some(p0), Some(p1)) = (vpos(v0.usize()), vpos(v1.usize())) else {
            continue;
        };
        // Side test before sampling: a straight edge by its midpoint; a curved
        // (parabolic) edge lies wholly on its point site's side of the segment's
        // line, so that point decides (exactly: integer coordinates).
        let probe = match (e.is_curved(), s1, s2) {
            (true, Site::Point(q), _) | (true, _, Site::Point(q)) => q,
            _ => [0.5 * (p0[0] + p1[0]), 0.5 * (p0[1] + p1[1])],
        };
        let inside = match (s1, s2) {
            (Site::Segment(..), _) => bd.inside(i1, k1, probe),
            (_, Site::Segment(..)) => bd.inside(i2, k2, probe),
            _ => bd.inside(i1, k1, probe),
        };
        if !inside {
            continue;
        }
        let pts = sample_edge(p0, p1, e.is_curved(), s1, s2, step);
        for p in [p0, p1] {
            let r = s1.distance(p);
            if r > best.0 {
                best = (r, p);
            }
        }
        if e.is_secondary() {
            continue;
        }
        // Two-point edges also at their midpoint (longer ones have a sample there).
        let midpoint = [0.5 * (p0[0] + p1[0]), 0.5 * (p0[1] + p1[1])];
        let extra = (pts.len() <= 2).then_some(midpoint);
        let angle = pts
            .iter()
            .copied()
            .chain(extra)
            .map(|p| object_angle_cos(p, s1, s2))
            .fold(1.0, f64::min)
            .acos();
        if angle < MIN_OBJECT_ANGLE {
            continue;
        }
        let points = pts
            .iter()
            .map(|&p| {
                let q = bd.to_mm(p);
                [q[0], q[1], s1.distance(p) / bd.scale]
            })
            .collect();
        let segments =
            (k1 == SourceCategory::Segment && k2 == SourceCategory::Segment).then_some([i1, i2]);
        kept.push(KeptEdge {
            v0: v0.usize(),
            v1: v1.usize(),
            points,
            angle,
            segments,
        });
    }
    Ok(assemble(&kept, vertices.len(), best, &bd))
}

/// The Voronoi diagram of the boundary's integer segments (shifted by its
/// origin to non-negative coordinates), its predicates evaluated `path`'s way.
fn voronoi_diagram(bd: &Boundary, path: VoronoiPath) -> Result<Diagram> {
    let o = bd.origin;
    let lines: Vec<Line<i32>> = bd
        .ints
        .iter()
        .map(|&[x0, y0, x1, y1]| Line::from([x0 + o, y0 + o, x1 + o, y1 + o]))
        .collect();
    let _mode = PredicateMode::set(path);
    Builder::<i32>::default()
        .with_segments(lines.iter())
        .and_then(|b| b.build())
        .map_err(voronoi_error)
}

/// The medial axis from the kept edges (of a diagram of `vertex_count`
/// vertices) and the largest inscribed circle `best` (radius, centre in the
/// boundary's frame): branches chained, smooth ends completed, in mm.
fn assemble(
    kept: &[KeptEdge],
    vertex_count: usize,
    best: (f64, Point2),
    bd: &Boundary,
) -> MedialAxis {
    let centre = bd.to_mm(best.1);
    let rmax = best.0 / bd.scale;
    let (mut branches, end_segments, mut nodes) = chain_branches(kept, vertex_count);
    extend_smooth_ends(&mut branches, &end_segments, &mut nodes, bd);
    let min_corner_radius = corner_radii(&branches, &nodes)
        .min_by(f64::total_cmp)
        .unwrap_or(rmax);
    MedialAxis {
        branches,
        nodes,
        dmax: 2.0 * rmax,
        dmax_center: centre,
        min_corner_radius,
    }
}

/// Corner radius at every end point: its r when the axis ends inside (the tip
/// of a smooth lobe); at a polygon vertex 0 when the vertex is a sharp corner,
/// else the radius at the other end of its branch.
fn corner_radii<'a>(branches: &'a [Branch], nodes: &'a [Node]) -> impl Iterator<Item = f64> + 'a {
    let tiny = 1e-6;
    branches.iter().flat_map(move |b| {
        let ends = [
            (b.start, b.end, b.end_angles[0]),
            (b.end, b.start, b.end_angles[1]),
        ];
        ends.into_iter().filter_map(move |(here, there, angle)| {
            let n = nodes.get(here)?;
            if n.degree != 1 {
                return None;
            }
            if n.r > tiny {
                return Some(n.r);
            }
            if angle >= SHARP_CORNER_TURN {
                return Some(0.0);
            }
            nodes.get(there).map(|m| m.r)
        })
    })
}

/// The boundary segments either side of a branch's first and last edge.
type EndSegments = [Option<[usize; 2]>; 2];

/// Joins kept edges through degree-2 vertices into branches.
fn chain_branches(
    kept: &[KeptEdge],
    vertex_count: usize,
) -> (Vec<Branch>, Vec<EndSegments>, Vec<Node>) {
    let mut incident: Vec<Vec<usize>> = vec![Vec::new(); vertex_count];
    for (k, e) in kept.iter().enumerate() {
        if let Some(v) = incident.get_mut(e.v0) {
            v.push(k);
        }
        if let Some(v) = incident.get_mut(e.v1) {
            v.push(k);
        }
    }
    let mut node_of: Vec<Option<usize>> = vec![None; vertex_count];
    let mut nodes: Vec<Node> = Vec::new();
    let mut used = vec![false; kept.len()];
    let mut branches = Vec::new();
    let mut end_segments: Vec<EndSegments> = Vec::new();
    let mut node_id = |v: usize, p: [f64; 3], nodes: &mut Vec<Node>, deg: usize| -> usize {
        *node_of[v].get_or_insert_with(|| {
            nodes.push(Node {
                x: p[0],
                y: p[1],
                r: p[2],
                degree: deg,
            });
            nodes.len() - 1
        })
    };
    let walk = |v: usize, k: usize, used: &mut Vec<bool>| walk_branch(kept, &incident, v, k, used);
    for v in 0..vertex_count {
        if incident[v].is_empty() || incident[v].len() == 2 {
            continue;
        }
        for idx in 0..incident[v].len() {
            let k = incident[v][idx];
            if used[k] {
                continue;
            }
            let (pts, w, end_angles, ends) = walk(v, k, &mut used);
            let (Some(&first), Some(&last)) = (pts.first(), pts.last()) else {
                continue;
            };
            let a = node_id(v, first, &mut nodes, incident[v].len());
            let b = node_id(w, last, &mut nodes, incident[w].len());
            branches.push(Branch {
                points: pts,
                start: a,
                end: b,
                end_angles,
            });
            end_segments.push(ends);
        }
    }
    // Closed loops with no branch point (e.g. around a hole in an annulus).
    for k in 0..kept.len() {
        if used[k] {
            continue;
        }
        let v = kept[k].v0;
        let (pts, _, end_angles, ends) = walk(v, k, &mut used);
        let Some(&first) = pts.first() else { continue };
        let a = node_id(v, first, &mut nodes, 2);
        branches.push(Branch {
            points: pts,
            start: a,
            end: a,
            end_angles,
        });
        end_segments.push(ends);
    }
    (branches, end_segments, nodes)
}

/// A branch walked from vertex `start_v` along kept edge `first`, through
/// degree-2 vertices (`incident`: the kept edges at each vertex), marking the
/// edges `used`: its points, the vertex it ends at, the object angles of its
/// first and last edge, and their boundary segments.
fn walk_branch(
    kept: &[KeptEdge],
    incident: &[Vec<usize>],
    start_v: usize,
    first: usize,
    used: &mut [bool],
) -> (Vec<[f64; 3]>, usize, [f64; 2], EndSegments) {
    let mut pts: Vec<[f64; 3]> = Vec::new();
    let (mut v, mut k) = (start_v, first);
    let first_angle = kept[first].angle;
    loop {
        used[k] = true;
        let e = &kept[k];
        let angles = [first_angle, e.angle];
        let forward = e.v0 == v;
        let seq: Vec<[f64; 3]> = if forward {
            e.points.clone()
        } else {
            e.points.iter().rev().copied().collect()
        };
        let skip = usize::from(!pts.is_empty());
        pts.extend(seq.into_iter().skip(skip));
        v = if forward { e.v1 } else { e.v0 };
        let ends = [kept[first].segments, e.segments];
        if incident[v].len() != 2 || v == start_v {
            return (pts, v, angles, ends);
        }
        match incident[v].iter().copied().find(|&j| !used[j]) {
            Some(j) => k = j,
            None => return (pts, v, angles, ends),
        }
    }
}

/// Completes the branches that stop inside the pocket at a smooth lobe.
///
/// A polygonised smooth lobe has no medial-axis end of its own: the axis of
/// the polygon runs on into the fan of tiny branches towards its vertices,
/// which the object-angle rule prunes, so the kept axis stops where the
/// object angle falls to [`MIN_OBJECT_ANGLE`], short of the true end (0.05 mm
/// short on the 50 x 30 ellipse). The true end is the centre of curvature at
/// the lobe's curvature maximum, which lies on the boundary between the two
/// segments of the last kept edge: it is found there from the unrounded
/// vertices (circle through each vertex and its neighbours, the maximum
/// refined by a parabola), and kept when it continues the branch (r no larger,
/// not further than r away).
fn extend_smooth_ends(
    branches: &mut [Branch],
    end_segments: &[EndSegments],
    nodes: &mut [Node],
    bd: &Boundary,
) {
    let mut done = vec![false; nodes.len()];
    for (b, ends) in branches.iter_mut().zip(end_segments) {
        if b.start == b.end {
            continue;
        }
        let mut tips = [None, None];
        for (side, node) in [b.start, b.end].into_iter().enumerate() {
            let Some(n) = nodes.get(node) else { continue };
            // Ends on a polygon vertex (r = 0) are true corners.
            if n.degree != 1 || n.r <= 1e-6 || done.get(node).copied().unwrap_or(true) {
                continue;
            }
            let Some(tip) = ends[side].and_then(|segs| lobe_centre(bd, segs)) else {
                continue;
            };
            let gap = (tip[0] - n.x).hypot(tip[1] - n.y);
            if tip[2] <= n.r + 1e-9 && tip[2] > 0.0 && gap <= n.r {
                tips[side] = Some((node, tip));
            }
        }
        for (side, t) in tips.into_iter().enumerate() {
            let Some((node, tip)) = t else { continue };
            if side == 0 {
                b.points.insert(0, tip);
            } else {
                b.points.push(tip);
            }
            if let Some(n) = nodes.get_mut(node) {
                (n.x, n.y, n.r) = (tip[0], tip[1], tip[2]);
            }
            if let Some(d) = done.get_mut(node) {
                *d = true;
            }
        }
    }
}

/// Centre and radius of curvature (x, y, r) at the curvature maximum of the
/// boundary between segments `segs` (same loop, the shorter way round).
fn lobe_centre(bd: &Boundary, segs: [usize; 2]) -> Option<[f64; 3]> {
    let (&(l0, a, a_end), &(l1, b, b_end)) = (bd.seg_loop.get(segs[0])?, bd.seg_loop.get(segs[1])?);
    let verts = bd.loops_mm.get(l0)?;
    let n = verts.len();
    if l0 != l1 || n < 3 {
        return None;
    }
    // The given vertices strictly after the first given segment inside
    // segment a up to the start of the last one inside segment b (or the
    // other way round, whichever is shorter): with no simplification, the
    // vertices after segment a up to the start of segment b.
    let fwd = (b_end + n - 1 - a) % n;
    let bwd = (a_end + n - 1 - b) % n;
    let (from, count) = if fwd <= bwd { (a, fwd) } else { (b, bwd) };
    if count == 0 || count > n / 2 {
        return None;
    }
    let vertex = |k: usize| verts.get(k % n).copied();
    // Circle through vertices k-1, k, k+1: (centre, curvature); None unless turning left.
    let circle = |k: usize| -> Option<(Point2, f64)> {
        let (a, b, c) = (vertex(k + n - 1)?, vertex(k)?, vertex(k + 1)?);
        let (ab, ac) = (sub(b, a), sub(c, a));
        let d = 2.0 * cross(ab, ac);
        if d <= 0.0 {
            return None;
        }
        let (l1, l2) = (dot(ab, ab), dot(ac, ac));
        let centre = [
            a[0] + (ac[1] * l1 - ab[1] * l2) / d,
            a[1] + (ab[0] * l2 - ac[0] * l1) / d,
        ];
        Some((centre, 1.0 / norm(sub(centre, b))))
    };
    let (mut best, mut best_k) = (0.0, None);
    for m in 1..=count {
        let k = from + m;
        if let Some((_, kappa)) = circle(k) {
            if kappa > best {
                best = kappa;
                best_k = Some(k);
            }
        }
    }
    let k = best_k?;
    let (c0, k0) = circle(k)?;
    let (cm, km) = circle(k + n - 1).unwrap_or((c0, k0));
    let (cp, kp) = circle(k + 1).unwrap_or((c0, k0));
    // Parabola through the three curvatures: offset of the maximum in [-1/2, 1/2].
    let den = km - 2.0 * k0 + kp;
    let t = if den < 0.0 {
        (0.5 * (km - kp) / den).clamp(-0.5, 0.5)
    } else {
        0.0
    };
    let lerp = |i: usize| {
        cm[i] * 0.5 * t * (t - 1.0) + c0[i] * (1.0 - t * t) + cp[i] * 0.5 * t * (t + 1.0)
    };
    let kappa = km * 0.5 * t * (t - 1.0) + k0 * (1.0 - t * t) + kp * 0.5 * t * (t + 1.0);
    Some([lerp(0), lerp(1), 1.0 / kappa])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_has_one_branch_point_and_four_corner_branches() {
        let p = Pocket::new(&[[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]], &[]).unwrap();
        let ma = medial_axis(&p).unwrap();
        assert!((ma.dmax - 10.0).abs() < 1e-6);
        assert_eq!(ma.end_points().count(), 4);
        assert!(ma.min_corner_radius < 1e-9);
    }

    #[test]
    fn rounded_corners_give_their_radius() {
        // 40 x 30 rectangle with corners rounded to radius 3, 8 segments per quarter.
        let (w, h, rc) = (40.0, 30.0, 3.0);
        let mut outer = Vec::new();
        for (cx, cy, a0) in [
            (w - rc, rc, -90.0),
            (w - rc, h - rc, 0.0),
            (rc, h - rc, 90.0),
            (rc, rc, 180.0),
        ] {
            for k in 0..=8 {
                let t = (a0 + 90.0 * k as f64 / 8.0f64).to_radians();
                outer.push([cx + rc * t.cos(), cy + rc * t.sin()]);
            }
        }
        let p = Pocket::new(&outer, &[]).unwrap();
        let ma = medial_axis(&p).unwrap();
        let apothem = rc * (std::f64::consts::PI / 32.0).cos();
        assert!(
            (ma.min_corner_radius - apothem).abs() < 1e-3,
            "{}",
            ma.min_corner_radius
        );
        assert!((ma.dmax - 30.0).abs() < 1e-6);
    }

    #[test]
    fn reflex_vertex_gives_parabolic_branch() {
        // L-shape: the reflex corner at (10, 10) faces the far walls.
        let outer = [
            [0.0, 0.0],
            [30.0, 0.0],
            [30.0, 10.0],
            [10.0, 10.0],
            [10.0, 30.0],
            [0.0, 30.0],
        ];
        let p = Pocket::new(&outer, &[]).unwrap();
        let ma = medial_axis(&p).unwrap();
        // Every medial point is equidistant from the boundary at its radius: check against brute force.
        let segs: Vec<(Point2, Point2)> = (0..6).map(|i| (outer[i], outer[(i + 1) % 6])).collect();
        for b in &ma.branches {
            for q in &b.points {
                let d = segs
                    .iter()
                    .map(|&(a, c)| Site::Segment(a, c).distance([q[0], q[1]]))
                    .fold(f64::INFINITY, f64::min);
                assert!((d - q[2]).abs() < 1e-3, "r {} vs distance {}", q[2], d);
            }
        }
    }

    /// Douglas-Peucker on the closed loop `pts`, split at vertex 0 and the
    /// vertex farthest from it: how many vertices it keeps within `tol`.
    fn douglas_peucker_kept(pts: &[Point2], tol: f64) -> usize {
        fn split(pts: &[Point2], a: usize, b: usize, tol: f64) -> usize {
            let chord = Site::Segment(pts[a], pts[b % pts.len()]);
            let far = (a + 1..b)
                .max_by(|&i, &j| chord.distance(pts[i]).total_cmp(&chord.distance(pts[j])));
            match far {
                Some(k) if chord.distance(pts[k]) > tol => {
                    1 + split(pts, a, k, tol) + split(pts, k, b, tol)
                }
                _ => 0,
            }
        }
        let far = (1..pts.len())
            .max_by(|&i, &j| norm(sub(pts[i], pts[0])).total_cmp(&norm(sub(pts[j], pts[0]))))
            .unwrap();
        2 + split(pts, 0, far, tol) + split(pts, far, pts.len(), tol)
    }

    /// The fast path's simplification of the 10 000-vertex wavy outline of
    /// the medial-axis benchmark (benches/pocket_mat.rs) in the scaled
    /// integer frame: greedy furthest reach keeps every dropped vertex
    /// within the tolerance of its segment, keeps about 7 750 of the 10 000
    /// vertices, and about 4 % fewer than Douglas-Peucker with the same
    /// tolerance (7 746 against 8 040).
    #[test]
    fn greedy_reach_keeps_fewer_vertices_than_douglas_peucker() {
        let n = 10_000;
        let pts: Vec<Point2> = (0..n)
            .map(|i| {
                let t = std::f64::consts::TAU * i as f64 / n as f64;
                let r = 50.0 + 10.0 * (7.0 * t).sin() + 3.0 * (23.0 * t).sin();
                [r * t.cos() * UNITS_PER_MM, r * t.sin() * UNITS_PER_MM]
            })
            .collect();
        let kept = simplify_loop(&pts, SIMPLIFY_TOLERANCE_UNITS);
        for w in kept
            .windows(2)
            .chain(std::iter::once(&[kept[kept.len() - 1], n][..]))
        {
            let chord = Site::Segment(pts[w[0]], pts[w[1] % n]);
            for (k, p) in pts.iter().enumerate().take(w[1]).skip(w[0] + 1) {
                assert!(chord.distance(*p) <= SIMPLIFY_TOLERANCE_UNITS, "vertex {k}");
            }
        }
        let dp = douglas_peucker_kept(&pts, SIMPLIFY_TOLERANCE_UNITS);
        let fewer = 1.0 - kept.len() as f64 / dp as f64;
        eprintln!(
            "greedy {} of {n}, Douglas-Peucker {dp}: {:.1} % fewer",
            kept.len(),
            100.0 * fewer
        );
        assert!((7_650..7_850).contains(&kept.len()), "{} kept", kept.len());
        assert!((0.03..0.05).contains(&fewer), "{} against {dp}", kept.len());
    }
}
