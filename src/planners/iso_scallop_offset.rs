//! Lee-style iso-scallop offsetting (Lee 1998, methods.md A), shared by
//! `iso_scallop` (the whole surface as one region, from a boundary curve) and
//! `tensor_regions` (per region, from the pass through its widest-strip
//! point). Each point of the current pass is carried across the feed, on the
//! surface, to where the current pass's half-width on that side and the next
//! pass's half-width on the other side meet at the scallop height. Passes run
//! zig-zag; a point of the next pass is kept while the strip edge of the
//! current pass still leaves region material uncut.

use super::partition::Region;
use super::pass_points::{extend_pass, walk_on_surface as walk, Contact, PassSettings};
use crate::error::{Error, Result};
use crate::formats::Pass;
use crate::geometry::NurbsSurface;
use nalgebra::{Vector2, Vector3};

/// A point of a pass front: its contact and the unit tangent pointing to
/// the side still to be covered.
#[derive(Clone, Copy, Debug)]
struct FrontPoint {
    c: Contact,
    away: Vector3<f64>,
}

/// Passes cannot exceed this count per region (a guard against runaway offsetting).
const MAX_PASSES: usize = 5_000;

/// Whether `travel` is within 30 deg of the domain edge through `uv`.
fn runs_along_boundary(surface: &NurbsSurface, uv: Vector2<f64>, travel: Vector3<f64>) -> bool {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let d = surface.derivs(uv.x, uv.y);
    let tol = 1e-9 * ((u1 - u0) + (v1 - v0));
    let mut edges = Vec::new();
    if (uv.x - u0).abs() <= tol || (uv.x - u1).abs() <= tol {
        edges.push(d.sv);
    }
    if (uv.y - v0).abs() <= tol || (uv.y - v1).abs() <= tol {
        edges.push(d.su);
    }
    edges.iter().any(|e| {
        let n = e.norm() * travel.norm();
        n > 0.0 && (e.dot(&travel) / n).abs() > 30f64.to_radians().cos()
    })
}

fn singular(uv: Vector2<f64>) -> Error {
    Error::planning(format!(
        "the surface is singular at uv ({:.4}, {:.4}): no normal there",
        uv.x, uv.y
    ))
}

/// One offset point: where the next pass goes from `fp`, and whether it is needed.
struct Offset {
    uv: Vector2<f64>,
    away: Vector3<f64>,
    needed: bool,
    /// The walk hit the domain boundary: the point is not a pass point (the
    /// pass is extended to the boundary along its own direction instead).
    clipped: bool,
    /// Distance walked from the front point, mm (the two half-widths).
    dist: f64,
}

fn offset_point(
    surface: &NurbsSurface,
    s: &PassSettings,
    region: &Region,
    fp: &FrontPoint,
) -> Result<Offset> {
    let w_here = fp.c.half_width_towards(s, fp.away)?;
    let mut dist = 2.0 * w_here;
    let mut end = walk(surface, fp.c.uv(), fp.away, dist).ok_or_else(|| singular(fp.c.uv()))?;
    for _ in 0..3 {
        let q = Contact::new(surface, end.0, -fp.c.travel).ok_or_else(|| singular(end.0))?;
        let w_there = q.half_width_towards(s, -end.1)?;
        let new_dist = w_here + w_there;
        let settled = (new_dist - dist).abs() < 1e-4;
        dist = new_dist;
        end = walk(surface, fp.c.uv(), fp.away, dist).ok_or_else(|| singular(fp.c.uv()))?;
        if settled || end.2 {
            break;
        }
    }
    // Is there region material beyond this pass's strip edge?
    let edge =
        walk(surface, fp.c.uv(), fp.away, w_here * 0.98).ok_or_else(|| singular(fp.c.uv()))?;
    let needed = (!edge.2 && region.contains(edge.0)) || (!end.2 && region.contains(end.0));
    // A point stopped by the boundary is a pass point only where the pass
    // runs along that boundary (the last pass of a side); where the pass
    // meets the boundary at an angle, it ends there instead.
    let clipped = end.2 && !runs_along_boundary(surface, end.0, fp.c.travel);
    Ok(Offset {
        uv: end.0,
        away: end.1,
        needed,
        clipped,
        dist,
    })
}

/// Covers `region` with passes offset from `initial` (a uv polyline in the
/// travel direction of the first pass), to both sides. Passes are returned
/// in machining order (outermost of one side first) with `region` set.
pub fn cover(
    surface: &NurbsSurface,
    s: &PassSettings,
    region: &Region,
    initial: &[Vector2<f64>],
) -> Result<Vec<Pass>> {
    let mut initial = initial.to_vec();
    extend_ends(surface, s, region, &mut initial);
    let first = front_from_uv(surface, &initial, None)?;
    if first.len() < 2 {
        return Ok(Vec::new());
    }
    let mut sides: Vec<Vec<Vec<Contact>>> = Vec::new();
    let mut total = 0usize;
    for side in [1.0, -1.0] {
        let mut done: Vec<Vec<Contact>> = Vec::new();
        let start: Vec<FrontPoint> = first
            .iter()
            .map(|c| FrontPoint {
                c: *c,
                away: c.cross() * side,
            })
            .collect();
        let mut queue = vec![start];
        while let Some(front) = queue.pop() {
            for run in offset_front(surface, s, region, &front)? {
                total += 1;
                if total > MAX_PASSES {
                    return Err(Error::planning(format!(
                        "region {} needs more than {MAX_PASSES} passes: the scallop is too small for the surface",
                        region.id
                    )));
                }
                done.push(run.iter().map(|f| f.c).collect());
                queue.push(run);
            }
        }
        sides.push(done);
    }
    let mut passes = Vec::new();
    let to_pass = |contacts: &[Contact]| -> Result<Pass> {
        let mut pass = Pass {
            region: region.id,
            points: Vec::with_capacity(contacts.len() + 1),
            min_strip_width: None,
        };
        let mut prev: Option<Contact> = None;
        for c in contacts {
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
            prev = Some(*c);
        }
        extend_pass(surface, &mut pass.points, s)?;
        Ok(pass)
    };
    for run in sides[0].iter().rev() {
        passes.push(to_pass(run)?);
    }
    passes.push(to_pass(&first)?);
    for run in &sides[1] {
        passes.push(to_pass(run)?);
    }
    Ok(passes)
}

/// Where the travel turns sharply between two contacts (a corner of an
/// offset pass), the tool swivels about the second contact in steps of at
/// most 5 deg: with the lead angle tied to the travel, jumping the tilt
/// across one straight motion would drag the cutter edge off the contact.
fn pivot(
    a: &Contact,
    b: &Contact,
    s: &PassSettings,
    out: &mut Vec<crate::formats::PathPoint>,
) -> Result<()> {
    let cos = a.travel.dot(&b.travel).clamp(-1.0, 1.0);
    let angle = cos.acos();
    let max_step = 5f64.to_radians();
    if angle <= 2.0 * max_step {
        return Ok(());
    }
    let steps = (angle / max_step).ceil() as usize;
    for k in 1..steps {
        let f = k as f64 / steps as f64;
        // Rotate a's travel towards b's in b's tangent plane.
        let t = a.travel * (1.0 - f) + b.travel * f;
        let t = if t.norm() < 1e-9 { b.cross() } else { t };
        if let Some(c) = Contact::from_geometry(b.g, t) {
            out.push(c.path_point(s)?);
        }
    }
    Ok(())
}

/// Contacts along a uv polyline, travelling along it; `reference` orients
/// the travel (None: the polyline's own order).
fn front_from_uv(
    surface: &NurbsSurface,
    uv: &[Vector2<f64>],
    reference: Option<&[Vector3<f64>]>,
) -> Result<Vec<Contact>> {
    let xyz: Vec<_> = uv.iter().map(|p| surface.point(p.x, p.y)).collect();
    let n = uv.len();
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
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
fn smooth_indices(surface: &NurbsSurface, uv: &[Vector2<f64>], max_chord: f64) -> Vec<usize> {
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

/// Extends a pass polyline at both ends along its own direction on the
/// surface, to the domain boundary or until it has run the cutter radius
/// beyond the region, so that the strip covers the region up to its
/// boundary even where the pass meets it obliquely. Returns the number of
/// points added at the head and the tail.
fn extend_ends(
    surface: &NurbsSurface,
    s: &PassSettings,
    region: &Region,
    uv: &mut Vec<Vector2<f64>>,
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
        // The gap to close is at most about a strip width: never extend
        // further (a short run's direction is not to be trusted far).
        let mut budget = 2.0 * s.cutter.radius;
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
fn offset_front(
    surface: &NurbsSurface,
    s: &PassSettings,
    region: &Region,
    front: &[FrontPoint],
) -> Result<Vec<Vec<FrontPoint>>> {
    // Offsets of the front points, with midpoints inserted where the new
    // pass would be too sparse or deviate from its chords.
    let mut pts: Vec<(Offset, Vector3<f64>)> = Vec::with_capacity(front.len());
    for (i, fp) in front.iter().enumerate() {
        let o = offset_point(surface, s, region, fp)?;
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
                        let m = offset_point(surface, s, region, &mfp)?;
                        pts.push((m, c.travel));
                    }
                }
            }
        }
        pts.push((o, fp.c.travel));
    }
    // Remove swallowtails: a point that does not advance along the travel.
    let mut kept: Vec<(Offset, Vector3<f64>)> = Vec::with_capacity(pts.len());
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
    // Runs of needed points, each extended by one neighbour at both ends.
    // Clipped points are not pass points; their need passes to the neighbours.
    for k in 0..kept.len() {
        if kept[k].0.clipped && kept[k].0.needed {
            if k > 0 {
                kept[k - 1].0.needed = true;
            }
            if k + 1 < kept.len() {
                kept[k + 1].0.needed = true;
            }
        }
    }
    kept.retain(|(o, _)| !o.clipped);
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
        if b > a {
            let keep = smooth_indices(
                surface,
                &kept[a..=b].iter().map(|(o, _)| o.uv).collect::<Vec<_>>(),
                2.0 * s.point_step,
            );
            let sel: Vec<&(Offset, Vector3<f64>)> = keep.iter().map(|&k| &kept[a + k]).collect();
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
            let (head, tail) = extend_ends(surface, s, region, &mut uv);
            let t0 = kept[a].1;
            let t1 = kept[b].1;
            for _ in 0..head {
                aways.insert(0, kept[a].0.away);
            }
            for _ in 0..tail {
                aways.push(kept[b].0.away);
            }
            // The new pass travels against the current one (zig-zag).
            let mut reference: Vec<Vector3<f64>> = vec![-t0; head];
            reference.extend(travels.iter().map(|t| -t));
            reference.extend(std::iter::repeat_n(-t1, tail));
            let contacts = front_from_uv(surface, &uv, Some(&reference))?;
            if contacts.len() >= 2 {
                let mut run: Vec<FrontPoint> = Vec::with_capacity(contacts.len());
                for c in contacts {
                    // The carried direction of the nearest offset point, made
                    // perpendicular to the new travel.
                    let k = uv
                        .iter()
                        .enumerate()
                        .min_by(|x, y| (x.1 - c.uv()).norm().total_cmp(&(y.1 - c.uv()).norm()))
                        .map_or(0, |(k, _)| k);
                    let mut away = c.cross();
                    if away.dot(&aways[k]) < 0.0 {
                        away = -away;
                    }
                    run.push(FrontPoint { c, away });
                }
                // Travel order: reverse so the pass runs along its travel.
                run.reverse();
                runs.push(run);
            }
        }
        i = j + 1;
    }
    Ok(runs)
}

/// Nearest point of the front polyline to `p`: (distance, uv there), `None`
/// where that is an end of the front (beyond its ends the pass's run-in
/// and run-out cover, not an offset).
fn nearest_on_front(
    front_xyz: &[nalgebra::Point3<f64>],
    front_uv: &[Vector2<f64>],
    p: &nalgebra::Point3<f64>,
) -> Option<(f64, Vector2<f64>)> {
    let mut best: Option<(f64, Vector2<f64>, bool)> = None;
    let last = front_xyz.len().saturating_sub(1);
    for k in 0..front_xyz.len() {
        let (a, ua) = (front_xyz[k], front_uv[k]);
        let (b, ub) = if k + 1 < front_xyz.len() {
            (front_xyz[k + 1], front_uv[k + 1])
        } else {
            (a, ua)
        };
        let d = b - a;
        let dd = d.norm_squared();
        let f = if dd > 0.0 {
            ((p - a).dot(&d) / dd).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let dist = (a + d * f - p).norm();
        let at_end = (k == 0 && f <= 0.0) || (k + 1 >= last && f >= 1.0) || last == 0;
        if best.is_none_or(|(bd, _, _)| dist < bd) {
            best = Some((dist, ua + (ub - ua) * f, at_end));
        }
    }
    best.and_then(|(d, uv, at_end)| (!at_end).then_some((d, uv)))
}

/// Where the new pass (points `uv`, each offset `dists[k]` from its source)
/// lies farther from the current pass than the two half-widths allow, it
/// is pulled in: points and, recursively, chord midpoints are moved towards
/// their nearest point on the current pass to that distance. Lee's point
/// offsets leave such gaps at the inner side of pass corners (the offsets
/// of the two legs cross and the loop between them is cut out) and between
/// offset points that spread apart; a gap there is a scallop above h.
fn pull_in(
    surface: &NurbsSurface,
    front: &[FrontPoint],
    uv: &mut Vec<Vector2<f64>>,
    aways: &mut Vec<Vector3<f64>>,
    travels: &mut Vec<Vector3<f64>>,
    dists: &[f64],
    region: &Region,
) {
    const SLACK: f64 = 1.01;
    const MAX_PULL: f64 = 1.35;
    const DEPTH: usize = 5;
    let _ = region;
    let front_xyz: Vec<_> = front.iter().map(|f| f.c.point()).collect();
    let front_uv: Vec<_> = front.iter().map(|f| f.c.uv()).collect();
    let pull = |q: Vector2<f64>, r: f64| -> Option<Vector2<f64>> {
        let p = surface.point(q.x, q.y);
        let (d, s_uv) = nearest_on_front(&front_xyz, &front_uv, &p)?;
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
fn subdivide(
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
