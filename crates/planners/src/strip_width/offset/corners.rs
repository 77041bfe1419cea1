//! Where a pass turns sharply: corner spikes that carry the tool out along the
//! bisector and sweep across the tip, and run-ons past a turning contact, so
//! the strip edge behind the contact still reaches the corner material
//! (docs/methods.md, "Corner spikes" and "Run-ons before turns").

use crate::strip_width::passes::{walk_on_surface as walk, Contact, PassSettings};
use nalgebra::{Point3, Vector2, Vector3};
use toolpath_kernel::error::Result;
use toolpath_kernel::geometry::NurbsSurface;

/// Least turn of a pass, deg, over a cutter radius either side of a
/// contact, that makes it a corner with a spike.
pub(super) const SPIKE_MIN_TURN_DEG: f64 = 30.0;

/// Length of a corner spike in shifts of the corner that would close the
/// gap outside it by the discs' geometry, d (1 - s) / (2 s): a spike cuts
/// only a band h / sin(lead) wide on its way out, so it runs well past the
/// point the shift reaches (docs/methods.md, "Corner spikes"). The
/// partition of `wing_mould`, whose region boundaries meet passes at
/// corners, holds h with it (tests/wing_mould.rs,
/// `wing_mould_three_strategies_against_the_simulator`).
pub(super) const SPIKE_SHARE: f64 = 4.0;

/// Longest corner spike, in cutter radii. The shift grows without bound as
/// the turn nears a hairpin (28 mm at 160 deg for a 3 mm strip), and a
/// spike that long runs across the passes beside the corner; what is left
/// beyond this length is the repair passes' (docs/methods.md, "Repair
/// passes").
pub(super) const SPIKE_MAX_RADII: f64 = 2.0;

/// Half-length of the sweep across a spike's tip, in cutter radii. At the
/// tip the tool moves along its own heading, so it cuts its full strip
/// width along the bisector there, reaching past the tip and to both sides
/// of it, where the material outside a corner spreads (most to one side
/// where the corners of successive passes do not line up along the
/// bisector). Legs along the bisector would not do: a tilted flat bottom
/// moving sideways cuts only a band h / sin(lead) wide behind its contact
/// line. 0.8 R reaches the material beside chevrons of about 105 deg
/// (the second surface of tests/wing_mould.rs,
/// `second_freeform_surface_is_cut_without_gouge_or_gaps`).
pub(super) const SPIKE_SWEEP_RADII: f64 = 0.8;

/// A corner spike: unit direction out of the corner and length, mm.
pub(super) type Spike = (Vector3<f64>, f64);

/// Spikes at the sharp corners of a pass: (unit direction out of the
/// corner, length, mm) at the contact where the turn peaks. Outside a
/// corner whose legs meet at theta, the material next to the corner lies
/// farther than the half-width from this pass and from the neighbouring
/// pass across the corner: d / (1 + s) instead of d / 2 (s = sin(theta / 2),
/// d the strip width) when the neighbour is the exact offset (7 % at
/// 120 deg), more where it was itself smoothed. The tool runs out along the
/// corner's outer bisector and back.
pub(super) fn corner_spikes(s: &PassSettings, contacts: &[Contact]) -> Result<Vec<Option<Spike>>> {
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
        let len = SPIKE_SHARE * w * (1.0 - sn) / (2.0 * sn);
        spikes[j] = Some((out, len.min(SPIKE_MAX_RADII * r)));
    }
    Ok(spikes)
}

/// Contacts walked on the surface from `from` along `dir` for `dist` in
/// steps within the chord tolerance, travelling along `heading`; stops at
/// the domain edge.
pub(super) fn walk_contacts(
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
pub(super) fn spike(
    surface: &NurbsSurface,
    s: &PassSettings,
    c: &Contact,
    dir: Vector3<f64>,
    len: f64,
    out: &mut Vec<toolpath_formats::PathPoint>,
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
pub(super) const RUN_ON_MIN_TURN_DEG: f64 = 8.0;

/// Lag of a tilted flat end's strip edge behind its contact, mm: the
/// disc's rim cuts the edge of the strip, at half-width w across, a lag
/// R - sqrt(R^2 - w^2) behind the contact (0 for a ball, whose strip edge is
/// level with the contact).
pub(super) fn edge_lag(s: &PassSettings, c: &Contact, towards: Vector3<f64>) -> Result<f64> {
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
/// lag x tan(turn): 0.16 mm at a 21 deg kink of an offset pass, enough
/// for a scallop above h between two kinked passes.
pub(super) fn turn_starts(s: &PassSettings, contacts: &[Contact]) -> Result<Vec<Option<f64>>> {
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
pub(super) fn run_on(
    surface: &NurbsSurface,
    s: &PassSettings,
    c: &Contact,
    lag: f64,
    out: &mut Vec<toolpath_formats::PathPoint>,
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
pub(super) fn pivot(
    a: &Contact,
    b: &Contact,
    s: &PassSettings,
    out: &mut Vec<toolpath_formats::PathPoint>,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::strip_width::passes::Contact;

    /// Contacts of a pass on the plane sample that runs along +x and turns
    /// by `turn_deg` at x = 50 mm, a contact every 0.5 mm.
    fn bent_pass(turn_deg: f64) -> Vec<Contact> {
        let surface = toolpath_samples::surfaces::plane();
        let a = turn_deg.to_radians();
        let (leg_in, leg_out) = (Vector3::x(), Vector3::new(a.cos(), a.sin(), 0.0));
        let corner = Point3::new(50.0, 30.0, 0.0);
        let points: Vec<(Point3<f64>, Vector3<f64>)> = (-40..=0)
            .map(|k| (corner + leg_in * (0.5 * k as f64), leg_in))
            .chain((1..=40).map(|k| (corner + leg_out * (0.5 * k as f64), leg_out)))
            .collect();
        points
            .iter()
            .map(|(p, t)| Contact::new(&surface, Vector2::new(p.x / 100.0, p.y / 100.0), *t))
            .collect::<Option<Vec<_>>>()
            .unwrap()
    }

    /// One spike per corner, at the corner, out along the outer bisector,
    /// longer the sharper the turn, and never beyond 2 R: near a hairpin
    /// the disc geometry's shift would run it 28 mm across the passes
    /// beside the corner.
    #[test]
    fn corner_spikes_grow_with_the_turn_up_to_two_radii() {
        let job = toolpath_samples::job("plane").unwrap();
        let s = PassSettings::from_job(&job).unwrap();
        let r = s.cutter.radius;
        let mut lengths = Vec::new();
        for turn_deg in [40.0, 60.0, 90.0, 110.0, 150.0, 165.0, 175.0] {
            let contacts = bent_pass(turn_deg);
            let spikes = corner_spikes(&s, &contacts).unwrap();
            let found: Vec<(usize, Spike)> = spikes
                .iter()
                .enumerate()
                .filter_map(|(j, sp)| sp.map(|sp| (j, sp)))
                .collect();
            assert_eq!(found.len(), 1, "turn {turn_deg} deg: {found:?}");
            let (j, (out, len)) = found[0];
            assert_eq!(j, 40, "turn {turn_deg} deg: spike at contact {j}");
            // The outer bisector of legs along +x and at turn_deg.
            let a = turn_deg.to_radians();
            let want = Vector3::new(1.0 - a.cos(), -a.sin(), 0.0).normalize();
            assert!((out - want).norm() < 1e-9, "turn {turn_deg} deg: {out:?}");
            assert!(
                len > 0.0 && len <= 2.0 * r + 1e-12,
                "turn {turn_deg} deg: {len} mm"
            );
            lengths.push((turn_deg, len));
        }
        for w in lengths.windows(2) {
            assert!(w[1].1 >= w[0].1, "{lengths:?}");
        }
        // A right-angle corner's spike is well short of the cap (about a
        // strip width); the sharpest turns reach it.
        assert!(lengths[2].1 < 1.5 * r, "{lengths:?}");
        for &(turn_deg, len) in &lengths[4..] {
            assert!(
                (len - 2.0 * r).abs() < 1e-12,
                "turn {turn_deg} deg: {len} mm"
            );
        }
    }
}
