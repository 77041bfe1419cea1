//! The belt-grinding contact model shared by `belt_iso_parametric` and
//! `belt_iso_planar` (docs/methods.md, "Belt contact").
//!
//! Seen along the feed `t`, the contact wheel with its belt is a straight
//! segment of length `w` (the belt width) lying in the tangent plane across the
//! feed. At a contact point T1 the cross-section `l` of the surface with the
//! plane through T1 normal to `t` is traced in both directions. The belt
//! segment of a neighbouring contact point T2 on `l` (same feed, as the paper
//! assumes) is the tangent of `l` at T2, because `n2 x t` is tangent to both
//! the surface and the plane. So the whole projected picture is planar:
//! - next contact: the farthest T2 within arc length `w` along `l` such that
//!   the two tangent segments meet at most the scallop height `h` above `l`;
//! - rigid-belt gouge at T1: the largest height of `l` above the segment
//!   tangent at T1 within `|a| <= w/2` (concave sections), reported, never hidden.

use nalgebra::{Point3, Vector2, Vector3};
use toolpath_formats::{Job, PathPoint};
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::{LocalGeometry, NurbsSurface};
use toolpath_kernel::tools::{Tool, BELT_GOUGE_EPS};

/// Belt size and the scallop height the planners work to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BeltSpec {
    /// Belt width across the feed, mm.
    pub width: f64,
    /// Contact-wheel radius, mm.
    pub wheel_radius: f64,
    /// Allowed scallop height, mm.
    pub scallop: f64,
}

impl BeltSpec {
    pub fn from_job(job: &Job) -> Result<Self> {
        let Tool::Belt {
            width,
            wheel_radius,
        } = *job.tool()?
        else {
            return Err(Error::invalid(
                "tool.kind",
                format!(
                    "strategy {} needs a belt tool, got {}",
                    job.strategy.name(),
                    job.tool()?.kind()
                ),
            ));
        };
        job.tool()?.validate().map_err(|e| e.within("tool"))?;
        Ok(Self {
            width,
            wheel_radius,
            scallop: job.scallop()?,
        })
    }

    /// Arc-length step of the cross-section trace: fine enough that the
    /// interpolated scallop is accurate to far below `h` (error ~ step^2 / (32 rho)).
    pub(crate) fn trace_step(&self) -> f64 {
        self.width / 32.0
    }
}

/// One node of a traced cross-section, in the 2-D frame of the contact point:
/// `a` along the belt axis b0, `h` along the surface normal n0 (tool side).
#[derive(Clone, Copy, Debug)]
pub(crate) struct SectionNode {
    /// Arc length from the contact point, mm (always >= 0).
    pub sigma: f64,
    pub uv: Vector2<f64>,
    pub a: f64,
    pub h: f64,
    /// Unit tangent in the (a, h) frame, pointing away from the contact point
    /// on the forward side and towards it on the backward side (i.e. along +a).
    pub ta: f64,
    pub th: f64,
}

/// The cross-section `l` through a contact point, traced forward (towards the
/// next path) up to arc length `w` and backward up to `w / 2`.
#[derive(Clone, Debug)]
pub(crate) struct CrossSection {
    /// Starts with the contact point itself (sigma = 0, a = h = 0, tangent (1, 0)).
    pub forward: Vec<SectionNode>,
    /// Backward nodes, nearest first; their `a` is negative.
    pub backward: Vec<SectionNode>,
    /// The forward trace ran into the edge of the surface.
    pub forward_hit_boundary: bool,
}

/// Where the next contact point lies on the cross-section.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct NextContact {
    /// Arc length from the current contact point, mm (<= belt width).
    pub sigma: f64,
    pub uv: Vector2<f64>,
    /// Scallop height between the two belt segments, mm (<= h).
    pub scallop: f64,
    /// The surface edge came before the scallop or width limit.
    pub at_boundary: bool,
}

/// Unit feed direction and belt axis at a surface point: `t` is `feed`
/// projected onto the tangent plane, the axis is `n x t`.
pub fn frame(geom: &LocalGeometry, feed: Vector3<f64>) -> Option<(Vector3<f64>, Vector3<f64>)> {
    let n = geom.forms.n;
    let t = (feed - n * feed.dot(&n)).try_normalize(1e-12)?;
    let b = n.cross(&t).try_normalize(1e-12)?;
    Some((t, b))
}

/// The contact wheel's pose at a contact point: cc on the surface, wheel
/// centre cl = cc + R n, wheel axis along the belt width (n x feed).
pub fn pose(
    geom: &LocalGeometry,
    feed: Vector3<f64>,
    wheel_radius: f64,
    gouge: f64,
) -> Option<PathPoint> {
    let (t, b) = frame(geom, feed)?;
    let p = geom.point();
    let cl = p + geom.forms.n * wheel_radius;
    let arr = |v: Vector3<f64>| [v.x, v.y, v.z];
    Some(PathPoint {
        cc: [p.x, p.y, p.z],
        cl: [cl.x, cl.y, cl.z],
        axis: arr(b),
        uv: [geom.forms.uv.x, geom.forms.uv.y],
        feed: Some(arr(t)),
        wheel_center: Some([cl.x, cl.y, cl.z]),
        wheel_axis: Some(arr(b)),
        normal: Some(arr(geom.forms.n)),
        gouge: (gouge > BELT_GOUGE_EPS).then_some(gouge),
        ..Default::default()
    })
}

/// What the planners collect along the way and judge at the end.
#[derive(Clone, Debug, Default)]
pub(crate) struct Diagnostics {
    /// Path points skipped where the surface normal is undefined.
    pub skipped: usize,
    /// The largest concave normal curvature along the feed, with its place.
    pub worst_concave: Option<(f64, Vector2<f64>, Point3<f64>)>,
}

impl Diagnostics {
    fn record_feed_curvature(&mut self, geom: &LocalGeometry, t: Vector3<f64>) {
        let kappa = geom.normal_curvature(t);
        if kappa > 0.0 && self.worst_concave.is_none_or(|(k, _, _)| kappa > k) {
            self.worst_concave = Some((kappa, geom.forms.uv, geom.point()));
        }
    }

    /// Error when the wheel cannot roll along a concave feed section: its
    /// radius must not exceed the smallest concave radius of curvature along
    /// the feed over the whole plan.
    pub(crate) fn check_wheel_fits(&self, wheel_radius: f64) -> Result<()> {
        let Some((kappa, uv, p)) = self.worst_concave else {
            return Ok(());
        };
        if kappa * wheel_radius > 1.0 + 1e-9 {
            return Err(Error::invalid(
                "tool.wheel_radius",
                format!(
                    "wheel radius {wheel_radius} mm is larger than the smallest concave radius of curvature along the feed, {:.3} mm, at (u, v) = ({:.4}, {:.4}), xyz = ({:.3}, {:.3}, {:.3}): the wheel would gouge there; use a wheel radius of at most {:.3} mm",
                    1.0 / kappa,
                    uv.x,
                    uv.y,
                    p.x,
                    p.y,
                    p.z,
                    1.0 / kappa
                ),
            ));
        }
        Ok(())
    }
}

/// Traces the cross-section through `geom`'s point normal to the unit feed `t`,
/// forward along `b` (the side where `b . hint >= 0`).
pub(crate) fn cross_section(
    surface: &NurbsSurface,
    geom: &LocalGeometry,
    t: Vector3<f64>,
    hint: Vector3<f64>,
    spec: &BeltSpec,
) -> Option<CrossSection> {
    let (t, mut b) = frame(geom, t)?;
    if b.dot(&hint) < 0.0 {
        b = -b;
    }
    let n0 = geom.forms.n;
    let origin = geom.point();
    let step = spec.trace_step();
    let (fwd, hit) = trace(surface, geom, origin, t, b, spec.width, step);
    let (bwd, _) = trace(surface, geom, origin, t, -b, 0.5 * spec.width, step);
    let to_node = |(sigma, uv, p, tau): (f64, Vector2<f64>, Point3<f64>, Vector3<f64>),
                   sign: f64| {
        let d = p - origin;
        SectionNode {
            sigma,
            uv,
            a: d.dot(&b),
            h: d.dot(&n0),
            ta: sign * tau.dot(&b),
            th: sign * tau.dot(&n0),
        }
    };
    let mut forward = Vec::with_capacity(fwd.len() + 1);
    forward.push(SectionNode {
        sigma: 0.0,
        uv: geom.forms.uv,
        a: 0.0,
        h: 0.0,
        ta: 1.0,
        th: 0.0,
    });
    forward.extend(fwd.into_iter().map(|s| to_node(s, 1.0)));
    let backward = bwd.into_iter().map(|s| to_node(s, -1.0)).collect();
    Some(CrossSection {
        forward,
        backward,
        forward_hit_boundary: hit,
    })
}

type Traced = (f64, Vector2<f64>, Point3<f64>, Vector3<f64>);

/// Predictor-corrector march along the intersection of the surface with the
/// plane through `origin` normal to `t`: tangent step in uv, then one Newton
/// step back onto the plane. Returns (arc length, uv, point, unit tangent)
/// per node and whether the surface edge stopped the trace.
fn trace(
    surface: &NurbsSurface,
    start: &LocalGeometry,
    origin: Point3<f64>,
    t: Vector3<f64>,
    dir: Vector3<f64>,
    reach: f64,
    step: f64,
) -> (Vec<Traced>, bool) {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let mut out = Vec::with_capacity((reach / step) as usize + 2);
    let mut uv = start.forms.uv;
    let mut d = start.forms.derivs;
    let mut tau = dir;
    let mut sigma = 0.0;
    while sigma < reach {
        // Predictor: unit tangent step mapped to uv through the first fundamental form.
        let (e, f, g) = (d.su.dot(&d.su), d.su.dot(&d.sv), d.sv.dot(&d.sv));
        let det = e * g - f * f;
        if det.is_nan() || det <= 1e-300 {
            return (out, true);
        }
        let (ru, rv) = (tau.dot(&d.su), tau.dot(&d.sv));
        let mut duv = Vector2::new(g * ru - f * rv, e * rv - f * ru) * (step / det);
        // Clip the step at the domain edge.
        let mut clipped = false;
        let mut scale: f64 = 1.0;
        for (x, dx, lo, hi) in [(uv.x, duv.x, u0, u1), (uv.y, duv.y, v0, v1)] {
            if x + dx > hi && dx > 0.0 {
                scale = scale.min((hi - x) / dx);
                clipped = true;
            } else if x + dx < lo && dx < 0.0 {
                scale = scale.min((lo - x) / dx);
                clipped = true;
            }
        }
        if clipped {
            if scale <= 1e-12 {
                return (out, true);
            }
            duv *= scale;
        }
        let mut next = uv + duv;
        // Corrector: Newton on f(uv) = (S(uv) - origin) . t, along the gradient.
        let dp = surface.derivs(next.x, next.y);
        let fval = (dp.p - origin).dot(&t);
        let grad = Vector2::new(dp.su.dot(&t), dp.sv.dot(&t));
        let g2 = grad.norm_squared();
        if g2 > 1e-300 {
            next -= grad * (fval / g2);
        }
        next.x = next.x.clamp(u0, u1);
        next.y = next.y.clamp(v0, v1);
        let dn = surface.derivs(next.x, next.y);
        let Some(n) = dn.su.cross(&dn.sv).try_normalize(1e-300) else {
            return (out, true);
        };
        let Some(mut tau_new) = n.cross(&t).try_normalize(1e-12) else {
            return (out, true);
        };
        if tau_new.dot(&tau) < 0.0 {
            tau_new = -tau_new;
        }
        sigma += (dn.p - d.p).norm();
        out.push((sigma, next, dn.p, tau_new));
        uv = next;
        d = dn;
        tau = tau_new;
        if clipped {
            return (out, true);
        }
    }
    (out, false)
}

/// Signed curvature of the section at forward node `k` (positive: bending
/// towards +h, i.e. concave towards the tool), from the turning of its tangent.
fn node_curvature(nodes: &[SectionNode], k: usize) -> f64 {
    let lo = k.saturating_sub(1);
    let hi = (k + 1).min(nodes.len() - 1);
    if hi == lo {
        return 0.0;
    }
    let (a, b) = (&nodes[lo], &nodes[hi]);
    let dtheta = (a.ta * b.th - a.th * b.ta).atan2(a.ta * b.ta + a.th * b.th);
    let ds = b.sigma - a.sigma;
    if ds > 0.0 {
        dtheta / ds
    } else {
        0.0
    }
}

impl CrossSection {
    /// Height above `l` of the meeting point of the belt segment at the
    /// contact point (the line h = 0) and the segment tangent at forward node
    /// `k`. Negative or zero where they meet on the material side (concave) or
    /// are parallel.
    pub(crate) fn scallop_at(&self, k: usize, width: f64) -> f64 {
        let nodes = &self.forward;
        let q = &nodes[k];
        // Segments laid end to end exactly (arc step w on a straight section)
        // must count as touching: allow rounding and the trace's overshoot of w.
        let half = 0.5 * width + 1e-6 * width + (q.sigma - width).max(0.0);
        // Tangent line at node k meets h = 0 at a = s, at distance lambda from node k.
        let (s, lambda) = if q.th.abs() > 1e-12 {
            let lambda = -q.h / q.th;
            (q.a + lambda * q.ta, lambda)
        } else {
            (f64::INFINITY, f64::INFINITY)
        };
        if !(s.abs() <= half && lambda.abs() <= half) {
            return self.envelope_residual(k, half);
        }
        // Nearest node (in a) to the meeting point among nodes 0..=k.
        let mut j = 0;
        let mut best = f64::INFINITY;
        for (i, nd) in nodes.iter().enumerate().take(k + 1) {
            let dist = (nd.a - s).abs();
            if dist < best {
                best = dist;
                j = i;
            }
        }
        let nj = &nodes[j];
        // Distance of X = (s, 0) from the curve near node j, to second order.
        let (dx, dh) = (s - nj.a, -nj.h);
        let e = dx * nj.ta + dh * nj.th;
        let above = -dx * nj.th + dh * nj.ta;
        above - 0.5 * node_curvature(nodes, j) * e * e
    }

    /// The finite segments do not meet (nearly parallel, e.g. across an
    /// inflection): the residual is the largest clearance between the section
    /// and the lower of the segments covering it, checked at the nodes, where
    /// the clearances cross and at each segment's end (where the other segment
    /// alone is left). Points covered by neither count with the lines extended.
    fn envelope_residual(&self, k: usize, half: f64) -> f64 {
        let nodes = &self.forward;
        let q = &nodes[k];
        // Per node: clearance below segment 0 and 1, and coverage margins.
        let eval = |nd: &SectionNode| -> [f64; 4] {
            let (dx, dh) = (nd.a - q.a, nd.h - q.h);
            [
                -nd.h,
                dx * q.th - dh * q.ta,
                half - nd.a.abs(),
                half - (dx * q.ta + dh * q.th).abs(),
            ]
        };
        let residual = |c: [f64; 4], skip0: bool, skip1: bool| -> f64 {
            let cov0 = c[2] >= 0.0 && !skip0;
            let cov1 = c[3] >= 0.0 && !skip1;
            match (cov0, cov1) {
                (true, true) => c[0].min(c[1]),
                (true, false) => c[0],
                (false, true) => c[1],
                (false, false) => c[0].min(c[1]),
            }
        };
        let mut worst: f64 = 0.0;
        let mut prev = eval(&nodes[0]);
        worst = worst.max(residual(prev, false, false));
        for nd in &nodes[1..=k] {
            let cur = eval(nd);
            worst = worst.max(residual(cur, false, false));
            let lerp =
                |t: f64| -> [f64; 4] { std::array::from_fn(|i| prev[i] + t * (cur[i] - prev[i])) };
            let crossing = |x0: f64, x1: f64| -> Option<f64> {
                ((x0 < 0.0) != (x1 < 0.0) && x0 != x1).then(|| x0 / (x0 - x1))
            };
            if let Some(t) = crossing(prev[0] - prev[1], cur[0] - cur[1]) {
                worst = worst.max(residual(lerp(t), false, false));
            }
            if let Some(t) = crossing(prev[2], cur[2]) {
                worst = worst.max(residual(lerp(t), true, false));
            }
            if let Some(t) = crossing(prev[3], cur[3]) {
                worst = worst.max(residual(lerp(t), false, true));
            }
            prev = cur;
        }
        worst
    }

    /// The farthest next contact point within arc length `w` with scallop <= `h`.
    pub(crate) fn next_contact(&self, spec: &BeltSpec) -> NextContact {
        let nodes = &self.forward;
        let (w, h) = (spec.width, spec.scallop);
        let mut prev_scallop = 0.0;
        for k in 1..nodes.len() {
            let sc = self.scallop_at(k, w);
            let (p, q) = (&nodes[k - 1], &nodes[k]);
            if sc > h {
                // Linear interpolation of the scallop between the two nodes.
                let f = ((h - prev_scallop) / (sc - prev_scallop)).clamp(0.0, 1.0);
                return NextContact {
                    sigma: p.sigma + f * (q.sigma - p.sigma),
                    uv: p.uv + (q.uv - p.uv) * f,
                    scallop: h,
                    at_boundary: false,
                };
            }
            if q.sigma >= w {
                let f = ((w - p.sigma) / (q.sigma - p.sigma)).clamp(0.0, 1.0);
                return NextContact {
                    sigma: w,
                    uv: p.uv + (q.uv - p.uv) * f,
                    scallop: prev_scallop + f * (sc - prev_scallop),
                    at_boundary: false,
                };
            }
            prev_scallop = sc.max(0.0);
        }
        let last = nodes.last().copied().unwrap_or(nodes[0]);
        NextContact {
            sigma: last.sigma,
            uv: last.uv,
            scallop: prev_scallop,
            at_boundary: self.forward_hit_boundary || nodes.len() == 1,
        }
    }

    /// Depth by which the rigid belt segment (length `w`, tangent at the
    /// contact point) lies below the surface: the largest height of the section
    /// above the segment within |a| <= w/2, measured along the surface normal.
    pub(crate) fn rigid_gouge(&self, width: f64) -> f64 {
        let half = 0.5 * width;
        let mut worst: f64 = 0.0;
        for nodes in [&self.forward[..], &self.backward[..]] {
            let mut prev: Option<&SectionNode> = None;
            for nd in nodes {
                if nd.a.abs() <= half {
                    worst = worst.max(nd.h);
                } else {
                    // Interpolate to the segment's end and stop.
                    if let Some(p) = prev {
                        let end = half * nd.a.signum();
                        let f = (end - p.a) / (nd.a - p.a);
                        if f.is_finite() {
                            worst = worst.max(p.h + f.clamp(0.0, 1.0) * (nd.h - p.h));
                        }
                    }
                    break;
                }
                prev = Some(nd);
            }
        }
        worst
    }
}

/// Spacing of the contact points along a path, mm: fine enough for the
/// removal simulation and for the per-point step search to see the surface.
pub fn point_spacing(spec: &BeltSpec) -> f64 {
    (spec.width / 8.0).clamp(0.05, 2.0)
}

/// What the contact model says about one point of a path.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ContactPoint {
    pub geom: LocalGeometry,
    /// Unit feed direction (sign not yet matched to the travel direction).
    pub t: Vector3<f64>,
    /// Rigid-belt gouge depth, mm (0 when none).
    pub gouge: f64,
    /// Next contact point across the feed (`None` when not asked or not traceable).
    pub next: Option<NextContact>,
}

/// Runs the contact model along one path given by its uv points. `feed` gives
/// the feed direction at a point, `hint` the side the next path lies on.
/// Points where the surface normal is undefined are skipped and counted.
pub(crate) fn analyse_path(
    surface: &NurbsSurface,
    uvs: &[Vector2<f64>],
    feed: &dyn Fn(&LocalGeometry) -> Vector3<f64>,
    hint: &dyn Fn(&LocalGeometry) -> Vector3<f64>,
    spec: &BeltSpec,
    want_next: bool,
    diag: &mut Diagnostics,
) -> Vec<ContactPoint> {
    let mut out = Vec::with_capacity(uvs.len());
    for uv in uvs {
        let Some(geom) = LocalGeometry::at(surface, uv.x, uv.y) else {
            diag.skipped += 1;
            continue;
        };
        let Some((t, _)) = frame(&geom, feed(&geom)) else {
            diag.skipped += 1;
            continue;
        };
        diag.record_feed_curvature(&geom, t);
        let (gouge, next) = match cross_section(surface, &geom, t, hint(&geom), spec) {
            Some(cs) => (
                cs.rigid_gouge(spec.width),
                want_next.then(|| cs.next_contact(spec)),
            ),
            None => (0.0, None),
        };
        out.push(ContactPoint {
            geom,
            t,
            gouge,
            next,
        });
    }
    out
}

/// [`assemble`] of paths given with their levels (cross parameter or section
/// offset), put in order of level first; a stable sort, so the planned
/// paths keep their order among equal levels (the sections of one plane).
pub(crate) fn assemble_levelled(
    mut paths: Vec<(f64, Vec<ContactPoint>)>,
    spec: &BeltSpec,
    result: &mut toolpath_formats::PlanResult,
    diag: &Diagnostics,
) -> Result<()> {
    paths.sort_by(|a, b| a.0.total_cmp(&b.0));
    assemble(
        paths.into_iter().map(|(_, p)| p).collect(),
        spec,
        result,
        diag,
    )
}

/// Turns analysed paths (in machining order) into result passes: each pass
/// runs opposite to the previous one (zig-zag), feed and wheel axis follow the
/// travel direction. Fills `max_gouge_mm` and the contact-path length.
pub(crate) fn assemble(
    paths: Vec<Vec<ContactPoint>>,
    spec: &BeltSpec,
    result: &mut toolpath_formats::PlanResult,
    diag: &Diagnostics,
) -> Result<()> {
    diag.check_wheel_fits(spec.wheel_radius)?;
    let skipped = diag.skipped;
    let mut max_gouge: f64 = 0.0;
    let mut gouged_points = 0usize;
    let mut cc_length = 0.0;
    for (i, mut path) in paths.into_iter().enumerate() {
        if path.len() < 2 {
            continue;
        }
        if i % 2 == 1 {
            path.reverse();
        }
        let mut points = Vec::with_capacity(path.len());
        for k in 0..path.len() {
            let (prev, next) = (
                &path[k.saturating_sub(1)],
                &path[(k + 1).min(path.len() - 1)],
            );
            let travel = next.geom.point() - prev.geom.point();
            let cp = &path[k];
            let t = if cp.t.dot(&travel) < 0.0 { -cp.t } else { cp.t };
            max_gouge = max_gouge.max(cp.gouge);
            if cp.gouge > BELT_GOUGE_EPS {
                gouged_points += 1;
            }
            if k > 0 {
                cc_length += (cp.geom.point() - path[k - 1].geom.point()).norm();
            }
            let pt = pose(&cp.geom, t, spec.wheel_radius, cp.gouge).ok_or_else(|| {
                Error::planning("internal: belt frame undefined at an analysed point")
            })?;
            points.push(pt);
        }
        result.passes.push(toolpath_formats::Pass {
            region: 0,
            points,
            min_strip_width: None,
        });
    }
    if result.passes.is_empty() {
        return Err(Error::planning(
            "the belt cannot reach the surface: no contact path could be built (surface normal undefined everywhere?)",
        ));
    }
    result.stats.max_gouge_mm = Some(max_gouge);
    result
        .stats
        .extra
        .insert("cc_path_length_mm".into(), cc_length);
    if gouged_points > 0 {
        result.warnings.push(format!(
            "rigid belt gouges concave sections at {gouged_points} contact points, up to {max_gouge:.4} mm (see the per-point \"gouge\"; a compliant belt would conform there)"
        ));
    }
    if skipped > 0 {
        result.warnings.push(format!(
            "{skipped} path points skipped where the surface normal is undefined"
        ));
    }
    Ok(())
}
