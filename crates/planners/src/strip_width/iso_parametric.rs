//! Strategy `iso_parametric`: passes along iso-parameter curves (feed along
//! `feed_direction`, u by default), zig-zag, with the next iso-parameter
//! chosen so that the strips of neighbouring passes meet at the scallop
//! height everywhere along the pass (the narrowest gap decides). Same cutter
//! model and tool axis as `tensor_regions`, so the two compare fairly
//! (docs/methods.md, "Iso-parametric passes").

use super::parametric::plan_passes;
use super::passes::PassSettings;
use crate::Progress;
use toolpath_formats::{FeedDirection, Job, PlanResult};
use toolpath_kernel::error::Result;

/// The strategy `iso_parametric`.
pub struct IsoParametric;

impl crate::Strategy for IsoParametric {
    fn id(&self) -> toolpath_formats::Strategy {
        toolpath_formats::Strategy::IsoParametric
    }
    fn plan(&self, job: &Job, progress: &dyn Progress) -> Result<PlanResult> {
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_surfaces;
    use crate::NoProgress;
    use crate::Strategy as _;
    use toolpath_formats::Strategy;

    fn ellipse_scallop(r: f64, lead: f64, spacing: f64) -> f64 {
        // Plane: the swept flat end's silhouette at half the spacing.
        let y = spacing / 2.0;
        r * lead.sin() * (1.0 - (1.0 - (y / r).powi(2)).max(0.0).sqrt())
    }

    #[test]
    fn plane_passes_are_straight_and_spaced_for_the_scallop() {
        let surface = test_surfaces::sheared_plane();
        let job = test_surfaces::job(surface, Strategy::IsoParametric, 2.5, 5.0, 0.05);
        let r = IsoParametric.plan(&job, &NoProgress).unwrap();
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
        let r = IsoParametric.plan(&job, &NoProgress).unwrap();
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
        let e = IsoParametric
            .plan(&job, &NoProgress)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("tool too large for the curvature") && e.contains("lead angle of at least"),
            "{e}"
        );
        let surface = test_surfaces::concave_cylinder(2.0, 50.0);
        let job = test_surfaces::job(surface, Strategy::IsoParametric, 2.5, 5.0, 0.05);
        let e = IsoParametric
            .plan(&job, &NoProgress)
            .unwrap_err()
            .to_string();
        assert!(e.contains("no lead angle avoids gouging"), "{e}");
    }
}
