//! Shared by the strip-width planners (iso_parametric, iso_scallop,
//! tensor_regions): tool poses along a pass of contact points, the widths each
//! pose leaves, and chord-tolerance sampling of a pass (docs/methods.md,
//! "Spacing margin and chord tolerance").

use super::width::{curvatures_along, cutter_of_job, gouge_error, Curvatures, WidthError};
use nalgebra::{Point3, Vector2, Vector3};
use toolpath_formats::PathPoint;
use toolpath_kernel::error::Result;
use toolpath_kernel::geometry::differential::TangentFrame;
use toolpath_kernel::geometry::{FundamentalForms, LocalGeometry, NurbsSurface};
use toolpath_kernel::tools::LeadCutter;

/// Planning parameters shared by the three strategies.
#[derive(Clone, Copy, Debug)]
pub struct PassSettings {
    pub cutter: LeadCutter,
    /// Scallop height the passes are spaced for (a margin below the job's).
    pub scallop: f64,
    /// Chord tolerance along a pass, mm.
    pub chord_tolerance: f64,
    /// Longest step along a pass, mm.
    pub max_step: f64,
    /// Longest step along a pass that keeps the chord error within the
    /// tolerance on the most curved part of the surface, mm.
    pub point_step: f64,
    /// Passes built only for an estimate of their length: run-outs past an
    /// edge are not lifted clear of the surface (the disc tests cost far
    /// more than the lift adds to the length).
    pub estimate: bool,
}

/// Share of the job's scallop the spacing is planned for: the rest absorbs
/// the chord error between tool positions and the model's approximations
/// (osculating circle across the feed).
pub(crate) const SCALLOP_MARGIN: f64 = 0.9;

impl PassSettings {
    pub fn from_job(job: &toolpath_formats::Job) -> Result<Self> {
        let cutter = cutter_of_job(job)?;
        let h = job.scallop()?;
        let surface = job.surface()?;
        let chord_tolerance = h * 0.05;
        let max_step = (cutter.radius * 2.0).max(1.0);
        // Chord error of a step s on curvature k: k s^2 / 8.
        let k = max_curvature(surface);
        let point_step = if k > 0.0 {
            (8.0 * chord_tolerance / k).sqrt().clamp(0.05, max_step)
        } else {
            max_step
        };
        Ok(Self {
            cutter,
            scallop: h * SCALLOP_MARGIN,
            chord_tolerance,
            max_step,
            point_step,
            estimate: false,
        })
    }

    /// Settings for estimating a plan's length at a fraction of its cost: a
    /// point step `factor` times longer (at most the longest step), the
    /// chord tolerance that step keeps, and [`PassSettings::estimate`] set.
    pub(crate) fn coarsened(&self, factor: f64) -> Self {
        let point_step = (self.point_step * factor).min(self.max_step);
        let ratio = point_step / self.point_step;
        Self {
            point_step,
            chord_tolerance: self.chord_tolerance * ratio * ratio,
            estimate: true,
            ..*self
        }
    }
}

/// Largest principal curvature magnitude over a 33 x 33 sample grid, 1/mm.
pub fn max_curvature(surface: &NurbsSurface) -> f64 {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let n = 32;
    let mut k = 0.0f64;
    for i in 0..=n {
        for j in 0..=n {
            let (u, v) = (
                u0 + (u1 - u0) * i as f64 / n as f64,
                v0 + (v1 - v0) * j as f64 / n as f64,
            );
            if let Some(g) = LocalGeometry::at(surface, u, v) {
                k = k.max(g.k_min.abs()).max(g.k_max.abs());
            }
        }
    }
    k
}

/// A contact on the surface with its travel direction.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Contact {
    /// The surface at the contact (no principal curvatures: a contact
    /// needs the curvatures along its travel only).
    pub g: FundamentalForms,
    /// Unit travel direction (3-D tangent).
    pub travel: Vector3<f64>,
    pub k: Curvatures,
    /// The half-widths on sides +1 and -1 (towards and away from n x t)
    /// for the cutter and scallop they were computed for
    /// ([`Contact::with_half_widths`]): a pass contact is asked for them by
    /// the coverage, the run-ons, the offsetting and its path point.
    widths: Option<HalfWidths>,
}

/// [`LeadCutter::half_width`] on both sides of a contact, for one cutter
/// and scallop.
#[derive(Clone, Copy, Debug)]
struct HalfWidths {
    cutter: LeadCutter,
    scallop: f64,
    sides: [std::result::Result<f64, WidthError>; 2],
}

impl Contact {
    /// `travel` is projected onto the tangent plane and normalised; `None`
    /// where the surface is singular or the direction is normal to it.
    pub fn new(surface: &NurbsSurface, uv: Vector2<f64>, travel: Vector3<f64>) -> Option<Self> {
        let g = FundamentalForms::at(surface, uv.x, uv.y)?;
        Self::from_geometry(g, travel)
    }

    pub(crate) fn from_geometry(g: FundamentalForms, travel: Vector3<f64>) -> Option<Self> {
        let t = (travel - g.n * travel.dot(&g.n)).try_normalize(1e-12)?;
        Some(Self {
            k: curvatures_along(&g, t),
            g,
            travel: t,
            widths: None,
        })
    }

    /// The contact with its half-widths for `s` on both sides computed
    /// once: the same values [`Self::half_width_towards`] and
    /// [`Self::path_point`] compute otherwise.
    pub(crate) fn with_half_widths(mut self, s: &PassSettings) -> Self {
        self.widths = Some(HalfWidths {
            cutter: s.cutter,
            scallop: s.scallop,
            sides: [1.0, -1.0].map(|side| s.cutter.half_width(s.scallop, self.k, side)),
        });
        self
    }

    /// Half-width on side `side` (+1 towards n x t, -1 away) for `s`.
    fn half_width(&self, s: &PassSettings, side: f64) -> std::result::Result<f64, WidthError> {
        match &self.widths {
            Some(w) if w.cutter == s.cutter && w.scallop == s.scallop => {
                w.sides[if side > 0.0 { 0 } else { 1 }]
            }
            _ => s.cutter.half_width(s.scallop, self.k, side),
        }
    }

    pub fn uv(&self) -> Vector2<f64> {
        self.g.uv
    }
    pub fn point(&self) -> Point3<f64> {
        self.g.point()
    }
    /// Unit cross-feed n x t.
    pub fn cross(&self) -> Vector3<f64> {
        self.g.n.cross(&self.travel)
    }

    /// Half-width on the side of `towards` (a 3-D direction), for scallop h.
    pub(crate) fn half_width_towards(
        &self,
        s: &PassSettings,
        towards: Vector3<f64>,
    ) -> Result<f64> {
        let side = if towards.dot(&self.cross()) >= 0.0 {
            1.0
        } else {
            -1.0
        };
        self.half_width(s, side)
            .map_err(|WidthError::Gouge { depth }| {
                gouge_error(&s.cutter, self.uv().into(), self.k.cross, depth)
            })
    }

    /// The path point: pose, strip width and feed. Errors where the cutter gouges.
    pub(crate) fn path_point(&self, s: &PassSettings) -> Result<PathPoint> {
        let depth = s.cutter.disc_gouge(self.k);
        if depth > 1e-3 * s.scallop {
            return Err(gouge_error(
                &s.cutter,
                self.uv().into(),
                self.k.cross.max(self.k.feed),
                depth,
            ));
        }
        // LeadCutter::strip_width: side +1, then side -1.
        let w = self
            .half_width(s, 1.0)
            .and_then(|a| Ok(a + self.half_width(s, -1.0)?))
            .map_err(|WidthError::Gouge { depth }| {
                gouge_error(&s.cutter, self.uv().into(), self.k.cross, depth)
            })?;
        let cc = self.point();
        let (cl, axis) = s.cutter.pose(cc, self.g.n, self.travel);
        Ok(PathPoint {
            cc: cc.into(),
            cl: cl.into(),
            axis: axis.into(),
            uv: self.uv().into(),
            strip_width: Some(w),
            feed: Some(self.travel.into()),
            normal: Some(self.g.n.into()),
            ..Default::default()
        })
    }
}

/// Samples a curve `curve(s)`, s in [0, 1], so that every chord stays within
/// `tol` of the curve (checked at chord midpoints, recursively) and no step is
/// longer than `max_step`. Returns the parameters, sorted, including 0 and 1.
pub(crate) fn sample_curve(
    curve: &dyn Fn(f64) -> Point3<f64>,
    tol: f64,
    max_step: f64,
    initial: usize,
) -> Vec<f64> {
    let n0 = initial.max(2);
    let mut out = vec![0.0];
    // (a, b, curve(a), curve(b), depth)
    type Span = (f64, f64, Point3<f64>, Point3<f64>, u32);
    let mut stack: Vec<Span> = Vec::new();
    for k in (0..n0 - 1).rev() {
        let (a, b) = (k as f64 / (n0 - 1) as f64, (k + 1) as f64 / (n0 - 1) as f64);
        stack.push((a, b, curve(a), curve(b), 0));
    }
    while let Some((a, b, pa, pb, depth)) = stack.pop() {
        let m = 0.5 * (a + b);
        let pm = curve(m);
        let chord = pb - pa;
        let len = chord.norm();
        let dev = if len > 0.0 {
            let t = chord / len;
            let d = pm - pa;
            (d - t * d.dot(&t)).norm()
        } else {
            (pm - pa).norm()
        };
        // Quarter points too, so that an S-shaped span is not missed.
        let q1 = curve(0.5 * (a + m));
        let dev_q = if len > 0.0 {
            let t = chord / len;
            let d = q1 - pa;
            (d - t * d.dot(&t)).norm()
        } else {
            0.0
        };
        if depth < 24 && (dev > tol || dev_q > tol || len > max_step) {
            stack.push((m, b, pm, pb, depth + 1));
            stack.push((a, m, pa, pm, depth + 1));
        } else {
            out.push(b);
        }
    }
    out
}

/// The point where the step from `p` (inside the domain) to `next` (outside)
/// crosses the domain boundary.
fn clip_step(surface: &NurbsSurface, p: Vector2<f64>, next: Vector2<f64>) -> Vector2<f64> {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let delta = next - p;
    let mut f = 1.0f64;
    if delta.x > 0.0 {
        f = f.min((u1 - p.x) / delta.x);
    } else if delta.x < 0.0 {
        f = f.min((u0 - p.x) / delta.x);
    }
    if delta.y > 0.0 {
        f = f.min((v1 - p.y) / delta.y);
    } else if delta.y < 0.0 {
        f = f.min((v0 - p.y) / delta.y);
    }
    let end = p + delta * f.clamp(0.0, 1.0);
    let (eu, ev) = surface.clamp_uv(end.x, end.y);
    Vector2::new(eu, ev)
}

/// Longest sub-step of a walk on the surface, mm.
const WALK_STEP: f64 = 0.75;

/// Walks of several distances along one line (the iso-scallop offsetting
/// settling the distance at which two strips meet): each walk continues
/// from the last sub-step end of the earlier walks short of its distance
/// instead of integrating again from the start. A walk to `dist` is thus
/// the walk to that end plus sub-steps of at most [`WALK_STEP`] over the
/// rest; it differs from a fresh [`walk_on_surface`] by the midpoint rule's
/// integration error only (its steps are not the same), as much as either
/// walk's own error (`continued_walks_match_fine_walks`).
#[derive(Clone, Debug)]
pub(crate) struct Walker {
    /// Sub-step ends of the walks so far, by distance from the start: the
    /// distance, the uv point, the carried heading and the sub-step
    /// direction there (computed when a walk first continues from it). The
    /// first is the start, with its sub-step direction.
    marks: Vec<WalkMark>,
}

#[derive(Clone, Copy, Debug)]
struct WalkMark {
    s: f64,
    p: Vector2<f64>,
    d: Vector3<f64>,
    step: Option<(Vector2<f64>, Vector3<f64>)>,
}

impl Walker {
    /// `None` where the surface has no tangent plane at `uv` or `dir` is
    /// along its normal (every walk from there fails).
    pub fn new(surface: &NurbsSurface, uv: Vector2<f64>, dir: Vector3<f64>) -> Option<Self> {
        let first = walk_step_at(surface, uv, dir)?;
        Some(Self {
            marks: vec![WalkMark {
                s: 0.0,
                p: uv,
                d: dir,
                step: Some(first),
            }],
        })
    }

    /// The walk from the start for `dist` mm, as [`walk_on_surface`]: the
    /// first walk is the same bits; later ones continue from the farthest
    /// sub-step end short of `dist` (the ends beyond it are dropped, so the
    /// result depends only on the sequence of distances asked).
    pub fn walk(
        &mut self,
        surface: &NurbsSurface,
        dist: f64,
    ) -> Option<(Vector2<f64>, Vector3<f64>, bool)> {
        // The start always stays; a walk of 0 mm takes one empty step, as
        // walk_on_surface does.
        let keep = self.marks.iter().rposition(|m| m.s < dist).unwrap_or(0);
        self.marks.truncate(keep + 1);
        let s0 = self.marks[keep].s;
        let rest = dist - s0;
        let n = ((rest / WALK_STEP).ceil() as usize).clamp(1, 64);
        let h = rest / n as f64;
        for i in 0..n {
            let last = self.marks.len() - 1;
            let m = self.marks[last];
            let (k1, t1) = match m.step {
                Some(step) => step,
                None => {
                    let step = walk_step_at(surface, m.p, m.d)?;
                    self.marks[last].step = Some(step);
                    step
                }
            };
            let (next, t2) = match midpoint_step(surface, m.p, (k1, t1), h)? {
                SubStep::Inside(next, t2) => (next, t2),
                SubStep::Left(end, t2) => return Some((end, t2, true)),
            };
            self.marks.push(WalkMark {
                s: if i + 1 == n {
                    dist
                } else {
                    s0 + (i + 1) as f64 * h
                },
                p: next,
                d: t2,
                step: None,
            });
        }
        let end = self.marks[self.marks.len() - 1];
        Some((end.p, end.d, false))
    }
}

/// Walks on the surface from `uv` along the 3-D tangent direction `dir`
/// (re-projected on the tangent plane each sub-step, midpoint rule) for `dist`
/// mm. Returns the end, the carried direction there, and whether the domain
/// boundary stopped the walk (the end then lies on it). Not a field line:
/// the heading is carried along the walk (the offset distance of the
/// iso-scallop offsetting is measured along it), so it is not traced with
/// geometry::field_trace.
pub(crate) fn walk_on_surface(
    surface: &NurbsSurface,
    uv: Vector2<f64>,
    dir: Vector3<f64>,
    dist: f64,
) -> Option<(Vector2<f64>, Vector3<f64>, bool)> {
    WalkStart::new(surface, uv, dir)?.walk(surface, dist)
}

/// The start of a walk on the surface from one point along one direction
/// ([`walk_on_surface`]; [`Walker`] for several distances along one line).
#[derive(Clone, Copy, Debug)]
pub(crate) struct WalkStart {
    uv: Vector2<f64>,
    /// The first sub-step's uv direction and unit tangent at `uv`.
    first: (Vector2<f64>, Vector3<f64>),
}

/// A walk's sub-step direction at `p` for heading `d`: the heading projected
/// on the tangent plane (first derivatives only: the same bits as the full
/// local geometry for what the step uses, at about half the cost), in uv
/// and as a unit 3-D tangent.
fn walk_step_at(
    surface: &NurbsSurface,
    p: Vector2<f64>,
    d: Vector3<f64>,
) -> Option<(Vector2<f64>, Vector3<f64>)> {
    let g = TangentFrame::at(surface, p.x, p.y)?;
    let t = (d - g.n * d.dot(&g.n)).try_normalize(1e-12)?;
    Some((g.tangent_to_uv(t), t))
}

/// Where one midpoint sub-step of a walk ends.
enum SubStep {
    /// Inside the domain: the end and the carried heading there.
    Inside(Vector2<f64>, Vector3<f64>),
    /// It left the domain: where it crosses the boundary, and the heading.
    Left(Vector2<f64>, Vector3<f64>),
}

/// One sub-step of length `h` of a walk from `p`, whose sub-step direction
/// there is `(k1, t1)` (uv and unit tangent): the midpoint rule, the
/// heading re-projected at the clamped midpoint.
#[inline]
fn midpoint_step(
    surface: &NurbsSurface,
    p: Vector2<f64>,
    (k1, t1): (Vector2<f64>, Vector3<f64>),
    h: f64,
) -> Option<SubStep> {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let mid = p + k1 * (0.5 * h);
    let (mu, mv) = surface.clamp_uv(mid.x, mid.y);
    let (k2, t2) = walk_step_at(surface, Vector2::new(mu, mv), t1)?;
    let next = p + k2 * h;
    Some(
        if next.x < u0 || next.x > u1 || next.y < v0 || next.y > v1 {
            SubStep::Left(clip_step(surface, p, next), t2)
        } else {
            SubStep::Inside(next, t2)
        },
    )
}

impl WalkStart {
    /// `None` where the surface has no tangent plane at `uv` or `dir` is
    /// along its normal (every walk from there fails).
    pub fn new(surface: &NurbsSurface, uv: Vector2<f64>, dir: Vector3<f64>) -> Option<Self> {
        Some(Self {
            uv,
            first: walk_step_at(surface, uv, dir)?,
        })
    }

    /// [`walk_on_surface`] from this start for `dist` mm.
    pub fn walk(
        &self,
        surface: &NurbsSurface,
        dist: f64,
    ) -> Option<(Vector2<f64>, Vector3<f64>, bool)> {
        let n = ((dist / WALK_STEP).ceil() as usize).clamp(1, 64);
        let h = dist / n as f64;
        let mut p = self.uv;
        let mut d = Vector3::zeros();
        for step in 0..n {
            let (k1, t1) = if step == 0 {
                self.first
            } else {
                walk_step_at(surface, p, d)?
            };
            match midpoint_step(surface, p, (k1, t1), h)? {
                SubStep::Inside(next, t2) => {
                    p = next;
                    d = t2;
                }
                SubStep::Left(end, t2) => return Some((end, t2, true)),
            }
        }
        Some((p, d, false))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A walk chained from 0.01 mm steps: the midpoint rule's error is then
    /// far below that of the 0.75 mm sub-steps.
    fn fine_walk(
        surface: &NurbsSurface,
        uv: Vector2<f64>,
        dir: Vector3<f64>,
        dist: f64,
    ) -> (Vector2<f64>, bool) {
        let n = (dist / 0.01).ceil() as usize;
        let (mut p, mut d) = (uv, dir);
        for _ in 0..n {
            let (q, e, clipped) = walk_on_surface(surface, p, d, dist / n as f64).unwrap();
            if clipped {
                return (q, true);
            }
            (p, d) = (q, e);
        }
        (p, false)
    }

    /// Continued walks (`Walker`) land where the walk of the same distance
    /// does to within the integration error (about 1e-4 mm for both at
    /// 0.75 mm sub-steps on this surface): against a walk of 0.01 mm
    /// steps, on the wing mould, for the sequence of distances the
    /// offsetting asks (a first guess, corrections both ways, a short walk
    /// back to the strip edge). The first walk is walk_on_surface's bits.
    #[test]
    fn continued_walks_match_fine_walks() {
        let surface = toolpath_samples::surfaces::wing_mould();
        let ((u0, u1), (v0, v1)) = surface.domain();
        let mut rng = toolpath_kernel::rng::XorShift(0x003a_1c0b_7e11);
        let (mut worst_fresh, mut worst_continued, mut checked) = (0.0f64, 0.0f64, 0);
        for _ in 0..60 {
            let uv = Vector2::new(
                u0 + (u1 - u0) * (0.1 + 0.8 * rng.unit()),
                v0 + (v1 - v0) * (0.1 + 0.8 * rng.unit()),
            );
            let a = std::f64::consts::TAU * rng.unit();
            let g = TangentFrame::at(&surface, uv.x, uv.y).unwrap();
            let dir = g.su.normalize() * a.cos() + g.n.cross(&g.su).normalize() * a.sin();
            let d0 = 1.0 + 4.0 * rng.unit();
            let mut walker = Walker::new(&surface, uv, dir).unwrap();
            let first = walker.walk(&surface, d0).unwrap();
            assert_eq!(Some(first), walk_on_surface(&surface, uv, dir, d0));
            for f in [1.07, 0.96, 0.9601, 1.2, 0.49, 1.0] {
                let dist = d0 * f;
                let (end, _, clipped) = walker.walk(&surface, dist).unwrap();
                let (fine, fine_clipped) = fine_walk(&surface, uv, dir, dist);
                let (fresh, _, _) = walk_on_surface(&surface, uv, dir, dist).unwrap();
                assert_eq!(clipped, fine_clipped);
                if clipped {
                    continue;
                }
                let at = |p: Vector2<f64>| surface.point(p.x, p.y);
                worst_continued = worst_continued.max((at(end) - at(fine)).norm());
                worst_fresh = worst_fresh.max((at(fresh) - at(fine)).norm());
                checked += 1;
            }
        }
        assert!(checked > 300, "{checked}");
        assert!(
            worst_continued < 2e-4 && worst_continued < 1.5 * worst_fresh,
            "continued {worst_continued} mm, fresh {worst_fresh} mm"
        );
    }

    #[test]
    fn circle_sampling_keeps_the_chord_error() {
        let r = 50.0;
        let curve = |s: f64| Point3::new(r * (s * 3.0).cos(), r * (s * 3.0).sin(), 0.0);
        let tol = 0.005;
        let ts = sample_curve(&curve, tol, 100.0, 4);
        // Exact chord error of a circle: r (1 - cos(dtheta/2)).
        for w in ts.windows(2) {
            let dth = 3.0 * (w[1] - w[0]);
            assert!(r * (1.0 - (dth / 2.0).cos()) <= tol * 1.0001);
        }
        // Not absurdly dense: within 2x of the optimum count 3 / (2 acos(1 - tol/r)).
        let optimum = 3.0 / (2.0 * (1.0 - tol / r).acos());
        assert!(
            (ts.len() as f64) < 2.2 * optimum + 2.0,
            "{} vs {optimum}",
            ts.len()
        );
    }
}
