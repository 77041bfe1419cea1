//! Lee-style iso-scallop offsetting (Lee 1998, methods.md A), shared by
//! `iso_scallop` (the whole surface as one region, from a boundary curve) and
//! `tensor_regions` (per region, from the pass through its widest-strip
//! point). Each point of the current pass is carried across the feed, on the
//! surface, to where the current pass's half-width on that side and the next
//! pass's half-width on the other side meet at the scallop height. Passes run
//! zig-zag; a point of the next pass is kept while the strip edge of the
//! current pass still leaves region material uncut.

use super::partition::Region;
use super::pass_points::{edges_at, extend_pass, walk_on_surface as walk, Contact, PassSettings};
use crate::error::{Error, Result};
use crate::formats::Pass;
use crate::geometry::NurbsSurface;
use nalgebra::{Point3, Vector2, Vector3};
use std::collections::BTreeMap;

/// A point of a pass front: its contact and the unit tangent pointing to
/// the side still to be covered.
#[derive(Clone, Copy, Debug)]
struct FrontPoint {
    c: Contact,
    away: Vector3<f64>,
}

/// Offset runs shorter than this many cutter radii are not passes.
const MIN_RUN_SPAN: f64 = 2.0;

/// Passes cannot exceed this count per region (a guard against runaway offsetting).
const MAX_PASSES: usize = 5_000;

/// Whether `travel` is within 30 deg of a domain edge through `uv` that a
/// walk heading `exit` (3-D tangent) leaves the domain through. Only the
/// edge that stopped the walk counts: at a corner, an offset stopped by the
/// edge across the pass is not a point of a pass along the other edge (it
/// was, and every pass after it then hooked round into that edge).
fn runs_along_boundary(
    surface: &NurbsSurface,
    uv: Vector2<f64>,
    exit: Vector3<f64>,
    travel: Vector3<f64>,
) -> bool {
    let Some(g) = crate::geometry::LocalGeometry::at(surface, uv.x, uv.y) else {
        return false;
    };
    let Some(t) = travel.try_normalize(1e-300) else {
        return false;
    };
    edges_at(surface, uv, Some(g.tangent_to_uv(exit)))
        .iter()
        .any(|e| e.dot(&t).abs() > 30f64.to_radians().cos())
}

/// The strips of the passes placed so far in a region, so that an offset
/// point is kept only where material is still uncut: where a front folds
/// back over machined area (strongly varying widths make passes fan out),
/// region containment alone would offset it forever.
struct Coverage {
    cell: f64,
    /// Share of a pass's half-width within which material counts as cut.
    share: f64,
    /// Segment ends, the smaller half-width at its ends, the pass it belongs to.
    segments: Vec<(Point3<f64>, Point3<f64>, f64, usize)>,
    grid: BTreeMap<[i64; 3], Vec<usize>>,
}

impl Coverage {
    fn new(s: &PassSettings, share: f64) -> Self {
        Self {
            cell: 2.0 * s.cutter.radius * share.max(1.0),
            share,
            segments: Vec::new(),
            grid: BTreeMap::new(),
        }
    }

    fn key(&self, p: Point3<f64>) -> [i64; 3] {
        [
            (p.x / self.cell).floor() as i64,
            (p.y / self.cell).floor() as i64,
            (p.z / self.cell).floor() as i64,
        ]
    }

    /// Adds pass `id`'s strip; points where no width can be given add nothing.
    fn add(&mut self, s: &PassSettings, id: usize, contacts: &[Contact]) {
        let half = |c: &Contact| -> Option<(Point3<f64>, f64)> {
            let a = c.half_width_towards(s, c.cross()).ok()?;
            let b = c.half_width_towards(s, -c.cross()).ok()?;
            Some((c.point(), a.min(b)))
        };
        let strip: Vec<(Point3<f64>, f64)> = contacts.iter().filter_map(half).collect();
        self.add_points(id, &strip);
    }

    /// Adds pass `id`'s strip from its points and half-widths.
    fn add_points(&mut self, id: usize, strip: &[(Point3<f64>, f64)]) {
        for k in 1..strip.len() {
            let ((a, wa), (b, wb)) = (strip[k - 1], strip[k]);
            if !(wa > 0.0 && wb > 0.0) {
                continue;
            }
            let w = wa.min(wb);
            let index = self.segments.len();
            self.segments.push((a, b, w, id));
            let (lo, hi) = (a.inf(&b), a.sup(&b));
            let pad = Vector3::repeat(w);
            let (k0, k1) = (self.key(lo - pad), self.key(hi + pad));
            for i in k0[0]..=k1[0] {
                for j in k0[1]..=k1[1] {
                    for l in k0[2]..=k1[2] {
                        self.grid.entry([i, j, l]).or_default().push(index);
                    }
                }
            }
        }
    }

    /// Unit direction of the strip segment nearest to `p` within reach.
    fn nearest_direction(&self, p: Point3<f64>) -> Option<Vector3<f64>> {
        let k = self.key(p);
        let mut best: Option<(f64, Vector3<f64>)> = None;
        for i in -1..=1 {
            for j in -1..=1 {
                for l in -1..=1 {
                    let Some(list) = self.grid.get(&[k[0] + i, k[1] + j, k[2] + l]) else {
                        continue;
                    };
                    for &index in list {
                        let (a, b, _, _) = self.segments[index];
                        let d = b - a;
                        let dd = d.norm_squared();
                        if dd <= 0.0 {
                            continue;
                        }
                        let f = segment_parameter(a, b, p);
                        let dist = (a + d * f - p).norm();
                        if best.is_none_or(|(bd, _)| dist < bd) {
                            best = Some((dist, d / dd.sqrt()));
                        }
                    }
                }
            }
        }
        best.map(|(_, d)| d)
    }

    /// Whether `p` lies well inside the strip of a pass other than `exclude`.
    fn covered(&self, p: Point3<f64>, exclude: usize) -> bool {
        let Some(list) = self.grid.get(&self.key(p)) else {
            return false;
        };
        list.iter().any(|&i| {
            let (a, b, w, id) = self.segments[i];
            if id == exclude {
                return false;
            }
            (a + (b - a) * segment_parameter(a, b, p) - p).norm() < self.share * w
        })
    }
}

/// Share of an earlier pass's half-width within which an offset point
/// counts as cut (well inside: fronts that only touch are still offset).
const FOLD_SHARE: f64 = 0.9;
/// Share of the half-widths beyond which material counts as missed by all
/// passes: neighbouring strips meet at their half-widths, so a point
/// farther than this from every pass is a gap, not a scallop ridge.
const GAP_SHARE: f64 = 1.04;

/// Parameter in [0, 1] of the point of segment ab nearest to `p` (0 for a
/// degenerate segment).
fn segment_parameter(a: Point3<f64>, b: Point3<f64>, p: Point3<f64>) -> f64 {
    let d = b - a;
    let dd = d.norm_squared();
    if dd > 0.0 {
        ((p - a).dot(&d) / dd).clamp(0.0, 1.0)
    } else {
        0.0
    }
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

/// One offset point: where the next pass goes from `fp`, and whether it is needed.
struct Offset {
    uv: Vector2<f64>,
    away: Vector3<f64>,
    needed: bool,
    /// The walk hit the domain boundary: the point is not a pass point (the
    /// pass is extended to the boundary along its own direction instead).
    clipped: bool,
    /// The walk reached the domain boundary (this point or a clipped neighbour).
    at_edge: bool,
    /// Distance walked from the front point, mm (the two half-widths).
    dist: f64,
}

fn offset_point(
    surface: &NurbsSurface,
    s: &PassSettings,
    region: &Region,
    coverage: &Coverage,
    front_id: usize,
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
    let uncut = |(uv, _, clipped): (Vector2<f64>, Vector3<f64>, bool)| {
        !clipped && region.contains(uv) && !coverage.covered(surface.point(uv.x, uv.y), front_id)
    };
    let needed = uncut(edge) || uncut(end);
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
    let mut coverage = Coverage::new(s, FOLD_SHARE);
    coverage.add(s, 0, &first);
    for side in [1.0, -1.0] {
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
    let mut passes = Vec::new();
    let to_pass = |contacts: &[Contact]| -> Result<Pass> {
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
    };
    for run in sides[0].iter().rev() {
        passes.push(to_pass(run)?);
    }
    passes.push(to_pass(&first)?);
    for run in &sides[1] {
        passes.push(to_pass(run)?);
    }
    // Corners the offsetting leaves between pass ends, region boundaries
    // and fronts that split: short passes through what no strip reached.
    let mut reached = Coverage::new(s, GAP_SHARE);
    for (id, pass) in passes.iter().enumerate() {
        reached.add_points(id, &strip_of(pass));
    }
    for uv in uncut_samples(surface, s, region, &reached) {
        if reached.covered(surface.point(uv.x, uv.y), usize::MAX) {
            continue;
        }
        let Some(line) = gap_line(surface, s, region, &reached, uv) else {
            continue;
        };
        let contacts = front_from_uv(surface, &line, None)?;
        if contacts.len() < 2 {
            continue;
        }
        let pass = to_pass(&contacts)?;
        reached.add_points(passes.len(), &strip_of(&pass));
        passes.push(pass);
        if passes.len() > MAX_PASSES {
            return Err(too_many_passes(region));
        }
    }
    Ok(passes)
}

/// The contact points of a pass with their smaller half-width (run-in and
/// run-out points carry their neighbour's).
fn strip_of(pass: &Pass) -> Vec<(Point3<f64>, f64)> {
    let mut out = Vec::with_capacity(pass.points.len());
    let first = pass
        .points
        .iter()
        .find_map(|p| p.strip_width)
        .unwrap_or(0.0);
    let mut w = first;
    for p in &pass.points {
        if let Some(sw) = p.strip_width {
            w = sw;
        }
        out.push((Point3::from(p.cc), 0.5 * w));
    }
    out
}

/// Points of the region, about a quarter cutter radius apart, that no
/// strip covers, in a fixed order.
fn uncut_samples(
    surface: &NurbsSurface,
    s: &PassSettings,
    region: &Region,
    reached: &Coverage,
) -> Vec<Vector2<f64>> {
    let (lo, hi) = region.boundary_uv.iter().fold(
        (
            Vector2::repeat(f64::INFINITY),
            Vector2::repeat(f64::NEG_INFINITY),
        ),
        |(lo, hi), p| (lo.inf(p), hi.sup(p)),
    );
    if !(lo.x <= hi.x && lo.y <= hi.y) {
        return Vec::new();
    }
    // Sample counts from the longest iso-curve chords across the box.
    let chord = |a: Vector2<f64>, b: Vector2<f64>, n: usize| -> f64 {
        (0..n)
            .map(|k| {
                let (p, q) = (
                    a + (b - a) * (k as f64 / n as f64),
                    a + (b - a) * ((k + 1) as f64 / n as f64),
                );
                (surface.point(q.x, q.y) - surface.point(p.x, p.y)).norm()
            })
            .sum()
    };
    let spacing = 0.25 * s.cutter.radius;
    let mut len_u = 0.0f64;
    let mut len_v = 0.0f64;
    for f in [0.0, 0.5, 1.0] {
        let y = lo.y + (hi.y - lo.y) * f;
        let x = lo.x + (hi.x - lo.x) * f;
        len_u = len_u.max(chord(Vector2::new(lo.x, y), Vector2::new(hi.x, y), 16));
        len_v = len_v.max(chord(Vector2::new(x, lo.y), Vector2::new(x, hi.y), 16));
    }
    let nu = ((len_u / spacing).ceil() as usize).clamp(1, 4000);
    let nv = ((len_v / spacing).ceil() as usize).clamp(1, 4000);
    let mut out = Vec::new();
    for i in 0..=nu {
        for j in 0..=nv {
            let uv = Vector2::new(
                lo.x + (hi.x - lo.x) * i as f64 / nu as f64,
                lo.y + (hi.y - lo.y) * j as f64 / nv as f64,
            );
            if region.contains(uv) && !reached.covered(surface.point(uv.x, uv.y), usize::MAX) {
                out.push(uv);
            }
        }
    }
    out
}

/// A short pass through the uncut point `uv`: along the nearest strip's
/// direction (else the surface's minimum-curvature direction), both ways
/// until covered material or the region's end, then run on like any pass end.
fn gap_line(
    surface: &NurbsSurface,
    s: &PassSettings,
    region: &Region,
    reached: &Coverage,
    uv: Vector2<f64>,
) -> Option<Vec<Vector2<f64>>> {
    let g = crate::geometry::LocalGeometry::at(surface, uv.x, uv.y)?;
    let p = g.point();
    let dir = reached.nearest_direction(p).unwrap_or(g.dir_min);
    let step = s.point_step.min(0.5 * s.cutter.radius);
    let mut halves: Vec<Vec<Vector2<f64>>> = Vec::new();
    for sign in [-1.0, 1.0] {
        let mut at = uv;
        let mut d = dir * sign;
        let mut line = Vec::new();
        for _ in 0..((4.0 * s.cutter.radius / step).ceil() as usize) {
            let (next, nd, clipped) = walk(surface, at, d, step)?;
            if (next - at).norm() == 0.0 {
                break;
            }
            line.push(next);
            let q = surface.point(next.x, next.y);
            if clipped || !region.contains(next) || reached.covered(q, usize::MAX) {
                break;
            }
            at = next;
            d = nd;
        }
        halves.push(line);
    }
    let mut line: Vec<Vector2<f64>> = halves[0].iter().rev().copied().collect();
    line.push(uv);
    line.extend(halves[1].iter().copied());
    if line.len() < 2 {
        return None;
    }
    extend_ends(surface, s, region, &mut line);
    Some(line)
}

/// Least turn of a pass, deg, over a cutter radius either side of a
/// contact, that makes it a corner with a spike.
const SPIKE_MIN_TURN_DEG: f64 = 30.0;

/// Length of a corner spike in shifts of the corner that would close the
/// gap outside it by the discs' geometry, d (1 - s) / (2 s). Measured with
/// the simulator (tensor_regions, max scallop, with the tip sweep below):
/// on the anisotropic mould (`wing_mould`) 3 / 4 shifts 0.0551 / 0.0462 mm,
/// on the earlier nearly isotropic one 0.0493 either way.
const SPIKE_SHARE: f64 = 4.0;

/// Half-length of the sweep across a spike's tip, in cutter radii. At the
/// tip the tool moves along its own heading, so it cuts its full strip
/// width along the bisector there, reaching past the tip and to both sides
/// of it, where the material outside a corner spreads (most to one side
/// where the corners of successive passes do not line up along the
/// bisector). Measured as above on the anisotropic mould: 0.46 / 0.48 /
/// 0.5 / 0.6 / 0.8 R: 0.0551 / 0.0551 / 0.0462 / 0.0462 / 0.0462 mm; on the
/// second test surface (chevrons of about 105 deg) 0.6 R left 0.0649 mm
/// just beyond the sweep's end, 0.8 R 0.0496 (+0.9 % path on the mould).
/// The previous spike, four legs along the bisector a band (h / sin(lead))
/// apart, left 0.0597 on the mould: a tilted flat bottom moving sideways
/// cuts only the band behind its contact line, and spots were left just
/// beyond the outer legs.
const SPIKE_SWEEP_RADII: f64 = 0.8;

/// A corner spike: unit direction out of the corner and length, mm.
type Spike = (Vector3<f64>, f64);

/// Spikes at the sharp corners of a pass: (unit direction out of the
/// corner, length, mm) at the contact where the turn peaks. Outside a
/// corner whose legs meet at theta, the material next to the corner lies
/// farther than the half-width from this pass and from the neighbouring
/// pass across the corner: d / (1 + s) instead of d / 2 (s = sin(theta / 2),
/// d the strip width) when the neighbour is the exact offset (7 % at
/// 120 deg), more where it was itself smoothed. The tool runs out along the
/// corner's outer bisector and back.
fn corner_spikes(s: &PassSettings, contacts: &[Contact]) -> Result<Vec<Option<Spike>>> {
    let n = contacts.len();
    let r = s.cutter.radius;
    let xyz: Vec<Point3<f64>> = contacts.iter().map(|c| c.point()).collect();
    let turns: Vec<Option<(f64, Vector3<f64>)>> = (0..n)
        .map(|j| {
            // Near a pass end the leg is shorter than R but runs on in the
            // run-in or run-out along its own direction: a quarter R will do.
            let far = |k: usize| (xyz[j] - xyz[k]).norm() >= r;
            let end = |k: usize| (xyz[j] - xyz[k]).norm() >= 0.25 * r;
            let back = (0..j)
                .rev()
                .find(|&k| far(k))
                .or_else(|| (j > 0 && end(0)).then_some(0))?;
            let ahead = (j + 1..n)
                .find(|&k| far(k))
                .or_else(|| (j + 1 < n && end(n - 1)).then_some(n - 1))?;
            let d_in = (xyz[j] - xyz[back]).try_normalize(1e-12)?;
            let d_out = (xyz[ahead] - xyz[j]).try_normalize(1e-12)?;
            let turn = d_in.dot(&d_out).clamp(-1.0, 1.0).acos();
            let out = (d_in - d_out).try_normalize(1e-12)?;
            Some((turn, out))
        })
        .collect();
    let min_turn = SPIKE_MIN_TURN_DEG.to_radians();
    let mut spikes = vec![None; n];
    for j in 0..n {
        let Some((turn, out)) = turns[j] else {
            continue;
        };
        if turn < min_turn {
            continue;
        }
        // The peak of the turn within a cutter radius (first of equals).
        let peak = (0..n).all(|k| {
            k == j
                || (xyz[k] - xyz[j]).norm() >= r
                || turns[k].is_none_or(|(t, _)| t < turn || (t == turn && k > j))
        });
        if !peak {
            continue;
        }
        let half = 0.5 * turn;
        let sn = half.cos();
        let w = 2.0 * contacts[j].half_width_towards(s, out)?;
        spikes[j] = Some((out, SPIKE_SHARE * w * (1.0 - sn) / (2.0 * sn)));
    }
    Ok(spikes)
}

/// Contacts walked on the surface from `from` along `dir` for `dist` in
/// steps within the chord tolerance, travelling along `heading`; stops at
/// the domain edge.
fn walk_contacts(
    surface: &NurbsSurface,
    s: &PassSettings,
    from: Vector2<f64>,
    dir: Vector3<f64>,
    dist: f64,
    heading: Vector3<f64>,
) -> Vec<Contact> {
    let steps = ((dist / s.point_step).ceil() as usize).max(1);
    let mut path = Vec::with_capacity(steps);
    let (mut at, mut d) = (from, dir);
    for _ in 0..steps {
        let Some((next, nd, clipped)) = walk(surface, at, d, dist / steps as f64) else {
            break;
        };
        let Some(p) = Contact::new(surface, next, heading) else {
            break;
        };
        path.push(p);
        (at, d) = (next, nd);
        if clipped {
            break;
        }
    }
    path
}

/// Runs the tool out of a corner at `c` along `dir` (tangent) for `len` on
/// the surface, across the tip along its heading by `SPIKE_SWEEP_RADII`
/// each way and back, swivelling at `c` to the spike's heading and back.
fn spike(
    surface: &NurbsSurface,
    s: &PassSettings,
    c: &Contact,
    dir: Vector3<f64>,
    len: f64,
    out: &mut Vec<crate::formats::PathPoint>,
) -> Result<()> {
    // The tool keeps the corner's heading (across the spike, on the side
    // of the travel here): a sideways move of a few tenths of a mm, with no
    // swivel at its tip (a reversed heading would swing the lead-tilted
    // tool round the contact, 2 R of motion each way).
    let mut heading = c.g.n.cross(&dir);
    if heading.dot(&c.travel) < 0.0 {
        heading = -heading;
    }
    let Some(c_side) = Contact::from_geometry(c.g, heading) else {
        return Ok(());
    };
    // A ball (or an untilted flat end) cuts both sides of a move along
    // the bisector: no sweep.
    let sweep_across = !s.cutter.ball && s.cutter.lead > 0.0;
    let line = |from, d, dist| walk_contacts(surface, s, from, d, dist, heading);
    let leg = line(c.uv(), dir, len);
    pivot(c, &c_side, s, out)?;
    for p in &leg {
        out.push(p.path_point(s)?);
    }
    let tip = leg.last().copied().unwrap_or(c_side);
    if sweep_across {
        for side in [heading, -heading] {
            let sweep = line(tip.uv(), side, SPIKE_SWEEP_RADII * s.cutter.radius);
            for p in sweep.iter().chain(sweep.iter().rev().skip(1)) {
                out.push(p.path_point(s)?);
            }
            out.push(tip.path_point(s)?);
        }
    }
    for p in leg.iter().rev().skip(1) {
        out.push(p.path_point(s)?);
    }
    out.push(c_side.path_point(s)?);
    pivot(&c_side, c, s, out)?;
    out.push(c.path_point(s)?);
    Ok(())
}

/// Least turn of a pass, deg, within the lag of its strip edge ahead of a
/// contact, that makes the tool run on there before turning.
const RUN_ON_MIN_TURN_DEG: f64 = 8.0;

/// Lag of a tilted flat end's strip edge behind its contact, mm: the
/// disc's rim cuts the edge of the strip, at half-width w across, a lag
/// R - sqrt(R^2 - w^2) behind the contact (0 for a ball, whose strip edge is
/// level with the contact).
fn edge_lag(s: &PassSettings, c: &Contact, towards: Vector3<f64>) -> Result<f64> {
    if s.cutter.ball || s.cutter.lead <= 0.0 {
        return Ok(0.0);
    }
    let r = s.cutter.radius;
    let w = c.half_width_towards(s, towards)?.min(r);
    Ok(r - (r * r - w * w).max(0.0).sqrt())
}

/// Contacts where a pass starts to turn by more than
/// `RUN_ON_MIN_TURN_DEG` within the lag of its inner strip edge, with that
/// lag. Turning towards its inner side swings the rim's end there back,
/// so the strip's inner edge just before the turn falls short by about
/// lag x tan(turn) (0.16 mm at a 21 deg kink of an offset pass: 0.051 mm
/// between two kinked passes, by the simulator).
fn turn_starts(s: &PassSettings, contacts: &[Contact]) -> Result<Vec<Option<f64>>> {
    let n = contacts.len();
    let mut out = vec![None; n];
    let mut turning = false;
    for i in 0..n {
        let c = &contacts[i];
        let lag = edge_lag(s, c, c.cross())?.max(edge_lag(s, c, -c.cross())?);
        let turn = (i + 1..n)
            .find(|&k| (contacts[k].point() - c.point()).norm() >= lag)
            .filter(|_| lag > 0.0)
            .map(|k| (k, c.travel.dot(&contacts[k].travel).clamp(-1.0, 1.0).acos()))
            .filter(|&(_, t)| t > RUN_ON_MIN_TURN_DEG.to_radians());
        if let Some((k, _)) = turn {
            let inner = edge_lag(s, c, contacts[k].travel - c.travel)?;
            if !turning {
                out[i] = Some(inner);
            }
        }
        turning = turn.is_some();
    }
    Ok(out)
}

/// Runs the tool on from `c` along its travel by 1.5 `lag` and back, so
/// that the rim's inner end sweeps the strip edge up to the turn that
/// follows (`turn_starts`).
fn run_on(
    surface: &NurbsSurface,
    s: &PassSettings,
    c: &Contact,
    lag: f64,
    out: &mut Vec<crate::formats::PathPoint>,
) -> Result<()> {
    // In steps within the chord tolerance: one straight move would dip
    // below a surface convex along the travel.
    let path = walk_contacts(surface, s, c.uv(), c.travel, 1.5 * lag, c.travel);
    for p in path.iter().chain(path.iter().rev().skip(1)) {
        out.push(p.path_point(s)?);
    }
    if !path.is_empty() {
        out.push(c.path_point(s)?);
    }
    Ok(())
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
        // The gap to close is at most about a strip width across the pass:
        // along a pass meeting the boundary at 30 deg (below that, offset
        // points on the boundary are kept as pass points) twice that. Never
        // further: a short run's direction is not to be trusted far.
        let mut budget = 4.0 * s.cutter.radius;
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
    coverage: &Coverage,
    front_id: usize,
    front: &[FrontPoint],
) -> Result<Vec<Vec<FrontPoint>>> {
    // Offsets of the front points, with midpoints inserted where the new
    // pass would be too sparse or deviate from its chords.
    let mut pts: Vec<(Offset, Vector3<f64>)> = Vec::with_capacity(front.len());
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
        // A run shorter than the cutter diameter inside the surface is a
        // fragment of a folding front: its direction is not to be trusted
        // for extending and offsetting it again (that cascades into
        // crossing passes); what it would cut is left to the gap passes.
        // At the surface edge a short run is a corner's last pass: kept.
        let span: f64 = (a..b)
            .map(|k| {
                let (p, q) = (kept[k].0.uv, kept[k + 1].0.uv);
                (surface.point(q.x, q.y) - surface.point(p.x, p.y)).norm()
            })
            .sum();
        let at_edge = kept[a..=b].iter().any(|(o, _)| o.at_edge);
        if b > a && (span >= MIN_RUN_SPAN * s.cutter.radius || at_edge) {
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
        let f = segment_parameter(a, b, *p);
        let dist = (a + (b - a) * f - p).norm();
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
