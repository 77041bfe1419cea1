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

use toolpath_formats::{Job, Pass, PlanResult};
use toolpath_kernel::error::Result;
use toolpath_kernel::geometry::{NurbsSurface, Trim};
use toolpath_kernel::tools::Tool;

/// How far from the face a contact must be before the tool can no longer
/// touch it, mm: the cutter radius (every point of a cutter's footprint
/// lies within it of the contact), half the belt's width.
pub(crate) fn reach(tool: &Tool) -> f64 {
    match *tool {
        Tool::Belt { width, .. } => 0.5 * width,
        _ => tool.radius(),
    }
}

/// Longest run-in or run-out past the boundary crossing, in reaches: a
/// pass grazing the boundary stays within reach of the face a long way.
pub(crate) const RUN_MAX: f64 = 4.0;

/// Clips a surface result's passes (and its degenerate points) to the
/// job's trimmed face; nothing changes on an untrimmed surface.
pub(crate) fn clip_result(job: &Job, result: &mut PlanResult) -> Result<()> {
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
pub(crate) fn clip_passes(surface: &NurbsSurface, passes: &[Pass], reach: f64) -> Vec<Pass> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use toolpath_formats::PathPoint;
    use toolpath_kernel::geometry::trim::circle;

    /// The plane z = 0 over [0, 100]² with a hole of radius 20 mm at its
    /// centre (u, v in [0, 1]).
    fn holed_plane() -> NurbsSurface {
        let k = vec![0.0, 0.0, 1.0, 1.0];
        let s = NurbsSurface::new(
            1,
            1,
            k.clone(),
            k,
            &[
                vec![[0.0, 0.0, 0.0], [0.0, 100.0, 0.0]],
                vec![[100.0, 0.0, 0.0], [100.0, 100.0, 0.0]],
            ],
            None,
        )
        .unwrap();
        let square = toolpath_kernel::geometry::TrimCurve::Polyline(vec![
            [0.0, 0.0],
            [1.0, 0.0],
            [1.0, 1.0],
            [0.0, 1.0],
            [0.0, 0.0],
        ]);
        let trim = Trim::new(
            &s,
            vec![square],
            vec![vec![circle([0.5, 0.5], 0.2, false)]],
            Some(1e-4),
        )
        .unwrap();
        s.with_trim(trim)
    }

    /// A pass along x at height y (mm), a point every 1 mm from x = 0 to 100.
    fn pass_at(y: f64) -> Pass {
        Pass {
            region: 0,
            points: (0..=100)
                .map(|i| {
                    let x = i as f64;
                    PathPoint {
                        cc: [x, y, 0.0],
                        cl: [x, y, 0.0],
                        axis: [0.0, 0.0, 1.0],
                        uv: [x / 100.0, y / 100.0],
                        ..Default::default()
                    }
                })
                .collect(),
            min_strip_width: None,
        }
    }

    #[test]
    fn a_pass_across_the_hole_is_split_where_its_contacts_clear_the_face() {
        let s = holed_plane();
        let out = clip_passes(&s, &[pass_at(50.0)], 4.5);
        // Off the face for 30 < x < 70; the run-out stops at the first
        // contact at least 4.5 mm from the hole's edge (x = 35, 5 mm from
        // it), the run-in starts at the last such contact before the face
        // (x = 65).
        let ends: Vec<(f64, f64)> = out
            .iter()
            .map(|p| (p.points[0].cc[0], p.points.last().unwrap().cc[0]))
            .collect();
        assert_eq!(ends, vec![(0.0, 35.0), (65.0, 100.0)]);
    }

    #[test]
    fn a_graze_within_reach_keeps_the_pass_whole() {
        let s = holed_plane();
        // At y = 69 the pass crosses 1 mm of the hole's depth: every contact
        // stays within 5 mm of the face, so the pass is not split.
        let out = clip_passes(&s, &[pass_at(69.0)], 5.0);
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].points.len(), 101);
        // With a reach of 0.5 mm the middle of the chord is clear: split.
        let out = clip_passes(&s, &[pass_at(69.0)], 0.5);
        assert_eq!(out.len(), 2);
    }

    #[test]
    fn a_pass_off_the_face_is_dropped_and_untrimmed_surfaces_are_untouched() {
        let s = holed_plane();
        let mut inside = pass_at(50.0);
        inside.points.retain(|p| (p.cc[0] - 50.0).abs() < 10.0);
        assert!(clip_passes(&s, &[inside.clone()], 5.0).is_empty());
        let whole = NurbsSurface::clone(&s);
        let plain = NurbsSurface::new(
            whole.degree_u(),
            whole.degree_v(),
            whole.knots_u().to_vec(),
            whole.knots_v().to_vec(),
            &whole.control_grid(),
            None,
        )
        .unwrap();
        assert_eq!(clip_passes(&plain, &[inside.clone()], 5.0), vec![inside]);
    }
}
