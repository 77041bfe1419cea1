// SPDX-License-Identifier:BSL-1.0

// Boost.Polygon library detail/voronoi_predicates.hpp header file

//          Copyright Andrii Sydorchuk 2010-2012.
// Distributed under the Boost Software License, Version 1.0.
//    (See accompanying file LICENSE_1_0.txt or copy at
//          http://www.boost.org/LICENSE_1_0.txt)

// See http://www.boost.org for updates, documentation, and revision history of C++ code.

// Ported from C++ boost 1.76.0 to Rust in 2020/2021 by Eadf (github.com/eadf)

//! Lazy evaluation of circle event

use crate::circle_event::CircleEvent;
use crate::extended_scalar::robust_fpt as rf;
use crate::predicate::orientation_predicate::{self, Orientation};
use crate::predicate::{ULPSX2, exact_circle_formation, robust_cross_product};
use crate::site_event as vse;
use crate::{InputType, cast, geometry::Point, predicate::SiteIndex, t, tln};

/// Lazy evaluation of point, point, point circle events
pub(crate) fn ppp<I: InputType>(
    point1: Point<I>,
    point2: Point<I>,
    point3: Point<I>,
    mut c_event: CircleEvent,
) -> Option<CircleEvent> {
    // toolpath_planner patch: evaluated in a frame centred on point1 (see `to_global`).
    let global = (point1, point2, point3);
    let (point1, point2, point3, origin) = match (
        local_point(point1, global.0),
        local_point(point2, global.0),
        local_point(point3, global.0),
    ) {
        (Some(p1), Some(p2), Some(p3)) => (
            p1,
            p2,
            p3,
            (cast::<I, f64>(global.0.x), cast::<I, f64>(global.0.y)),
        ),
        _ => (point1, point2, point3, (0.0, 0.0)),
    };
    let dif_x1 = cast::<I, f64>(point1.x) - cast::<I, f64>(point2.x);
    let dif_x2 = cast::<I, f64>(point2.x) - cast::<I, f64>(point3.x);
    let dif_y1 = cast::<I, f64>(point1.y) - cast::<I, f64>(point2.y);
    let dif_y2 = cast::<I, f64>(point2.y) - cast::<I, f64>(point3.y);
    let orientation = robust_cross_product::<i64>(
        cast::<I, i64>(point1.x) - cast::<I, i64>(point2.x),
        cast::<I, i64>(point2.x) - cast::<I, i64>(point3.x),
        cast::<I, i64>(point1.y) - cast::<I, i64>(point2.y),
        cast::<I, i64>(point2.y) - cast::<I, i64>(point3.y),
    );
    let inv_orientation: rf::RobustFpt = rf::RobustFpt::new(
        cast::<f32, f64>(0.5f32) / orientation,
        cast::<f32, f64>(2.0f32),
    );
    let sum_x1: f64 = cast::<I, f64>(point1.x) + cast::<I, f64>(point2.x);
    let sum_x2: f64 = cast::<I, f64>(point2.x) + cast::<I, f64>(point3.x);
    let sum_y1: f64 = cast::<I, f64>(point1.y) + cast::<I, f64>(point2.y);
    let sum_y2: f64 = cast::<I, f64>(point2.y) + cast::<I, f64>(point3.y);
    let dif_x3: f64 = cast::<I, f64>(point1.x) - cast::<I, f64>(point3.x);
    let dif_y3: f64 = cast::<I, f64>(point1.y) - cast::<I, f64>(point3.y);
    let mut c_x = rf::RobustDif::default();
    let mut c_y = rf::RobustDif::default();
    let error = 2_f64;
    c_x += rf::RobustFpt::new(dif_x1 * sum_x1 * dif_y2, error);
    c_x += rf::RobustFpt::new(dif_y1 * sum_y1 * dif_y2, error);
    c_x -= rf::RobustFpt::new(dif_x2 * sum_x2 * dif_y1, error);
    c_x -= rf::RobustFpt::new(dif_y2 * sum_y2 * dif_y1, error);
    c_y += rf::RobustFpt::new(dif_x2 * sum_x2 * dif_x1, error);
    c_y += rf::RobustFpt::new(dif_y2 * sum_y2 * dif_x1, error);
    c_y -= rf::RobustFpt::new(dif_x1 * sum_x1 * dif_x2, error);
    c_y -= rf::RobustFpt::new(dif_y1 * sum_y1 * dif_x2, error);
    let mut lower_x = c_x;
    lower_x -= rf::RobustFpt::new(
        ((dif_x1 * dif_x1 + dif_y1 * dif_y1)
            * (dif_x2 * dif_x2 + dif_y2 * dif_y2)
            * (dif_x3 * dif_x3 + dif_y3 * dif_y3))
            .sqrt(),
        cast::<f32, f64>(5.0f32),
    );

    // Upstream checks the numerators' bounds and scales afterwards.
    let scaled = |v: rf::RobustDif, origin: f64| {
        if upstream_predicates() {
            rf::RobustFpt::new(v.dif().fpv() * inv_orientation.fpv(), v.dif().ulp())
        } else {
            to_global(v.dif() * inv_orientation, origin)
        }
    };
    let c_x = scaled(c_x, origin.0);
    let c_y = scaled(c_y, origin.1);
    let lower_x = scaled(lower_x, origin.0);
    let (point1, point2, point3) = global;
    c_event.set_3(c_x.fpv(), c_y.fpv(), lower_x.fpv());
    let ulps = ULPSX2 as f64;
    let recompute_c_x = c_x.ulp() > ulps;
    let recompute_c_y = c_y.ulp() > ulps;
    let recompute_lower_x = lower_x.ulp() > ulps;
    #[cfg(feature = "console_debug")]
    {
        assert!(!c_x.ulp().is_nan());
        assert!(!c_y.ulp().is_nan());
        assert!(!lower_x.ulp().is_nan());
    }

    if recompute_c_x || recompute_c_y || recompute_lower_x {
        exact_circle_formation::ppp::<I>(
            point1,
            point2,
            point3,
            &mut c_event,
            recompute_c_x,
            recompute_c_y,
            recompute_lower_x,
        );
    }
    Some(c_event)
}

// toolpath_planner patch (vendor/boostvoronoi/PATCH.md): the pps, pss and sss
// circle events are evaluated in a frame centred on one of their own sites and
// moved back with the error bound of that addition. In absolute coordinates a
// circle tangent to nearly collinear neighbouring segments (a finely sampled
// smooth outline) or touching a segment at its own end point loses ~1/angle
// relative precision to cancellation and nearly always fell back to the exact
// (big-integer) formulas; in the local frame the terms are small and the lazy
// value usually passes. Any value whose bound still exceeds the ULP budget is
// recomputed exactly from the untranslated sites, as before.

thread_local! {
    static UPSTREAM: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// On this thread, evaluate the lazy circle predicates as upstream 0.12.1
/// does (absolute frame, no refinement), e.g. to compare both in tests.
pub fn set_upstream_predicates(on: bool) {
    UPSTREAM.with(|u| u.set(on));
}

pub(crate) fn upstream_predicates() -> bool {
    UPSTREAM.with(|u| u.get())
}

/// `p - origin`, or None when a coordinate difference overflows `I`
/// (always None in upstream mode, which keeps the absolute frame).
fn local_point<I: InputType>(p: Point<I>, origin: Point<I>) -> Option<Point<I>> {
    if upstream_predicates() {
        return None;
    }
    Some(Point {
        x: p.x.checked_sub(&origin.x)?,
        y: p.y.checked_sub(&origin.y)?,
    })
}

/// A value computed in the local frame moved back by the frame's origin
/// (exact in f64), with the error bound of the addition: the local value's
/// absolute error over the result, plus one rounding. (`RobustFpt`'s own `+`
/// keeps the larger relative error of two same-signed terms, which is a valid
/// but, for a small local value plus a large origin, very loose bound.)
#[inline]
fn to_global(local: rf::RobustFpt, origin: f64) -> rf::RobustFpt {
    if origin == 0.0 {
        return local;
    }
    let value = local.fpv() + origin;
    if value == 0.0 {
        // Let the caller's budget check send it to the exact formulas.
        return rf::RobustFpt::new(value, f64::INFINITY);
    }
    let re = (local.fpv() * local.re() / value).abs() + 1.0;
    rf::RobustFpt::new(value, if re.is_nan() { f64::INFINITY } else { re })
}

type Triple = (rf::RobustFpt, rf::RobustFpt, rf::RobustFpt);
type Vec2 = (rf::RobustFpt, rf::RobustFpt);

/// Does an event computed in the local frame pass the budget once moved back?
/// Only then do the refinements below run.
fn within_budget(lazy: Triple, origin: (f64, f64)) -> bool {
    let ulps = ULPSX2 as f64;
    to_global(lazy.0, origin.0).ulp() <= ulps
        && to_global(lazy.1, origin.1).ulp() <= ulps
        && to_global(lazy.2, origin.0).ulp() <= ulps
}

/// The pss circle event when the point is an end point of one of the two
/// segments ("own" segment S, other segment T), refined with a formula that
/// stays accurate where the general one cancels. toolpath_planner patch.
///
/// Every polygon vertex gives such events, and along a finely sampled smooth
/// curve (S and T nearly parallel) the general formula loses ~(R/|S|)^2 in
/// relative precision. Here the circle touches S's line at the point P itself,
/// so its centre is c = P + t nS (nS the unit normal of S) and its distance to
/// T's line is |t|: t (cos(phi) - s) = q with s = +-1, phi the angle between
/// S and T and q = cross(dT, T0 - P) / |dT|. cos(phi) -+ 1 is taken as
/// -+sin^2 / (1 +- cos) where it would cancel, sin from the exact integer cross
/// product, so both roots keep a small relative error. The root is the one
/// inside the general formula's error interval (the other root lies far
/// outside it); when that is not unambiguous the general values are returned
/// unchanged and the caller's budget check sends them to the exact formulas.
fn pss_on_own_segment<I: InputType>(
    point: Point<I>,
    site2: &vse::SiteEvent<I>,
    site3: &vse::SiteEvent<I>,
    lazy: Triple,
    origin: (f64, f64),
) -> Triple {
    if upstream_predicates() || within_budget(lazy, origin) {
        return lazy;
    }
    let on = |s: &vse::SiteEvent<I>| point == s.point0() || point == s.point1();
    let (own, other) = match (on(site2), on(site3)) {
        (true, false) => (site2, site3),
        (false, true) => (site3, site2),
        _ => return lazy,
    };
    let i = |v: I| cast::<I, i64>(v);
    let (px, py) = (i(point.x), i(point.y));
    let (sx, sy) = (i(own.x1()) - i(own.x0()), i(own.y1()) - i(own.y0()));
    let (tx, ty) = (i(other.x1()) - i(other.x0()), i(other.y1()) - i(other.y0()));
    let (ox, oy) = (i(other.x0()) - px, i(other.y0()) - py);
    // Exact in i64 for coordinates below 2^30 in magnitude (differences below
    // 2^31); larger input keeps the general values.
    let small = |v: i64| v.abs() < (1_i64 << 30);
    if ![sx, sy, tx, ty, ox, oy].into_iter().all(small) {
        return lazy;
    }
    // One rounding each from the exact integers.
    let exact = |v: i64| rf::RobustFpt::new(v as f64, 1_f64);
    let ls2 = exact(sx * sx + sy * sy);
    let lt2 = exact(tx * tx + ty * ty);
    if ls2.fpv() == 0.0 || lt2.fpv() == 0.0 {
        return lazy;
    }
    let (ls, lt) = (ls2.sqrt(), lt2.sqrt());
    let dot = exact(sx * tx + sy * ty);
    let cross = exact(sx * ty - sy * tx);
    let q = exact(tx * oy - ty * ox);
    if q.fpv() == 0.0 {
        return lazy;
    }
    let one = rf::RobustFpt::from(1_f64);
    let cos = dot / (ls * lt);
    let sin2 = (cross * cross) / (ls2 * lt2);
    // cos - 1 and cos + 1 without cancellation.
    let (cos_minus_1, cos_plus_1) = if !cos.is_neg() {
        (-(sin2 / (one + cos)), cos + one)
    } else {
        (cos - one, sin2 / (one - cos))
    };
    let (nx, ny) = (exact(-sy) / ls, exact(sx) / ls);
    let candidate = |d: rf::RobustFpt| -> Option<(rf::RobustFpt, rf::RobustFpt, rf::RobustFpt)> {
        if d.fpv() == 0.0 || !d.fpv().is_finite() {
            return None;
        }
        let t = q / (lt * d);
        let c_x = to_global(t * nx, px as f64);
        let c_y = to_global(t * ny, py as f64);
        let r = if t.is_neg() { -t } else { t };
        Some((c_x, c_y, c_x + r))
    };
    // Does the root lie within `slack` times the two error bounds of the general value?
    let near = |c: &(rf::RobustFpt, rf::RobustFpt, rf::RobustFpt), slack: f64| {
        let close = |a: rf::RobustFpt, b: rf::RobustFpt| {
            let bound = (a.fpv().abs() * a.ulp() + b.fpv().abs() * b.ulp() + a.fpv().abs())
                * f64::EPSILON
                * slack;
            (a.fpv() - b.fpv()).abs() <= bound
        };
        close(lazy.0, c.0) && close(lazy.1, c.1)
    };
    let roots = [candidate(cos_minus_1), candidate(cos_plus_1)];
    match roots {
        [Some(a), b] if near(&a, 2.0) && !b.as_ref().is_some_and(|b| near(b, 8.0)) => a,
        [a, Some(b)] if near(&b, 2.0) && !a.as_ref().is_some_and(|a| near(a, 8.0)) => b,
        _ => lazy,
    }
}

/// The root among `roots` that lies inside the general formula's error
/// interval while no other root comes near it; else the general values.
fn pick_root(lazy: Triple, roots: &[Option<Triple>]) -> Triple {
    let near = |c: &Triple, slack: f64| {
        let close = |a: rf::RobustFpt, b: rf::RobustFpt| {
            let bound = (a.fpv().abs() * a.ulp() + b.fpv().abs() * b.ulp() + a.fpv().abs())
                * f64::EPSILON
                * slack;
            (a.fpv() - b.fpv()).abs() <= bound
        };
        close(lazy.0, c.0) && close(lazy.1, c.1)
    };
    let mut found = None;
    for (k, root) in roots.iter().enumerate() {
        let Some(root) = root else { continue };
        if near(root, 8.0) {
            if found.is_some() || !near(root, 2.0) {
                return lazy;
            }
            found = Some(k);
        }
    }
    match found.and_then(|k| roots[k]) {
        Some(root) => root,
        None => lazy,
    }
}

/// Integer inputs of the refinements must stay below 2^30 in magnitude, so
/// that the squares and cross products below are exact in i64.
fn small_enough(values: &[i64]) -> bool {
    values.iter().all(|v| v.abs() < (1_i64 << 30))
}

/// One rounding from an exact integer.
fn exact_fpt(v: i64) -> rf::RobustFpt {
    rf::RobustFpt::new(v as f64, 1_f64)
}

/// Unit vector along the integer vector d (None for a zero vector).
fn unit(d: (i64, i64)) -> Option<Vec2> {
    let l2 = exact_fpt(d.0 * d.0 + d.1 * d.1);
    if l2.fpv() == 0.0 {
        return None;
    }
    let l = l2.sqrt();
    Some((exact_fpt(d.0) / l, exact_fpt(d.1) / l))
}

/// The two bisector directions (unit) of the lines along integer vectors a
/// and b, each with the sine |cross(u_a, bisector)| (the distance to line a per
/// unit length along the bisector) and its square's complement
/// (u_a . bisector)^2, formed without cancellation from the exact cross
/// product.
fn bisectors(a: (i64, i64), b: (i64, i64)) -> Option<[(Vec2, rf::RobustFpt, rf::RobustFpt); 2]> {
    let (ua, ub) = (unit(a)?, unit(b)?);
    let la = exact_fpt(a.0 * a.0 + a.1 * a.1).sqrt();
    let lb = exact_fpt(b.0 * b.0 + b.1 * b.1).sqrt();
    let dot = exact_fpt(a.0 * b.0 + a.1 * b.1) / (la * lb);
    let cross = exact_fpt(a.0 * b.1 - a.1 * b.0) / (la * lb);
    // s = u_a + sigma u_b with sigma making u_a . (sigma u_b) = d >= 0.
    let (sigma, d) = if dot.is_neg() { (-1_f64, -dot) } else { (1_f64, dot) };
    let one = rf::RobustFpt::from(1_f64);
    let one_d = one + d;
    let s_len = (rf::RobustFpt::from(2_f64) * one_d).sqrt();
    let sig = rf::RobustFpt::from(sigma);
    let b1 = ((ua.0 + sig * ub.0) / s_len, (ua.1 + sig * ub.1) / s_len);
    let b2 = (-b1.1, b1.0);
    let abs = |v: rf::RobustFpt| if v.is_neg() { -v } else { v };
    let half = rf::RobustFpt::from(0.5_f64);
    // Along b1: sine |cross| / |s|, complement (1 + d) / 2.
    let k1 = abs(cross) / s_len;
    let a1 = one_d * half;
    // Along b2 (perpendicular): sine (1 + d) / |s|, complement cross^2 / |s|^2.
    let k2 = one_d / s_len;
    let a2 = (cross * cross) / (s_len * s_len);
    Some([(b1, k1, a1), (b2, k2, a2)])
}

/// The pss circle event when the two segments share an end point V and the
/// point P is elsewhere (toolpath_planner patch): along two nearly collinear
/// neighbours of a finely sampled curve the general formula cancels. The
/// centre lies on a bisector of the two lines through V, c = V + u b, and
/// |c - P| = u k (k the bisector's sine): a u^2 + 2 (w . b) u + |w|^2 = 0 with
/// w = V - P and a = 1 - k^2 from `bisectors`, solved in the stable form. The
/// root inside the general formula's error interval is taken (`pick_root`).
fn pss_shared_vertex<I: InputType>(
    point: Point<I>,
    site2: &vse::SiteEvent<I>,
    site3: &vse::SiteEvent<I>,
    lazy: Triple,
    origin: (f64, f64),
) -> Triple {
    if upstream_predicates() || within_budget(lazy, origin) {
        return lazy;
    }
    let i = |v: I| cast::<I, i64>(v);
    let pt = |p: Point<I>| (i(p.x), i(p.y));
    let (s0, s1, t0, t1) = (
        pt(site2.point0()),
        pt(site2.point1()),
        pt(site3.point0()),
        pt(site3.point1()),
    );
    let p = pt(point);
    if p == s0 || p == s1 || p == t0 || p == t1 {
        return lazy;
    }
    // The shared vertex and the two directions away from it.
    let (v, ds, dt) = if s0 == t0 {
        (s0, (s1.0 - s0.0, s1.1 - s0.1), (t1.0 - t0.0, t1.1 - t0.1))
    } else if s0 == t1 {
        (s0, (s1.0 - s0.0, s1.1 - s0.1), (t0.0 - t1.0, t0.1 - t1.1))
    } else if s1 == t0 {
        (s1, (s0.0 - s1.0, s0.1 - s1.1), (t1.0 - t0.0, t1.1 - t0.1))
    } else if s1 == t1 {
        (s1, (s0.0 - s1.0, s0.1 - s1.1), (t0.0 - t1.0, t0.1 - t1.1))
    } else {
        return lazy;
    };
    let w = (v.0 - p.0, v.1 - p.1);
    if !small_enough(&[ds.0, ds.1, dt.0, dt.1, w.0, w.1, v.0, v.1, p.0, p.1]) {
        return lazy;
    }
    let Some(bis) = bisectors(ds, dt) else {
        return lazy;
    };
    let gamma = exact_fpt(w.0 * w.0 + w.1 * w.1);
    let (wx, wy) = (exact_fpt(w.0), exact_fpt(w.1));
    let (vx, vy) = (exact_fpt(v.0), exact_fpt(v.1));
    let mut roots: [Option<Triple>; 4] = [None; 4];
    for (k, (b, sine, a)) in bis.into_iter().enumerate() {
        let beta = wx * b.0 + wy * b.1;
        let disc = beta * beta - a * gamma;
        if disc.is_neg() || !disc.fpv().is_finite() {
            continue;
        }
        let sq = disc.sqrt();
        let q = if beta.is_neg() { sq - beta } else { -(beta + sq) };
        let centre = |u: rf::RobustFpt| -> Triple {
            let c_x = vx + u * b.0;
            let c_y = vy + u * b.1;
            let r = (if u.is_neg() { -u } else { u }) * sine;
            (c_x, c_y, c_x + r)
        };
        if a.fpv() != 0.0 {
            roots[2 * k] = Some(centre(q / a));
        }
        if q.fpv() != 0.0 {
            roots[2 * k + 1] = Some(centre(gamma / q));
        }
    }
    pick_root(lazy, &roots)
}

/// The sss circle event of three consecutive segments (the middle one shares
/// an end point with each of the others; toolpath_planner patch): the centre
/// is where a bisector through one shared vertex X meets a bisector through
/// the other, Y: c = X + u bX, u = cross(Y - X, bY) / cross(bX, bY), with
/// r = u kX. Nearly collinear neighbours make the bisectors nearly parallel,
/// which costs 1/angle here instead of the general formula's ~1/angle^2. The
/// root inside the general formula's error interval is taken (`pick_root`).
fn sss_consecutive<I: InputType>(
    site1: &vse::SiteEvent<I>,
    site2: &vse::SiteEvent<I>,
    site3: &vse::SiteEvent<I>,
    lazy: Triple,
    origin: (f64, f64),
) -> Triple {
    if upstream_predicates() || within_budget(lazy, origin) {
        return lazy;
    }
    let i = |v: I| cast::<I, i64>(v);
    let ends = |s: &vse::SiteEvent<I>| {
        (
            (i(s.point0().x), i(s.point0().y)),
            (i(s.point1().x), i(s.point1().y)),
        )
    };
    let segs = [ends(site1), ends(site2), ends(site3)];
    // (shared point, direction of m away from it, direction of o away from it)
    let shared = |m: ((i64, i64), (i64, i64)), o: ((i64, i64), (i64, i64))| {
        let away = |from: (i64, i64), to: (i64, i64)| (to.0 - from.0, to.1 - from.1);
        for (pm, qm) in [(m.0, m.1), (m.1, m.0)] {
            for (po, qo) in [(o.0, o.1), (o.1, o.0)] {
                if pm == po {
                    return Some((pm, away(pm, qm), away(po, qo)));
                }
            }
        }
        None
    };
    let mut joints = None;
    for mid in 0..3 {
        let (o1, o2) = ((mid + 1) % 3, (mid + 2) % 3);
        if let (Some(x), Some(y)) = (shared(segs[mid], segs[o1]), shared(segs[mid], segs[o2])) {
            if x.0 != y.0 {
                joints = Some((x, y));
                break;
            }
        }
    }
    let Some(((x, dmx, dox), (y, dmy, doy))) = joints else {
        return lazy;
    };
    if !small_enough(&[x.0, x.1, y.0, y.1, dmx.0, dmx.1, dox.0, dox.1, dmy.0, dmy.1, doy.0, doy.1])
    {
        return lazy;
    }
    let (Some(bx), Some(by)) = (bisectors(dmx, dox), bisectors(dmy, doy)) else {
        return lazy;
    };
    let (xx, xy) = (exact_fpt(x.0), exact_fpt(x.1));
    let (yx, yy) = (exact_fpt(y.0 - x.0), exact_fpt(y.1 - x.1));
    let mut roots: [Option<Triple>; 4] = [None; 4];
    for (k, (b1, sine, _)) in bx.into_iter().enumerate() {
        for (l, (b2, _, _)) in by.into_iter().enumerate() {
            let den = b1.0 * b2.1 - b1.1 * b2.0;
            if den.fpv() == 0.0 {
                continue;
            }
            let u = (yx * b2.1 - yy * b2.0) / den;
            let c_x = xx + u * b1.0;
            let c_y = xy + u * b1.1;
            let r = (if u.is_neg() { -u } else { u }) * sine;
            roots[2 * k + l] = Some((c_x, c_y, c_x + r));
        }
    }
    pick_root(lazy, &roots)
}

/// Lazy evaluation of point, point, segment circle events
pub(crate) fn pps<I: InputType>(
    point1: Point<I>,
    point2: Point<I>,
    site3: &vse::SiteEvent<I>,
    segment_index: SiteIndex,
    mut c_event: CircleEvent,
) -> Option<CircleEvent> {
    tln!(
        "->LazyCircleFormationFunctor::pps(site1:{:?}, site2:{:?}, site3:{:?}, segment_index:{:?})",
        point1,
        point2,
        site3,
        segment_index
    );

    let global = (point1, point2, *site3);
    let (point1, point2, site3_local, origin) = match (
        local_point(point1, global.0),
        local_point(point2, global.0),
        site3.translated_unless_upstream(global.0),
    ) {
        (Some(p1), Some(p2), Some(s3)) => (
            p1,
            p2,
            s3,
            (cast::<I, f64>(global.0.x), cast::<I, f64>(global.0.y)),
        ),
        _ => (point1, point2, *site3, (0.0, 0.0)),
    };
    let site3 = &site3_local;
    // (line_a,line_b) it the perpendicular vector of site3-point0 -> site3-point1
    let line_a = cast::<I, f64>(site3.y1()) - cast::<I, f64>(site3.y0());
    let line_b = cast::<I, f64>(site3.x0()) - cast::<I, f64>(site3.x1());
    // (vec_x,vec_y) it the perpendicular vector of site1->site2
    // t*(vec_x,vec_y) + midpoint(site1->site2) is our circle event position
    let vec_x = cast::<I, f64>(point2.y) - cast::<I, f64>(point1.y);
    let vec_y = cast::<I, f64>(point1.x) - cast::<I, f64>(point2.x);

    let teta = rf::RobustFpt::new(
        robust_cross_product::<i64>(
            cast::<I, i64>(site3.y1()) - cast::<I, i64>(site3.y0()),
            cast::<I, i64>(site3.x0()) - cast::<I, i64>(site3.x1()),
            cast::<I, i64>(point2.x) - cast::<I, i64>(point1.x),
            cast::<I, i64>(point2.y) - cast::<I, i64>(point1.y),
        ),
        1_f64,
    );
    let a = rf::RobustFpt::new(
        robust_cross_product::<i64>(
            cast::<I, i64>(site3.y0()) - cast::<I, i64>(site3.y1()),
            cast::<I, i64>(site3.x0()) - cast::<I, i64>(site3.x1()),
            cast::<I, i64>(site3.y1()) - cast::<I, i64>(point1.y),
            cast::<I, i64>(site3.x1()) - cast::<I, i64>(point1.x),
        ),
        1_f64,
    );
    let b = rf::RobustFpt::new(
        robust_cross_product::<i64>(
            cast::<I, i64>(site3.y0()) - cast::<I, i64>(site3.y1()),
            cast::<I, i64>(site3.x0()) - cast::<I, i64>(site3.x1()),
            cast::<I, i64>(site3.y1()) - cast::<I, i64>(point2.y),
            cast::<I, i64>(site3.x1()) - cast::<I, i64>(point2.x),
        ),
        1_f64,
    );
    let denom = rf::RobustFpt::new(
        robust_cross_product::<i64>(
            cast::<I, i64>(point1.y) - cast::<I, i64>(point2.y),
            cast::<I, i64>(point1.x) - cast::<I, i64>(point2.x),
            cast::<I, i64>(site3.y1()) - cast::<I, i64>(site3.y0()),
            cast::<I, i64>(site3.x1()) - cast::<I, i64>(site3.x0()),
        ),
        1_f64,
    );
    let inv_segm_len =
        rf::RobustFpt::new(1_f64 / (line_a * line_a + line_b * line_b).sqrt(), 3_f64);
    let mut t = rf::RobustDif::default();
    //tln!("0t:{:?}", t);
    if orientation_predicate::eval_f(denom.fpv()) == Orientation::Collinear {
        t += teta / (rf::RobustFpt::from(8_f64) * a);
        //tln!("1t:{:?}", t);
        t -= a / (rf::RobustFpt::from(2_f64) * teta);
        //tln!("2t:{:?}", t);
    } else {
        let det = ((teta * teta + denom * denom) * a * b).sqrt();
        //tln!("det:{:?}", det);
        if segment_index == SiteIndex::Two {
            //tln!("3 det:{:?}", det);
            //tln!("3 denom:{:?}", denom);
            //tln!("3 det/denom:{:?}", det / (denom * denom));
            t -= det / (denom * denom);
            //tln!("3t:{:?}", t);
        } else {
            t += det / (denom * denom);
            //tln!("4t:{:?}", t);
        }
        //tln!("5teta:{:?}", teta);
        //tln!("A:{:?}", a);
        //tln!("B:{:?}", b);
        t += teta * (a + b) / (rf::RobustFpt::from(2_f64) * denom * denom);
        //tln!("5t:{:?}", t);
    }
    //tln!("6t:{:?}", t);
    let mut c_x = rf::RobustDif::default();
    tln!("0: c_x:{:?}", c_x);
    let mut c_y = rf::RobustDif::default();
    c_x += rf::RobustFpt::from(0.5 * (cast::<I, f64>(point1.x) + cast::<I, f64>(point2.x)));
    tln!("1: c_x:{:?}", c_x);
    c_x += t * rf::RobustFpt::from(vec_x);
    tln!("2: c_x:{:?}", c_x);
    c_y += rf::RobustFpt::from(0.5 * (cast::<I, f64>(point1.y) + cast::<I, f64>(point2.y)));
    c_y += t * rf::RobustFpt::from(vec_y);

    let mut r = rf::RobustDif::default();
    let mut lower_x = c_x;
    r -= rf::RobustFpt::from(line_a) * rf::RobustFpt::from(cast::<I, f64>(site3.x0()));
    r -= rf::RobustFpt::from(line_b) * rf::RobustFpt::from(cast::<I, f64>(site3.y0()));
    r += c_x * rf::RobustFpt::from(line_a);
    r += c_y * rf::RobustFpt::from(line_b);
    if r.positive().fpv() < r.negative().fpv() {
        r = -r;
    }
    lower_x += r * inv_segm_len;

    let c_x = to_global(c_x.dif(), origin.0);
    let c_y = to_global(c_y.dif(), origin.1);
    let lower_x = to_global(lower_x.dif(), origin.0);
    let (point1, point2, site3) = (global.0, global.1, &global.2);
    c_event.set_3(c_x.fpv(), c_y.fpv(), lower_x.fpv());

    tln!("  c_x:{:?}, c_y:{:?}, l_x:{:?}", c_x, c_y, lower_x);

    let ulps = ULPSX2 as f64;
    let recompute_c_x = c_x.ulp() > ulps;
    let recompute_c_y = c_y.ulp() > ulps;
    let recompute_lower_x = lower_x.ulp() > ulps;
    tln!(
        "  recompute_c_x:{}, recompute_c_y:{}, recompute_lower_x:{}",
        recompute_c_x,
        recompute_c_y,
        recompute_lower_x
    );

    #[cfg(feature = "console_debug")]
    {
        assert!(!c_x.ulp().is_nan());
        assert!(!c_y.ulp().is_nan());
        assert!(!lower_x.ulp().is_nan());
    }

    if recompute_c_x || recompute_c_y || recompute_lower_x {
        exact_circle_formation::pps::<I>(
            point1,
            point2,
            site3,
            segment_index,
            &mut c_event,
            recompute_c_x,
            recompute_c_y,
            recompute_lower_x,
        );
    }
    // All sites must be unique, or the dot calculation will be invalid
    let unique_endpoints = !(
        point1 == point2
            || site3.point0() == point1
            || site3.point0() == point2
            || site3.point1() == point1
            || site3.point1() == point2
        //|| site3.point0() == site3.point1() this can never happen
    );
    tln!("pps unique_endpoints:{}", unique_endpoints);

    if unique_endpoints {
        // site3.point0 -> c
        let v_3_c = (
            c_event.x() - cast::<I, f64>(site3.point0().x),
            c_event.y() - cast::<I, f64>(site3.point0().y),
        );
        // site3.point0 -> site3.point1
        let v_3 = (
            cast::<I, f64>(site3.point1().x) - cast::<I, f64>(site3.point0().x),
            cast::<I, f64>(site3.point1().y) - cast::<I, f64>(site3.point0().y),
        );
        #[allow(clippy::suspicious_operation_groupings)]
        let dot = (v_3_c.0 * v_3.0 + v_3_c.1 * v_3.1) / (v_3.0 * v_3.0 + v_3.1 * v_3.1);
        tln!("pps dot:{:.12}", dot);

        // allow the dot to be [0..1] + some ULP fuzz
        let rv =
            (-0.0..=1.0).contains(&dot) || approx::ulps_eq!(0.0, dot) || approx::ulps_eq!(1.0, dot);

        #[cfg(all(feature = "ce_corruption_check", feature = "geo"))]
        if !rv {
            println!(
                "\n->LazyCircleFormationFunctor::pps(site1:{:?}, site2:{:?}, site3:{:?}, segment_index:{:?})",
                point1, point2, site3, segment_index
            );

            println!("let site1=[{},{}];", point1.x, point1.y);
            println!("let site2=[{},{}];", point2.x, point2.y);
            println!(
                "let site3=[{},{},{},{}];",
                site3.point0().x,
                site3.point0().y,
                site3.point1().x,
                site3.point1().y
            );
            println!(
                "let c1=[{:.12},{:.12}];//lx={:.12}",
                c_x.fpv(),
                c_y.fpv(),
                lower_x.fpv()
            );

            println!(
                "site1->c distance:{:-12}",
                point1.distance_to_point(c_event.x(), c_event.y())
            );
            println!(
                "site2->c distance:{:-12}",
                point2.distance_to_point(c_event.x(), c_event.y())
            );
            println!(
                "site3->c distance:{:-12}",
                site3.distance_to_point(c_event.x(), c_event.y())
            );

            println!("v_a_c:{:?}, v3:{:?}", v_3_c, v_3);
            println!("dot:{:?}", dot);
            println!("ignoring this CE\n");
        }
        return rv.then_some(c_event);
    };
    Some(c_event)
}

/// Lazy evaluation of point, segment, segment circle events
#[allow(unused_parens)]
pub(crate) fn pss<I: InputType>(
    point1: Point<I>,
    site2: &vse::SiteEvent<I>,
    site3: &vse::SiteEvent<I>,
    point_index: SiteIndex,
    mut c_event: CircleEvent,
) -> Option<CircleEvent> {
    tln!(
        "->LazyCircleFormationFunctor::pss(site1:{:?}, site2:{:?}, site3:{:?}, point_index:{:?})",
        point1,
        site2,
        site3,
        point_index
    );

    // This is a case that does not exists in C++ boost voronoi.
    // If site1 is a point shared by both site2 and site3 there can only be one CE solution.
    // The CE must be the site1 point with zero radius.
    // It seems better to use the pristine int coordinate instead of spending cycles
    // re-calculating it again with lossy floats.
    #[allow(clippy::suspicious_operation_groupings)]
    if (point1 == site2.point0() || point1 == site2.point1())
        && (point1 == site3.point0() || point1 == site3.point1())
    {
        c_event.set_is_site_point();
        let x = cast::<I, f64>(point1.x);
        let y = cast::<I, f64>(point1.y);
        c_event.set_3(x, y, x);
        tln!("<-LazyCircleFormationFunctor::pss shortcut");
        return Some(c_event);
    }

    let global = (point1, *site2, *site3);
    let (point1, site2_local, site3_local, origin) = match (
        local_point(point1, global.0),
        site2.translated_unless_upstream(global.0),
        site3.translated_unless_upstream(global.0),
    ) {
        (Some(p1), Some(s2), Some(s3)) => (
            p1,
            s2,
            s3,
            (cast::<I, f64>(global.0.x), cast::<I, f64>(global.0.y)),
        ),
        _ => (point1, *site2, *site3, (0.0, 0.0)),
    };
    let (site2, site3) = (&site2_local, &site3_local);
    let segm_start1 = site2.point1();
    let segm_end1 = site2.point0();
    let segm_start2 = site3.point0();
    let segm_end2 = site3.point1();
    let a1 = cast::<I, f64>(segm_end1.x) - cast::<I, f64>(segm_start1.x);
    let b1 = cast::<I, f64>(segm_end1.y) - cast::<I, f64>(segm_start1.y);
    let a2 = cast::<I, f64>(segm_end2.x) - cast::<I, f64>(segm_start2.x);
    let b2 = cast::<I, f64>(segm_end2.y) - cast::<I, f64>(segm_start2.y);
    let recompute_c_x: bool;
    let recompute_c_y: bool;
    let recompute_lower_x: bool;

    let orientation = rf::RobustFpt::new(
        robust_cross_product::<i64>(
            cast::<I, i64>(segm_end1.y) - cast::<I, i64>(segm_start1.y),
            cast::<I, i64>(segm_end1.x) - cast::<I, i64>(segm_start1.x),
            cast::<I, i64>(segm_end2.y) - cast::<I, i64>(segm_start2.y),
            cast::<I, i64>(segm_end2.x) - cast::<I, i64>(segm_start2.x),
        ),
        1_f64,
    );
    let is_collinear = orientation_predicate::eval_f(orientation.fpv()) == Orientation::Collinear;
    if is_collinear {
        tln!("  LazyCircleFormationFunctor::pss collinear");
        let a = rf::RobustFpt::new(a1 * a1 + b1 * b1, 2_f64);
        let c = rf::RobustFpt::new(
            robust_cross_product::<i64>(
                cast::<I, i64>(segm_end1.y) - cast::<I, i64>(segm_start1.y),
                cast::<I, i64>(segm_end1.x) - cast::<I, i64>(segm_start1.x),
                cast::<I, i64>(segm_start2.y) - cast::<I, i64>(segm_start1.y),
                cast::<I, i64>(segm_start2.x) - cast::<I, i64>(segm_start1.x),
            ),
            1_f64,
        );
        let det = rf::RobustFpt::new(
            robust_cross_product::<i64>(
                cast::<I, i64>(segm_end1.x) - cast::<I, i64>(segm_start1.x),
                cast::<I, i64>(segm_end1.y) - cast::<I, i64>(segm_start1.y),
                cast::<I, i64>(point1.x) - cast::<I, i64>(segm_start1.x),
                cast::<I, i64>(point1.y) - cast::<I, i64>(segm_start1.y),
            ) * robust_cross_product::<i64>(
                cast::<I, i64>(segm_end1.y) - cast::<I, i64>(segm_start1.y),
                cast::<I, i64>(segm_end1.x) - cast::<I, i64>(segm_start1.x),
                cast::<I, i64>(point1.y) - cast::<I, i64>(segm_start2.y),
                cast::<I, i64>(point1.x) - cast::<I, i64>(segm_start2.x),
            ),
            3.0,
        );
        #[cfg(feature = "console_debug")]
        {
            if det.fpv() < 0.0 {
                println!("det was negative!  {:?}", det);
            }
            assert!(det.fpv() >= 0.0);
            assert!(det.fpv().is_finite());
            assert!(det.sqrt().fpv().is_finite());
        }

        let mut t = rf::RobustDif::default();
        t -= rf::RobustFpt::from(a1)
            * rf::RobustFpt::from(
                (cast::<I, f64>(segm_start1.x) + cast::<I, f64>(segm_start2.x)) * 0.5
                    - cast::<I, f64>(point1.x),
            );
        t -= rf::RobustFpt::from(b1)
            * rf::RobustFpt::from(
                (cast::<I, f64>(segm_start1.y) + cast::<I, f64>(segm_start2.y)) * 0.5
                    - cast::<I, f64>(point1.y),
            );
        if point_index == SiteIndex::Two {
            t += det.sqrt();
        } else {
            t -= det.sqrt();
        }
        t /= a;
        let mut c_x = rf::RobustDif::default();
        let mut c_y = rf::RobustDif::default();
        //tln!("ulps0: x:{:.12}, y:{:.12}", c_x.dif().fpv(), c_y.dif().fpv());
        c_x += rf::RobustFpt::from(
            0.5 * (cast::<I, f64>(segm_start1.x) + cast::<I, f64>(segm_start2.x)),
        );
        //tln!("ulps1: x:{:.12}, y:{:.12}", c_x.dif().fpv(), c_y.dif().fpv());
        //tln!("ulps1.5: 1:{:.12}, 2:{:.12}", rf::RobustFpt::from(a1).fpv(), t.dif().fpv());
        //tln!("ulps1.6: 1:{:.12}", (t*rf::RobustFpt::from(a1)).dif().fpv());
        c_x += t * rf::RobustFpt::from(a1);
        c_y += rf::RobustFpt::from(
            0.5 * (cast::<I, f64>(segm_start1.y) + cast::<I, f64>(segm_start2.y)),
        );
        //tln!("ulps2: x:{:.12}, y:{:.12}", c_x.dif().fpv(), c_y.dif().fpv());
        c_y += t * rf::RobustFpt::from(b1);
        //tln!("ulps3: x:{:.12}, y:{:.12}", c_x.dif().fpv(), c_y.dif().fpv());
        let mut lower_x = c_x;
        if c.is_neg() {
            lower_x -= rf::RobustFpt::from(0.5) * c / a.sqrt();
        } else {
            lower_x += rf::RobustFpt::from(0.5) * c / a.sqrt();
        }
        let lazy = (c_x.dif(), c_y.dif(), lower_x.dif());
        let lazy = pss_on_own_segment(point1, site2, site3, lazy, origin);
        let (c_x, c_y, lower_x) = pss_shared_vertex(point1, site2, site3, lazy, origin);
        let c_x = to_global(c_x, origin.0);
        let c_y = to_global(c_y, origin.1);
        let lower_x = to_global(lower_x, origin.0);
        let ulps = ULPSX2 as f64;
        recompute_c_x = c_x.ulp() > ulps;
        recompute_c_y = c_y.ulp() > ulps;
        recompute_lower_x = lower_x.ulp() > ulps;
        #[cfg(feature = "console_debug")]
        {
            tln!(
                "ulps:{}, x:{:.12}, y:{:.12}, lx:{:.12}",
                ulps,
                c_x.ulp(),
                c_y.ulp(),
                lower_x.ulp()
            );
            tln!(
                "x:{:.12}, y:{:.12}, lx:{:.12}",
                c_x.fpv(),
                c_y.fpv(),
                lower_x.fpv()
            );
            assert!(!c_x.ulp().is_nan());
            assert!(!c_y.ulp().is_nan());
            assert!(!lower_x.ulp().is_nan());
        }
        c_event.set_3(c_x.fpv(), c_y.fpv(), lower_x.fpv());
    } else {
        tln!("  LazyCircleFormationFunctor::pss !collinear");
        let sqr_sum1 = rf::RobustFpt::new((a1 * a1 + b1 * b1).sqrt(), 2_f64);
        let sqr_sum2 = rf::RobustFpt::new((a2 * a2 + b2 * b2).sqrt(), 2_f64);
        let mut a = rf::RobustFpt::new(
            robust_cross_product::<i64>(
                cast::<I, i64>(segm_end1.x) - cast::<I, i64>(segm_start1.x),
                cast::<I, i64>(segm_end1.y) - cast::<I, i64>(segm_start1.y),
                cast::<I, i64>(segm_start2.y) - cast::<I, i64>(segm_end2.y),
                cast::<I, i64>(segm_end2.x) - cast::<I, i64>(segm_start2.x),
            ),
            1_f64,
        );
        tln!("0: a:{:?}", a);
        if !a.is_neg() {
            a += sqr_sum1 * sqr_sum2;
            tln!("1: a:{:?}", a);
        } else {
            a = (orientation * orientation) / (sqr_sum1 * sqr_sum2 - a);
            tln!("2: a:{:?}", a);
        }
        let or1 = rf::RobustFpt::new(
            robust_cross_product::<i64>(
                cast::<I, i64>(segm_end1.y) - cast::<I, i64>(segm_start1.y),
                cast::<I, i64>(segm_end1.x) - cast::<I, i64>(segm_start1.x),
                cast::<I, i64>(segm_end1.y) - cast::<I, i64>(point1.y),
                cast::<I, i64>(segm_end1.x) - cast::<I, i64>(point1.x),
            ),
            1_f64,
        );
        let or2 = rf::RobustFpt::new(
            robust_cross_product::<i64>(
                cast::<I, i64>(segm_end2.x) - cast::<I, i64>(segm_start2.x),
                cast::<I, i64>(segm_end2.y) - cast::<I, i64>(segm_start2.y),
                cast::<I, i64>(segm_end2.x) - cast::<I, i64>(point1.x),
                cast::<I, i64>(segm_end2.y) - cast::<I, i64>(point1.y),
            ),
            1_f64,
        );
        let det = rf::RobustFpt::from(2_f64) * a * or1 * or2;
        let c1 = rf::RobustFpt::new(
            robust_cross_product::<i64>(
                cast::<I, i64>(segm_end1.y) - cast::<I, i64>(segm_start1.y),
                cast::<I, i64>(segm_end1.x) - cast::<I, i64>(segm_start1.x),
                cast::<I, i64>(segm_end1.y),
                cast::<I, i64>(segm_end1.x),
            ),
            1_f64,
        );
        let c2 = rf::RobustFpt::new(
            robust_cross_product::<i64>(
                cast::<I, i64>(segm_end2.x) - cast::<I, i64>(segm_start2.x),
                cast::<I, i64>(segm_end2.y) - cast::<I, i64>(segm_start2.y),
                cast::<I, i64>(segm_end2.x),
                cast::<I, i64>(segm_end2.y),
            ),
            1_f64,
        );
        let inv_orientation = rf::RobustFpt::from(1_f64) / orientation;
        let mut t = rf::RobustDif::default();
        tln!("0: t:{:?}", t);
        let mut b = rf::RobustDif::default();
        tln!("0: b:{:?}", b);
        let mut ix = rf::RobustDif::default();
        let mut iy = rf::RobustDif::default();

        ix += rf::RobustFpt::from(a2) * c1 * inv_orientation;
        ix += rf::RobustFpt::from(a1) * c2 * inv_orientation;
        iy += rf::RobustFpt::from(b1) * c2 * inv_orientation;
        iy += rf::RobustFpt::from(b2) * c1 * inv_orientation;
        tln!("1: ix:{:?}", ix);
        tln!("1: s:{:?}", rf::RobustFpt::from(a1) * sqr_sum2);
        tln!("1: p:{:?}", ix * (rf::RobustFpt::from(a1) * sqr_sum2));
        b += ix * (rf::RobustFpt::from(a1) * sqr_sum2);
        tln!("1: b:{:?}", b);
        b += ix * (rf::RobustFpt::from(a2) * sqr_sum1);
        tln!("2: b:{:?}", b);
        b += iy * (rf::RobustFpt::from(b1) * sqr_sum2);
        tln!("3: b:{:?}", b);
        b += iy * (rf::RobustFpt::from(b2) * sqr_sum1);
        tln!("4: b:{:?}", b);
        b -= sqr_sum1
            * rf::RobustFpt::new(
                robust_cross_product::<i64>(
                    cast::<I, i64>(segm_end2.x) - cast::<I, i64>(segm_start2.x),
                    cast::<I, i64>(segm_end2.y) - cast::<I, i64>(segm_start2.y),
                    -cast::<I, i64>(point1.y),
                    cast::<I, i64>(point1.x),
                ),
                1_f64,
            );
        tln!("5: b:{:?}", b);
        b -= sqr_sum2
            * rf::RobustFpt::new(
                robust_cross_product::<i64>(
                    cast::<I, i64>(segm_end1.x) - cast::<I, i64>(segm_start1.x),
                    cast::<I, i64>(segm_end1.y) - cast::<I, i64>(segm_start1.y),
                    -cast::<I, i64>(point1.y),
                    cast::<I, i64>(point1.x),
                ),
                1_f64,
            );
        tln!("6: b:{:?}", b);
        tln!("  LazyCircleFormationFunctor::pss a:{:?} b:{:?}", a, b);
        tln!("1: b:{:?}", b);
        t -= b;
        tln!("1: t:{:?}", t);
        if point_index == SiteIndex::Two {
            t += det.sqrt();
            tln!("2: t:{:?}", t);
        } else {
            t -= det.sqrt();
            tln!("3: t:{:?}", t);
        }

        t /= (a * a);
        tln!("4: t:{:?}", t);
        tln!(
            "  LazyCircleFormationFunctor::pss t:{:.12} det:{:.12}",
            t.dif().fpv(),
            det.fpv()
        );
        let mut c_x = ix;
        let mut c_y = iy;
        tln!("0: c_x:{:?}", c_x);
        tln!("0: t:{:?}", t);
        c_x += t * (rf::RobustFpt::from(a1) * sqr_sum2);
        tln!("1: c_x:{:?}", c_x);
        c_x += t * (rf::RobustFpt::from(a2) * sqr_sum1);
        tln!("2: c_x:{:?}", c_x);
        c_y += t * (rf::RobustFpt::from(b1) * sqr_sum2);
        c_y += t * (rf::RobustFpt::from(b2) * sqr_sum1);

        if t.positive().fpv() < t.negative().fpv() {
            t = -t;
        }
        let mut lower_x = c_x;
        if orientation.is_neg() {
            lower_x -= t * orientation;
        } else {
            lower_x += t * orientation;
        }
        tln!(
            "  LazyCircleFormationFunctor::pss c_x:{:?} c_y:{:?} l_x:{:?}",
            c_x,
            c_y,
            lower_x
        );

        let lazy = (c_x.dif(), c_y.dif(), lower_x.dif());
        let lazy = pss_on_own_segment(point1, site2, site3, lazy, origin);
        let (c_x, c_y, lower_x) = pss_shared_vertex(point1, site2, site3, lazy, origin);
        let c_x = to_global(c_x, origin.0);
        let c_y = to_global(c_y, origin.1);
        let lower_x = to_global(lower_x, origin.0);
        let ulps = ULPSX2 as f64;
        recompute_c_x = c_x.ulp() > ulps;
        recompute_c_y = c_y.ulp() > ulps;
        recompute_lower_x = lower_x.ulp() > ulps;
        #[cfg(feature = "console_debug")]
        {
            assert!(!c_x.ulp().is_nan());
            assert!(!c_y.ulp().is_nan());
            assert!(!lower_x.ulp().is_nan());
        }
        // Todo! Is this correct? it was let c_event = ...
        c_event.set_3(c_x.fpv(), c_y.fpv(), lower_x.fpv());
    }

    let (point1, site2, site3) = (global.0, &global.1, &global.2);
    if recompute_c_x || recompute_c_y || recompute_lower_x {
        exact_circle_formation::pss(
            point1,
            site2,
            site3,
            point_index,
            &mut c_event,
            recompute_c_x,
            recompute_c_y,
            recompute_lower_x,
        );
    }
    Some(c_event)
}

/// Lazy evaluation of segment, segment, segment circle events
pub(crate) fn sss<I: InputType>(
    site1: &vse::SiteEvent<I>,
    site2: &vse::SiteEvent<I>,
    site3: &vse::SiteEvent<I>,
    mut c_event: CircleEvent,
) -> Option<CircleEvent> {
    let global = (*site1, *site2, *site3);
    let origin_point = site1.point0();
    let (site1_local, site2_local, site3_local, origin) = match (
        site1.translated_unless_upstream(origin_point),
        site2.translated_unless_upstream(origin_point),
        site3.translated_unless_upstream(origin_point),
    ) {
        (Some(s1), Some(s2), Some(s3)) => (
            s1,
            s2,
            s3,
            (cast::<I, f64>(origin_point.x), cast::<I, f64>(origin_point.y)),
        ),
        _ => (*site1, *site2, *site3, (0.0, 0.0)),
    };
    let (site1, site2, site3) = (&site1_local, &site2_local, &site3_local);
    let a1 = rf::RobustFpt::from(cast::<I, f64>(site1.x1()) - cast::<I, f64>(site1.x0()));
    let b1 = rf::RobustFpt::from(cast::<I, f64>(site1.y1()) - cast::<I, f64>(site1.y0()));
    let c1 = rf::RobustFpt::new(
        robust_cross_product::<i64>(
            cast::<I, i64>(site1.x0()),
            cast::<I, i64>(site1.y0()),
            cast::<I, i64>(site1.x1()),
            cast::<I, i64>(site1.y1()),
        ),
        1_f64,
    );

    let a2 = rf::RobustFpt::from(cast::<I, f64>(site2.x1()) - cast::<I, f64>(site2.x0()));
    let b2 = rf::RobustFpt::from(cast::<I, f64>(site2.y1()) - cast::<I, f64>(site2.y0()));
    let c2 = rf::RobustFpt::new(
        robust_cross_product::<i64>(
            cast::<I, i64>(site2.x0()),
            cast::<I, i64>(site2.y0()),
            cast::<I, i64>(site2.x1()),
            cast::<I, i64>(site2.y1()),
        ),
        1_f64,
    );

    let a3 = rf::RobustFpt::from(cast::<I, f64>(site3.x1()) - cast::<I, f64>(site3.x0()));
    let b3 = rf::RobustFpt::from(cast::<I, f64>(site3.y1()) - cast::<I, f64>(site3.y0()));
    let c3 = rf::RobustFpt::new(
        robust_cross_product::<i64>(
            cast::<I, i64>(site3.x0()),
            cast::<I, i64>(site3.y0()),
            cast::<I, i64>(site3.x1()),
            cast::<I, i64>(site3.y1()),
        ),
        1_f64,
    );

    let len1 = (a1 * a1 + b1 * b1).sqrt();
    let len2 = (a2 * a2 + b2 * b2).sqrt();
    let len3 = (a3 * a3 + b3 * b3).sqrt();
    let cross_12 = rf::RobustFpt::new(
        robust_cross_product::<i64>(
            cast::<I, i64>(site1.x1()) - cast::<I, i64>(site1.x0()),
            cast::<I, i64>(site1.y1()) - cast::<I, i64>(site1.y0()),
            cast::<I, i64>(site2.x1()) - cast::<I, i64>(site2.x0()),
            cast::<I, i64>(site2.y1()) - cast::<I, i64>(site2.y0()),
        ),
        1_f64,
    );
    let cross_23 = rf::RobustFpt::new(
        robust_cross_product::<i64>(
            cast::<I, i64>(site2.x1()) - cast::<I, i64>(site2.x0()),
            cast::<I, i64>(site2.y1()) - cast::<I, i64>(site2.y0()),
            cast::<I, i64>(site3.x1()) - cast::<I, i64>(site3.x0()),
            cast::<I, i64>(site3.y1()) - cast::<I, i64>(site3.y0()),
        ),
        1_f64,
    );
    let cross_31 = rf::RobustFpt::new(
        robust_cross_product::<i64>(
            cast::<I, i64>(site3.x1()) - cast::<I, i64>(site3.x0()),
            cast::<I, i64>(site3.y1()) - cast::<I, i64>(site3.y0()),
            cast::<I, i64>(site1.x1()) - cast::<I, i64>(site1.x0()),
            cast::<I, i64>(site1.y1()) - cast::<I, i64>(site1.y0()),
        ),
        1_f64,
    );

    // denom = cross_12 * len3 + cross_23 * len1 + cross_31 * len2.
    let mut denom = rf::RobustDif::default();
    denom += cross_12 * len3;
    denom += cross_23 * len1;
    denom += cross_31 * len2;

    // denom * r = (b2 * c_x - a2 * c_y - c2 * denom) / len2.
    let mut r = rf::RobustDif::default();
    r -= cross_12 * c3;
    r -= cross_23 * c1;
    r -= cross_31 * c2;

    let mut c_x = rf::RobustDif::default();
    c_x += a1 * c2 * len3;
    c_x -= a2 * c1 * len3;
    c_x += a2 * c3 * len1;
    c_x -= a3 * c2 * len1;
    c_x += a3 * c1 * len2;
    c_x -= a1 * c3 * len2;

    let mut c_y = rf::RobustDif::default();
    c_y += b1 * c2 * len3;
    c_y -= b2 * c1 * len3;
    c_y += b2 * c3 * len1;
    c_y -= b3 * c2 * len1;
    c_y += b3 * c1 * len2;
    c_y -= b1 * c3 * len2;

    let lower_x = c_x + r;

    let denom_dif = denom.dif();
    //tln!("  denom_dif:{:?}", denom_dif);
    let c_x_dif = c_x.dif() / denom_dif;
    let c_y_dif = c_y.dif() / denom_dif;
    let lower_x_dif = lower_x.dif() / denom_dif;
    let (c_x_dif, c_y_dif, lower_x_dif) =
        sss_consecutive(site1, site2, site3, (c_x_dif, c_y_dif, lower_x_dif), origin);
    let c_x_dif = to_global(c_x_dif, origin.0);
    let c_y_dif = to_global(c_y_dif, origin.1);
    let lower_x_dif = to_global(lower_x_dif, origin.0);
    let (site1, site2, site3) = (&global.0, &global.1, &global.2);

    let ulps = ULPSX2 as f64;
    let recompute_c_x = c_x_dif.ulp() > ulps;
    let recompute_c_y = c_y_dif.ulp() > ulps;
    let recompute_lower_x = lower_x_dif.ulp() > ulps;

    t!(" c_x_dif.ulp():{:.12}", c_x_dif.ulp());
    t!("  c_y_dif.ulp() :{:.12}", c_y_dif.ulp());
    tln!(" lower_x_dif.ulp():{:.12}", lower_x_dif.ulp());

    #[cfg(feature = "console_debug")]
    {
        assert!(!denom_dif.ulp().is_nan());
        assert!(!c_x.dif().ulp().is_nan());
        assert!(!c_y.dif().ulp().is_nan());
        assert!(!lower_x.dif().ulp().is_nan());
    }
    c_event.set_3(c_x_dif.fpv(), c_y_dif.fpv(), lower_x_dif.fpv());

    if recompute_c_x || recompute_c_y || recompute_lower_x {
        exact_circle_formation::sss(
            site1,
            site2,
            site3,
            &mut c_event,
            recompute_c_x,
            recompute_c_y,
            recompute_lower_x,
        );
    }

    tln!("<-LazyCircleFormationFunctor::sss(");
    tln!("  site1:{:?}", site1);
    tln!("  site2:{:?}", site2);
    tln!("  site3:{:?}", site3);
    tln!("  c_event:{:?}", c_event);

    Some(c_event)
}
