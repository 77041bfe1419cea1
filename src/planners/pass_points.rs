//! Shared by the strip-width planners (iso_parametric, iso_scallop,
//! tensor_regions): tool poses along a pass of contact points, the widths each
//! pose leaves, and chord-tolerance sampling of a pass.

use super::strip_width::{curvatures_along, gouge_error, Curvatures, Cutter, WidthError};
use crate::error::Result;
use crate::formats::PathPoint;
use crate::geometry::{LocalGeometry, NurbsSurface};
use nalgebra::{Point3, Vector2, Vector3};

/// Planning parameters shared by the three strategies.
#[derive(Clone, Copy, Debug)]
pub struct PassSettings {
    pub cutter: Cutter,
    /// Scallop height the passes are spaced for (a margin below the job's).
    pub scallop: f64,
    /// Chord tolerance along a pass, mm.
    pub chord_tolerance: f64,
    /// Longest step along a pass, mm.
    pub max_step: f64,
    /// Longest step along a pass that keeps the chord error within the
    /// tolerance on the most curved part of the surface, mm.
    pub point_step: f64,
}

/// Share of the job's scallop the spacing is planned for: the rest absorbs
/// the chord error between tool positions and the model's approximations
/// (osculating circle across the feed).
pub const SCALLOP_MARGIN: f64 = 0.9;

impl PassSettings {
    pub fn from_job(job: &crate::formats::Job) -> Result<Self> {
        let cutter = Cutter::from_job(job)?;
        let h = job.scallop()?;
        let surface = job.surface()?;
        let chord_tolerance = h * 0.05;
        let max_step = (cutter.radius * 2.0).max(1.0);
        // Chord error of a step s on curvature k: k s^2 / 8.
        let k = max_curvature(surface);
        let point_step = if k > 0.0 {
            (8.0 * chord_tolerance / k).sqrt().clamp(0.05, max_step)
        } else {
            max_step
        };
        Ok(Self {
            cutter,
            scallop: h * SCALLOP_MARGIN,
            chord_tolerance,
            max_step,
            point_step,
        })
    }
}

/// Largest principal curvature magnitude over a 33 x 33 sample grid, 1/mm.
pub fn max_curvature(surface: &NurbsSurface) -> f64 {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let n = 32;
    let mut k = 0.0f64;
    for i in 0..=n {
        for j in 0..=n {
            let (u, v) = (
                u0 + (u1 - u0) * i as f64 / n as f64,
                v0 + (v1 - v0) * j as f64 / n as f64,
            );
            if let Some(g) = LocalGeometry::at(surface, u, v) {
                k = k.max(g.k_min.abs()).max(g.k_max.abs());
            }
        }
    }
    k
}

/// A contact on the surface with its travel direction.
#[derive(Clone, Copy, Debug)]
pub struct Contact {
    pub g: LocalGeometry,
    /// Unit travel direction (3-D tangent).
    pub travel: Vector3<f64>,
    pub k: Curvatures,
}

impl Contact {
    /// `travel` is projected onto the tangent plane and normalised; `None`
    /// where the surface is singular or the direction is normal to it.
    pub fn new(surface: &NurbsSurface, uv: Vector2<f64>, travel: Vector3<f64>) -> Option<Self> {
        let g = LocalGeometry::at(surface, uv.x, uv.y)?;
        Self::from_geometry(g, travel)
    }

    pub fn from_geometry(g: LocalGeometry, travel: Vector3<f64>) -> Option<Self> {
        let t = (travel - g.n * travel.dot(&g.n)).try_normalize(1e-12)?;
        Some(Self {
            k: curvatures_along(&g, t),
            g,
            travel: t,
        })
    }

    pub fn uv(&self) -> Vector2<f64> {
        self.g.uv
    }
    pub fn point(&self) -> Point3<f64> {
        self.g.point()
    }
    /// Unit cross-feed n x t.
    pub fn cross(&self) -> Vector3<f64> {
        self.g.n.cross(&self.travel)
    }

    /// Half-width on the side of `towards` (a 3-D direction), for scallop h.
    pub fn half_width_towards(&self, s: &PassSettings, towards: Vector3<f64>) -> Result<f64> {
        let side = if towards.dot(&self.cross()) >= 0.0 {
            1.0
        } else {
            -1.0
        };
        s.cutter
            .half_width(s.scallop, self.k, side)
            .map_err(|WidthError::Gouge { depth }| {
                gouge_error(&s.cutter, self.uv().into(), self.k.cross, depth)
            })
    }

    /// The path point: pose, strip width and feed. Errors where the cutter gouges.
    pub fn path_point(&self, s: &PassSettings) -> Result<PathPoint> {
        let depth = s.cutter.disc_gouge(self.k);
        if depth > 1e-3 * s.scallop {
            return Err(gouge_error(
                &s.cutter,
                self.uv().into(),
                self.k.cross.max(self.k.feed),
                depth,
            ));
        }
        let w =
            s.cutter
                .strip_width(s.scallop, self.k)
                .map_err(|WidthError::Gouge { depth }| {
                    gouge_error(&s.cutter, self.uv().into(), self.k.cross, depth)
                })?;
        let cc = self.point();
        let (cl, axis) = s.cutter.pose(cc, self.g.n, self.travel);
        Ok(PathPoint {
            cc: cc.into(),
            cl: cl.into(),
            axis: axis.into(),
            uv: self.uv().into(),
            strip_width: Some(w),
            feed: Some(self.travel.into()),
            normal: Some(self.g.n.into()),
            ..Default::default()
        })
    }
}

/// Samples a curve `curve(s)`, s in [0, 1], so that every chord stays within
/// `tol` of the curve (checked at chord midpoints, recursively) and no step is
/// longer than `max_step`. Returns the parameters, sorted, including 0 and 1.
pub fn sample_curve(
    curve: &dyn Fn(f64) -> Point3<f64>,
    tol: f64,
    max_step: f64,
    initial: usize,
) -> Vec<f64> {
    let n0 = initial.max(2);
    let mut out = vec![0.0];
    // (a, b, curve(a), curve(b), depth)
    type Span = (f64, f64, Point3<f64>, Point3<f64>, u32);
    let mut stack: Vec<Span> = Vec::new();
    for k in (0..n0 - 1).rev() {
        let (a, b) = (k as f64 / (n0 - 1) as f64, (k + 1) as f64 / (n0 - 1) as f64);
        stack.push((a, b, curve(a), curve(b), 0));
    }
    while let Some((a, b, pa, pb, depth)) = stack.pop() {
        let m = 0.5 * (a + b);
        let pm = curve(m);
        let chord = pb - pa;
        let len = chord.norm();
        let dev = if len > 0.0 {
            let t = chord / len;
            let d = pm - pa;
            (d - t * d.dot(&t)).norm()
        } else {
            (pm - pa).norm()
        };
        // Quarter points too, so that an S-shaped span is not missed.
        let q1 = curve(0.5 * (a + m));
        let dev_q = if len > 0.0 {
            let t = chord / len;
            let d = q1 - pa;
            (d - t * d.dot(&t)).norm()
        } else {
            0.0
        };
        if depth < 24 && (dev > tol || dev_q > tol || len > max_step) {
            stack.push((m, b, pm, pb, depth + 1));
            stack.push((a, m, pa, pm, depth + 1));
        } else {
            out.push(b);
        }
    }
    out
}

/// Extends a pass past its last contact along the travel tangent, so that
/// the trailing edge points (which lag R (1 - cos phi) cos(lambda) behind the
/// contact at lateral offset R sin phi) sweep the material up to the end
/// contact's cross-section. The extension runs in the tangent plane, which
/// stays above the surface to second order on both concave and convex parts.
pub fn extend_end(points: &mut Vec<PathPoint>, s: &PassSettings) {
    let Some(last) = points.last().cloned() else {
        return;
    };
    let (Some(feed), Some(normal)) = (last.feed, last.normal) else {
        return;
    };
    let r = s.cutter.radius;
    let w = last.strip_width.unwrap_or(2.0 * r).min(2.0 * r);
    // The wider half of the strip decides; both halves are at most w.
    let y = w.min(r);
    let lag = if s.cutter.ball {
        0.0
    } else {
        r * (1.0 - (1.0 - (y / r).powi(2)).max(0.0).sqrt()) * s.cutter.lead.cos()
    };
    if lag <= 0.0 {
        return;
    }
    let t = Vector3::from(feed);
    let n = Vector3::from(normal);
    let cc = Point3::from(last.cc) + t * (lag * 1.05);
    let (cl, axis) = s.cutter.pose(cc, n, t);
    points.push(PathPoint {
        cc: cc.into(),
        cl: cl.into(),
        axis: axis.into(),
        ..last
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn circle_sampling_keeps_the_chord_error() {
        let r = 50.0;
        let curve = |s: f64| Point3::new(r * (s * 3.0).cos(), r * (s * 3.0).sin(), 0.0);
        let tol = 0.005;
        let ts = sample_curve(&curve, tol, 100.0, 4);
        // Exact chord error of a circle: r (1 - cos(dtheta/2)).
        for w in ts.windows(2) {
            let dth = 3.0 * (w[1] - w[0]);
            assert!(r * (1.0 - (dth / 2.0).cos()) <= tol * 1.0001);
        }
        // Not absurdly dense: within 2x of the optimum count 3 / (2 acos(1 - tol/r)).
        let optimum = 3.0 / (2.0 * (1.0 - tol / r).acos());
        assert!(
            (ts.len() as f64) < 2.2 * optimum + 2.0,
            "{} vs {optimum}",
            ts.len()
        );
    }
}
