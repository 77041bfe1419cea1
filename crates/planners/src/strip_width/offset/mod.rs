//! Lee-style iso-scallop offsetting (after Lee 1998; docs/methods.md,
//! "Iso-scallop offsetting"), shared by
//! `iso_scallop` (the whole surface as one region, from a boundary curve,
//! the first pass inset by its half-width) and
//! `tensor_regions` (per region, from the pass through its widest-strip
//! point). Each point of the current pass is carried across the feed, on the
//! surface, to where the current pass's half-width on that side and the next
//! pass's half-width on the other side meet at the scallop height. Passes run
//! zig-zag; a point of the next pass is kept while the strip edge of the
//! current pass still leaves region material uncut.

use super::pass_ends::{edges_at, extend_pass};
use super::passes::{sample_curve, walk_on_surface, Contact, PassSettings};
use super::regions::Region;
use crate::Progress;
use nalgebra::{Vector2, Vector3};
use toolpath_formats::{FeedDirection, Pass};
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::NurbsSurface;

mod corners;
mod coverage;
mod fronts;

use corners::*;
use coverage::*;
use fronts::*;

/// Offset runs shorter than this many cutter radii are not passes.
pub(crate) const MIN_RUN_SPAN: f64 = 2.0;

/// Passes cannot exceed this count per region (a guard against runaway offsetting).
const MAX_PASSES: usize = 5_000;

/// Whether `travel` is within 30 deg of a domain edge through `uv` that a
/// walk heading `exit` (3-D tangent) leaves the domain through. Only the
/// edge that stopped the walk counts: at a corner, an offset stopped by the
/// edge across the pass is not a point of a pass along the other edge
/// (otherwise every later pass hooks round into that edge).
fn runs_along_boundary(
    surface: &NurbsSurface,
    uv: Vector2<f64>,
    exit: Vector3<f64>,
    travel: Vector3<f64>,
) -> bool {
    let Some(g) = toolpath_kernel::geometry::LocalGeometry::at(surface, uv.x, uv.y) else {
        return false;
    };
    let Some(t) = travel.try_normalize(1e-300) else {
        return false;
    };
    edges_at(surface, uv, Some(g.tangent_to_uv(exit)))
        .iter()
        .any(|e| e.dot(&t).abs() > 30f64.to_radians().cos())
}

fn too_many_passes(region: &Region) -> Error {
    Error::planning(format!(
        "region {} needs more than {MAX_PASSES} passes: the scallop is too small for the surface",
        region.id
    ))
}

fn singular(uv: Vector2<f64>) -> Error {
    Error::planning(format!(
        "the surface is singular at uv ({:.4}, {:.4}): no normal there",
        uv.x, uv.y
    ))
}

/// The boundary curve an iso-scallop cover of the whole surface starts
/// from: an edge along the feed parameter, at the start of the cross-feed
/// parameter (v = v0 for feed along u, u = u0 for feed along v) or, with
/// `far`, at its end, sampled to the chord tolerance.
pub fn boundary_start(
    surface: &NurbsSurface,
    s: &PassSettings,
    feed: FeedDirection,
    far: bool,
) -> Vec<Vector2<f64>> {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let (vc, uc) = if far { (v1, u1) } else { (v0, u0) };
    let curve_uv = |t: f64| match feed {
        FeedDirection::U => Vector2::new(u0 + (u1 - u0) * t, vc),
        FeedDirection::V => Vector2::new(uc, v0 + (v1 - v0) * t),
    };
    let curve = |t: f64| {
        let p = curve_uv(t);
        surface.point(p.x, p.y)
    };
    sample_curve(&curve, s.chord_tolerance, s.point_step, 9)
        .into_iter()
        .map(curve_uv)
        .collect()
}

/// Covers `region` with passes offset from `initial` (a uv polyline in the
/// travel direction of the first pass), to both sides. Passes are returned
/// in machining order (outermost of one side first) with `region` set.
/// `progress` is checked once per pass.
pub(crate) fn cover(
    surface: &NurbsSurface,
    s: &PassSettings,
    region: &Region,
    initial: &[Vector2<f64>],
    progress: &dyn Progress,
) -> Result<Vec<Pass>> {
    cover_sides(surface, s, region, initial, &[1.0, -1.0], progress)
}

/// Covers the whole surface `region` from a domain edge (`edge`, a uv
/// polyline along it from [`boundary_start`]): the first pass lies inside
/// the surface where its strip edge meets the domain edge at the scallop
/// height (the edge curve walked inwards, on the surface, by the half-width
/// of a pass there), and the passes are offset to the inner side only. A
/// pass on the edge itself would cut half its strip beyond it. On a surface
/// with a collapsed edge (a pole) the first pass stays on the edge: the
/// passes converge on the pole, and the inset moves the last one into a
/// small loop round it.
pub fn cover_from_edge(
    surface: &NurbsSurface,
    s: &PassSettings,
    region: &Region,
    edge: &[Vector2<f64>],
    progress: &dyn Progress,
) -> Result<Vec<Pass>> {
    if surface.collapsed_boundaries().iter().any(|&c| c) {
        return cover(surface, s, region, edge, progress);
    }
    let contacts = front_from_uv(surface, s, edge, None)?;
    if contacts.len() < 2 {
        return cover(surface, s, region, edge, progress);
    }
    // The side of the edge the domain lies on, from the middle contact.
    let ((u0, u1), (v0, v1)) = surface.domain();
    let centre = Vector2::new(0.5 * (u0 + u1), 0.5 * (v0 + v1));
    let mid = &contacts[contacts.len() / 2];
    let side = if mid.g.tangent_to_uv(mid.cross()).dot(&(centre - mid.uv())) >= 0.0 {
        1.0
    } else {
        -1.0
    };
    let mut inset = Vec::with_capacity(contacts.len());
    for c in &contacts {
        let away = c.cross() * side;
        let mut dist = c.half_width_towards(s, away)?;
        let mut end =
            walk_on_surface(surface, c.uv(), away, dist).ok_or_else(|| singular(c.uv()))?;
        for _ in 0..3 {
            if end.2 {
                break;
            }
            let Some(q) = Contact::new(surface, end.0, c.travel) else {
                break;
            };
            let w = q.half_width_towards(s, -end.1)?;
            let settled = (w - dist).abs() < 1e-4;
            dist = w;
            end = walk_on_surface(surface, c.uv(), away, dist).ok_or_else(|| singular(c.uv()))?;
            if settled {
                break;
            }
        }
        if !end.2 {
            inset.push(end.0);
        }
    }
    if inset.len() < 2 {
        return cover(surface, s, region, edge, progress);
    }
    let keep = smooth_indices(surface, &inset, 2.0 * s.point_step);
    let inset: Vec<Vector2<f64>> = keep.iter().map(|&k| inset[k]).collect();
    cover_sides(surface, s, region, &inset, &[side], progress)
}

/// [`cover`] offsetting only to the given sides of the first pass (1: n x
/// travel, -1: the other).
fn cover_sides(
    surface: &NurbsSurface,
    s: &PassSettings,
    region: &Region,
    initial: &[Vector2<f64>],
    sides_to_cover: &[f64],
    progress: &dyn Progress,
) -> Result<Vec<Pass>> {
    let mut initial = initial.to_vec();
    extend_ends(surface, s, region, &mut initial, None);
    let first = pass_contacts(s, front_from_uv(surface, s, &initial, None)?);
    if first.len() < 2 {
        return Ok(Vec::new());
    }
    let sides = offset_sides(surface, s, region, &first, sides_to_cover, progress)?;
    let mut passes = Vec::new();
    for run in sides[0].iter().rev() {
        progress.check()?;
        passes.push(to_pass(surface, s, region, run)?);
    }
    passes.push(to_pass(surface, s, region, &first)?);
    for run in &sides[1] {
        progress.check()?;
        passes.push(to_pass(surface, s, region, run)?);
    }
    fill_gaps(surface, s, region, &mut passes, progress)?;
    Ok(passes)
}

/// The offset runs to each side of the `first` pass (side 1, then -1; an
/// empty list for a side not in `sides_to_cover`), in offsetting order: each
/// run's front offset again until the region is covered.
fn offset_sides(
    surface: &NurbsSurface,
    s: &PassSettings,
    region: &Region,
    first: &[Contact],
    sides_to_cover: &[f64],
    progress: &dyn Progress,
) -> Result<Vec<Vec<Vec<Contact>>>> {
    let mut sides: Vec<Vec<Vec<Contact>>> = Vec::new();
    let mut total = 0usize;
    let mut coverage = Coverage::new(s, FOLD_SHARE);
    coverage.add(s, 0, first);
    for side in [1.0, -1.0] {
        if !sides_to_cover.contains(&side) {
            sides.push(Vec::new());
            continue;
        }
        let mut done: Vec<Vec<Contact>> = Vec::new();
        let start: Vec<FrontPoint> = first
            .iter()
            .map(|c| FrontPoint {
                c: *c,
                away: c.cross() * side,
            })
            .collect();
        let mut queue = vec![(start, 0usize)];
        while let Some((front, front_id)) = queue.pop() {
            progress.check()?;
            for run in offset_front(surface, s, region, &coverage, front_id, &front)? {
                total += 1;
                if total > MAX_PASSES {
                    return Err(too_many_passes(region));
                }
                let contacts: Vec<Contact> = run.iter().map(|f| f.c).collect();
                coverage.add(s, total, &contacts);
                done.push(contacts);
                queue.push((run, total));
            }
        }
        sides.push(done);
    }
    Ok(sides)
}

/// The pass through `contacts` in `region`: contacts in between where they
/// lie far apart, pivots, spikes into corners and run-ons past turns, then
/// the run-in and run-out.
fn to_pass(
    surface: &NurbsSurface,
    s: &PassSettings,
    region: &Region,
    contacts: &[Contact],
) -> Result<Pass> {
    let mut pass = Pass {
        region: region.id,
        points: Vec::with_capacity(contacts.len() + 1),
        min_strip_width: None,
    };
    let spikes = corner_spikes(s, contacts)?;
    let run_ons = turn_starts(s, contacts)?;
    let mut prev: Option<Contact> = None;
    for (i, c) in contacts.iter().enumerate() {
        if let Some(a) = prev {
            // Offset points follow the front, not the chord tolerance
            // (points clipped onto an edge can lie far apart): contacts
            // in between keep each straight move within the tolerance.
            let gap = (c.point() - a.point()).norm();
            let n = (gap / s.point_step).ceil() as usize;
            let mut last = a;
            for m in 1..n {
                let f = m as f64 / n as f64;
                let uv = a.uv() * (1.0 - f) + c.uv() * f;
                let t = a.travel * (1.0 - f) + c.travel * f;
                if let Some(mc) = Contact::new(surface, uv, t) {
                    pivot(&last, &mc, s, &mut pass.points)?;
                    pass.points.push(mc.path_point(s)?);
                    last = mc;
                }
            }
            pivot(&last, c, s, &mut pass.points)?;
        }
        pass.points.push(c.path_point(s)?);
        if let Some((dir, len)) = spikes[i] {
            spike(surface, s, c, dir, len, &mut pass.points)?;
        } else if let Some(lag) = run_ons[i] {
            run_on(surface, s, c, lag, &mut pass.points)?;
        }
        prev = Some(*c);
    }
    extend_pass(surface, &mut pass.points, s)?;
    Ok(pass)
}

/// Corners the offsetting leaves between pass ends, region boundaries and
/// fronts that split: short passes through what no strip reached, added to
/// `passes`.
fn fill_gaps(
    surface: &NurbsSurface,
    s: &PassSettings,
    region: &Region,
    passes: &mut Vec<Pass>,
    progress: &dyn Progress,
) -> Result<()> {
    let mut reached = Coverage::new(s, GAP_SHARE);
    for (id, pass) in passes.iter().enumerate() {
        reached.add_points(id, &strip_of(pass));
    }
    for uv in uncut_samples(surface, s, region, &reached) {
        progress.check()?;
        if reached.covered_sided(surface, s, surface.point(uv.x, uv.y)) {
            continue;
        }
        let Some(line) = gap_line(surface, s, region, &reached, uv) else {
            continue;
        };
        let contacts = pass_contacts(s, front_from_uv(surface, s, &line, None)?);
        if contacts.len() < 2 {
            continue;
        }
        let pass = to_pass(surface, s, region, &contacts)?;
        reached.add_points(passes.len(), &strip_of(&pass));
        passes.push(pass);
        if passes.len() > MAX_PASSES {
            return Err(too_many_passes(region));
        }
    }
    Ok(())
}
