//! Which parts of a region the passes so far leave uncut: the strips of the
//! passes in a spatial hash, the samples of a front beyond every strip, and
//! the gap lines that start the passes over uncut material (docs/methods.md,
//! "Iso-scallop offsetting").

use super::*;
use crate::strip_width::passes::{walk_on_surface as walk, Contact, PassSettings};
use crate::strip_width::regions::partition::{inside_of_row, row_crossings};
use crate::strip_width::regions::Region;
use nalgebra::{Point3, Vector2, Vector3};
use std::cell::Cell;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};
use toolpath_formats::Pass;
use toolpath_kernel::geometry::NurbsSurface;

/// The strips of the passes placed so far in a region, so that an offset
/// point is kept only where material is still uncut: where a front folds
/// back over machined area (strongly varying widths make passes fan out),
/// region containment alone would offset it forever.
pub(super) struct Coverage {
    pub(super) cell: f64,
    /// Share of a pass's half-width within which material counts as cut.
    pub(super) share: f64,
    /// Segment ends, the smaller half-width at its ends, the pass it belongs to.
    pub(super) segments: Vec<(Point3<f64>, Point3<f64>, f64, usize)>,
    /// Per segment, the contacts (uv, feed) at its ends where both are
    /// contacts of their own (not run-ins, run-outs or carried widths): what
    /// [`Coverage::covered_sided`] measures the half-width on a side from.
    pub(super) contacts: Vec<Option<[StripContact; 2]>>,
    /// Per segment, the box [`Coverage::covered`] rejects points outside
    /// of, and the pass it belongs to: stored once at insertion, since a
    /// lookup scans every segment listed in a cell and most fail this test.
    pub(super) quick: Vec<QuickBox>,
    /// The segment that last covered a point in [`Coverage::covered`],
    /// tried first for the next point (samples come in rows, so the same
    /// strip usually covers the next one too).
    last_hit: Cell<Option<usize>>,
    pub(super) grid: HashMap<[i64; 3], Vec<usize>, BuildHasherDefault<CellHasher>>,
}

impl Coverage {
    pub(super) fn new(s: &PassSettings, share: f64) -> Self {
        Self {
            cell: 2.0 * s.cutter.radius * share.max(1.0),
            share,
            segments: Vec::new(),
            contacts: Vec::new(),
            quick: Vec::new(),
            last_hit: Cell::new(None),
            grid: HashMap::default(),
        }
    }

    pub(super) fn key(&self, p: Point3<f64>) -> [i64; 3] {
        [
            floor_i64(p.x / self.cell),
            floor_i64(p.y / self.cell),
            floor_i64(p.z / self.cell),
        ]
    }

    /// Adds pass `id`'s strip; points where no width can be given add nothing.
    pub(super) fn add(&mut self, s: &PassSettings, id: usize, contacts: &[Contact]) {
        let half = |c: &Contact| -> Option<(Point3<f64>, f64)> {
            let a = c.half_width_towards(s, c.cross()).ok()?;
            let b = c.half_width_towards(s, -c.cross()).ok()?;
            Some((c.point(), a.min(b)))
        };
        let strip: Vec<StripPoint> = contacts
            .iter()
            .filter_map(half)
            .map(|(p, w)| (p, w, None))
            .collect();
        self.add_points(id, &strip);
    }

    /// Adds pass `id`'s strip from its points and half-widths.
    pub(super) fn add_points(&mut self, id: usize, strip: &[StripPoint]) {
        for k in 1..strip.len() {
            let ((a, wa, ca), (b, wb, cb)) = (strip[k - 1], strip[k]);
            if !(wa > 0.0 && wb > 0.0) {
                continue;
            }
            let w = wa.min(wb);
            let index = self.segments.len();
            self.segments.push((a, b, w, id));
            self.contacts.push(ca.zip(cb).map(|(ca, cb)| [ca, cb]));
            self.quick.push(QuickBox::new(a, b, self.share * w, id));
            let (k0, k1) = self.cells_of(index);
            for i in k0[0]..=k1[0] {
                for j in k0[1]..=k1[1] {
                    for l in k0[2]..=k1[2] {
                        self.grid.entry([i, j, l]).or_default().push(index);
                    }
                }
            }
        }
    }

    /// The range of grid cells segment `index` is listed in.
    #[inline]
    fn cells_of(&self, index: usize) -> ([i64; 3], [i64; 3]) {
        let (a, b, w, _) = self.segments[index];
        let (lo, hi) = (a.inf(&b), a.sup(&b));
        // Every point the sided test may count lies within the pad.
        let pad = Vector3::repeat(w * SIDED_REACH * self.share.max(1.0));
        (self.key(lo - pad), self.key(hi + pad))
    }

    /// Whether segment `i` covers `p` for [`Coverage::covered`].
    #[inline]
    fn covers(&self, i: usize, p: Point3<f64>, exclude: usize) -> bool {
        let q = &self.quick[i];
        if q.id == exclude || !q.holds(p) {
            return false;
        }
        let (a, b, _, _) = self.segments[i];
        (a + (b - a) * segment_parameter(a, b, p) - p).norm() < q.reach
    }

    /// The first strip other than `exclude`'s that covers `p` (as in
    /// [`Self::covered`]): its unit direction and half-width.
    pub(super) fn covering(&self, p: Point3<f64>, exclude: usize) -> Option<(Vector3<f64>, f64)> {
        let list = self.grid.get(&self.key(p))?;
        let &i = list.iter().find(|&&i| self.covers(i, p, exclude))?;
        let (a, b, w, _) = self.segments[i];
        Some(((b - a).try_normalize(1e-300)?, w))
    }

    /// Unit direction of the strip segment nearest to `p` within reach.
    pub(super) fn nearest_direction(&self, p: Point3<f64>) -> Option<Vector3<f64>> {
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
    pub(super) fn covered(&self, p: Point3<f64>, exclude: usize) -> bool {
        let key = self.key(p);
        // The last covering segment first: if it is listed in p's cell and
        // covers p, the scan of the list would say so too.
        if let Some(i) = self.last_hit.get() {
            let (k0, k1) = self.cells_of(i);
            if (0..3).all(|d| (k0[d]..=k1[d]).contains(&key[d])) && self.covers(i, p, exclude) {
                return true;
            }
        }
        let Some(list) = self.grid.get(&key) else {
            return false;
        };
        match list.iter().find(|&&i| self.covers(i, p, exclude)) {
            Some(&i) => {
                self.last_hit.set(Some(i));
                true
            }
            None => false,
        }
    }

    /// Whether `p` lies on the seam of two strips other than `exclude`'s:
    /// between two passes whose strips meet there, its distances to them,
    /// each over that strip's half-width, summing to at most twice
    /// [`GAP_SHARE`]. [`Self::covered`] asks for well inside one strip, so
    /// the line where two neighbouring strips meet counts as uncut to it;
    /// there both passes cut (the nearer within [`GAP_SHARE`] of its
    /// half-width), and a front of another family crossing those strips
    /// must not be offset along each seam.
    pub(super) fn on_seam(&self, p: Point3<f64>, exclude: usize) -> bool {
        let Some(list) = self.grid.get(&self.key(p)) else {
            return false;
        };
        let limit = 2.0 * GAP_SHARE;
        // The two nearest passes, by distance over half-width.
        let mut near: [(usize, f64); 2] = [(usize::MAX, limit); 2];
        for &i in list {
            let (a, b, w, id) = self.segments[i];
            if id == exclude || w <= 0.0 {
                continue;
            }
            let reach = limit * w;
            if (0..3).any(|k| p[k] < a[k].min(b[k]) - reach || p[k] > a[k].max(b[k]) + reach) {
                continue;
            }
            let d = (a + (b - a) * segment_parameter(a, b, p) - p).norm() / w;
            if id == near[0].0 {
                near[0].1 = near[0].1.min(d);
            } else if id == near[1].0 {
                near[1].1 = near[1].1.min(d);
            } else if d < near[1].1 {
                near[1] = (id, d);
            }
            if near[1].1 < near[0].1 {
                near.swap(0, 1);
            }
        }
        near[1].0 != usize::MAX && near[0].1 + near[1].1 < limit
    }

    /// [`Self::covered`] by any pass, and where that fails, with the
    /// half-width on `p`'s side of each strip within reach: a strip is
    /// symmetric (the mean half-width) only to the quick test, but the twist
    /// of the surface makes one side wider than the other
    /// (`sided_coverage_counts_the_wider_side_only`), and a point beyond the
    /// mean but within its side's width is cut. The side's width is the
    /// smaller at the segment's two contacts. On the narrow side the quick
    /// test counts up to the mean: the 0.9 h spacing and the simulator's
    /// repair passes hold h there (docs/methods.md, "Iso-scallop offsetting").
    pub(super) fn covered_sided(
        &self,
        surface: &NurbsSurface,
        s: &PassSettings,
        p: Point3<f64>,
    ) -> bool {
        if self.covered(p, usize::MAX) {
            return true;
        }
        let Some(list) = self.grid.get(&self.key(p)) else {
            return false;
        };
        list.iter().any(|&i| {
            let (a, b, w, _) = self.segments[i];
            let Some(Some(ends)) = self.contacts.get(i) else {
                return false;
            };
            let foot = a + (b - a) * segment_parameter(a, b, p);
            let dist = (foot - p).norm();
            if dist >= SIDED_REACH * self.share * w {
                return false;
            }
            let side = |(uv, feed): StripContact| -> Option<f64> {
                Contact::new(surface, uv, feed)?
                    .half_width_towards(s, p - foot)
                    .ok()
            };
            match (side(ends[0]), side(ends[1])) {
                (Some(wa), Some(wb)) => dist < self.share * wa.min(wb),
                _ => false,
            }
        })
    }
}

/// `x.floor() as i64` (saturating, 0 for NaN) without the call to libm's
/// floor, which the baseline x86-64 target does not inline: the truncation
/// is exact, and one less where it rounded a negative fraction up.
#[inline]
fn floor_i64(x: f64) -> i64 {
    let t = x as i64;
    if (t as f64) > x {
        t.saturating_sub(1)
    } else {
        t
    }
}

/// A strip segment's box grown by a little more than its reach (the share
/// of its half-width within which a point counts as cut): beyond it the
/// distance is surely beyond the reach, so [`Coverage::covered`] gives the
/// same answer as its exact test without the division and root.
pub(super) struct QuickBox {
    lo: [f64; 3],
    hi: [f64; 3],
    reach: f64,
    id: usize,
}

impl QuickBox {
    fn new(a: Point3<f64>, b: Point3<f64>, reach: f64, id: usize) -> Self {
        let far = 1.001 * reach;
        Self {
            lo: [0, 1, 2].map(|k| a[k].min(b[k]) - far),
            hi: [0, 1, 2].map(|k| a[k].max(b[k]) + far),
            reach,
            id,
        }
    }

    fn holds(&self, p: Point3<f64>) -> bool {
        !(0..3).any(|k| p[k] < self.lo[k] || p[k] > self.hi[k])
    }
}

/// A contact of a strip: its uv and feed direction.
pub(super) type StripContact = (Vector2<f64>, Vector3<f64>);

/// A strip point: cc, half-width for the quick test, and the contact where
/// the point is a contact of its own.
pub(super) type StripPoint = (Point3<f64>, f64, Option<StripContact>);

/// How far beyond the quick test's reach [`Coverage::covered_sided`] looks
/// for a wider side: sides differ by far less than this.
const SIDED_REACH: f64 = 1.5;

/// A multiply-rotate hash of a grid cell's key: the grid is only looked up,
/// never iterated, so the hash decides speed, not results, and a cheap one
/// suffices (SipHash guards against hostile keys, which these are not).
#[derive(Default)]
pub(super) struct CellHasher(u64);

impl Hasher for CellHasher {
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }
    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(5) ^ x).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    fn write_usize(&mut self, x: usize) {
        self.write_u64(x as u64);
    }
    fn finish(&self) -> u64 {
        self.0
    }
}

/// Share of an earlier pass's half-width within which an offset point
/// counts as cut (well inside: fronts that only touch are still offset).
pub(super) const FOLD_SHARE: f64 = 0.9;
/// Share of the half-widths beyond which material counts as missed by all
/// passes: neighbouring strips meet at their half-widths, so a point
/// farther than this from every pass is a gap, not a scallop ridge.
pub(super) const GAP_SHARE: f64 = 1.04;

/// The contact points of a pass with their smaller half-width (run-in and
/// run-out points carry their neighbour's).
pub(super) fn strip_of(pass: &Pass) -> Vec<StripPoint> {
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
        // A contact of its own: a width of its own and a feed.
        let contact = p.strip_width.and(p.feed);
        let contact = contact.map(|f| (Vector2::from(p.uv), Vector3::from(f)));
        out.push((Point3::from(p.cc), 0.5 * w, contact));
    }
    out
}

/// Points of the region, about a quarter cutter radius apart, that no
/// strip covers, in a fixed order.
pub(super) fn uncut_samples(
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
    // The region's boundary crossings of each row of samples, once: the
    // inside test of a sample is then a count over a few of them.
    let rows: Vec<(f64, Vec<f64>)> = (0..=nv)
        .map(|j| {
            let y = lo.y + (hi.y - lo.y) * j as f64 / nv as f64;
            let mut crossings = Vec::new();
            row_crossings(&region.boundary_uv, y, &mut crossings);
            (y, crossings)
        })
        .collect();
    let mut out = Vec::new();
    for i in 0..=nu {
        let x = lo.x + (hi.x - lo.x) * i as f64 / nu as f64;
        for (y, crossings) in &rows {
            let uv = Vector2::new(x, *y);
            if inside_of_row(crossings, x)
                && !reached.covered_sided(surface, s, surface.point(uv.x, uv.y))
            {
                out.push(uv);
            }
        }
    }
    out
}

/// A short pass through the uncut point `uv`: along the nearest strip's
/// direction (else the surface's minimum-curvature direction), both ways
/// until covered material or the region's end, then run on like any pass end.
pub(super) fn gap_line(
    surface: &NurbsSurface,
    s: &PassSettings,
    region: &Region,
    reached: &Coverage,
    uv: Vector2<f64>,
) -> Option<Vec<Vector2<f64>>> {
    let g = toolpath_kernel::geometry::LocalGeometry::at(surface, uv.x, uv.y)?;
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
            if clipped || !region.contains(next) || reached.covered_sided(surface, s, q) {
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
    extend_ends(surface, s, region, &mut line, None);
    Some(line)
}

#[cfg(test)]
mod tests {
    use super::*;
    use toolpath_kernel::geometry::interpolation::interpolate_height_field;
    use toolpath_kernel::rng::XorShift;
    use toolpath_kernel::tools::lead_cutter::LeadCutter;

    /// Between two strips that meet, every point counts as on their seam
    /// (though well inside neither near the seam); between strips a gap
    /// apart, and beyond a lone strip's edge, none does.
    #[test]
    fn seams_are_where_two_strips_meet() {
        let surface = toolpath_samples::surfaces::plane();
        let job = toolpath_samples::job("plane").unwrap();
        let s = PassSettings::from_job(&job).unwrap();
        let uv = |x: f64, y: f64| Vector2::new(x / 100.0, y / 100.0);
        let strip = |y: f64| -> Vec<Contact> {
            (0..=100)
                .map(|x| Contact::new(&surface, uv(x as f64, y), Vector3::x()).unwrap())
                .collect()
        };
        let w = strip(50.0)[0].half_width_towards(&s, Vector3::y()).unwrap();
        let at = |x: f64, y: f64| surface.point(x / 100.0, y / 100.0);
        for (spacing, meet) in [(2.0 * w, true), (1.9 * w, true), (2.3 * w, false)] {
            let mut coverage = Coverage::new(&s, FOLD_SHARE);
            coverage.add(&s, 1, &strip(40.0));
            coverage.add(&s, 2, &strip(40.0 + spacing));
            for k in 0..=20 {
                let y = 40.0 + spacing * k as f64 / 20.0;
                for x in [13.0, 50.25, 87.0] {
                    let p = at(x, y);
                    if coverage.covered(p, usize::MAX) {
                        continue;
                    }
                    assert_eq!(
                        coverage.on_seam(p, usize::MAX),
                        meet,
                        "spacing {spacing:.3} (w {w:.3}), y {y:.3}"
                    );
                    // Excluding either strip leaves one: no seam.
                    assert!(!coverage.on_seam(p, 1) && !coverage.on_seam(p, 2));
                }
            }
            // Beyond the outer edges there is one strip only.
            for y in [40.0 - 1.01 * w, 40.0 + spacing + 1.01 * w] {
                assert!(!coverage.on_seam(at(50.0, y), usize::MAX), "y {y}");
            }
        }
    }

    #[test]
    fn floor_i64_is_floor_as_i64() {
        let mut cases = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            -1.0 - f64::EPSILON,
            -1e-300,
            2.5e15 + 0.5,
            -2.5e15 - 0.5,
            9.007_199_254_740_993e15,
            -9.007_199_254_740_993e15,
            9.3e18,
            -9.3e18,
            f64::MAX,
            f64::MIN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        // Pseudo-random values over many scales, with both signs.
        let mut rng = XorShift(0x2545_f491_4f6c_dd1d);
        for _ in 0..10_000 {
            let state = rng.next_u64();
            let mantissa = (state >> 11) as f64 / (1u64 << 53) as f64;
            let scale = 10f64.powi((state % 40) as i32 - 20);
            let sign = if state & 1 == 0 { 1.0 } else { -1.0 };
            cases.push(sign * mantissa * scale);
        }
        for x in cases {
            assert_eq!(floor_i64(x), x.floor() as i64, "{x:e}");
        }
    }

    fn settings() -> PassSettings {
        PassSettings {
            cutter: LeadCutter {
                radius: 2.5,
                lead: 5f64.to_radians(),
                ball: false,
            },
            scallop: 0.045,
            chord_tolerance: 0.0025,
            max_step: 5.0,
            point_step: 1.0,
            estimate: false,
        }
    }

    /// A pass along the x axis of z = c x y (no curvature along it, a twist
    /// across it): the trailing rim rises on one side and falls on the
    /// other, so the two half-widths differ. A point beyond the mean
    /// half-width but within its side's counts as cut on the wider side
    /// only, and every point the sided test counts lies within that side's
    /// width of the pass.
    #[test]
    fn sided_coverage_counts_the_wider_side_only() {
        let c = 6e-3;
        let surface = interpolate_height_field(
            move |x, y| c * x * y,
            (-30.0, 30.0),
            (-30.0, 30.0),
            (3, 3),
            (3, 3),
        )
        .unwrap();
        let s = settings();
        let uv_of = |x: f64, y: f64| Vector2::new((x + 30.0) / 60.0, (y + 30.0) / 60.0);
        let travel = Vector3::x();
        let contacts: Vec<Contact> = (-10..=10)
            .map(|i| Contact::new(&surface, uv_of(i as f64, 0.0), travel).unwrap())
            .collect();
        let mut reached = Coverage::new(&s, GAP_SHARE);
        let strip: Vec<StripPoint> = contacts
            .iter()
            .map(|k| {
                let w = s.cutter.strip_width(s.scallop, k.k).unwrap();
                (k.point(), 0.5 * w, Some((k.uv(), k.travel)))
            })
            .collect();
        reached.add_points(0, &strip);
        let mid = Contact::new(&surface, uv_of(0.0, 0.0), travel).unwrap();
        let plus = mid.half_width_towards(&s, mid.cross()).unwrap();
        let minus = mid.half_width_towards(&s, -mid.cross()).unwrap();
        let mean = 0.5 * (plus + minus);
        assert!((plus - minus).abs() > 0.05 * mean, "sides {plus} {minus}");
        let (wide, narrow) = if plus > minus {
            (1.0, -1.0)
        } else {
            (-1.0, 1.0)
        };
        // The cross direction at the x axis is +-y (the surface is level there).
        let at = |side: f64, d: f64| {
            let y = side * mid.cross().y.signum() * d;
            surface.point(uv_of(0.0, y).x, uv_of(0.0, y).y)
        };
        let beyond_mean = 0.5 * (GAP_SHARE * mean + GAP_SHARE * plus.max(minus));
        assert!(!reached.covered(at(wide, beyond_mean), usize::MAX));
        assert!(reached.covered_sided(&surface, &s, at(wide, beyond_mean)));
        assert!(!reached.covered_sided(&surface, &s, at(narrow, GAP_SHARE * mean)));
        // Scan both sides: the wide side counts to its own width, the narrow
        // one to the symmetric test's mean (never to the wide side's width).
        for k in 0..200 {
            let d = 2.0 * plus.max(minus) * k as f64 / 200.0;
            for (side, w) in [(wide, plus.max(minus)), (narrow, mean)] {
                let p = at(side, d);
                let dist = (p - mid.point()).norm();
                let expected = dist < 0.999 * GAP_SHARE * w;
                if expected || dist > 1.001 * GAP_SHARE * w {
                    assert_eq!(
                        reached.covered_sided(&surface, &s, p),
                        expected,
                        "side {side}: {dist} vs {w}"
                    );
                }
            }
        }
    }
}
