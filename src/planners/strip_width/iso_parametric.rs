//! Strategy `iso_parametric`: passes along iso-parameter curves (feed along
//! `feed_direction`, u by default), zig-zag, with the next iso-parameter
//! chosen so that the strips of neighbouring passes meet at the scallop
//! height everywhere along the pass (the narrowest gap decides). Same cutter
//! model and tool axis as `tensor_regions`, so the two compare fairly
//! (docs/methods.md, "Iso-parametric passes").

use super::pass_ends::extend_pass;
use super::passes::{sample_curve, Contact, PassSettings};
use crate::error::{Error, Result};
use crate::formats::{FeedDirection, Job, Pass, PlanResult};
use crate::geometry::NurbsSurface;
use crate::planners::Progress;
use nalgebra::{Vector2, Vector3};

pub fn plan(job: &Job, progress: &dyn Progress) -> Result<PlanResult> {
    let surface = job.surface()?;
    let settings = PassSettings::from_job(job)?;
    let feed = job.feed_direction.unwrap_or(FeedDirection::U);
    let passes = plan_passes(surface, &settings, feed, progress)?;
    let mut result = PlanResult::new(&job.job_id, job.strategy.name());
    result.passes = passes;
    result.stats.path_length_lower_bound_mm = Some(
        super::lower_bound::job_path_length_lower_bound(job, surface, &settings.cutter)?,
    );
    Ok(result)
}

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
pub fn plan_passes(
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
    }
    for _attempt in 0..4 {
        let count = ((span / worst) * (1.0 + 1e-9)).ceil().max(1.0) as usize;
        if count > MAX_PASSES {
            return Err(too_many());
        }
        let step = span / count as f64;
        let mut passes = Vec::with_capacity(count + 1);
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
            let mut pass = Pass {
                region: 0,
                points: Vec::with_capacity(contacts.len() + 1),
                min_strip_width: None,
            };
            for c in &contacts {
                pass.points.push(c.path_point(s)?);
            }
            extend_pass(surface, &mut pass.points, s)?;
            passes.push(pass);
            progress.set((0.5 + 0.45 * k as f64 / count as f64) as f32);
        }
        if ok {
            return Ok(passes);
        }
    }
    Err(Error::planning(
        "iso_parametric: the constant parameter step did not settle (the required step varies too fast)",
    ))
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::Strategy;
    use crate::planners::test_surfaces;
    use crate::planners::NoProgress;

    fn ellipse_scallop(r: f64, lead: f64, spacing: f64) -> f64 {
        // Plane: the swept flat end's silhouette at half the spacing.
        let y = spacing / 2.0;
        r * lead.sin() * (1.0 - (1.0 - (y / r).powi(2)).max(0.0).sqrt())
    }

    #[test]
    fn plane_passes_are_straight_and_spaced_for_the_scallop() {
        let surface = test_surfaces::sheared_plane();
        let job = test_surfaces::job(surface, Strategy::IsoParametric, 2.5, 5.0, 0.05);
        let r = plan(&job, &NoProgress).unwrap();
        assert!(r.passes.len() > 20);
        let lead = 5f64.to_radians();
        let last = r.passes.len() - 2;
        for (i, w) in r.passes.windows(2).enumerate() {
            // Passes are lines y = const on the plane (v iso-curves of the shear).
            let (ya, yb) = (w[0].points[0].cc[1], w[1].points[0].cc[1]);
            for p in &w[0].points {
                assert!((p.cc[1] - ya).abs() < 1e-9 && p.cc[2].abs() < 1e-12);
            }
            let spacing = (yb - ya).abs();
            let scallop = ellipse_scallop(2.5, lead, spacing);
            // The last pass sits on the boundary edge, closer than needed.
            assert!(
                scallop <= 0.05 + 1e-9 && (i == last || scallop > 0.8 * 0.05),
                "{scallop}"
            );
        }
        // Zig-zag: travel alternates and the lead tilts along the travel.
        let (a, b) = (&r.passes[0].points[0], &r.passes[1].points[0]);
        assert!(a.feed.unwrap()[0] > 0.99 && b.feed.unwrap()[0] < -0.99);
        for p in [a, b] {
            let tilt = p.axis[0] * p.feed.unwrap()[0];
            assert!((tilt - lead.sin()).abs() < 1e-9);
        }
        // The first and last passes lie on the boundary edges.
        assert!(r.passes[0].points[0].cc[1].abs() < 1e-9);
        assert!((r.passes.last().unwrap().points[0].cc[1] - 100.0).abs() < 1e-9);
        let lb = r.stats.path_length_lower_bound_mm.unwrap();
        assert!((lb - 10000.0 / 3.18704).abs() / lb < 1e-3);
    }

    #[test]
    fn cylinder_along_the_axis_uses_the_wider_concave_strip() {
        // Feed along the axis: the spacing is wider than on the plane.
        let surface = test_surfaces::concave_cylinder(100.0, 100.0);
        let job = test_surfaces::job(surface, Strategy::IsoParametric, 2.5, 5.0, 0.05);
        let r = plan(&job, &NoProgress).unwrap();
        let arc = std::f64::consts::PI * 100.0;
        let per_pass = arc / (r.passes.len() - 1) as f64;
        assert!(
            per_pass > 3.18704 * 0.9 && per_pass <= 3.58875 * 1.001,
            "{per_pass}"
        );
        // Every cc is on the cylinder and the cl is R sin(lead) above the contact plane.
        for p in r.passes.iter().flat_map(|p| p.points.iter()) {
            let rad = (p.cc[1].powi(2) + (p.cc[2] - 100.0).powi(2)).sqrt();
            assert!((rad - 100.0).abs() < 1e-6);
            let n = p.normal.unwrap();
            let up = (0..3).map(|k| (p.cl[k] - p.cc[k]) * n[k]).sum::<f64>();
            assert!((up - 2.5 * 5f64.to_radians().sin()).abs() < 1e-9);
        }
    }

    #[test]
    fn too_large_a_tool_is_a_clear_error() {
        let surface = test_surfaces::concave_cylinder(10.0, 50.0);
        let job = test_surfaces::job(surface, Strategy::IsoParametric, 2.5, 5.0, 0.05);
        let e = plan(&job, &NoProgress).unwrap_err().to_string();
        assert!(
            e.contains("tool too large for the curvature") && e.contains("lead angle of at least"),
            "{e}"
        );
        let surface = test_surfaces::concave_cylinder(2.0, 50.0);
        let job = test_surfaces::job(surface, Strategy::IsoParametric, 2.5, 5.0, 0.05);
        let e = plan(&job, &NoProgress).unwrap_err().to_string();
        assert!(e.contains("no lead angle avoids gouging"), "{e}");
    }
}
