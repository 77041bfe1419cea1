//! Plane/surface intersection curves (the section curves of iso-planar paths;
//! docs/methods.md, "Plane sections").
//!
//! Marching squares on a parameter grid of the signed distance
//! d(u, v) = (S(u, v) - p) . n, with every crossing on a grid edge solved to
//! rounding by a safeguarded secant (Illinois) search, and segments refined by
//! Newton projection onto d = 0 until no chord is longer than `max_segment`.
//! Crossing points are joined into polylines through shared grid edges.
//!
//! Output order is deterministic: open curves first (by the grid edge they
//! start on), then closed ones; every curve runs in the direction
//! n_plane x n_surface (for a horizontal section of a surface facing +z with a
//! plane normal +y, that is +x).

use super::numeric::Bracket;
use super::nurbs::NurbsSurface;
use nalgebra::{Point3, Vector2, Vector3};
use std::collections::BTreeMap;

/// A plane through `point` with unit `normal`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    pub point: Point3<f64>,
    pub normal: Vector3<f64>,
}

impl Plane {
    /// Normalises `normal`; `None` for a zero or non-finite normal.
    pub fn new(point: Point3<f64>, normal: Vector3<f64>) -> Option<Self> {
        let n = normal.try_normalize(1e-300)?;
        (n.iter().all(|c| c.is_finite()) && point.iter().all(|c| c.is_finite()))
            .then_some(Self { point, normal: n })
    }
    /// Signed distance of `q` from the plane (positive on the normal's side).
    pub fn distance(&self, q: &Point3<f64>) -> f64 {
        (q - self.point).dot(&self.normal)
    }
}

/// One intersection curve: matching parameter and space polylines.
#[derive(Clone, Debug, PartialEq)]
pub struct SectionCurve {
    pub uv: Vec<[f64; 2]>,
    pub xyz: Vec<[f64; 3]>,
    /// The curve is a loop (first point not repeated at the end).
    pub closed: bool,
}

impl SectionCurve {
    /// Length of the space polyline, mm (including the closing chord of a loop).
    pub fn length(&self) -> f64 {
        let d = |a: &[f64; 3], b: &[f64; 3]| {
            ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
        };
        let open: f64 = self.xyz.windows(2).map(|w| d(&w[0], &w[1])).sum();
        match (self.closed, self.xyz.first(), self.xyz.last()) {
            (true, Some(a), Some(b)) => open + d(b, a),
            _ => open,
        }
    }
}

/// Sampling of the intersection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SectionOptions {
    /// Grid cells along u and v. Features smaller than a cell may be missed.
    pub cells_u: usize,
    pub cells_v: usize,
    /// Longest chord between consecutive output points, mm.
    pub max_segment: f64,
}

impl SectionOptions {
    /// Defaults for `surface`: 8 cells per knot span (at least 64) per direction, chords <= 2 mm.
    pub fn for_surface(surface: &NurbsSurface) -> Self {
        let cells = |k: &[f64]| (k.windows(2).filter(|w| w[1] > w[0]).count() * 8).clamp(64, 1024);
        Self {
            cells_u: cells(surface.knots_u()),
            cells_v: cells(surface.knots_v()),
            max_segment: 2.0,
        }
    }
}

/// Grid edge id: horizontal edges (along u) from vertex (i, j) are `2 (i (nv + 1) + j)`,
/// vertical ones (along v) `+ 1`.
type EdgeId = usize;

/// All intersection curves of `surface` with `plane`: signed distances on a
/// grid, the crossing on every grid edge with a sign change, marching squares
/// to link them cell by cell, and the links chained into curves.
pub fn intersect_plane(
    surface: &NurbsSurface,
    plane: &Plane,
    options: &SectionOptions,
) -> Vec<SectionCurve> {
    let grid = Grid::new(surface, plane, options);
    let crossing = grid.edge_crossings();
    let links = grid.cell_links(&crossing);
    let max_seg = if options.max_segment > 0.0 {
        options.max_segment
    } else {
        f64::INFINITY
    };
    chains(&links)
        .into_iter()
        .map(|(chain, closed)| {
            let uv: Vec<Vector2<f64>> = chain
                .iter()
                .filter_map(|e| crossing.get(e).copied())
                .collect();
            build_curve(surface, plane, uv, closed, max_seg)
        })
        .collect()
}

/// The signed distance to the plane on a grid over the parameter domain.
struct Grid<'a> {
    surface: &'a NurbsSurface,
    plane: &'a Plane,
    nu: usize,
    nv: usize,
    u: (f64, f64),
    v: (f64, f64),
    /// Values at the grid vertices, row i = u index.
    vals: Vec<f64>,
}

impl<'a> Grid<'a> {
    fn new(surface: &'a NurbsSurface, plane: &'a Plane, options: &SectionOptions) -> Self {
        let (nu, nv) = (options.cells_u.max(1), options.cells_v.max(1));
        let (u, v) = surface.domain();
        let mut grid = Self {
            surface,
            plane,
            nu,
            nv,
            u,
            v,
            vals: Vec::new(),
        };
        grid.vals = (0..=nu)
            .flat_map(|i| (0..=nv).map(move |j| (i, j)))
            .map(|(i, j)| grid.dist(grid.uat(i), grid.vat(j)))
            .collect();
        grid
    }

    fn uat(&self, i: usize) -> f64 {
        self.u.0 + (self.u.1 - self.u.0) * i as f64 / self.nu as f64
    }

    fn vat(&self, j: usize) -> f64 {
        self.v.0 + (self.v.1 - self.v.0) * j as f64 / self.nv as f64
    }

    fn dist(&self, u: f64, v: f64) -> f64 {
        self.plane.distance(&self.surface.point(u, v))
    }

    fn val(&self, i: usize, j: usize) -> f64 {
        self.vals[i * (self.nv + 1) + j]
    }

    /// (i, j) -> (i + 1, j)
    fn edge_u(&self, i: usize, j: usize) -> EdgeId {
        2 * (i * (self.nv + 1) + j)
    }

    /// (i, j) -> (i, j + 1)
    fn edge_v(&self, i: usize, j: usize) -> EdgeId {
        2 * (i * (self.nv + 1) + j) + 1
    }

    /// The crossing point on every grid edge with a sign change (zero counts
    /// as positive, so that every crossing is a strict sign change).
    fn edge_crossings(&self) -> BTreeMap<EdgeId, Vector2<f64>> {
        let pos = |x: f64| x >= 0.0;
        let mut crossing = BTreeMap::new();
        for i in 0..=self.nu {
            for j in 0..=self.nv {
                if i < self.nu && pos(self.val(i, j)) != pos(self.val(i + 1, j)) {
                    let t = root_on_edge(
                        |u| self.dist(u, self.vat(j)),
                        self.uat(i),
                        self.uat(i + 1),
                        self.val(i, j),
                        self.val(i + 1, j),
                    );
                    crossing.insert(self.edge_u(i, j), Vector2::new(t, self.vat(j)));
                }
                if j < self.nv && pos(self.val(i, j)) != pos(self.val(i, j + 1)) {
                    let t = root_on_edge(
                        |v| self.dist(self.uat(i), v),
                        self.vat(j),
                        self.vat(j + 1),
                        self.val(i, j),
                        self.val(i, j + 1),
                    );
                    crossing.insert(self.edge_v(i, j), Vector2::new(self.uat(i), t));
                }
            }
        }
        crossing
    }

    /// Marching squares: each cell links its crossed edges in pairs; a saddle
    /// cell (four crossings) is decided by the value at its centre.
    fn cell_links(
        &self,
        crossing: &BTreeMap<EdgeId, Vector2<f64>>,
    ) -> BTreeMap<EdgeId, Vec<EdgeId>> {
        let pos = |x: f64| x >= 0.0;
        let mut links: BTreeMap<EdgeId, Vec<EdgeId>> = BTreeMap::new();
        for i in 0..self.nu {
            for j in 0..self.nv {
                // Edges in counter-clockwise order round the cell: bottom, right, top, left.
                let edges = [
                    self.edge_u(i, j),
                    self.edge_v(i + 1, j),
                    self.edge_u(i, j + 1),
                    self.edge_v(i, j),
                ];
                let crossed: Vec<EdgeId> = edges
                    .iter()
                    .copied()
                    .filter(|e| crossing.contains_key(e))
                    .collect();
                let pairs: Vec<(EdgeId, EdgeId)> = match crossed.len() {
                    2 => vec![(crossed[0], crossed[1])],
                    4 => {
                        let centre = pos(self.dist(
                            0.5 * (self.uat(i) + self.uat(i + 1)),
                            0.5 * (self.vat(j) + self.vat(j + 1)),
                        ));
                        if centre == pos(self.val(i, j)) {
                            // The corner (i, j) region connects through the centre: cut off the other two corners.
                            vec![(edges[0], edges[1]), (edges[2], edges[3])]
                        } else {
                            vec![(edges[3], edges[0]), (edges[1], edges[2])]
                        }
                    }
                    _ => vec![],
                };
                for (a, b) in pairs {
                    links.entry(a).or_default().push(b);
                    links.entry(b).or_default().push(a);
                }
            }
        }
        links
    }
}

/// Chains of linked edges: first from edges with one link (curves that end on
/// the boundary), then the loops; `true` marks a closed chain.
fn chains(links: &BTreeMap<EdgeId, Vec<EdgeId>>) -> Vec<(Vec<EdgeId>, bool)> {
    let mut used: BTreeMap<EdgeId, bool> = links.keys().map(|&e| (e, false)).collect();
    let mut chains: Vec<(Vec<EdgeId>, bool)> = Vec::new();
    let starts: Vec<EdgeId> = links
        .iter()
        .filter(|(_, l)| l.len() == 1)
        .map(|(&e, _)| e)
        .collect();
    let loop_starts: Vec<EdgeId> = links.keys().copied().collect();
    for (start, closed) in starts
        .into_iter()
        .map(|s| (s, false))
        .chain(loop_starts.into_iter().map(|s| (s, true)))
    {
        if used.get(&start).copied().unwrap_or(true) {
            continue;
        }
        let mut chain = vec![start];
        used.insert(start, true);
        let mut current = start;
        loop {
            let next = links.get(&current).and_then(|l| {
                l.iter()
                    .copied()
                    .find(|e| !used.get(e).copied().unwrap_or(true))
            });
            match next {
                Some(n) => {
                    used.insert(n, true);
                    chain.push(n);
                    current = n;
                }
                None => break,
            }
        }
        if chain.len() >= 2 {
            chains.push((chain, closed));
        }
    }
    chains
}

/// Root of `f` on [a, b] with f(a) = fa, f(b) = fb of opposite signs, to a
/// relative 1e-15: every crossing is solved on its grid edge to round-off
/// (docs/methods.md, "Plane sections" and "One root finder").
fn root_on_edge(f: impl Fn(f64) -> f64, a: f64, b: f64, fa: f64, fb: f64) -> f64 {
    if fa == 0.0 {
        return a;
    }
    let mut br = Bracket::new(a, fa, b, fb);
    for _ in 0..100 {
        let c = br.trial();
        let fc = f(c);
        let (lo, hi) = (br.neg, br.pos);
        if fc == 0.0 || (hi - lo).abs() <= 1e-15 * (lo.abs() + hi.abs()).max(1e-300) {
            return c;
        }
        br.narrow(c, fc);
    }
    br.mid()
}

/// Newton projection of `uv` onto d = 0 along the parameter gradient of d, kept in the domain.
pub(crate) fn project_to_plane(
    surface: &NurbsSurface,
    plane: &Plane,
    uv: Vector2<f64>,
) -> Vector2<f64> {
    let mut x = uv;
    for _ in 0..20 {
        let d = surface.derivs(x.x, x.y);
        let f = plane.distance(&d.p);
        let g = Vector2::new(d.su.dot(&plane.normal), d.sv.dot(&plane.normal));
        let gg = g.norm_squared();
        if gg <= 0.0 || !gg.is_finite() {
            break;
        }
        let step = -g * (f / gg);
        let (u, v) = surface.clamp_uv(x.x + step.x, x.y + step.y);
        let moved = (Vector2::new(u, v) - x).norm();
        x = Vector2::new(u, v);
        if moved <= 1e-15 * (1.0 + x.norm()) {
            break;
        }
    }
    x
}

fn build_curve(
    surface: &NurbsSurface,
    plane: &Plane,
    uv: Vec<Vector2<f64>>,
    closed: bool,
    max_seg: f64,
) -> SectionCurve {
    // Refine: split chords longer than max_seg at Newton-projected parameter midpoints.
    let mut pts: Vec<(Vector2<f64>, Point3<f64>)> = Vec::with_capacity(uv.len());
    let n = uv.len();
    let seg_count = if closed { n } else { n.saturating_sub(1) };
    let eval = |x: Vector2<f64>| (x, surface.point(x.x, x.y));
    for k in 0..n {
        let a = eval(uv[k]);
        pts.push(a);
        if k < seg_count {
            let b = eval(uv[(k + 1) % n]);
            refine(surface, plane, a, b, max_seg, 0, &mut pts);
        }
    }
    // Orient along n_plane x n_surface (majority vote over the segments).
    let mut vote = 0.0;
    for w in pts.windows(2) {
        let mid = 0.5 * (w[0].0 + w[1].0);
        if let Some(ns) = surface.normal(mid.x, mid.y) {
            vote += plane.normal.cross(&ns).dot(&(w[1].1 - w[0].1));
        }
    }
    if vote < 0.0 {
        pts.reverse();
        if closed && !pts.is_empty() {
            // Keep the same first point for loops.
            pts.rotate_right(1);
        }
    }
    SectionCurve {
        uv: pts.iter().map(|(x, _)| [x.x, x.y]).collect(),
        xyz: pts.iter().map(|(_, p)| [p.x, p.y, p.z]).collect(),
        closed,
    }
}

/// Inserts points strictly between `a` and `b` (not `b` itself) until chords are <= max_seg.
fn refine(
    surface: &NurbsSurface,
    plane: &Plane,
    a: (Vector2<f64>, Point3<f64>),
    b: (Vector2<f64>, Point3<f64>),
    max_seg: f64,
    depth: usize,
    out: &mut Vec<(Vector2<f64>, Point3<f64>)>,
) {
    if depth >= 16 || (b.1 - a.1).norm() <= max_seg {
        return;
    }
    let mid = project_to_plane(surface, plane, 0.5 * (a.0 + b.0));
    let m = (mid, surface.point(mid.x, mid.y));
    refine(surface, plane, a, m, max_seg, depth + 1, out);
    out.push(m);
    refine(surface, plane, m, b, max_seg, depth + 1, out);
}
