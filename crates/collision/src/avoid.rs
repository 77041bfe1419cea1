//! Collision avoidance by tilting: the nearest collision-free tool axis in a
//! cone round the planned one, keeping the contact point.
//!
//! Candidates are a(alpha, phi) = cos(alpha) a0 + sin(alpha) (cos(phi) l +
//! sin(phi) t), a0 the planned axis, l the lead direction, t = a0 x l the tilt
//! direction; alpha on rings 0, step, 2 step, .. up to the largest angle, phi
//! on `directions` equally spaced rays. Rings are tried in order of alpha, so
//! the first clear candidate is the nearest on the grid; within a ring pure
//! lead comes first (+l, then -l), then pure tilt (+t, then -t), then the
//! other rays from the coarsest angular subdivision to the finest. The
//! caller's function gives the tip (cl) that keeps the cc point for an axis
//! (a flat end, ball or torus touching the surface at cc), and its admissible
//! set refuses axes outside the machine's rotary limits. On the ray where the
//! clear candidate lies, the angle is bisected back towards the previous ring
//! (which collided there) down to the tolerance.

use crate::assembly::{Pose, ToolAssembly};
use crate::error::{positive, Error, Result};
use crate::query::{PoseReport, QueryOptions};
use crate::workpiece::Workpiece;
use nalgebra::Vector3;

/// The cone to search.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisSearch {
    /// The planned axis a0 (normalised here).
    pub base_axis: Vector3<f64>,
    /// The lead direction l (the feed direction, say): positive lead leans
    /// the axis towards it. Made perpendicular to a0 here.
    pub lead_direction: Vector3<f64>,
    /// Largest angle from a0, radians.
    pub max_angle: f64,
    /// Ring spacing, radians.
    pub step: f64,
    /// Rays per ring: a multiple of 4 (4: lead and tilt only).
    pub directions: usize,
    /// The found angle is bisected down to this, radians (0: no bisection).
    pub tolerance: f64,
}

/// A collision-free axis.
#[derive(Clone, Debug, PartialEq)]
pub struct ClearAxis {
    pub pose: Pose,
    /// Angle from the planned axis, and the ray's azimuth from l towards t.
    pub angle: f64,
    pub azimuth: f64,
    /// Lead and tilt of the axis: atan2(a.l, a.a0) and atan2(a.t, a.a0).
    pub lead: f64,
    pub tilt: f64,
    /// The full query at the pose, when the certified fast path did not
    /// already prove it clear.
    pub report: Option<PoseReport>,
    /// Poses checked by the search.
    pub poses: usize,
}

struct Frame {
    a0: Vector3<f64>,
    l: Vector3<f64>,
    t: Vector3<f64>,
}

impl Frame {
    fn axis(&self, alpha: f64, phi: f64) -> Vector3<f64> {
        (self.a0 * alpha.cos() + (self.l * phi.cos() + self.t * phi.sin()) * alpha.sin())
            .normalize()
    }
}

fn frame(search: &AxisSearch) -> Result<Frame> {
    let n = search.base_axis.norm();
    if !n.is_finite() || n < 1e-12 {
        return Err(Error::invalid("base_axis", "is not a direction"));
    }
    let a0 = search.base_axis / n;
    let l = search.lead_direction - a0 * a0.dot(&search.lead_direction);
    let ln = l.norm();
    if !ln.is_finite() || ln < 1e-9 {
        return Err(Error::invalid(
            "lead_direction",
            "is zero or parallel to the base axis",
        ));
    }
    let l = l / ln;
    Ok(Frame {
        a0,
        l,
        t: a0.cross(&l),
    })
}

/// The rays' order within a ring: +l, -l, +t, -t, then the rest from the
/// coarsest subdivision to the finest, by index within a subdivision.
fn ray_order(n: usize) -> Vec<usize> {
    let mut rays: Vec<usize> = (0..n).collect();
    let key = |j: usize| {
        let first = [0, n / 2, n / 4, 3 * n / 4];
        match first.iter().position(|&f| f == j) {
            Some(k) => (0, k, 0),
            None => (1, 64 - j.trailing_zeros() as usize, j),
        }
    };
    rays.sort_by_key(|&j| key(j));
    rays
}

/// Searches the cone for the nearest clear axis (see the module); `None`
/// when none within the largest angle is clear and admissible. Errors name
/// `search.*`.
pub fn find_clear_axis(
    work: &Workpiece,
    tool: &ToolAssembly,
    opts: &QueryOptions,
    search: &AxisSearch,
    tip_for_axis: impl Fn(&Vector3<f64>) -> Option<Vector3<f64>>,
    admissible: impl Fn(&Vector3<f64>) -> bool,
) -> Result<Option<ClearAxis>> {
    opts.validate().map_err(|e| e.within("opts"))?;
    let f = frame(search).map_err(|e| e.within("search"))?;
    positive("search.step", search.step)?;
    if !(search.max_angle >= 0.0 && search.max_angle <= std::f64::consts::PI) {
        return Err(Error::invalid(
            "search.max_angle",
            format!("must lie in [0, pi], got {}", search.max_angle),
        ));
    }
    if search.directions < 4 || !search.directions.is_multiple_of(4) {
        return Err(Error::invalid(
            "search.directions",
            format!(
                "must be a positive multiple of 4, got {}",
                search.directions
            ),
        ));
    }
    let rays = ray_order(search.directions);
    let rings = (search.max_angle / search.step).ceil() as usize;
    let mut poses = 0usize;
    let mut check = |alpha: f64, phi: f64| -> Check {
        let axis = f.axis(alpha, phi);
        if !admissible(&axis) {
            return Check::Refused;
        }
        let Some(tip) = tip_for_axis(&axis) else {
            return Check::Refused;
        };
        poses += 1;
        let pose = Pose { tip, axis };
        if work.clear_by(tool, &pose, opts) {
            return Check::Clear(pose, None);
        }
        let report = work.query(tool, &pose, opts);
        if report.collides() {
            Check::Collides
        } else {
            Check::Clear(pose, Some(report))
        }
    };
    // Whether the previous ring's candidate on each ray collided (the
    // planned axis is every ray's first candidate).
    let mut prev_collided = vec![false; search.directions];
    for ring in 0..=rings {
        let alpha = (ring as f64 * search.step).min(search.max_angle);
        let prev_alpha = (ring.saturating_sub(1) as f64 * search.step).min(search.max_angle);
        let ring_rays: &[usize] = if ring == 0 { &rays[..1] } else { &rays };
        for &j in ring_rays {
            let phi = j as f64 * std::f64::consts::TAU / search.directions as f64;
            match check(alpha, phi) {
                Check::Refused => prev_collided[j] = false,
                Check::Collides => prev_collided[j] = true,
                Check::Clear(pose, report) => {
                    let lo = prev_collided[j].then_some(prev_alpha);
                    let (alpha, pose, report) =
                        bisect(&mut check, lo, (alpha, pose, report), phi, search.tolerance);
                    return Ok(Some(clear_axis(&f, alpha, phi, pose, report, poses)));
                }
            }
        }
        if ring == 0 {
            let c = prev_collided[rays[0]];
            prev_collided.iter_mut().for_each(|x| *x = c);
        }
    }
    Ok(None)
}

enum Check {
    Refused,
    Collides,
    Clear(Pose, Option<PoseReport>),
}

/// Bisects the angle between a colliding `lo` and the clear `hi` on one ray.
fn bisect(
    check: &mut impl FnMut(f64, f64) -> Check,
    lo: Option<f64>,
    mut hi: (f64, Pose, Option<PoseReport>),
    phi: f64,
    tolerance: f64,
) -> (f64, Pose, Option<PoseReport>) {
    let Some(mut lo) = lo else {
        return hi;
    };
    while tolerance > 0.0 && hi.0 - lo > tolerance {
        let mid = 0.5 * (lo + hi.0);
        match check(mid, phi) {
            Check::Clear(pose, report) => hi = (mid, pose, report),
            _ => lo = mid,
        }
    }
    hi
}

fn clear_axis(
    f: &Frame,
    alpha: f64,
    phi: f64,
    pose: Pose,
    report: Option<PoseReport>,
    poses: usize,
) -> ClearAxis {
    let a = pose.axis;
    ClearAxis {
        pose,
        angle: alpha,
        azimuth: phi,
        lead: a.dot(&f.l).atan2(a.dot(&f.a0)),
        tilt: a.dot(&f.t).atan2(a.dot(&f.a0)),
        report,
        poses,
    }
}
