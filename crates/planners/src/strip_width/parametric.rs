//! Passes along iso-parameter curves, shared by `iso_parametric` and the
//! candidate plans of `tensor_regions` (docs/methods.md, "Iso-parametric
//! passes"): zig-zag passes along one parameter, the next iso-parameter
//! chosen so that the strips of neighbouring passes meet at the scallop
//! height everywhere along the pass (the narrowest gap decides).

use super::pass_ends::extend_pass;
use super::passes::{sample_curve, Contact, PassSettings};
use crate::Progress;
use nalgebra::{Vector2, Vector3};
use toolpath_formats::{FeedDirection, Pass};
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::NurbsSurface;

/// Maps (along, across) pass coordinates to (u, v).
fn uv_of(feed: FeedDirection, along: f64, across: f64) -> Vector2<f64> {
    match feed {
        FeedDirection::U => Vector2::new(along, across),
        FeedDirection::V => Vector2::new(across, along),
    }
}

/// The passes; `forward` alternates (zig-zag) so the lead tilts along the
/// travel. The classic iso-parametric method: one constant parameter step
/// across the passes, the worst case over the surface (found by sweeping
/// with the locally required step, then checked at the final passes).
pub(crate) fn plan_passes(
    surface: &NurbsSurface,
    s: &PassSettings,
    feed: FeedDirection,
    progress: &dyn Progress,
) -> Result<Vec<Pass>> {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let ((a0, a1), (c0, c1)) = match feed {
        FeedDirection::U => ((u0, u1), (v0, v1)),
        FeedDirection::V => ((v0, v1), (u0, u1)),
    };
    let span = c1 - c0;
    // Sweep with the locally required step to find the worst case.
    let mut across = c0;
    let mut worst = span;
    let mut forward = true;
    let mut sweeps = 0;
    while across < c1 {
        sweeps += 1;
        if sweeps > MAX_PASSES {
            return Err(too_many());
        }
        let contacts = pass_contacts(surface, s, feed, (a0, a1), across, forward)?;
        let step = next_step(surface, s, feed, &contacts, across, span)?;
        worst = worst.min(step);
        across += step;
        forward = !forward;
        progress.set((0.45 * ((across - c0) / span).min(1.0)) as f32);
        progress.check()?;
    }
    for _attempt in 0..4 {
        let count = ((span / worst) * (1.0 + 1e-9)).ceil().max(1.0) as usize;
        if count > MAX_PASSES {
            return Err(too_many());
        }
        let step = span / count as f64;
        let mut runs: Vec<Vec<Contact>> = Vec::with_capacity(count + 1);
        let mut ok = true;
        for k in 0..=count {
            let across = if k == count { c1 } else { c0 + step * k as f64 };
            let forward = k % 2 == 0;
            let contacts = pass_contacts(surface, s, feed, (a0, a1), across, forward)?;
            if k < count {
                let need = next_step(surface, s, feed, &contacts, across, span)?;
                if need < step * (1.0 - 1e-6) {
                    worst = worst.min(need);
                    ok = false;
                    break;
                }
            }
            runs.push(contacts);
            progress.set((0.5 + 0.45 * k as f64 / count as f64) as f32);
            progress.check()?;
        }
        if ok {
            if converges_on_pole(surface, feed) {
                trim_at_pole(s, &mut runs)?;
            }
            let mut passes = Vec::with_capacity(runs.len());
            for contacts in runs.iter().filter(|r| !r.is_empty()) {
                let mut pass = Pass {
                    region: 0,
                    points: Vec::with_capacity(contacts.len() + 1),
                    min_strip_width: None,
                };
                for c in contacts {
                    pass.points.push(c.path_point(s)?);
                }
                extend_pass(surface, &mut pass.points, s)?;
                passes.push(pass);
            }
            return Ok(passes);
        }
    }
    Err(Error::planning(
        "iso_parametric: the constant parameter step did not settle (the required step varies too fast)",
    ))
}

/// Do the passes (iso-curves along the feed parameter) run into a pole:
/// a collapsed boundary across the feed (docs/methods.md, "Degenerate
/// boundaries")?
fn converges_on_pole(surface: &NurbsSurface, feed: FeedDirection) -> bool {
    let c = surface.collapsed_boundaries();
    match feed {
        FeedDirection::U => c[0] || c[1],
        FeedDirection::V => c[2] || c[3],
    }
}

/// Share of a contact's strip width within which a point of an earlier
/// pass already covers it.
const POLE_COVER_SHARE: f64 = 0.25;

/// Passes that all run into a pole would pile up there: from each end of
/// every pass after the first, contacts are dropped while one of an
/// earlier pass lies within [`POLE_COVER_SHARE`] of their strip width (that
/// pass's strip covers them), so only the first pass reaches the pole.
fn trim_at_pole(s: &PassSettings, runs: &mut [Vec<Contact>]) -> Result<()> {
    let mut kept: Vec<nalgebra::Point3<f64>> = Vec::new();
    for run in runs.iter_mut() {
        let covered = |c: &Contact| -> Result<bool> {
            let w = c.path_point(s)?.strip_width.unwrap_or(0.0);
            let reach = POLE_COVER_SHARE * w;
            Ok(kept.iter().any(|p| (p - c.point()).norm() < reach))
        };
        let mut start = 0;
        while start < run.len() && covered(&run[start])? {
            start += 1;
        }
        let mut end = run.len();
        while end > start && covered(&run[end - 1])? {
            end -= 1;
        }
        // A pass left with fewer than two contacts is dropped whole.
        let trimmed: Vec<Contact> = if end >= start + 2 {
            run[start..end].to_vec()
        } else {
            Vec::new()
        };
        *run = trimmed;
        kept.extend(run.iter().map(|c| c.point()));
    }
    Ok(())
}

fn too_many() -> Error {
    Error::planning(format!(
        "iso_parametric needs more than {MAX_PASSES} passes: the scallop is too small for the surface"
    ))
}

const MAX_PASSES: usize = 20_000;

/// Contacts along the iso-curve `across`, sampled to the chord tolerance,
/// ordered in the travel direction.
fn pass_contacts(
    surface: &NurbsSurface,
    s: &PassSettings,
    feed: FeedDirection,
    (a0, a1): (f64, f64),
    across: f64,
    forward: bool,
) -> Result<Vec<Contact>> {
    let curve = |t: f64| {
        let uv = uv_of(feed, a0 + (a1 - a0) * t, across);
        surface.point(uv.x, uv.y)
    };
    let mut ts = sample_curve(&curve, s.chord_tolerance, s.max_step, 9);
    if !forward {
        ts.reverse();
    }
    let mut out = Vec::with_capacity(ts.len());
    for t in ts {
        let uv = uv_of(feed, a0 + (a1 - a0) * t, across);
        let d = surface.derivs(uv.x, uv.y);
        let along = match feed {
            FeedDirection::U => d.su,
            FeedDirection::V => d.sv,
        };
        let travel = if forward { along } else { -along };
        let c = Contact::new(surface, uv, travel).ok_or_else(|| {
            Error::planning(format!(
                "the surface is singular at uv ({:.4}, {:.4}): no normal there",
                uv.x, uv.y
            ))
        })?;
        out.push(c);
    }
    Ok(out)
}

/// Parameter step to the next pass: the smallest over the pass of the step at
/// which the right half-width here and the left half-width there add up to
/// the cross-feed distance between the passes.
fn next_step(
    surface: &NurbsSurface,
    s: &PassSettings,
    feed: FeedDirection,
    contacts: &[Contact],
    across: f64,
    remaining: f64,
) -> Result<f64> {
    let mut best = remaining;
    for p in contacts {
        let along = match feed {
            FeedDirection::U => p.uv().x,
            FeedDirection::V => p.uv().y,
        };
        let d = surface.derivs(p.uv().x, p.uv().y);
        let dir_across: Vector3<f64> = match feed {
            FeedDirection::U => d.sv,
            FeedDirection::V => d.su,
        };
        let w_here = p.half_width_towards(s, dir_across)?;
        // First guess from the first-order distance per unit parameter.
        let lateral_rate = (dir_across - p.travel * dir_across.dot(&p.travel))
            .norm()
            .max(1e-12);
        let mut step = (2.0 * w_here / lateral_rate).min(remaining);
        for _ in 0..6 {
            let uv = uv_of(feed, along, across + step);
            let q = Contact::new(surface, uv, -p.travel).ok_or_else(|| {
                Error::planning(format!(
                    "the surface is singular at uv ({:.4}, {:.4}): no normal there",
                    uv.x, uv.y
                ))
            })?;
            let w_there = q.half_width_towards(s, -dir_across)?;
            let gap = q.point() - p.point();
            let lateral = (gap - p.travel * gap.dot(&p.travel)).norm();
            if lateral <= 0.0 {
                break;
            }
            let target = w_here + w_there;
            let new_step = step * target / lateral;
            let done = (new_step - step).abs() <= 1e-4 * step;
            step = new_step;
            if done || step >= remaining {
                break;
            }
        }
        best = best.min(step);
    }
    if best.is_nan() || best <= 0.0 {
        return Err(Error::planning("iso_parametric: zero step between passes"));
    }
    Ok(best)
}
