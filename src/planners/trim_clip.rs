//! Passes on a trimmed face (docs/methods.md, "Trimmed faces"): every
//! surface strategy plans on the whole surface, then this one step clips
//! its passes to the face. A pass is split where it leaves the face; each
//! piece keeps its contacts on the face and runs in and out along the
//! pass's own planned motion past the boundary crossing, until its contact
//! is a footprint's reach from the face (or back on it: a short excursion,
//! over a small hole or a bulge of the boundary, does not split the pass).
//! The run-ins and run-outs are poses the strategy planned on the surface
//! continued past the trim, with its own gouge checks and pass-end
//! extensions, so the tool moves exactly as planned there and cannot cut
//! into the face; off the face it only ever meets the untrimmed surface's
//! continuation (an empty hole or air past the outer loop, as the trim
//! says).

use crate::error::Result;
use crate::formats::{Job, Pass, PlanResult};
use crate::geometry::{NurbsSurface, Trim};
use crate::tools::Tool;

/// How far from the face a contact must be before the tool can no longer
/// touch it, mm: the cutter radius (every point of a cutter's footprint
/// lies within it of the contact), half the belt's width.
pub fn reach(tool: &Tool) -> f64 {
    match *tool {
        Tool::Belt { width, .. } => 0.5 * width,
        _ => tool.radius(),
    }
}

/// Longest run-in or run-out past the boundary crossing, in reaches: a
/// pass grazing the boundary stays within reach of the face a long way.
pub const RUN_MAX: f64 = 4.0;

/// Clips a surface result's passes (and its degenerate points) to the
/// job's trimmed face; nothing changes on an untrimmed surface.
pub fn clip_result(job: &Job, result: &mut PlanResult) -> Result<()> {
    let Some(surface) = job.shape.as_surface() else {
        return Ok(());
    };
    if surface.trim().is_none() {
        return Ok(());
    }
    let reach = reach(job.tool()?);
    result.passes = clip_passes(surface, &result.passes, reach);
    if let Some(points) = &mut result.degenerate_points {
        points.retain(|p| surface.in_face(p.uv[0], p.uv[1]));
    }
    Ok(())
}

/// The passes clipped to `surface`'s face (all of them, untrimmed).
pub fn clip_passes(surface: &NurbsSurface, passes: &[Pass], reach: f64) -> Vec<Pass> {
    let Some(trim) = surface.trim() else {
        return passes.to_vec();
    };
    let mut out = Vec::new();
    for pass in passes {
        for (a, b) in pieces(surface, trim, pass, reach) {
            out.push(Pass {
                points: pass.points[a..=b].to_vec(),
                ..pass.clone()
            });
        }
    }
    out
}

/// Index ranges [a, b] of the pieces of one pass: runs of contacts on the
/// face, joined across short excursions, each widened by its run-in and
/// run-out.
fn pieces(surface: &NurbsSurface, trim: &Trim, pass: &Pass, reach: f64) -> Vec<(usize, usize)> {
    let pts = &pass.points;
    let n = pts.len();
    let on: Vec<bool> = pts
        .iter()
        .map(|p| surface.in_face(p.uv[0], p.uv[1]))
        .collect();
    let clear = |k: usize| trim.distance_mm(surface, pts[k].uv) >= reach;
    let step = |k: usize, l: usize| {
        let (a, b) = (pts[k].cc, pts[l].cc);
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    };
    let max_run = RUN_MAX * reach;
    // Maximal runs of contacts on the face, grouped: a run joins the one
    // before when every contact between them stays within reach of the
    // face and the excursion is no longer than a run-out and a run-in.
    let mut groups: Vec<(usize, usize)> = Vec::new();
    let mut k = 0;
    while k < n {
        if !on[k] {
            k += 1;
            continue;
        }
        let s = k;
        while k + 1 < n && on[k + 1] {
            k += 1;
        }
        let e = k;
        k += 1;
        if let Some(last) = groups.last_mut() {
            let gap = last.1 + 1..s;
            let length: f64 = (last.1..s).map(|i| step(i, i + 1)).sum();
            if length <= 2.0 * max_run && !gap.clone().any(clear) {
                last.1 = e;
                continue;
            }
        }
        groups.push((s, e));
    }
    // Run-in and run-out: along the pass away from the face until a
    // contact is clear of it, at most `max_run`.
    groups
        .into_iter()
        .map(|(s, e)| {
            let (mut a, mut run) = (s, 0.0);
            while a > 0 && !on[a - 1] && run < max_run {
                run += step(a - 1, a);
                a -= 1;
                if clear(a) {
                    break;
                }
            }
            let (mut b, mut run) = (e, 0.0);
            while b + 1 < n && !on[b + 1] && run < max_run {
                run += step(b, b + 1);
                b += 1;
                if clear(b) {
                    break;
                }
            }
            (a, b)
        })
        .collect()
}
