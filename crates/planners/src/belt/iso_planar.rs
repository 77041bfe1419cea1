//! Strategy `belt_iso_planar` (the belt-grinding paper's algorithm 2;
//! docs/methods.md, "Belt paths" and "Section normal"):
//! contact paths are the intersections of parallel planes with the surface.
//!
//! Section-plane normal: the minimum-curvature directions have no sign, so they
//! are averaged with the orientation tensor M = sum d_i d_i^T over a grid of
//! surface points and the normal is the eigenvector of M's largest eigenvalue
//! (the paper's "least squares"). "Minimum curvature" is the principal
//! direction of smallest |kappa|: on a ruled surface the ruling, along which
//! the belt lies flat (zero scallop). Points where both curvatures are equal
//! in size (planar or umbilic points) have no direction and are left out.
//! `job.section_normal` overrides the automatic normal.
//!
//! Planes start through the middle of the surface's extent along the normal
//! and step to both sides; each step is the smallest offset (along the
//! normal) of the next contact points found from every point of the current
//! section by the belt contact model. A last plane touches each far edge.

use super::contact::{self, BeltSpec, ContactPoint};
use crate::refine::Refinement;
use crate::Progress;
use nalgebra::{Matrix3, Point3, SymmetricEigen, Vector2, Vector3};
use toolpath_formats::{Job, PlanResult};
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::plane_intersection::{intersect_plane, Plane, SectionOptions};
use toolpath_kernel::geometry::{LocalGeometry, NurbsSurface};

/// Grid of surface samples for the automatic section normal, per direction.
const NORMAL_SAMPLES: usize = 48;
/// Eigenvalue ratio above 1 - this: the top two eigenvalues of the
/// orientation tensor are equal up to rounding (the normal is undefined
/// within their plane).
const EVEN_SPREAD: f64 = 1e-6;
/// Passes per side beyond this mean the step collapsed.
const MAX_PASSES: usize = 20_000;

/// The automatic section normal and how well it is defined.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SectionNormal {
    /// Unit normal; sign fixed so that its largest component is positive.
    pub normal: Vector3<f64>,
    /// Second-largest over largest eigenvalue of M: near 0 = well defined,
    /// near 1 = ill-defined (directions spread evenly).
    pub eigen_ratio: f64,
    /// Largest eigenvalue over the trace of M (fraction of the directions'
    /// spread explained by the normal; 1 = all directions parallel).
    pub eigen_fraction: f64,
    /// Number of directions used.
    pub samples: usize,
}

/// Minimum-|curvature| principal directions on a grid of `n x n` cell centres
/// in parameter space, leaving out points without a defined direction.
pub fn min_curvature_directions(surface: &NurbsSurface, n: usize) -> Vec<Vector3<f64>> {
    belt_directions(&cell_geometry(surface, n), f64::INFINITY)
}

/// The local geometry at the centres of a grid of `n x n` cells in
/// parameter space, row by row along u; points where it is undefined are
/// left out.
pub(crate) fn cell_geometry(surface: &NurbsSurface, n: usize) -> Vec<LocalGeometry> {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let mut cells = Vec::with_capacity(n * n);
    for i in 0..n {
        for j in 0..n {
            let u = u0 + (u1 - u0) * (i as f64 + 0.5) / n as f64;
            let v = v0 + (v1 - v0) * (j as f64 + 0.5) / n as f64;
            cells.extend(LocalGeometry::at(surface, u, v));
        }
    }
    cells
}

/// The directions a rigid belt should lie along at the points `cells`: of
/// the two principal directions, the one of smaller |kappa| unless it is
/// concave beyond `concave_limit` (the rigid belt would sink into the
/// surface more than h there: kappa w^2 / 8 > h), then the other one if that
/// is not, else the less concave one. Points where both curvatures are equal
/// in size have no direction and are left out.
pub(crate) fn belt_directions(cells: &[LocalGeometry], concave_limit: f64) -> Vec<Vector3<f64>> {
    let mut dirs = Vec::with_capacity(cells.len());
    for g in cells {
        let (kmin, kmax) = (g.k_min.abs(), g.k_max.abs());
        // Equal |kappa| (plane, umbilic): the direction is undefined.
        if (kmin - kmax).abs() <= 1e-9 * (kmin + kmax) + 1e-12 {
            continue;
        }
        // Positive curvature is concave (towards the tool).
        let (flat, other) = if kmin < kmax {
            ((g.k_min, g.dir_min), (g.k_max, g.dir_max))
        } else {
            ((g.k_max, g.dir_max), (g.k_min, g.dir_min))
        };
        let chosen = if flat.0 <= concave_limit || flat.0 <= other.0 {
            flat.1
        } else {
            other.1
        };
        dirs.push(chosen);
    }
    dirs
}

/// Orientation-tensor average of sign-free directions: eigenvector of the
/// largest eigenvalue of M = sum d d^T. `None` when there are no directions.
pub fn section_normal_from_directions(dirs: &[Vector3<f64>]) -> Option<SectionNormal> {
    if dirs.is_empty() {
        return None;
    }
    let mut m = Matrix3::zeros();
    for d in dirs {
        m += d * d.transpose();
    }
    let eig = SymmetricEigen::new(m);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let (l1, l2) = (eig.eigenvalues[order[0]], eig.eigenvalues[order[1]]);
    let trace = m.trace();
    let mut normal: Vector3<f64> = eig.eigenvectors.column(order[0]).into_owned();
    if l1 > 0.0 && l2 >= (1.0 - EVEN_SPREAD) * l1 {
        // The directions spread evenly over a plane: any normal in it is an
        // eigenvector, and which one the solver returns is rounding. Take the
        // first coordinate axis (x, then y, then z) projected into the plane,
        // so the same surface always gets the same sections.
        let across: Vector3<f64> = eig.eigenvectors.column(order[2]).into_owned();
        if let Some(a) = across.try_normalize(1e-300) {
            if let Some(axis) = [Vector3::x(), Vector3::y(), Vector3::z()]
                .iter()
                .find_map(|e| (e - a * e.dot(&a)).try_normalize(1e-6))
            {
                normal = axis;
            }
        }
    }
    normal = normal.try_normalize(1e-300)?;
    // Deterministic sign: the largest component positive.
    let imax = (0..3)
        .max_by(|&a, &b| normal[a].abs().total_cmp(&normal[b].abs()))
        .unwrap_or(0);
    if normal[imax] < 0.0 {
        normal = -normal;
    }
    Some(SectionNormal {
        normal,
        eigen_ratio: if l1 > 0.0 { (l2 / l1).max(0.0) } else { 1.0 },
        eigen_fraction: if trace > 0.0 { l1 / trace } else { 0.0 },
        samples: dirs.len(),
    })
}

/// The automatic section normal of a surface for a belt of this width and
/// scallop height: the mean of the least-curvature directions, unless the
/// mean of [`belt_directions`] (which turn away from concave sections) lets
/// the rigid belt sink in less by more than h / 2 ([`rigid_sinking`]).
pub(crate) fn automatic_section_normal(
    surface: &NurbsSurface,
    spec: &BeltSpec,
) -> Option<SectionNormal> {
    let cells = cell_geometry(surface, NORMAL_SAMPLES);
    let least = section_normal_from_directions(&belt_directions(&cells, f64::INFINITY));
    let concave_limit = 8.0 * spec.scallop / (spec.width * spec.width);
    let aware = section_normal_from_directions(&belt_directions(&cells, concave_limit));
    match (least, aware) {
        (Some(l), Some(a)) => {
            let sink = |n: &SectionNormal| rigid_sinking(&cells, n.normal, spec.width);
            Some(if sink(&a) < sink(&l) - 0.5 * spec.scallop {
                a
            } else {
                l
            })
        }
        (l, a) => l.or(a),
    }
}

/// How deep a rigid belt of width `w` lying along the tangent projection of
/// `normal` (the belt axis of the section planes with that normal) sinks into
/// concave sections at most, kappa w^2 / 8 over the points `cells`.
pub(crate) fn rigid_sinking(cells: &[LocalGeometry], normal: Vector3<f64>, width: f64) -> f64 {
    let mut worst: f64 = 0.0;
    for g in cells {
        let axis = normal - g.forms.n * normal.dot(&g.forms.n);
        if axis.norm() <= 1e-9 {
            continue;
        }
        let kappa = g.normal_curvature(axis);
        if kappa.is_finite() {
            worst = worst.max(kappa * width * width / 8.0);
        }
    }
    worst
}

/// The strategy `belt_iso_planar`.
pub(crate) static BELT_ISO_PLANAR: super::BeltStrategy = super::BeltStrategy {
    id: toolpath_formats::Strategy::BeltIsoPlanar,
    levels: crate::strategy::PathLevels::SectionPlane,
    plan_with,
};

/// The plan as refined by the removal simulation (`crate::refine`): steps
/// aiming below h where it found material left, more paths in the section
/// planes at its added offsets along the section normal.
pub(crate) fn plan_with(
    job: &Job,
    progress: &dyn Progress,
    refinement: &Refinement,
) -> Result<PlanResult> {
    let surface = job.surface()?;
    let spec = BeltSpec::from_job(job)?;
    let mut result = PlanResult::new(&job.job_id, job.strategy.name());
    let normal = match job.section_normal {
        Some(n) => Vector3::new(n[0], n[1], n[2])
            .try_normalize(1e-12)
            .ok_or_else(|| Error::invalid("section_normal", "must be a finite non-zero vector"))?,
        None => match automatic_section_normal(surface, &spec) {
            Some(sn) => {
                result.section_normal_eigen_ratio = Some(sn.eigen_ratio);
                result
                    .stats
                    .extra
                    .insert("section_normal_eigen_fraction".into(), sn.eigen_fraction);
                if sn.eigen_ratio > 0.8 {
                    result.warnings.push(format!(
                        "section normal is ill-defined (eigenvalue ratio {:.3}): the minimum-curvature directions spread evenly",
                        sn.eigen_ratio
                    ));
                }
                sn.normal
            }
            None => {
                // No curvature anisotropy anywhere (a plane): any normal is as
                // good; take the u-direction at the centre.
                let ((u0, u1), (v0, v1)) = surface.domain();
                let g = LocalGeometry::at(surface, 0.5 * (u0 + u1), 0.5 * (v0 + v1)).ok_or_else(|| {
                    Error::planning("the belt cannot reach the surface: its normal is undefined at the centre")
                })?;
                result.warnings.push(
                    "no minimum-curvature direction defined anywhere: section normal along u"
                        .into(),
                );
                g.forms.derivs.su.normalize()
            }
        },
    };
    result.section_normal = Some([normal.x, normal.y, normal.z]);
    let (mut paths, mut diag) = plan_paths(surface, &spec, normal, refinement, progress)?;
    let spacing = contact::point_spacing(&spec);
    let (cells_u, cells_v) = cells(surface, spacing);
    let options = SectionOptions {
        cells_u,
        cells_v,
        max_segment: spacing,
    };
    let feed = move |g: &LocalGeometry| -> Vector3<f64> { normal.cross(&g.forms.n) };
    let hint = move |_: &LocalGeometry| -> Vector3<f64> { normal };
    for &offset in &refinement.added {
        let Some(plane) = Plane::new(Point3::from(normal * offset), normal) else {
            continue;
        };
        for uvs in section_curves(surface, &plane, &options) {
            let path = contact::analyse_path(surface, &uvs, &feed, &hint, &spec, false, &mut diag);
            paths.push((offset, path));
        }
    }
    contact::assemble_levelled(paths, &spec, &mut result, &diag)?;
    Ok(result)
}

/// Grid sizes (cells along u and v) with cells of about `spacing` mm.
fn cells(surface: &NurbsSurface, spacing: f64) -> (usize, usize) {
    let length = |along_u: bool| surface.longest_iso_curve_length(along_u);
    let n = |len: f64| ((len / spacing).ceil() as usize).clamp(16, 600);
    (n(length(true)), n(length(false)))
}

/// Smallest and largest `x . normal` over the surface, from a point grid.
fn extent(surface: &NurbsSurface, normal: Vector3<f64>, (cu, cv): (usize, usize)) -> (f64, f64) {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for i in 0..=cu {
        for j in 0..=cv {
            let u = u0 + (u1 - u0) * i as f64 / cu as f64;
            let v = v0 + (v1 - v0) * j as f64 / cv as f64;
            let x = surface.point(u, v).coords.dot(&normal);
            lo = lo.min(x);
            hi = hi.max(x);
        }
    }
    (lo, hi)
}

/// The section curves of one plane in (u, v), closed ones with their first
/// point repeated at the end. Points closer than a quarter of the point
/// spacing to the last one kept are dropped: the section is traced over uv
/// cells, and where a pole squeezes a row of cells into one point the trace
/// would pile points up there.
fn section_curves(
    surface: &NurbsSurface,
    plane: &Plane,
    options: &SectionOptions,
) -> Vec<Vec<Vector2<f64>>> {
    let min_gap = 0.25 * options.max_segment;
    intersect_plane(surface, plane, options)
        .into_iter()
        .map(|c| {
            let mut uv: Vec<Vector2<f64>> = c.uv.iter().map(|p| Vector2::new(p[0], p[1])).collect();
            if c.closed {
                if let Some(&first) = uv.first() {
                    uv.push(first);
                }
            }
            thin_out(surface, uv, min_gap)
        })
        .filter(|uv| uv.len() >= 2)
        .collect()
}

/// `uv` without the points closer than `min_gap` (mm, on the surface) to
/// the last point kept; both ends stay (the last one replacing a close point
/// before it), so a short section still grinds its bit of the part.
fn thin_out(surface: &NurbsSurface, uv: Vec<Vector2<f64>>, min_gap: f64) -> Vec<Vector2<f64>> {
    let n = uv.len();
    let mut out: Vec<Vector2<f64>> = Vec::with_capacity(n);
    let mut last_kept: Option<Point3<f64>> = None;
    for (k, q) in uv.into_iter().enumerate() {
        let p = surface.point(q.x, q.y);
        let close = last_kept.is_some_and(|l| (p - l).norm() < min_gap);
        if !close {
            out.push(q);
            last_kept = Some(p);
        } else if k + 1 == n {
            if out.len() > 1 {
                out.pop();
            }
            out.push(q);
        }
    }
    out
}

/// The smallest advance along `dir` to the next contacts of a path's points
/// (infinite when none is usable): points whose next contact is an edge within
/// the belt's half width are covered already, and sections that barely
/// advance run nearly inside the plane (plane tangent to the surface there).
fn next_step(
    surface: &NurbsSurface,
    spec: &BeltSpec,
    path: &[ContactPoint],
    dir: Vector3<f64>,
    extent: f64,
) -> f64 {
    let mut step = f64::INFINITY;
    for cp in path {
        let Some(nc) = cp.next else { continue };
        let q = surface.point(nc.uv.x, nc.uv.y);
        let d = (q - cp.geom.point()).dot(&dir);
        if nc.at_boundary && nc.sigma <= 0.5 * spec.width {
            continue;
        }
        if d <= 1e-9 * extent {
            continue;
        }
        step = step.min(d);
    }
    step
}

/// The contact paths in machining order (plane offsets increasing along the
/// normal) with their plane offsets, and what was noticed on the way.
#[allow(clippy::type_complexity)]
pub(crate) fn plan_paths(
    surface: &NurbsSurface,
    spec: &BeltSpec,
    normal: Vector3<f64>,
    refinement: &Refinement,
    progress: &dyn Progress,
) -> Result<(Vec<(f64, Vec<ContactPoint>)>, contact::Diagnostics)> {
    let spacing = contact::point_spacing(spec);
    let (cu, cv) = cells(surface, spacing);
    let options = SectionOptions {
        cells_u: cu,
        cells_v: cv,
        max_segment: spacing,
    };
    let (lo, hi) = extent(surface, normal, (cu, cv));
    let extent = hi - lo;
    if extent.is_nan() || extent <= 1e-9 {
        return Err(Error::planning(format!(
            "the belt cannot reach the surface along section normal ({:.4}, {:.4}, {:.4}): the surface lies in one section plane (the planes are tangent to it); choose a section_normal across the surface",
            normal.x, normal.y, normal.z
        )));
    }
    // Keep the end planes a hair inside so that they still cut the surface.
    let margin = 1e-6 * extent;
    let (lo, hi) = (lo + margin, hi - margin);
    let sections = Sections {
        surface,
        spec,
        normal,
        refinement,
        options,
        range: (lo, hi),
        extent,
    };
    let mut diag = contact::Diagnostics::default();
    let plus = sections.side(0, &mut diag, progress)?;
    let mut minus = sections.side(1, &mut diag, progress)?;
    // Machining order: the - side from its far end, then the + side.
    minus.reverse();
    minus.extend(plus);
    if minus.iter().all(|(_, p)| p.is_empty()) {
        return Err(Error::planning(
            "the belt cannot reach the surface: the section planes give no contact path",
        ));
    }
    Ok((minus, diag))
}

/// The section planes of one plan: normal, offsets `range` (the surface's
/// extent along the normal, a hair inside), and the settings every plane
/// shares.
struct Sections<'a> {
    surface: &'a NurbsSurface,
    spec: &'a BeltSpec,
    normal: Vector3<f64>,
    refinement: &'a Refinement,
    options: SectionOptions,
    range: (f64, f64),
    /// The extent along the normal before the margins, mm.
    extent: f64,
}

impl Sections<'_> {
    /// The paths of one side (0: towards +normal, 1: towards -normal) from
    /// the middle plane, each with its offset, in stepping order. The middle
    /// plane is planned on the + side only; the - side steps from it.
    fn side(
        &self,
        side: usize,
        diag: &mut contact::Diagnostics,
        progress: &dyn Progress,
    ) -> Result<Vec<(f64, Vec<ContactPoint>)>> {
        let (lo, hi) = self.range;
        let (extent, normal) = (self.extent, self.normal);
        let sign = if side == 0 { 1.0 } else { -1.0 };
        let start = 0.5 * (lo + hi);
        let limit = if sign > 0.0 { hi } else { lo };
        let mut paths_side = Vec::new();
        let mut offset = start;
        let mut first = true;
        loop {
            let last = (limit - offset) * sign <= 0.0;
            let plane = Plane::new(Point3::from(normal * offset), normal).ok_or_else(|| {
                Error::invalid("section_normal", "must be a finite non-zero vector")
            })?;
            let (analysed, step, any_curve) = self.plane_paths(&plane, offset, sign, last, diag);
            if !(side == 1 && first) {
                paths_side.extend(analysed.into_iter().map(|p| (offset, p)));
            }
            progress.set(
                0.45 * side as f32
                    + 0.45 * (((offset - start) * sign) / (0.5 * extent)).clamp(0.0, 1.0) as f32,
            );
            progress.check()?;
            if last {
                break;
            }
            if !any_curve && !first {
                break;
            }
            if !step.is_finite() {
                // No usable candidate: the remaining strip is reached from here.
                offset = limit;
                first = false;
                continue;
            }
            if step <= 1e-9 * extent {
                return Err(Error::planning(format!(
                    "belt step collapsed at section offset {offset:.6} mm: the next-path search made no progress"
                )));
            }
            if paths_side.len() >= MAX_PASSES {
                return Err(Error::planning(format!(
                    "more than {MAX_PASSES} belt passes needed: scallop {} mm is too small for this surface",
                    self.spec.scallop
                )));
            }
            offset += sign * step;
            if (limit - offset) * sign <= 0.0 {
                offset = limit;
            }
            first = false;
        }
        Ok(paths_side)
    }

    /// The contact paths of the section `plane` at `offset`, stepping
    /// towards `sign` x normal (the last plane with no next step), with the
    /// step to the next plane (infinite when no path gives one) and whether
    /// any path has contacts.
    fn plane_paths(
        &self,
        plane: &Plane,
        offset: f64,
        sign: f64,
        last: bool,
        diag: &mut contact::Diagnostics,
    ) -> (Vec<Vec<ContactPoint>>, f64, bool) {
        let (surface, spec, normal) = (self.surface, self.spec, self.normal);
        let feed = move |g: &LocalGeometry| -> Vector3<f64> { normal.cross(&g.forms.n) };
        let dir = normal * sign;
        let hint = move |_: &LocalGeometry| -> Vector3<f64> { dir };
        let curves = section_curves(surface, plane, &self.options);
        let mut step = f64::INFINITY;
        let mut any_curve = false;
        let mut analysed = Vec::new();
        let aim = BeltSpec {
            scallop: spec.scallop * self.refinement.factor(offset, sign > 0.0),
            ..*spec
        };
        for uvs in &curves {
            let path = contact::analyse_path(surface, uvs, &feed, &hint, &aim, !last, diag);
            step = step.min(next_step(surface, spec, &path, dir, self.extent));
            any_curve |= !path.is_empty();
            analysed.push(path);
        }
        (analysed, step, any_curve)
    }
}
