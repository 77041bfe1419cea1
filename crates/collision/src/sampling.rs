//! Adaptive sampling of a face on (u, v), each sample with a cover radius: a
//! ball round the sample that contains every point of the face in its cell.
//!
//! The domain is cut into a grid of root cells, and each cell is split in u
//! and/or v (quadtree or binary splits) while its extent along that direction
//! exceeds the spacing or its second-order term exceeds the chord tolerance.
//! A leaf cell [uc - a, uc + a] x [vc - b, vc + b] gets one sample at its centre
//! c with the cover radius (Taylor's theorem to second order about c):
//!
//!   rho = |S_u(c)| a + |S_v(c)| b + (M_uu a^2 + 2 M_uv a b + M_vv b^2) / 2
//!
//! M_xy bounds |S_xy| over the cell: the largest of |S_xy| at the centre and
//! the four corners times `curvature_safety`. That is the only estimate in
//! the certified bounds (docs/methods.md, "Collision checking"): second
//! derivatives that grow by more than that factor inside one leaf cell would
//! break it; leaf cells are small against the spacing and the chord
//! tolerance, where NURBS derivatives are nearly polynomial of low degree.
//!
//! Trim: a leaf whose centre and corners are all on the face is an interior
//! leaf (a hole smaller than the cell is covered as if it were material: safe
//! for a collision check). A leaf partly on the face is split down to the
//! boundary spacing, then sampled at its first probe on the face (a 4 x 4
//! grid), with the cover radius grown by that probe's distance from the
//! centre so that the ball still holds the whole cell. A leaf none of whose
//! 21 probes is on the face is dropped: pieces of the face narrower than a
//! quarter of the boundary spacing (in parameter units) are not covered.

use crate::error::{positive, Error, Result};
use crate::face::{Face, FaceDerivs};
use nalgebra::Vector3;

/// How densely faces are sampled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SamplingOptions {
    /// Largest extent of a leaf cell along u and along v on the surface, mm.
    pub spacing: f64,
    /// Largest second-order term of a leaf's cover radius, mm.
    pub chord_tolerance: f64,
    /// Leaf cells crossed by the trim are split down to this extent, mm.
    pub boundary_spacing: f64,
    /// Root cells per direction before any split.
    pub root_cells: usize,
    /// Factor on the largest |S_uu|, |S_uv|, |S_vv| seen at a leaf's centre
    /// and corners, taken as their bound over the leaf.
    pub curvature_safety: f64,
    /// A face needing more samples than this is refused (a spacing far too
    /// fine for the face, or a face with a wild parametrisation).
    pub max_samples_per_face: usize,
    /// Threads for the sampling (0: the machine's parallelism); the samples
    /// are the same on any count.
    pub threads: usize,
}

impl SamplingOptions {
    /// Defaults for a cutter of radius `radius`: spacing R/4 within
    /// [0.1, 2] mm, chord tolerance spacing/20, boundary spacing spacing/4.
    pub fn for_cutter_radius(radius: f64) -> Self {
        let spacing = (0.25 * radius).clamp(0.1, 2.0);
        Self {
            spacing,
            chord_tolerance: spacing / 20.0,
            boundary_spacing: spacing / 4.0,
            root_cells: 4,
            curvature_safety: 2.0,
            max_samples_per_face: 4_000_000,
            threads: 0,
        }
    }

    pub fn validate(&self) -> Result<()> {
        positive("spacing", self.spacing)?;
        positive("chord_tolerance", self.chord_tolerance)?;
        positive("boundary_spacing", self.boundary_spacing)?;
        if self.root_cells == 0 || self.root_cells > 4096 {
            return Err(Error::invalid(
                "root_cells",
                format!("must lie in 1..=4096, got {}", self.root_cells),
            ));
        }
        if !(self.curvature_safety >= 1.0 && self.curvature_safety.is_finite()) {
            return Err(Error::invalid(
                "curvature_safety",
                format!(
                    "must be finite and at least 1, got {}",
                    self.curvature_safety
                ),
            ));
        }
        if self.max_samples_per_face == 0 {
            return Err(Error::invalid("max_samples_per_face", "must be positive"));
        }
        Ok(())
    }
}

/// A point of a face with the radius of a ball round it that holds its cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub point: Vector3<f64>,
    pub cover: f64,
    pub face: u32,
    pub u: f64,
    pub v: f64,
}

/// Deepest splitting per direction (cells of 2^-40 of a root cell).
const MAX_DEPTH: u32 = 40;

/// Probes per direction in a boundary leaf.
const PROBES: usize = 4;

struct Cell {
    uc: f64,
    vc: f64,
    a: f64,
    b: f64,
    depth_u: u32,
    depth_v: u32,
    /// Split down to the boundary spacing (the trim crosses an ancestor leaf).
    boundary: bool,
}

/// Samples of one root cell of face `face_id`, depth first (deterministic).
pub(crate) fn sample_root_cell(
    face: &dyn Face,
    face_id: u32,
    root: (usize, usize),
    opts: &SamplingOptions,
    out: &mut Vec<Sample>,
) -> Result<()> {
    let ([u0, u1], [v0, v1]) = face.domain();
    let n = opts.root_cells as f64;
    let (du, dv) = ((u1 - u0) / n, (v1 - v0) / n);
    let mut stack = vec![Cell {
        uc: u0 + (root.0 as f64 + 0.5) * du,
        vc: v0 + (root.1 as f64 + 0.5) * dv,
        a: 0.5 * du,
        b: 0.5 * dv,
        depth_u: 0,
        depth_v: 0,
        boundary: false,
    }];
    while let Some(cell) = stack.pop() {
        let c = eval(face, face_id, cell.uc, cell.vc)?;
        let (split_u, split_v) = geometric_split(&c, &cell, opts, None);
        if split_u || split_v {
            push_children(&mut stack, cell, split_u, split_v);
            continue;
        }
        leaf(face, face_id, cell, &c, opts, &mut stack, out)?;
        if out.len() > opts.max_samples_per_face {
            return Err(Error::invalid(
                format!("faces[{face_id}]"),
                format!(
                    "needs more than {} samples at a spacing of {} mm",
                    opts.max_samples_per_face, opts.spacing
                ),
            ));
        }
    }
    Ok(())
}

/// A leaf of the geometric split: classified against the trim, sampled,
/// dropped, or split further at the boundary (children pushed on `stack`).
fn leaf(
    face: &dyn Face,
    face_id: u32,
    cell: Cell,
    c: &FaceDerivs,
    opts: &SamplingOptions,
    stack: &mut Vec<Cell>,
    out: &mut Vec<Sample>,
) -> Result<()> {
    let corners = [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)];
    let corner_uv = corners.map(|(su, sv)| (cell.uc + su * cell.a, cell.vc + sv * cell.b));
    let centre_in = face.inside(cell.uc, cell.vc);
    let corners_in = corner_uv.map(|(u, v)| face.inside(u, v));
    let all_in = centre_in && corners_in.iter().all(|&x| x);
    let mut derivs = [*c; 5];
    for (k, &(u, v)) in corner_uv.iter().enumerate() {
        derivs[k + 1] = eval(face, face_id, u, v)?;
    }
    let rho = cover_radius(&derivs, cell.a, cell.b, opts.curvature_safety);
    if all_in {
        out.push(sample(c.p, rho, face_id, cell.uc, cell.vc));
        return Ok(());
    }
    let Some((u, v)) = first_probe_on_face(face, &cell, centre_in, &corners_in, &corner_uv) else {
        return Ok(());
    };
    let (split_u, split_v) = geometric_split(c, &cell, opts, Some(opts.boundary_spacing));
    if split_u || split_v {
        let mut cell = cell;
        cell.boundary = true;
        push_children(stack, cell, split_u, split_v);
        return Ok(());
    }
    let p = eval(face, face_id, u, v)?.p;
    out.push(sample(p, rho + (p - c.p).norm(), face_id, u, v));
    Ok(())
}

fn sample(point: Vector3<f64>, cover: f64, face: u32, u: f64, v: f64) -> Sample {
    Sample {
        point,
        cover,
        face,
        u,
        v,
    }
}

/// The first of centre, corners and the 4 x 4 probes (in that order) that
/// lies on the face.
fn first_probe_on_face(
    face: &dyn Face,
    cell: &Cell,
    centre_in: bool,
    corners_in: &[bool; 4],
    corner_uv: &[(f64, f64); 4],
) -> Option<(f64, f64)> {
    if centre_in {
        return Some((cell.uc, cell.vc));
    }
    if let Some(k) = corners_in.iter().position(|&x| x) {
        return Some(corner_uv[k]);
    }
    for i in 0..PROBES {
        for j in 0..PROBES {
            let su = (2.0 * i as f64 + 1.0) / PROBES as f64 - 1.0;
            let sv = (2.0 * j as f64 + 1.0) / PROBES as f64 - 1.0;
            let (u, v) = (cell.uc + su * cell.a, cell.vc + sv * cell.b);
            if face.inside(u, v) {
                return Some((u, v));
            }
        }
    }
    None
}

/// Whether to split along u and along v: extent above the spacing (the
/// boundary spacing for a boundary cell, or `spacing` when given) or
/// second-order term above the chord tolerance, estimated at the centre.
fn geometric_split(
    c: &FaceDerivs,
    cell: &Cell,
    opts: &SamplingOptions,
    spacing: Option<f64>,
) -> (bool, bool) {
    let spacing = spacing.unwrap_or(if cell.boundary {
        opts.boundary_spacing
    } else {
        opts.spacing
    });
    let k = opts.curvature_safety;
    let (a, b) = (cell.a, cell.b);
    let (muu, muv, mvv) = (k * c.suu.norm(), k * c.suv.norm(), k * c.svv.norm());
    let chord_u = 0.5 * (muu * a * a + muv * a * b);
    let chord_v = 0.5 * (mvv * b * b + muv * a * b);
    let split_u = cell.depth_u < MAX_DEPTH
        && (2.0 * a * c.su.norm() > spacing || chord_u > opts.chord_tolerance);
    let split_v = cell.depth_v < MAX_DEPTH
        && (2.0 * b * c.sv.norm() > spacing || chord_v > opts.chord_tolerance);
    (split_u, split_v)
}

/// Children in a fixed order (pushed so that they pop low u, low v first).
fn push_children(stack: &mut Vec<Cell>, cell: Cell, split_u: bool, split_v: bool) {
    let (nu, nv) = (if split_u { 2 } else { 1 }, if split_v { 2 } else { 1 });
    let (a, b) = (
        if split_u { 0.5 * cell.a } else { cell.a },
        if split_v { 0.5 * cell.b } else { cell.b },
    );
    for i in (0..nu).rev() {
        for j in (0..nv).rev() {
            let ou = if split_u {
                (2.0 * i as f64 - 1.0) * a
            } else {
                0.0
            };
            let ov = if split_v {
                (2.0 * j as f64 - 1.0) * b
            } else {
                0.0
            };
            stack.push(Cell {
                uc: cell.uc + ou,
                vc: cell.vc + ov,
                a,
                b,
                depth_u: cell.depth_u + u32::from(split_u),
                depth_v: cell.depth_v + u32::from(split_v),
                boundary: cell.boundary,
            });
        }
    }
}

/// The cover radius of a cell from its centre's and corners' derivatives
/// (`d[0]` the centre): see the module's documentation.
fn cover_radius(d: &[FaceDerivs; 5], a: f64, b: f64, safety: f64) -> f64 {
    let m = |f: fn(&FaceDerivs) -> f64| safety * d.iter().map(f).fold(0.0, f64::max);
    let muu = m(|x| x.suu.norm());
    let muv = m(|x| x.suv.norm());
    let mvv = m(|x| x.svv.norm());
    d[0].su.norm() * a + d[0].sv.norm() * b + 0.5 * (muu * a * a + 2.0 * muv * a * b + mvv * b * b)
}

/// Derivatives at (u, v), refused when not finite.
pub(crate) fn eval(face: &dyn Face, face_id: u32, u: f64, v: f64) -> Result<FaceDerivs> {
    let d = face.derivatives(u, v);
    let finite = [d.p, d.su, d.sv, d.suu, d.suv, d.svv]
        .iter()
        .all(|x| x.iter().all(|c| c.is_finite()));
    if finite {
        Ok(d)
    } else {
        Err(Error::invalid(
            format!("faces[{face_id}]"),
            format!("the surface or its derivatives are not finite at (u, v) = ({u}, {v})"),
        ))
    }
}
