//! Pass ends: how a pass runs in and out past the edges of its region or of
//! the surface (docs/methods.md, "Pass ends: run-ins, run-outs and edge
//! walks"). On the surface an extension follows it with real contacts; a
//! pass heading along a domain edge walks the edge in parameter space; past
//! an edge a flat end runs straight in the edge contact's tangent plane, or
//! on the surface continued past the edge where it falls away, each pose
//! lifted by the posed bottom disc's depth below the real surface.

use super::passes::{walk_on_surface, Contact, PassSettings};
use nalgebra::{Point3, Vector2, Vector3};
use toolpath_formats::PathPoint;
use toolpath_kernel::error::Result;
use toolpath_kernel::geometry::{LocalGeometry, NurbsSurface};

/// The wider of the two half-widths of the strip at a pass end (the strip's
/// far side there), `None` where no contact or width can be given.
fn wider_half_width(
    surface: &NurbsSurface,
    s: &PassSettings,
    end: &PathPoint,
    travel: Vector3<f64>,
) -> Option<f64> {
    let c = Contact::new(surface, Vector2::from(end.uv), travel)?;
    let a = c.half_width_towards(s, c.cross()).ok()?;
    let b = c.half_width_towards(s, -c.cross()).ok()?;
    Some(a.max(b))
}

/// Unit 3-D tangents of the domain edges `uv` lies on (none inside).
fn boundary_edges(surface: &NurbsSurface, uv: Vector2<f64>) -> Vec<Vector3<f64>> {
    edges_at(surface, uv, None)
}

/// Unit 3-D tangents of the domain edges `uv` lies on; with `heading` (a
/// parameter-space direction) only those it leaves the domain through.
pub(crate) fn edges_at(
    surface: &NurbsSurface,
    uv: Vector2<f64>,
    heading: Option<Vector2<f64>>,
) -> Vec<Vector3<f64>> {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let d = surface.derivs(uv.x, uv.y);
    let tol = 1e-9 * ((u1 - u0) + (v1 - v0));
    let leaves = |at_lo: bool, at_hi: bool, h: f64| match heading {
        None => at_lo || at_hi,
        Some(_) => (at_lo && h < 0.0) || (at_hi && h > 0.0),
    };
    let h = heading.unwrap_or_default();
    let mut edges = Vec::new();
    if leaves((uv.x - u0).abs() <= tol, (uv.x - u1).abs() <= tol, h.x) {
        edges.extend(d.sv.try_normalize(1e-300));
    }
    if leaves((uv.y - v0).abs() <= tol, (uv.y - v1).abs() <= tol, h.y) {
        edges.extend(d.su.try_normalize(1e-300));
    }
    edges
}

/// Largest angle between a heading and a domain edge it counts as running
/// along, deg.
const ALONG_EDGE_DEG: f64 = 20.0;

/// The domain edge through `uv` (unit 3-D tangent) that `dir` runs along,
/// within [`ALONG_EDGE_DEG`], oriented with `dir`.
fn edge_along(surface: &NurbsSurface, uv: Vector2<f64>, dir: Vector3<f64>) -> Option<Vector3<f64>> {
    boundary_edges(surface, uv)
        .into_iter()
        .find(|e| e.dot(&dir).abs() >= ALONG_EDGE_DEG.to_radians().cos())
        .map(|e| if e.dot(&dir) < 0.0 { -e } else { e })
}

/// The point `dist` along the domain edge through `uv` in the direction of
/// the tangent `e` (the other parameter held on its bound: a walk in 3-D
/// drifts off a curved edge line), stopping at a corner; `uv` itself where
/// `uv` is on no edge.
fn walk_along_edge(
    surface: &NurbsSurface,
    uv: Vector2<f64>,
    e: Vector3<f64>,
    dist: f64,
) -> Vector2<f64> {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let tol = 1e-9 * ((u1 - u0) + (v1 - v0));
    let on_u = (uv.x - u0).abs() <= tol || (uv.x - u1).abs() <= tol;
    let on_v = (uv.y - v0).abs() <= tol || (uv.y - v1).abs() <= tol;
    // Moving along v on a u edge, along u on a v edge.
    let along_v = if on_u && on_v {
        let d = surface.derivs(uv.x, uv.y);
        e.dot(&d.sv).abs() * d.su.norm() >= e.dot(&d.su).abs() * d.sv.norm()
    } else if on_u || on_v {
        on_u
    } else {
        return uv;
    };
    let speed = |p: Vector2<f64>| {
        let d = surface.derivs(p.x, p.y);
        let t = if along_v { d.sv } else { d.su };
        (t.norm(), t.dot(&e).signum())
    };
    let (sp, sign) = speed(uv);
    if sp <= 0.0 {
        return uv;
    }
    let step = |s: f64| {
        let p = if along_v {
            Vector2::new(uv.x, uv.y + sign * s)
        } else {
            Vector2::new(uv.x + sign * s, uv.y)
        };
        let (u, v) = surface.clamp_uv(p.x, p.y);
        Vector2::new(u, v)
    };
    // Parameter step from the speed at the start, then at the midpoint.
    let mut s = dist / sp;
    let (sm, _) = speed((uv + step(s)) * 0.5);
    if sm > 0.0 {
        s = dist / sm;
    }
    step(s)
}

/// Run-in and run-out of a pass, so that the whole strip is cut up to the
/// pass ends and past the surface edges.
///
/// How far:
/// - Lag: the rim points of the flat end lag R (1 - cos phi) cos(lambda)
///   behind the contact at lateral offset R sin phi, so a pass end continues
///   by that lag (5 % margin) past its last contact: on a domain edge at the
///   strip's far side (the wider of the two half-widths at the end), inside
///   the surface (a region boundary) at the strip width; at most R. A pass start needs none,
///   except where it starts on a domain edge and runs along it with the edge
///   going on behind the start: it runs in by the lag too.
/// - Oblique edges: where an end meets a surface edge at an angle theta, one
///   side of the strip reaches the edge half-width * cot(theta) before
///   (run-in) or after (run-out) the contact: the pass continues by that much
///   more, at most 2 R. An edge the pass runs along adds nothing, except at
///   a corner, where its overrun is kept.
///
/// Where:
/// - On the surface the extension follows it with real contacts (a straight
///   run in the tangent plane would dip below a surface concave along the
///   feed).
/// - Where it reaches a domain edge it heads along (within
///   `ALONG_EDGE_DEG`), it walks that edge in parameter space, the other
///   parameter held on its bound (a walk in 3-D drifts off a curved edge
///   line), up to the corner.
/// - Past a surface edge, for at most [`RUN_OUT_MAX`] tool radii: straight in
///   the edge contact's tangent plane, or, for a flat end where the surface
///   continued past the edge falls below that plane (convex along the run),
///   on that continued surface, posed to its normal. Every pose there is
///   lifted along the edge normal by the depth its bottom disc reaches below
///   the real surface beyond the edge contact's own (a ball by the curvature
///   along the run).
pub(crate) fn extend_pass(
    surface: &NurbsSurface,
    points: &mut Vec<PathPoint>,
    s: &PassSettings,
) -> Result<()> {
    if points.is_empty() {
        return Ok(());
    }
    let tail = extension(surface, points, s, true)?;
    points.extend(tail);
    let mut head = extension(surface, points, s, false)?;
    head.reverse();
    head.append(points);
    *points = head;
    Ok(())
}

/// Longest straight run past a surface edge, in tool radii: a pass meeting
/// the edge at 35 deg needs half-width x cot(35 deg) plus the lag (up to
/// about 2.3 R) before the far side of its strip has crossed the edge; a
/// shorter cap leaves scallops above h along oblique edges.
pub(crate) const RUN_OUT_MAX: f64 = 2.3;

/// The points to add after the last (`at_end`) or before the first point,
/// in order away from the pass: on over the surface by the disc's lag, then,
/// where the pass heads out of the domain, along the edge and past it.
fn extension(
    surface: &NurbsSurface,
    points: &[PathPoint],
    s: &PassSettings,
    at_end: bool,
) -> Result<Vec<PathPoint>> {
    let Some(end) = (if at_end {
        points.last()
    } else {
        points.first()
    }) else {
        return Ok(Vec::new());
    };
    let (Some(feed), Some(_)) = (end.feed, end.normal) else {
        return Ok(Vec::new());
    };
    let mut run = Extension::new(surface, s, end, Vector3::from(feed), at_end);
    let mut out = Vec::new();
    run.on_surface(&mut out)?;
    if run.at_edge {
        run.along_edge(&mut out)?;
        if run.done < run.need - 1e-9 {
            run.past_edge(&mut out)?;
        }
    }
    Ok(out)
}

/// The state of one pass-end extension as it walks away from the pass.
struct Extension<'a> {
    surface: &'a NurbsSurface,
    s: &'a PassSettings,
    at_end: bool,
    /// Cutter radius and half the strip width at the pass end.
    r: f64,
    hw: f64,
    /// How far the disc lags behind the contact (the minimum run).
    lag: f64,
    step: f64,
    uv: Vector2<f64>,
    dir: Vector3<f64>,
    /// Distance run so far and distance to run.
    done: f64,
    need: f64,
    /// Whether the extension reached a domain edge it heads out of.
    at_edge: bool,
    guard: usize,
}

impl<'a> Extension<'a> {
    fn new(
        surface: &'a NurbsSurface,
        s: &'a PassSettings,
        end: &PathPoint,
        travel: Vector3<f64>,
        at_end: bool,
    ) -> Self {
        let r = s.cutter.radius;
        // Direction the extension goes: along the travel at the end, against it at the start.
        let out_dir = if at_end { travel } else { -travel };
        let w = end.strip_width.unwrap_or(2.0 * r).min(2.0 * r);
        // The disc lags behind the contact: at a pass end the far side of the
        // strip is cut only once the contact has run on by this much. At a pass
        // start it covers what lies behind the contact, except along an edge the
        // pass starts on and runs along: the material on that edge behind the
        // start is cut only within h / sin(lead) of it, so the start runs in by
        // the same.
        let along_edge = || {
            let end_uv = Vector2::from(end.uv);
            boundary_edges(surface, end_uv).iter().any(|e| {
                // ... and the edge goes on behind the start (not a corner).
                e.dot(&travel).abs() >= ALONG_EDGE_DEG.to_radians().cos()
                    && walk_along_edge(surface, end_uv, -travel, 1e-3 * r) != end_uv
            })
        };
        let lag = if s.cutter.ball || !(at_end || along_edge()) {
            0.0
        } else {
            // On a domain edge the strip's far side decides (the edge's
            // obliqueness is added below). A pass ending inside the surface
            // ends on a region boundary, which adds no oblique overrun for
            // the neighbour region's passes meeting it at an angle: there
            // the full strip width (at most R) keeps the corners cut.
            let on_edge = !boundary_edges(surface, Vector2::from(end.uv)).is_empty();
            let y = if on_edge {
                wider_half_width(surface, s, end, travel).unwrap_or(w)
            } else {
                w
            }
            .min(r);
            r * (1.0 - (1.0 - (y / r).powi(2)).max(0.0).sqrt()) * s.cutter.lead.cos() * 1.05
        };
        Self {
            surface,
            s,
            at_end,
            r,
            hw: 0.5 * w,
            lag,
            step: s.point_step.min(0.5 * r).max(1e-3),
            uv: Vector2::from(end.uv),
            dir: out_dir,
            done: 0.0,
            need: lag,
            at_edge: false,
            guard: 0,
        }
    }

    /// How far past the edges at `uv` the far side of the strip still is,
    /// for a pass crossing them along `t`: up to 2R (shallower passes run
    /// along the edge instead).
    fn oblique(&self, uv: Vector2<f64>, t: Vector3<f64>) -> f64 {
        boundary_edges(self.surface, uv)
            .iter()
            .map(|e| {
                let c = t.dot(e).abs().min(1.0);
                let sn = (1.0 - c * c).sqrt().max(1e-3);
                (self.hw * c / sn).min(2.0 * self.r)
            })
            .fold(0.0, f64::max)
    }

    /// The extension has reached an edge it heads out of: it runs on past it
    /// by the strip's overhang.
    fn reach_edge(&mut self) {
        self.at_edge = true;
        self.need = self.done.max(self.lag) + self.oblique(self.uv, self.dir);
    }

    /// One step of `len` along the domain edge through `uv` that `dir` heads
    /// along, followed on the surface (a straight run along a concave edge
    /// would cut below it): advances `uv`, `dir` and `done` and pushes the
    /// step's contact. Some(true) after a step with a contact, Some(false)
    /// after one without (the run stops there), None where `dir` heads
    /// along no edge or the edge ends (a corner).
    fn follow_edge(&mut self, len: f64, out: &mut Vec<PathPoint>) -> Result<Option<bool>> {
        let surface = self.surface;
        let Some(e) = edge_along(surface, self.uv, self.dir) else {
            return Ok(None);
        };
        let nx = walk_along_edge(surface, self.uv, e, len);
        let mv = (surface.point(nx.x, nx.y) - surface.point(self.uv.x, self.uv.y)).norm();
        if mv <= 1e-6 * self.step {
            return Ok(None);
        }
        self.done += mv;
        self.uv = nx;
        self.dir = e;
        let Some(c) = Contact::new(surface, nx, if self.at_end { e } else { -e }) else {
            return Ok(Some(false));
        };
        out.push(c.path_point(self.s)?);
        Ok(Some(true))
    }

    /// On over the surface by the lag; `at_edge` once the extension would
    /// leave the domain.
    fn on_surface(&mut self, out: &mut Vec<PathPoint>) -> Result<()> {
        let surface = self.surface;
        while self.done < self.need - 1e-9 && self.guard < 10_000 {
            self.guard += 1;
            let Some((next, d, clipped)) = walk_on_surface(
                surface,
                self.uv,
                self.dir,
                self.step.min(self.need - self.done),
            ) else {
                break;
            };
            let moved =
                (surface.point(next.x, next.y) - surface.point(self.uv.x, self.uv.y)).norm();
            if clipped && moved <= 1e-6 * self.step {
                // At an edge, heading out of the domain or along the edge.
                if self.guard < 9_999 {
                    let len = self.step.min(self.need - self.done);
                    match self.follow_edge(len, out)? {
                        Some(true) => continue,
                        Some(false) => break,
                        None => {}
                    }
                }
                // Out of the domain, or a corner where the edge ends.
                self.reach_edge();
                return Ok(());
            }
            if moved <= 0.0 {
                break;
            }
            self.done += moved;
            self.uv = next;
            self.dir = d;
            let t = if self.at_end { d } else { -d };
            let Some(c) = Contact::new(surface, self.uv, t) else {
                break;
            };
            out.push(c.path_point(self.s)?);
        }
        if self.done >= self.need - 1e-9 && !boundary_edges(surface, self.uv).is_empty() {
            // Ended exactly on an edge: check whether it heads out.
            // Along an edge (within 20 deg) the disc behind the contact covers
            // the edge: no run past it.
            let along = edge_along(surface, self.uv, self.dir).is_some();
            if let (false, Some((_, _, true))) = (
                along,
                walk_on_surface(surface, self.uv, self.dir, 1e-3 * self.step),
            ) {
                self.reach_edge();
            }
        }
        Ok(())
    }

    /// The overrun past the edge, where the pass heads along one: on along
    /// the edge (a straight run in the tangent plane would leave a convex
    /// edge, and the material along it, or cut into a concave one).
    fn along_edge(&mut self, out: &mut Vec<PathPoint>) -> Result<()> {
        while self.done < self.need - 1e-9 && self.guard < 10_000 {
            self.guard += 1;
            let len = self.step.min(self.need - self.done);
            if self.follow_edge(len, out)? != Some(true) {
                break;
            }
        }
        Ok(())
    }

    /// The rest of the overrun, off the domain: along the edge's tangent
    /// plane, or along the surface continued past the edge where it falls
    /// away, lifted where the disc would dip below the surface.
    fn past_edge(&self, out: &mut Vec<PathPoint>) -> Result<()> {
        let (surface, s, at_end) = (self.surface, self.s, self.at_end);
        let Some(g) = LocalGeometry::at(surface, self.uv.x, self.uv.y) else {
            return Ok(());
        };
        let Some(t) = (self.dir - g.forms.n * self.dir.dot(&g.forms.n)).try_normalize(1e-12) else {
            return Ok(());
        };
        let travel_t = if at_end { t } else { -t };
        let Some(c) = Contact::from_geometry(g.forms, travel_t) else {
            return Ok(());
        };
        let base = c.path_point(s)?;
        let run = (self.need - self.done).min(RUN_OUT_MAX * self.r);
        let n = (run / self.step).ceil().max(1.0) as usize;
        // Where the surface is concave round the run, it rises above the
        // tangent plane: along the run and, where the run leaves the edge at
        // a shallow angle, beside it under the disc too. Each run-out pose
        // lifts along the edge normal by the deepest its bottom disc reaches
        // below the surface itself (`disc_penetration`), beyond what the
        // pose at the edge contact already does; the ball by the curvature
        // along the run.
        let heel = 0.5 * c.k.feed.max(0.0);
        let o = g.point();
        let pen0 = if s.estimate {
            0.0
        } else {
            disc_penetration(surface, s, &g, t, o, g.forms.n, travel_t).max(0.0)
        };
        let duv = g.tangent_to_uv(t);
        for k in 1..=n {
            let d = run * k as f64 / n as f64;
            // Where the surface falls away from the tangent plane across
            // the edge (convex along the run), the run follows the surface
            // continued past the edge: straight, the tool would leave the
            // material beside the edge uncut.
            let ext = toolpath_kernel::geometry::inversion::extended_derivs(
                surface,
                g.forms.uv.x + duv.x * d,
                g.forms.uv.y + duv.y * d,
            );
            let n_ext = ext.su.cross(&ext.sv).try_normalize(1e-300).map(|m| {
                if m.dot(&g.forms.n) < 0.0 {
                    -m
                } else {
                    m
                }
            });
            let below = (ext.p - (o + t * d)).dot(&g.forms.n);
            // The continued surface is followed only while it stays near the
            // straight run: next to a pole the parameter step of a tangent
            // (through |S_v| -> 0) is far from linear, and the point it gives
            // far from the run.
            let near = (ext.p - (o + t * d)).norm() <= 0.5 * d;
            let (mut cc, n_pose, travel_k) = match n_ext {
                Some(m) if !s.cutter.ball && below < 0.0 && near => {
                    let tk = (travel_t - m * travel_t.dot(&m))
                        .try_normalize(1e-12)
                        .unwrap_or(travel_t);
                    (ext.p, m, tk)
                }
                _ => (o + t * d, g.forms.n, travel_t),
            };
            let lift = if s.estimate {
                0.0
            } else if s.cutter.ball {
                heel * d * d
            } else {
                // The penetration falls one for one with the lift (both
                // along the edge normal); twice for the disc's new place.
                let mut lift = 0.0f64;
                for _ in 0..2 {
                    let pen = disc_penetration(
                        surface,
                        s,
                        &g,
                        t,
                        cc + g.forms.n * lift,
                        n_pose,
                        travel_k,
                    );
                    lift = (lift + pen - pen0).max(lift);
                }
                lift
            };
            cc += g.forms.n * lift;
            let (cl, axis) = s.cutter.pose(cc, n_pose, travel_k);
            out.push(PathPoint {
                cc: cc.into(),
                cl: cl.into(),
                axis: axis.into(),
                feed: Some(travel_k.into()),
                normal: Some(n_pose.into()),
                ..base.clone()
            });
        }
        Ok(())
    }
}

/// How deep the bottom disc of the flat-end cutter posed at contact `cc`
/// (travelling along `travel`, axis tilted from the normal `n_pose`) reaches
/// below the surface, mm (negative: clear by that much), over rim and
/// interior samples whose foot on the surface lies inside its domain or
/// within a sample spacing of its edge (farther past the edge there is no
/// material). Heights are taken along the normal of the
/// edge contact `g`, over its tangent plane (`invert_in_frame`), so a lift
/// along that normal lowers them one for one.
fn disc_penetration(
    surface: &NurbsSurface,
    s: &PassSettings,
    g: &LocalGeometry,
    t: Vector3<f64>,
    cc: Point3<f64>,
    n_pose: Vector3<f64>,
    travel: Vector3<f64>,
) -> f64 {
    use toolpath_kernel::geometry::inversion::invert_in_frame;
    const RINGS: [(f64, usize); 3] = [(1.0, 36), (0.6, 18), (0.25, 8)];
    let o = g.point();
    let e2 = g.forms.n.cross(&t);
    let (cl, axis) = s.cutter.pose(cc, n_pose, travel);
    let Some(a1) = (travel - axis * axis.dot(&travel)).try_normalize(1e-12) else {
        return f64::NEG_INFINITY;
    };
    let a2 = axis.cross(&a1);
    let r = s.cutter.radius;
    // Feet up to a rim sample spacing past the edge count too (on the
    // surface continued past it): the material at the edge itself lies
    // between the samples there.
    let reach = std::f64::consts::TAU * r / RINGS[0].1 as f64;
    let inside = |foot: &toolpath_kernel::geometry::inversion::FramePoint| {
        let (u, v) = surface.clamp_uv(foot.uv.x, foot.uv.y);
        (surface.point(u, v) - foot.derivs.p).norm() <= reach
    };
    let mut seed = g.forms.uv;
    let mut worst = f64::NEG_INFINITY;
    for (share, count) in RINGS {
        for m in 0..count {
            let psi = std::f64::consts::TAU * m as f64 / count as f64;
            let q = cl + (a1 * psi.cos() + a2 * psi.sin()) * (share * r);
            let rel = q - o;
            let foot = invert_in_frame(surface, &o, &t, &e2, [rel.dot(&t), rel.dot(&e2)], seed);
            seed = foot.uv;
            if inside(&foot) {
                worst = worst.max(foot.height - rel.dot(&g.forms.n));
            }
        }
        seed = g.forms.uv;
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A walk along a curved edge (the edge line bends in 3-D) stays on it,
    /// covers the asked arc length and stops at the corner (a walk in 3-D
    /// drifts off such an edge and is clipped at once).
    #[test]
    fn edge_walk_follows_a_curved_edge_to_the_corner() {
        let surface = toolpath_kernel::geometry::interpolation::interpolate_height_field(
            |x, y| 0.004 * x * x + 2e-4 * x * y * y + 0.02 * y * y,
            (0.0, 100.0),
            (0.0, 80.0),
            (3, 3),
            (3, 3),
        )
        .unwrap();
        let start = Vector2::new(1.0, 0.3);
        let d = surface.derivs(start.x, start.y);
        let along = d.sv.normalize();
        // Arc length along the edge by fine chords.
        let arc = |a: f64, b: f64| -> f64 {
            (0..2000)
                .map(|k| {
                    let (p, q) = (
                        a + (b - a) * k as f64 / 2000.0,
                        a + (b - a) * (k + 1) as f64 / 2000.0,
                    );
                    (surface.point(1.0, q) - surface.point(1.0, p)).norm()
                })
                .sum()
        };
        for dist in [0.5, 2.0, 6.0] {
            let end = walk_along_edge(&surface, start, along, dist);
            assert_eq!(end.x, 1.0, "left the edge: {end:?}");
            assert!(end.y > start.y);
            let walked = arc(start.y, end.y);
            assert!((walked - dist).abs() < 0.01 * dist, "{walked} for {dist}");
        }
        let back = walk_along_edge(&surface, start, -along, 3.0);
        assert!(back.y < start.y && back.x == 1.0);
        assert_eq!(
            walk_along_edge(&surface, start, along, 1e4),
            Vector2::new(1.0, 1.0)
        );
        // Not on an edge: no walk.
        let inner = Vector2::new(0.5, 0.5);
        assert_eq!(walk_along_edge(&surface, inner, along, 1.0), inner);
    }
}
