//! Offsetting one front to the next: each contact carried across the feed to
//! where the two half-widths meet at the scallop height, smoothed, extended to
//! the region's edges, and split into runs over uncut material
//! (docs/methods.md, "Iso-scallop offsetting").

use super::*;
use crate::strip_width::crossings::segment_crossing;
use crate::strip_width::passes::{walk_on_surface as walk, Contact, PassSettings, Walker};
use crate::strip_width::regions::Region;
use nalgebra::{Point3, Vector2, Vector3};
use std::cell::Cell;
use std::collections::HashMap;
use toolpath_kernel::error::Result;
use toolpath_kernel::geometry::segment_index::{box_dist2, segment_box, BoxTree};
use toolpath_kernel::geometry::NurbsSurface;

/// A point of a pass front: its contact and the unit tangent pointing to
/// the side still to be covered.
#[derive(Clone, Copy, Debug)]
pub(super) struct FrontPoint {
    pub(super) c: Contact,
    pub(super) away: Vector3<f64>,
}

/// One offset point: where the next pass goes from `fp`, and whether it is needed.
#[derive(Clone, Copy, Debug)]
pub(super) struct Offset {
    pub(super) uv: Vector2<f64>,
    pub(super) away: Vector3<f64>,
    pub(super) needed: bool,
    /// The walk hit the domain boundary: the point is not a pass point (the
    /// pass is extended to the boundary along its own direction instead).
    pub(super) clipped: bool,
    /// The walk reached the domain boundary (this point or a clipped neighbour).
    pub(super) at_edge: bool,
    /// Distance walked from the front point, mm (the two half-widths).
    pub(super) dist: f64,
}

pub(super) fn offset_point(
    surface: &NurbsSurface,
    s: &PassSettings,
    region: &Region,
    coverage: &Coverage,
    front_id: usize,
    fp: &FrontPoint,
) -> Result<Offset> {
    let w_here = fp.c.half_width_towards(s, fp.away)?;
    // Every walk below runs from the front point along `away`, each
    // continuing the earlier ones (`Walker`): the distance changes by
    // little between them.
    let mut walker = Walker::new(surface, fp.c.uv(), fp.away);
    let mut walk = |dist: f64| {
        walker
            .as_mut()
            .and_then(|w| w.walk(surface, dist))
            .ok_or_else(|| singular(fp.c.uv()))
    };
    let mut dist = 2.0 * w_here;
    let mut end = walk(dist)?;
    for _ in 0..3 {
        let q = Contact::new(surface, end.0, -fp.c.travel).ok_or_else(|| singular(end.0))?;
        let w_there = q.half_width_towards(s, -end.1)?;
        let new_dist = w_here + w_there;
        let settled = (new_dist - dist).abs() < 1e-4;
        dist = new_dist;
        end = walk(dist)?;
        if settled || end.2 {
            break;
        }
    }
    // Is there region material beyond this pass's strip edge, or at the
    // next pass? The end is tested first: where it is uncut (the usual
    // case) the walk to the strip edge is not needed.
    let uncut = |(uv, _, clipped): (Vector2<f64>, Vector3<f64>, bool)| {
        if clipped || !region.contains(uv) {
            return false;
        }
        let p = surface.point(uv.x, uv.y);
        !coverage.covered(p, front_id) && !coverage.on_seam(p, front_id)
    };
    let needed = uncut(end) || uncut(walk(w_here * 0.98)?);
    // A point stopped by the boundary is a pass point only where the pass
    // runs along that boundary (the last pass of a side); where the pass
    // meets the boundary at an angle, it ends there instead.
    let clipped = end.2 && !runs_along_boundary(surface, end.0, end.1, fp.c.travel);
    Ok(Offset {
        uv: end.0,
        away: end.1,
        needed,
        clipped,
        at_edge: end.2,
        dist,
    })
}

/// Parameter in [0, 1] of the point of segment ab nearest to `p` (0 for a
/// degenerate segment).
pub(super) fn segment_parameter(a: Point3<f64>, b: Point3<f64>, p: Point3<f64>) -> f64 {
    let d = b - a;
    let dd = d.norm_squared();
    if dd > 0.0 {
        ((p - a).dot(&d) / dd).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// The contacts of a pass with their half-widths on both sides, which the
/// coverage, the run-ons, the next offset and the path points all ask for.
pub(super) fn pass_contacts(s: &PassSettings, contacts: Vec<Contact>) -> Vec<Contact> {
    contacts
        .into_iter()
        .map(|c| c.with_half_widths(s))
        .collect()
}

/// Share of the cutter radius over which a front point's travel is taken
/// (see [`front_from_uv`]).
const TRAVEL_SPAN_SHARE: f64 = 0.4;

/// Contacts along a uv polyline, travelling along it; `reference` orients
/// the travel (None: the polyline's own order). A point's travel is the
/// chord over [`TRAVEL_SPAN_SHARE`] R of polyline around it (at least its two
/// neighbours): the chord between neighbours a point step apart turns with
/// the offset points' last-digit scatter, the next front is carried across
/// that travel, and over many passes the scatter grows into folded fronts
/// (docs/methods.md, "Iso-scallop offsetting").
pub(super) fn front_from_uv(
    surface: &NurbsSurface,
    s: &PassSettings,
    uv: &[Vector2<f64>],
    reference: Option<&[Vector3<f64>]>,
) -> Result<Vec<Contact>> {
    let half_span = 0.5 * TRAVEL_SPAN_SHARE * s.cutter.radius;
    let xyz: Vec<_> = uv.iter().map(|p| surface.point(p.x, p.y)).collect();
    let n = uv.len();
    let mut arc = Vec::with_capacity(n);
    let mut acc = 0.0;
    for i in 0..n {
        if i > 0 {
            acc += (xyz[i] - xyz[i - 1]).norm();
        }
        arc.push(acc);
    }
    let mut out = Vec::with_capacity(n);
    let (mut a, mut b) = (0usize, 0usize);
    for i in 0..n {
        while a < i && arc[i] - arc[a + 1] >= half_span {
            a += 1;
        }
        b = b.max(i);
        while b + 1 < n && arc[b] - arc[i] < half_span {
            b += 1;
        }
        let (a, b) = (a.min(i.saturating_sub(1)), b.max((i + 1).min(n - 1)));
        let mut t = xyz[b] - xyz[a];
        if let Some(r) = reference {
            if t.dot(&r[i]) < 0.0 {
                t = -t;
            }
        }
        if t.norm() == 0.0 {
            continue;
        }
        if let Some(c) = Contact::new(surface, uv[i], t) {
            out.push(c);
        }
    }
    Ok(out)
}

/// Indices of the points of a pass polyline to keep: points where the pass
/// turns by more than 25 deg are dropped (offsetting near corners and
/// boundaries can leave such kinks; a smooth surface's passes turn by far
/// less between neighbouring points).
pub(super) fn smooth_indices(
    surface: &NurbsSurface,
    uv: &[Vector2<f64>],
    max_chord: f64,
) -> Vec<usize> {
    let xyz: Vec<_> = uv.iter().map(|p| surface.point(p.x, p.y)).collect();
    let mut keep: Vec<usize> = (0..uv.len()).collect();
    let limit = 25f64.to_radians().cos();
    loop {
        let mut worst: Option<(f64, usize)> = None;
        for w in 1..keep.len().saturating_sub(1) {
            let (a, b, c) = (xyz[keep[w - 1]], xyz[keep[w]], xyz[keep[w + 1]]);
            let (d1, d2) = (b - a, c - b);
            let n = d1.norm() * d2.norm();
            let cos = if n > 0.0 { d1.dot(&d2) / n } else { -1.0 };
            // A real corner (the chord across it would be long) stays.
            if cos < limit && (c - a).norm() <= max_chord && worst.is_none_or(|(wc, _)| cos < wc) {
                worst = Some((cos, w));
            }
        }
        match worst {
            Some((_, w)) => {
                keep.remove(w);
            }
            None => return keep,
        }
    }
}

/// How far a pass end runs through an earlier strip it enters heading
/// `dir`: the strip of `along`, half-width `w`. A pass of about that
/// half-width meeting the strip at an angle a covers up to it on both sides
/// once its centre has run w cot(a) in: nothing where it meets the strip
/// square (the two strips only meet), never more than a cutter radius
/// (along the strip, the strip's own cut reaches further than that).
pub(super) fn through_cut_budget(
    s: &PassSettings,
    dir: Vector3<f64>,
    along: Vector3<f64>,
    w: f64,
) -> f64 {
    let sin = dir.cross(&along).norm();
    let cos = dir.dot(&along).abs();
    if w * cos >= s.cutter.radius * sin {
        s.cutter.radius
    } else {
        w * cos / sin
    }
}

/// For a point of a pass end heading along a direction: how far the end
/// may run on through the machined material the point lies in, or `None`
/// where it is uncut.
pub(super) type CutBudget<'a> = dyn Fn(Point3<f64>, Vector3<f64>) -> Option<f64> + 'a;

/// Extends a pass polyline at both ends along its own direction on the
/// surface, to the domain boundary or until it has run the cutter radius
/// beyond the region, so that the strip covers the region up to its
/// boundary even where the pass meets it obliquely. Where `cut` gives a
/// budget for a point (it lies in an earlier strip, heading along the
/// given direction), the end is machined material, not a boundary: the
/// extension stops once it has run that far through it (see
/// [`through_cut_budget`]). Returns the number of points added at the head
/// and the tail.
pub(super) fn extend_ends(
    surface: &NurbsSurface,
    s: &PassSettings,
    region: &Region,
    uv: &mut Vec<Vector2<f64>>,
    cut: Option<&CutBudget<'_>>,
) -> (usize, usize) {
    let mut counts = [0usize; 2];
    for (end, count) in counts.iter_mut().enumerate() {
        if uv.len() < 2 {
            break;
        }
        // Direction over the last few points: one short segment is not to be trusted.
        let k = (uv.len() - 1).min(3);
        let (p, q) = if end == 0 {
            (uv[0], uv[k])
        } else {
            (uv[uv.len() - 1], uv[uv.len() - 1 - k])
        };
        let mut dir = surface.point(p.x, p.y) - surface.point(q.x, q.y);
        if dir.norm() == 0.0 {
            continue;
        }
        dir /= dir.norm();
        let mut at = p;
        let mut outside = 0.0;
        let step = s.point_step.min(s.cutter.radius);
        // The gap to close is at most about a strip width across the pass:
        // along a pass meeting the boundary at 30 deg (below that, offset
        // points on the boundary are kept as pass points) twice that. Never
        // further: a short run's direction is not to be trusted far.
        let mut budget = 4.0 * s.cutter.radius;
        let mut through_cut = 0.0;
        let mut cut_budget = s.cutter.radius;
        for _ in 0..10_000 {
            if budget <= 0.0 {
                break;
            }
            budget -= step;
            if region.contains(at) {
                outside = 0.0;
            } else if outside >= s.cutter.radius {
                break;
            }
            // Only offset runs pass `cut`: the point is evaluated for them alone.
            if let Some(allowed) = cut.and_then(|cut| cut(surface.point(at.x, at.y), dir)) {
                if through_cut == 0.0 {
                    cut_budget = allowed;
                }
                if through_cut >= cut_budget {
                    break;
                }
                through_cut += step;
            } else {
                through_cut = 0.0;
            }
            let Some((next, d, clipped)) = walk(surface, at, dir, step) else {
                break;
            };
            if (next - at).norm() == 0.0 {
                break;
            }
            if end == 0 {
                uv.insert(0, next);
            } else {
                uv.push(next);
            }
            *count += 1;
            if clipped {
                break;
            }
            if !region.contains(next) {
                outside += step;
            }
            at = next;
            dir = d;
        }
    }
    (counts[0], counts[1])
}

/// The next passes from one pass front: runs of needed offset points,
/// refined where they spread apart, loops removed, travel reversed.
pub(super) fn offset_front(
    surface: &NurbsSurface,
    s: &PassSettings,
    region: &Region,
    coverage: &Coverage,
    front_id: usize,
    front: &[FrontPoint],
) -> Result<Vec<Vec<FrontPoint>>> {
    let pts = offset_points(surface, s, region, coverage, front_id, front)?;
    let pts = without_loops(surface, s, pts);
    let mut kept = drop_clipped(without_swallowtails(surface, s, pts));
    bridge_short_gaps(surface, s, &mut kept);
    let n = kept.len();
    let mut runs = Vec::new();
    let mut i = 0;
    while i < n {
        if !kept[i].0.needed {
            i += 1;
            continue;
        }
        let mut j = i;
        while j + 1 < n && kept[j + 1].0.needed {
            j += 1;
        }
        let (a, b) = (i.saturating_sub(1), (j + 1).min(n - 1));
        let points = &kept[a..=b];
        if let Some(run) = run_front(surface, s, region, (coverage, front_id), front, points)? {
            runs.push(run);
        }
        i = j + 1;
    }
    Ok(runs)
}

/// An offset point and the travel of the front point it comes from.
type Carried = (Offset, Vector3<f64>);

/// Marks needed the points of a gap between two needed runs where the gap
/// spans less than [`MIN_RUN_SPAN`] cutter radii: a front whose corner
/// point alone lands on cut material stays one pass through its corner.
/// Split there, both runs would be extended past the corner into material
/// the other is to cut (4 R each way), and the two ends cross.
fn bridge_short_gaps(surface: &NurbsSurface, s: &PassSettings, kept: &mut [Carried]) {
    let n = kept.len();
    let xyz: Vec<Point3<f64>> = kept
        .iter()
        .map(|(o, _)| surface.point(o.uv.x, o.uv.y))
        .collect();
    let mut i = 0;
    while i < n {
        if kept[i].0.needed {
            i += 1;
            continue;
        }
        let mut j = i;
        while j < n && !kept[j].0.needed {
            j += 1;
        }
        // Gap i..j (exclusive), bounded by needed points at i - 1 and j.
        if i > 0 && j < n {
            let span: f64 = (i - 1..j).map(|k| (xyz[k + 1] - xyz[k]).norm()).sum();
            if span < MIN_RUN_SPAN * s.cutter.radius {
                for c in &mut kept[i..j] {
                    c.0.needed = true;
                }
            }
        }
        i = j;
    }
}

/// Offsets of the front points, with midpoints inserted where the new pass
/// would be too sparse or deviate from its chords.
fn offset_points(
    surface: &NurbsSurface,
    s: &PassSettings,
    region: &Region,
    coverage: &Coverage,
    front_id: usize,
    front: &[FrontPoint],
) -> Result<Vec<Carried>> {
    let mut pts: Vec<Carried> = Vec::with_capacity(front.len());
    for (i, fp) in front.iter().enumerate() {
        let o = offset_point(surface, s, region, coverage, front_id, fp)?;
        if i > 0 {
            if let Some((prev, _)) = pts.last() {
                let a = surface.point(prev.uv.x, prev.uv.y);
                let b = surface.point(o.uv.x, o.uv.y);
                if (b - a).norm() > s.point_step {
                    let src = &front[i - 1];
                    let mid_uv = (src.c.uv() + fp.c.uv()) * 0.5;
                    let travel = src.c.travel + fp.c.travel;
                    let away = src.away + fp.away;
                    if let Some(c) = Contact::new(surface, mid_uv, travel) {
                        let mfp = FrontPoint { c, away };
                        let m = offset_point(surface, s, region, coverage, front_id, &mfp)?;
                        pts.push((m, c.travel));
                    }
                }
            }
        }
        pts.push((o, fp.c.travel));
    }
    Ok(pts)
}

/// Longest loop of an offset front, in cutter radii, that [`without_loops`]
/// cuts out.
const MAX_LOOP_SPAN: f64 = 8.0;

/// Cuts the loops out of the offset points: where the offsets of two legs
/// of a concave front corner cross, the points between the crossing
/// segments lie inside the strip of the other leg (a swallowtail), and the
/// new front is the polyline through the crossing point, a sharp corner.
/// Loops up to [`MAX_LOOP_SPAN`] radii of polyline (the swallowtail of one
/// corner); the advance test of [`without_swallowtails`] misses a loop whose
/// points still advance along the travel smoothed over 0.4 R, and the
/// corner it leaves turns back on itself.
fn without_loops(surface: &NurbsSurface, s: &PassSettings, mut pts: Vec<Carried>) -> Vec<Carried> {
    let max_span = MAX_LOOP_SPAN * s.cutter.radius;
    let mut xyz: Vec<Point3<f64>> = pts
        .iter()
        .map(|(o, _)| surface.point(o.uv.x, o.uv.y))
        .collect();
    let mut i = 0;
    while i + 3 < pts.len() {
        let (a, b) = (pts[i].0.uv, pts[i + 1].0.uv);
        let mut span = (xyz[i + 1] - xyz[i]).norm();
        let mut cut = None;
        for j in i + 2..pts.len() - 1 {
            span += (xyz[j] - xyz[j - 1]).norm();
            if span > max_span {
                break;
            }
            if let Some(t) = segment_crossing(a, b, pts[j].0.uv, pts[j + 1].0.uv) {
                cut = Some((j, t));
                break;
            }
        }
        let Some((j, t)) = cut else {
            i += 1;
            continue;
        };
        // The loop's points i + 1 ..= j go; the crossing point takes their
        // place, needed where any of them was.
        let needed = pts[i..=j].iter().any(|(o, _)| o.needed);
        let (o, travel) = pts[i];
        let uv = a + (b - a) * t;
        let corner = Offset {
            uv,
            away: pts[j + 1].0.away + o.away,
            needed,
            clipped: false,
            at_edge: false,
            dist: o.dist + (pts[i + 1].0.dist - o.dist) * t,
        };
        pts.splice(i + 1..=j, [(corner, travel)]);
        xyz.splice(i + 1..=j, [surface.point(uv.x, uv.y)]);
        i += 1;
    }
    pts
}

/// Removes swallowtails: a point that does not advance along the travel.
fn without_swallowtails(
    surface: &NurbsSurface,
    s: &PassSettings,
    pts: Vec<Carried>,
) -> Vec<Carried> {
    let mut kept: Vec<Carried> = Vec::with_capacity(pts.len());
    for (o, t) in pts {
        if let Some((last, _)) = kept.last() {
            let a = surface.point(last.uv.x, last.uv.y);
            let b = surface.point(o.uv.x, o.uv.y);
            let adv = (b - a).dot(&t);
            if adv <= 1e-3 * s.scallop.max(1e-6) {
                // Keep the needed flag of the dropped point alive.
                if o.needed {
                    if let Some(l) = kept.last_mut() {
                        l.0.needed = true;
                    }
                }
                continue;
            }
        }
        kept.push((o, t));
    }
    kept
}

/// Clipped points are not pass points; their need passes to the neighbours,
/// which mark the run's end at the edge.
fn drop_clipped(mut kept: Vec<Carried>) -> Vec<Carried> {
    for k in 0..kept.len() {
        let (clipped, needed) = (kept[k].0.clipped, kept[k].0.needed);
        if !clipped {
            continue;
        }
        for m in [k.checked_sub(1), Some(k + 1)].into_iter().flatten() {
            if let Some((o, _)) = kept.get_mut(m) {
                o.at_edge = true;
                o.needed |= needed;
            }
        }
    }
    kept.retain(|(o, _)| !o.clipped);
    kept
}

/// The next pass's front from one run of needed offset points (extended by one
/// neighbour at both ends): smoothed, pulled in, extended to the region's
/// edges and re-contacted, in travel order. `None` for a fragment.
fn run_front(
    surface: &NurbsSurface,
    s: &PassSettings,
    region: &Region,
    (coverage, front_id): (&Coverage, usize),
    front: &[FrontPoint],
    run: &[Carried],
) -> Result<Option<Vec<FrontPoint>>> {
    // A run shorter than the cutter diameter inside the surface is a
    // fragment of a folding front: its direction is not to be trusted
    // for extending and offsetting it again (that cascades into
    // crossing passes); what it would cut is left to the gap passes.
    // At the surface edge a short run is a corner's last pass: kept.
    let span: f64 = run
        .windows(2)
        .map(|w| {
            let (p, q) = (w[0].0.uv, w[1].0.uv);
            (surface.point(q.x, q.y) - surface.point(p.x, p.y)).norm()
        })
        .sum();
    let at_edge = run.iter().any(|(o, _)| o.at_edge);
    if run.len() < 2 || !(span >= MIN_RUN_SPAN * s.cutter.radius || at_edge) {
        return Ok(None);
    }
    let keep = smooth_indices(
        surface,
        &run.iter().map(|(o, _)| o.uv).collect::<Vec<_>>(),
        2.0 * s.point_step,
    );
    let sel: Vec<&Carried> = keep.iter().map(|&k| &run[k]).collect();
    let mut uv: Vec<Vector2<f64>> = sel.iter().map(|(o, _)| o.uv).collect();
    let mut aways: Vec<Vector3<f64>> = sel.iter().map(|(o, _)| o.away).collect();
    let mut travels: Vec<Vector3<f64>> = sel.iter().map(|(_, t)| *t).collect();
    let dists: Vec<f64> = sel.iter().map(|(o, _)| o.dist).collect();
    pull_in(
        surface,
        front,
        &mut uv,
        &mut aways,
        &mut travels,
        &dists,
        region,
    );
    // A run that ends inside the region ends at machined material (its
    // next offset points are not needed): its extension stops in there.
    let cut = |p: Point3<f64>, dir: Vector3<f64>| -> Option<f64> {
        if let Some((along, w)) = coverage.covering(p, front_id) {
            return Some(through_cut_budget(s, dir, along, w));
        }
        coverage.on_seam(p, front_id).then_some(s.cutter.radius)
    };
    let (head, tail) = extend_ends(surface, s, region, &mut uv, Some(&cut));
    let (first, last) = (&run[0], &run[run.len() - 1]);
    for _ in 0..head {
        aways.insert(0, first.0.away);
    }
    for _ in 0..tail {
        aways.push(last.0.away);
    }
    // The new pass travels against the current one (zig-zag).
    let mut reference: Vec<Vector3<f64>> = vec![-first.1; head];
    reference.extend(travels.iter().map(|t| -t));
    reference.extend(std::iter::repeat_n(-last.1, tail));
    let contacts = pass_contacts(s, front_from_uv(surface, s, &uv, Some(&reference))?);
    if contacts.len() < 2 {
        return Ok(None);
    }
    let mut next: Vec<FrontPoint> = Vec::with_capacity(contacts.len());
    let first_at = first_index_of_each(&uv);
    for c in contacts {
        // The carried direction of the nearest offset point, made
        // perpendicular to the new travel.
        let k = nearest_index(&uv, &first_at, c.uv());
        let mut away = c.cross();
        if away.dot(&aways[k]) < 0.0 {
            away = -away;
        }
        next.push(FrontPoint { c, away });
    }
    // Travel order: reverse so the pass runs along its travel.
    next.reverse();
    Ok(Some(next))
}

/// The first index of every point of `uv` (by its bits, -0 as +0).
fn first_index_of_each(uv: &[Vector2<f64>]) -> HashMap<[u64; 2], usize> {
    let mut first = HashMap::with_capacity(uv.len());
    for (k, p) in uv.iter().enumerate() {
        first.entry(uv_bits(*p)).or_insert(k);
    }
    first
}

fn uv_bits(p: Vector2<f64>) -> [u64; 2] {
    [(p.x + 0.0).to_bits(), (p.y + 0.0).to_bits()]
}

/// Index of the point of `uv` nearest to `q` (the first of equals), `first_at`
/// from [`first_index_of_each`]. A contact lies on its own polyline point, so
/// the answer is usually the first point equal to `q` (distance 0): found by
/// its bits instead of a search over the polyline. Only where a coordinate
/// is so near 0 that a distinct point's squared distance could underflow
/// to 0 too (so an earlier one would tie), or `q` is on no point, it searches.
fn nearest_index(
    uv: &[Vector2<f64>],
    first_at: &HashMap<[u64; 2], usize>,
    q: Vector2<f64>,
) -> usize {
    const TINY: f64 = 1e-100;
    if q.x.abs() >= TINY && q.y.abs() >= TINY {
        if let Some(&k) = first_at.get(&uv_bits(q)) {
            return k;
        }
    }
    uv.iter()
        .enumerate()
        .min_by(|x, y| (x.1 - q).norm().total_cmp(&(y.1 - q).norm()))
        .map_or(0, |(k, _)| k)
}

/// Nearest point of the front polyline to `p`: (distance, uv there), `None`
/// where that is an end of the front (beyond its ends the pass's run-in
/// and run-out cover, not an offset).
pub(super) fn nearest_on_front(
    front_xyz: &[nalgebra::Point3<f64>],
    front_uv: &[Vector2<f64>],
    p: &nalgebra::Point3<f64>,
) -> Option<(f64, Vector2<f64>)> {
    let mut best: Option<(f64, usize)> = None;
    for k in 0..front_xyz.len() {
        let dist = front_segment(front_xyz, k, p).0;
        if best.is_none_or(|(bd, _)| dist < bd) {
            best = Some((dist, k));
        }
    }
    nearest_result(front_xyz, front_uv, p, best?.1)
}

/// Segment `k` of a front (from point k to k + 1; the last is the point
/// itself): the distance of `p` from it and the parameter of its nearest
/// point.
fn front_segment(
    front_xyz: &[nalgebra::Point3<f64>],
    k: usize,
    p: &nalgebra::Point3<f64>,
) -> (f64, f64) {
    let a = front_xyz[k];
    let b = front_xyz.get(k + 1).copied().unwrap_or(a);
    let f = segment_parameter(a, b, *p);
    ((a + (b - a) * f - p).norm(), f)
}

/// [`nearest_on_front`]'s answer when segment `k` is the nearest (the
/// first of the nearest): `None` past either end of the front.
fn nearest_result(
    front_xyz: &[nalgebra::Point3<f64>],
    front_uv: &[Vector2<f64>],
    p: &nalgebra::Point3<f64>,
    k: usize,
) -> Option<(f64, Vector2<f64>)> {
    let last = front_xyz.len().saturating_sub(1);
    let (dist, f) = front_segment(front_xyz, k, p);
    let (ua, ub) = (
        front_uv[k],
        front_uv.get(k + 1).copied().unwrap_or(front_uv[k]),
    );
    let at_end = (k == 0 && f <= 0.0) || (k + 1 >= last && f >= 1.0) || last == 0;
    (!at_end).then_some((dist, ua + (ub - ua) * f))
}

/// The segments of a front in a bounding-box tree, so that a nearest-point
/// query scans only the leaves whose box lies near enough.
pub(super) struct FrontIndex<'a> {
    xyz: &'a [nalgebra::Point3<f64>],
    uv: &'a [Vector2<f64>],
    /// Segment k (points k and k + 1; the last the point itself) is item k.
    tree: BoxTree<3>,
    /// Every front point finite (else queries scan every segment).
    finite: bool,
}

fn finite(q: &nalgebra::Point3<f64>) -> bool {
    q.x.is_finite() && q.y.is_finite() && q.z.is_finite()
}

impl<'a> FrontIndex<'a> {
    pub(super) fn new(xyz: &'a [nalgebra::Point3<f64>], uv: &'a [Vector2<f64>]) -> Self {
        let at = |k: usize| {
            let q = xyz[k.min(xyz.len() - 1)];
            [q.x, q.y, q.z]
        };
        let boxes: Vec<_> = (0..xyz.len())
            .map(|k| segment_box(&at(k), &at(k + 1)))
            .collect();
        Self {
            xyz,
            uv,
            tree: BoxTree::new(&boxes),
            finite: xyz.iter().all(finite),
        }
    }

    /// [`nearest_on_front`]: the same segment (the first of the nearest)
    /// and the same answer. A node whose box lies farther than the nearest
    /// segment found so far (with margins far beyond rounding: 1e-9 of it
    /// and 1e-9 mm) cannot hold a segment as near, so it is not searched;
    /// the nearer child by its box is searched first.
    pub(super) fn nearest(&self, p: &nalgebra::Point3<f64>) -> Option<(f64, Vector2<f64>)> {
        let n = self.xyz.len();
        if n == 0 || !self.finite || !finite(p) {
            return nearest_on_front(self.xyz, self.uv, p);
        }
        let q = [p.x, p.y, p.z];
        let best: Cell<Option<(f64, usize)>> = Cell::new(None);
        self.tree.search(
            |lo, hi| {
                let d = box_dist2(lo, hi, &q).sqrt();
                let far = best
                    .get()
                    .is_some_and(|(bd, _)| d > bd * (1.0 + 1e-9) + 1e-9);
                (!far).then_some(d)
            },
            |ks| {
                for &k in ks {
                    let k = k as usize;
                    let dist = front_segment(self.xyz, k, p).0;
                    // The first of the nearest, in front order.
                    if best
                        .get()
                        .is_none_or(|(bd, bk)| dist < bd || (dist == bd && k < bk))
                    {
                        best.set(Some((dist, k)));
                    }
                }
                false
            },
        );
        nearest_result(self.xyz, self.uv, p, best.get()?.1)
    }
}

/// Where the new pass (points `uv`, each offset `dists[k]` from its source)
/// lies farther from the current pass than the two half-widths allow, it
/// is pulled in: points and, recursively, chord midpoints are moved towards
/// their nearest point on the current pass to that distance. Lee's point
/// offsets leave such gaps at the inner side of pass corners (the offsets
/// of the two legs cross and the loop between them is cut out) and between
/// offset points that spread apart; a gap there is a scallop above h.
pub(super) fn pull_in(
    surface: &NurbsSurface,
    front: &[FrontPoint],
    uv: &mut Vec<Vector2<f64>>,
    aways: &mut Vec<Vector3<f64>>,
    travels: &mut Vec<Vector3<f64>>,
    dists: &[f64],
    region: &Region,
) {
    pub(super) const SLACK: f64 = 1.01;
    pub(super) const MAX_PULL: f64 = 1.35;
    pub(super) const DEPTH: usize = 5;
    let _ = region;
    let front_xyz: Vec<_> = front.iter().map(|f| f.c.point()).collect();
    let front_uv: Vec<_> = front.iter().map(|f| f.c.uv()).collect();
    let index = FrontIndex::new(&front_xyz, &front_uv);
    let pull = |q: Vector2<f64>, r: f64| -> Option<Vector2<f64>> {
        let p = surface.point(q.x, q.y);
        let (d, s_uv) = index.nearest(&p)?;
        // A gap wider than a third of the spacing is not a chord between
        // neighbouring offsets (the front ends or folds there): left alone.
        if d <= r * SLACK || d <= 0.0 || d > r * MAX_PULL {
            return None;
        }
        // Linear in (u, v) between the nearest front point and q, then
        // corrected once with the distance actually reached.
        let mut f = r / d;
        let mut m = s_uv + (q - s_uv) * f;
        for _ in 0..2 {
            let pm = surface.point(m.x, m.y);
            let dm = (pm - surface.point(s_uv.x, s_uv.y)).norm();
            if dm <= 0.0 {
                break;
            }
            f *= r / dm;
            m = s_uv + (q - s_uv) * f;
        }
        let (u, v) = surface.clamp_uv(m.x, m.y);
        Some(Vector2::new(u, v))
    };
    let n = uv.len();
    let mut out_uv = Vec::with_capacity(n);
    let mut out_away = Vec::with_capacity(n);
    let mut out_travel = Vec::with_capacity(n);
    for k in 0..n {
        let r = dists.get(k).copied().unwrap_or(0.0);
        // The offset points themselves lie at their distance from their
        // source point, so at most that far from the front.
        let q = uv[k];
        if k > 0 {
            // Chord midpoints between the previous (already placed) point and this one.
            let r_seg = dists[k - 1].min(r);
            let a = out_uv.last().copied().unwrap_or(q);
            let mut mids = Vec::new();
            subdivide(&pull, a, q, r_seg, DEPTH, &mut mids);
            for m in mids {
                out_uv.push(m);
                out_away.push(aways[k]);
                out_travel.push(travels[k]);
            }
        }
        out_uv.push(q);
        out_away.push(aways[k]);
        out_travel.push(travels[k]);
    }
    // Pulled points must still advance along the travel (no back-steps).
    let mut keep = vec![true; out_uv.len()];
    let mut last: Option<nalgebra::Point3<f64>> = None;
    for k in 0..out_uv.len() {
        let p = surface.point(out_uv[k].x, out_uv[k].y);
        if let Some(a) = last {
            if (p - a).dot(&out_travel[k]) <= 1e-6 {
                keep[k] = false;
                continue;
            }
        }
        last = Some(p);
    }
    let mut it = keep.iter();
    out_uv.retain(|_| *it.next().unwrap_or(&true));
    let mut it = keep.iter();
    out_away.retain(|_| *it.next().unwrap_or(&true));
    let mut it = keep.iter();
    out_travel.retain(|_| *it.next().unwrap_or(&true));
    *uv = out_uv;
    *aways = out_away;
    *travels = out_travel;
}

/// Pulled-in midpoints between `a` and `b`, in order.
pub(super) fn subdivide(
    pull: &dyn Fn(Vector2<f64>, f64) -> Option<Vector2<f64>>,
    a: Vector2<f64>,
    b: Vector2<f64>,
    r: f64,
    depth: usize,
    out: &mut Vec<Vector2<f64>>,
) {
    if depth == 0 {
        return;
    }
    let m = (a + b) * 0.5;
    if let Some(p) = pull(m, r) {
        subdivide(pull, a, p, r, depth - 1, out);
        out.push(p);
        subdivide(pull, p, b, r, depth - 1, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;
    use toolpath_kernel::rng::XorShift;

    #[test]
    fn front_index_finds_the_segment_the_full_scan_finds() {
        // Fronts that fold back over themselves (ties between segments at
        // the same distance) and query points on, near and far from them.
        let mut rng = XorShift(0x2545_f491_4f6c_dd1d);
        let mut next = || rng.unit();
        let mut answered = 0;
        for n in [1, 2, 7, 8, 9, 17, 64, 301] {
            let xyz: Vec<Point3<f64>> = (0..n)
                .map(|k| {
                    let t = k as f64 / 10.0;
                    // A zig-zag: points k and n - 1 - k mirror each other.
                    Point3::new(
                        20.0 * t.sin(),
                        (k % 16) as f64 * 0.5 + next() * 0.01,
                        t.cos(),
                    )
                })
                .collect();
            let uv: Vec<Vector2<f64>> = (0..n).map(|k| Vector2::new(k as f64, next())).collect();
            let index = FrontIndex::new(&xyz, &uv);
            for q in 0..400 {
                let p = if q % 4 == 0 {
                    // On a front point: distance 0, ties with its neighbours.
                    xyz[q % n]
                } else {
                    Point3::new(
                        25.0 * (2.0 * next() - 1.0),
                        10.0 * next() - 1.0,
                        2.0 * next() - 1.0,
                    )
                };
                let want = nearest_on_front(&xyz, &uv, &p);
                let got = index.nearest(&p);
                assert_eq!(
                    got.map(|(d, w)| (d.to_bits(), w.x.to_bits(), w.y.to_bits())),
                    want.map(|(d, w)| (d.to_bits(), w.x.to_bits(), w.y.to_bits())),
                    "front of {n}, query {q} at {p:?}"
                );
                answered += usize::from(want.is_some());
            }
        }
        assert!(answered > 1000, "{answered}");
    }

    /// The raw offsets of a concave L corner on the plane (legs along +x at
    /// y = 0 and along +y at x = 50 mm, covered side inside the L, offset
    /// 3 mm): the horizontal leg's offsets run past the corner to x = 50,
    /// the vertical leg's start below y = 3. The front left is the offset L
    /// itself, through its exact corner (47, 3) mm, with no crossing; the
    /// advance test alone leaves the jog to x = 49.7 and back (a corner
    /// that turns back on itself, as on suite seed 2 at h = 0.055).
    #[test]
    fn a_concave_corner_offsets_to_one_sharp_corner() {
        let surface = toolpath_samples::surfaces::plane();
        let job = toolpath_samples::job("plane").unwrap();
        let s = PassSettings::from_job(&job).unwrap();
        let carried = |x: f64, y: f64, travel: Vector3<f64>, needed: bool| -> Carried {
            let o = Offset {
                uv: Vector2::new(x / 100.0, y / 100.0),
                away: Vector3::new(-travel.y, travel.x, 0.0),
                needed,
                clipped: false,
                at_edge: false,
                dist: 3.0,
            };
            (o, travel)
        };
        let mut pts: Vec<Carried> = (0..=71)
            .map(|k| carried(0.7 * k as f64, 3.0, Vector3::x(), false))
            .collect();
        // Only points inside the other leg's reach are needed: the corner
        // takes over their need.
        pts.extend((0..=70).map(|k| carried(47.0, 0.3 + 0.7 * k as f64, Vector3::y(), k < 3)));
        let mm = |o: &Offset| (100.0 * o.uv.x, 100.0 * o.uv.y);
        let on_l = |(x, y): (f64, f64)| {
            ((y - 3.0).abs() < 1e-9 && x <= 47.0 + 1e-9)
                || ((x - 47.0).abs() < 1e-9 && y >= 3.0 - 1e-9)
        };
        let simple = |pts: &[Carried]| {
            (0..pts.len() - 1).all(|i| {
                (i + 2..pts.len() - 1).all(|j| {
                    let uv = |k: usize| pts[k].0.uv;
                    segment_crossing(uv(i), uv(i + 1), uv(j), uv(j + 1)).is_none()
                })
            })
        };
        let plain = without_swallowtails(&surface, &s, pts.clone());
        assert!(
            plain.iter().any(|(o, _)| !on_l(mm(o))),
            "the advance test alone left no jog"
        );

        let cut = without_loops(&surface, &s, pts);
        assert!(simple(&cut), "the front still crosses itself");
        for (o, _) in &cut {
            assert!(on_l(mm(o)), "{:?} is off the offset L", mm(o));
        }
        let corner = cut
            .iter()
            .find(|(o, _)| {
                let (x, y) = mm(o);
                (x - 47.0).hypot(y - 3.0) < 1e-9
            })
            .expect("no point at the corner (47, 3)");
        assert!(
            corner.0.needed,
            "the corner lost the need of the loop's points"
        );
        // What the loop removal leaves, the advance test keeps.
        assert_eq!(
            without_swallowtails(&surface, &s, cut.clone()).len(),
            cut.len()
        );
    }

    /// A pass running into machined material ends there: its extension
    /// runs a cutter radius through the earlier strips and stops, where
    /// without them it runs its whole 4 R (across the strips of a finished
    /// front, as on suite seed 2 at h = 0.055).
    #[test]
    fn extension_stops_a_cutter_radius_inside_machined_material() {
        let surface = toolpath_samples::surfaces::plane();
        let job = toolpath_samples::job("plane").unwrap();
        let s = PassSettings::from_job(&job).unwrap();
        let r = s.cutter.radius;
        let region = crate::strip_width::regions::whole_domain(&surface);
        let uv = |x: f64, y: f64| Vector2::new(x / 100.0, y / 100.0);
        // Earlier passes along +x, 2 mm apart, filling y = 30 .. 50 mm.
        let mut coverage = Coverage::new(&s, FOLD_SHARE);
        for (id, y) in (0..=10).map(|k| 30.0 + 2.0 * k as f64).enumerate() {
            let contacts: Vec<Contact> = (0..=100)
                .map(|x| Contact::new(&surface, uv(x as f64, y), Vector3::x()).unwrap())
                .collect();
            coverage.add(&s, id, &contacts);
        }
        let cut = |p: Point3<f64>, _: Vector3<f64>| coverage.covered(p, usize::MAX).then_some(r);
        for x in [20.0, 47.3, 80.0] {
            // A pass heading down (-y) that ends 3 mm above the strips, its
            // points 1 mm apart (the head is at the top).
            let line: Vec<Vector2<f64>> = (0..=20).map(|k| uv(x, 73.0 - k as f64)).collect();
            let tail_of = |with_cut: bool| {
                let mut l = line.clone();
                let stop: Option<&CutBudget<'_>> = with_cut.then_some(&cut);
                let (_, tail) = extend_ends(&surface, &s, &region, &mut l, stop);
                let pts: Vec<Point3<f64>> = l[l.len() - tail - 1..]
                    .iter()
                    .map(|p| surface.point(p.x, p.y))
                    .collect();
                pts
            };
            let length =
                |pts: &[Point3<f64>]| -> f64 { pts.windows(2).map(|w| (w[1] - w[0]).norm()).sum() };
            let free = tail_of(false);
            assert!(
                (length(&free) - 4.0 * r).abs() <= s.point_step.min(r) + 1e-9,
                "x {x}: {} mm without the earlier strips",
                length(&free)
            );
            let stopped = tail_of(true);
            let first_cut = stopped
                .iter()
                .position(|p| cut(*p, Vector3::zeros()).is_some())
                .expect("the extension reaches the earlier strips");
            let inside = length(&stopped[first_cut..]);
            assert!(
                inside >= r - 1e-9 && inside <= r + s.point_step.min(r) + 1e-9,
                "x {x}: ran {inside} mm through the earlier strips (R {r})"
            );
            assert!(length(&stopped) < length(&free), "x {x}");
        }
    }

    /// The budget through an earlier strip follows the angle the pass meets
    /// it at: w cot(a), none where it meets the strip square, at most R.
    #[test]
    fn through_cut_budget_follows_the_meeting_angle() {
        let job = toolpath_samples::job("plane").unwrap();
        let s = PassSettings::from_job(&job).unwrap();
        let r = s.cutter.radius;
        let w = 1.5;
        let along = Vector3::x();
        for deg in [90.0f64, 75.0, 60.0, 45.0, 30.0, 20.0, 5.0, 0.0] {
            let a = deg.to_radians();
            let dir = Vector3::new(a.cos(), -a.sin(), 0.0);
            let budget = through_cut_budget(&s, dir, along, w);
            // Independently: the strip's far corner trails its centre by
            // w / tan(a) along the pass.
            let want = if deg == 0.0 { r } else { (w / a.tan()).min(r) };
            assert!(
                (budget - want).abs() < 1e-9,
                "{deg} deg: {budget} mm, want {want}"
            );
            // Heading the other way along the strip changes nothing.
            assert!((through_cut_budget(&s, -dir, along, w) - budget).abs() < 1e-12);
        }
    }

    /// A front whose corner point alone lands on cut material stays one
    /// run: gaps of not-needed points shorter than MIN_RUN_SPAN radii
    /// between needed points are bridged; longer gaps, and the not-needed
    /// points before the first and after the last needed one, are kept.
    #[test]
    fn short_gaps_between_needed_points_are_bridged() {
        let surface = toolpath_samples::surfaces::plane();
        let job = toolpath_samples::job("plane").unwrap();
        let s = PassSettings::from_job(&job).unwrap();
        let span = MIN_RUN_SPAN * s.cutter.radius;
        // Points 0.5 mm apart along x at y = 50 (the plane is 100 mm square).
        let carried = |needed: &[bool]| -> Vec<Carried> {
            needed
                .iter()
                .enumerate()
                .map(|(k, &n)| {
                    let o = Offset {
                        uv: Vector2::new((10.0 + 0.5 * k as f64) / 100.0, 0.5),
                        away: Vector3::y(),
                        needed: n,
                        clipped: false,
                        at_edge: false,
                        dist: 3.0,
                    };
                    (o, Vector3::x())
                })
                .collect()
        };
        // A gap of g not-needed points spans (g + 1) * 0.5 mm between the
        // needed points on its sides.
        for g in 1..40usize {
            let mut pattern = vec![false; 3];
            pattern.extend([true; 5]);
            pattern.extend(vec![false; g]);
            pattern.extend([true; 5]);
            pattern.extend([false; 3]);
            let mut kept = carried(&pattern);
            bridge_short_gaps(&surface, &s, &mut kept);
            let got: Vec<bool> = kept.iter().map(|(o, _)| o.needed).collect();
            let bridged = (g as f64 + 1.0) * 0.5 < span;
            let mut want = pattern.clone();
            if bridged {
                want[8..8 + g].iter_mut().for_each(|n| *n = true);
            }
            assert_eq!(got, want, "gap of {g} points, bridged {bridged}");
        }
    }
}
