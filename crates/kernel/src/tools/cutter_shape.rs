//! Exact geometry of milling cutters: flat-end, ball and torus (bull-nose)
//! tools as solids of revolution, with the signed distance to the solid and
//! the lowest point of the solid along a line (the "drop" used by the scallop
//! simulator and by planners that need the real cutter profile).
//!
//! All three are one family (docs/methods.md, "Cutter solids"), the generalised
//! torus: cutter radius `R`, corner radius `rc` (0 = flat-end, `R` = ball),
//! tube-centre circle radius `R0 = R - rc` at height `rc` above the tip, flat
//! bottom disc of radius `R0`, cylinder of radius `R` from height `rc` up to
//! the flute length `L`. In the meridian half-plane (radial distance `r`,
//! height `z` along the axis from the tip) the profile is the rectangle
//! `[0, R] x [0, L]` with its bottom outer corner rounded by a quarter circle
//! centred at `(R0, rc)`. The solid is convex, so a line meets it in one
//! interval.

use super::Tool;
use crate::error::{Error, Result};
use nalgebra::Vector3;

/// A milling cutter's solid. Frame: `tip` (= cl, the lowest point of the axis),
/// unit `axis` from the tip towards the spindle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CutterShape {
    /// Cutter radius R (D/2).
    pub radius: f64,
    /// Corner radius rc: 0 flat-end, R ball, in between torus.
    pub corner_radius: f64,
    /// Flute length L (the solid ends there).
    pub length: f64,
}

impl CutterShape {
    /// The solid of a milling tool; the belt has no cutter solid.
    pub fn from_tool(tool: &Tool) -> Result<Self> {
        tool.validate().map_err(|e| e.within("tool"))?;
        match tool {
            Tool::Belt { .. } => Err(Error::invalid(
                "tool.kind",
                "a belt is not a milling cutter (use the belt removal simulation)",
            )),
            _ => {
                let radius = tool.radius();
                // Flutes shorter than the corner make no sense for the simulation.
                let length = tool.length().max(tool.corner_radius()).max(radius * 1e-3);
                Ok(Self {
                    radius,
                    corner_radius: tool.corner_radius().min(radius),
                    length,
                })
            }
        }
    }

    /// A torus cutter of radius R and corner radius rc < R (MPEC's tool), with
    /// the default flute length of [`Tool::length`].
    pub fn torus(radius: f64, corner_radius: f64) -> Self {
        let tool = Tool::Torus {
            radius,
            corner_radius,
            length: None,
        };
        Self {
            radius,
            corner_radius,
            length: tool.length(),
        }
    }

    /// Radius of the tube-centre circle (and of the flat bottom disc), R0 = R - rc.
    pub fn tube_radius(&self) -> f64 {
        (self.radius - self.corner_radius).max(0.0)
    }

    /// Signed distance from a point given in the meridian half-plane
    /// (`r` >= 0 radial distance from the axis, `z` height above the tip):
    /// negative inside. Exact inside and outside (the profile is a rectangle
    /// with one rounded corner; in the corner quadrant the arc is the nearest
    /// boundary, elsewhere the rectangle's sides are).
    pub(crate) fn signed_distance_rz(&self, r: f64, z: f64) -> f64 {
        let (rc, r0) = (self.corner_radius, self.tube_radius());
        let r = r.abs();
        if r > r0 && z < rc && rc > 0.0 {
            return (r - r0).hypot(z - rc) - rc;
        }
        let half = 0.5 * self.length;
        let dx = r - self.radius;
        let dz = (z - half).abs() - half;
        let outside = dx.max(0.0).hypot(dz.max(0.0));
        outside + dx.max(dz).min(0.0)
    }

    /// Signed distance from `x` to the cutter at (`tip`, unit `axis`), negative inside.
    pub(crate) fn signed_distance(
        &self,
        tip: &Vector3<f64>,
        axis: &Vector3<f64>,
        x: &Vector3<f64>,
    ) -> f64 {
        let d = x - tip;
        let z = d.dot(axis);
        let r = (d - axis * z).norm();
        self.signed_distance_rz(r, z)
    }

    /// Lowest `t` in `[t_lo, t_hi]` with `p + t n` inside the cutter at
    /// (`tip`, unit `axis`), `n` a unit direction; `None` when the line misses
    /// the solid within that range. A solid reaching below `t_lo` along the
    /// line gives `t_lo`.
    pub fn lowest_hit(
        &self,
        tip: &Vector3<f64>,
        axis: &Vector3<f64>,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        t_lo: f64,
        t_hi: f64,
    ) -> Option<f64> {
        let (big_r, rc, r0, len) = (
            self.radius,
            self.corner_radius,
            self.tube_radius(),
            self.length,
        );
        let x0 = p - tip;
        let z0 = x0.dot(axis);
        let na = n.dot(axis);
        let w0 = x0 - axis * z0;
        let m = n - axis * na;
        let mm = m.norm_squared();
        let wm = w0.dot(&m);
        let ww = w0.norm_squared();

        // Cylinder r <= R between heights rc and L (0 and L for the flat-end).
        let mut entry = f64::INFINITY;
        if let Some((a, b)) = radial_interval(mm, wm, ww, big_r * big_r) {
            if let Some((c, d)) = slab_interval(z0, na, rc, len) {
                let lo = a.max(c);
                if lo <= b.min(d) {
                    entry = lo;
                }
            }
        }
        // Rounded bottom: the points within rc of the disc of radius R0 at height rc.
        if rc > 0.0 {
            let t = if r0 <= 1e-12 * big_r {
                // Ball: sphere of radius rc centred on the axis at height rc.
                let c = x0 - axis * rc;
                let b = c.dot(n);
                let disc = b * b - (c.norm_squared() - rc * rc);
                (disc >= 0.0).then(|| -b - disc.sqrt())
            } else {
                self.torus_entry(z0, na, &w0, &m, tip, axis, p, n)
            };
            if let Some(t) = t {
                entry = entry.min(t);
            }
        }
        if !entry.is_finite() || entry > t_hi {
            return None;
        }
        if entry >= t_lo {
            return Some(entry);
        }
        // The solid starts below the search range: hit only if it is still there at t_lo.
        let q = p + n * t_lo;
        (self.signed_distance(tip, axis, &q) <= 0.0).then_some(t_lo)
    }

    /// Smallest root of g(t) = dist(x(t), disc) - rc by Newton's method from the
    /// left: g is convex along a line (distance to a convex set), so Newton
    /// started left of the root never overshoots it; reaching g' >= 0 with
    /// g > 0 means the minimum is positive (the line misses).
    #[allow(clippy::too_many_arguments)]
    fn torus_entry(
        &self,
        z0: f64,
        na: f64,
        w0: &Vector3<f64>,
        m: &Vector3<f64>,
        tip: &Vector3<f64>,
        axis: &Vector3<f64>,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
    ) -> Option<f64> {
        let (rc, r0) = (self.corner_radius, self.tube_radius());
        let centre = tip + axis * rc;
        // Every point of the rounded part lies within R of `centre`.
        let mut t = (centre - p).dot(n) - self.radius - 1e-9 * self.radius;
        let tol = 1e-11 * self.radius.max(1.0);
        for _ in 0..200 {
            let dz = z0 + t * na - rc;
            let w = w0 + m * t;
            let r = w.norm();
            let dr = (r - r0).max(0.0);
            // sqrt, not hypot: mm-sized values cannot overflow, and this loop is
            // the simulator's hot spot (hypot costs a quarter of its time).
            let dist = (dz * dz + dr * dr).sqrt();
            let g = dist - rc;
            if g <= tol {
                return Some(t);
            }
            let dr_dt = if dr > 0.0 && r > 0.0 {
                w.dot(m) / r
            } else {
                0.0
            };
            let slope = (dz * na + dr * dr_dt) / dist;
            if slope >= -1e-14 {
                return None;
            }
            let step = g / slope;
            t -= step;
            if step.abs() <= tol * 1e-3 {
                // Stalled at a tangency: the line grazes the tube.
                return (g <= 1e-7 * self.radius).then_some(t);
            }
        }
        None
    }

    /// The lowest value of `(x - p) . n` over the solid at (`tip`, `axis`):
    /// no point of the cutter lies lower along `n`.
    pub fn support_low(
        &self,
        tip: &Vector3<f64>,
        axis: &Vector3<f64>,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
    ) -> f64 {
        let na = n.dot(axis).clamp(-1.0, 1.0);
        let ms = (1.0 - na * na).max(0.0).sqrt();
        let (rc, r0) = (self.corner_radius, self.tube_radius());
        let bottom = rc * na - r0 * ms - rc;
        let lower_rim = rc * na - self.radius * ms;
        let top = self.length * na - self.radius * ms;
        (tip - p).dot(n) + bottom.min(lower_rim).min(top)
    }
}

/// Parameter interval where |w0 + t m|^2 <= r2 (all t when m = 0 and inside).
pub fn radial_interval(mm: f64, wm: f64, ww: f64, r2: f64) -> Option<(f64, f64)> {
    if mm <= 1e-24 {
        return (ww <= r2).then_some((f64::NEG_INFINITY, f64::INFINITY));
    }
    let disc = wm * wm - mm * (ww - r2);
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    Some(((-wm - s) / mm, (-wm + s) / mm))
}

/// Parameter interval where lo <= z0 + t na <= hi.
fn slab_interval(z0: f64, na: f64, lo: f64, hi: f64) -> Option<(f64, f64)> {
    if na.abs() <= 1e-15 {
        return (z0 >= lo && z0 <= hi).then_some((f64::NEG_INFINITY, f64::INFINITY));
    }
    let a = (lo - z0) / na;
    let b = (hi - z0) / na;
    Some((a.min(b), a.max(b)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64, z: f64) -> Vector3<f64> {
        Vector3::new(x, y, z)
    }

    const UP: [f64; 3] = [0.0, 0.0, 1.0];

    fn up() -> Vector3<f64> {
        v(UP[0], UP[1], UP[2])
    }

    /// Brute force: march up the line in tiny steps until the signed distance is <= 0.
    fn brute_lowest(
        c: &CutterShape,
        tip: &Vector3<f64>,
        axis: &Vector3<f64>,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
    ) -> Option<f64> {
        let (lo, hi) = (-20.0, 20.0);
        let steps = 400_000;
        (0..=steps)
            .map(|k| lo + (hi - lo) * k as f64 / steps as f64)
            .find(|&t| c.signed_distance(tip, axis, &(p + n * t)) <= 0.0)
    }

    #[test]
    fn ball_drop_on_vertical_line_matches_sphere() {
        let c = CutterShape::from_tool(&Tool::Ball {
            radius: 2.0,
            length: None,
        })
        .unwrap();
        let tip = v(0.0, 0.0, 1.0);
        // Line x = 1.2: sphere centre at z = 3, lowest point z = 3 - sqrt(4 - 1.44).
        let t = c
            .lowest_hit(&tip, &up(), &v(1.2, 0.0, 0.0), &up(), -10.0, 10.0)
            .unwrap();
        assert!((t - (3.0 - (4.0f64 - 1.44).sqrt())).abs() < 1e-12, "{t}");
        assert!(c
            .lowest_hit(&tip, &up(), &v(2.01, 0.0, 0.0), &up(), -10.0, 10.0)
            .is_none());
    }

    #[test]
    fn torus_profile_and_flat_bottom() {
        let c = CutterShape::from_tool(&Tool::Torus {
            radius: 5.0,
            corner_radius: 1.5,
            length: None,
        })
        .unwrap();
        let tip = v(0.0, 0.0, 0.0);
        for &x in &[0.0, 1.0, 3.49, 3.5, 3.8, 4.5, 4.99] {
            let hit = c.lowest_hit(&tip, &up(), &v(x, 0.3 * x, -2.0), &up(), -10.0, 10.0);
            let r = x.hypot(0.3 * x);
            if r > 5.0 {
                assert!(hit.is_none(), "r {r}: {hit:?}");
                continue;
            }
            let exact = if r <= 3.5 {
                0.0
            } else {
                1.5 - (1.5f64 * 1.5 - (r - 3.5) * (r - 3.5)).sqrt()
            };
            let t = hit.unwrap();
            assert!(
                (t - 2.0 - exact).abs() < 1e-8,
                "r {r}: {t} vs {}",
                exact + 2.0
            );
        }
    }

    #[test]
    fn tilted_tools_agree_with_brute_force_marching() {
        let tools = [
            Tool::FlatEnd {
                radius: 2.5,
                length: Some(10.0),
            },
            Tool::Ball {
                radius: 2.5,
                length: Some(10.0),
            },
            Tool::Torus {
                radius: 3.0,
                corner_radius: 1.0,
                length: Some(10.0),
            },
        ];
        let axis = v(0.3, -0.2, 1.0).normalize();
        let tip = v(0.1, 0.2, 0.5);
        for tool in tools {
            let c = CutterShape::from_tool(&tool).unwrap();
            for k in 0..40 {
                let a = k as f64 * 0.37;
                let p = v(2.9 * a.cos(), 2.9 * (1.3 * a).sin(), -1.0);
                let n = v(0.1 * a.sin(), 0.05, 1.0).normalize();
                let fast = c.lowest_hit(&tip, &axis, &p, &n, -20.0, 20.0);
                let slow = brute_lowest(&c, &tip, &axis, &p, &n);
                match (fast, slow) {
                    (Some(f), Some(s)) => {
                        assert!((f - s).abs() < 2e-4, "{tool:?} k {k}: {f} vs {s}")
                    }
                    (None, None) => {}
                    other => panic!("{tool:?} k {k}: {other:?}"),
                }
            }
        }
    }

    #[test]
    fn search_range_clamps_and_misses() {
        let c = CutterShape::from_tool(&Tool::FlatEnd {
            radius: 1.0,
            length: Some(5.0),
        })
        .unwrap();
        let tip = v(0.0, 0.0, -0.3);
        // Tool tip 0.3 below p: the lowest point is at t = -0.3.
        assert!(
            (c.lowest_hit(&tip, &up(), &v(0.0, 0.0, 0.0), &up(), -1.0, 1.0)
                .unwrap()
                + 0.3)
                .abs()
                < 1e-12
        );
        // The search starts above the tip: the solid is there, so t_lo.
        assert_eq!(
            c.lowest_hit(&tip, &up(), &v(0.0, 0.0, 0.0), &up(), -0.1, 1.0),
            Some(-0.1)
        );
        // Entirely above the range.
        assert!(c
            .lowest_hit(
                &v(0.0, 0.0, 2.0),
                &up(),
                &v(0.0, 0.0, 0.0),
                &up(),
                -1.0,
                1.0
            )
            .is_none());
    }

    #[test]
    fn signed_distance_of_points_around_a_torus() {
        let c = CutterShape::from_tool(&Tool::Torus {
            radius: 5.0,
            corner_radius: 1.0,
            length: Some(10.0),
        })
        .unwrap();
        assert!((c.signed_distance_rz(0.0, -2.0) - 2.0).abs() < 1e-12);
        assert!((c.signed_distance_rz(7.0, 5.0) - 2.0).abs() < 1e-12);
        // Corner: centre (4, 1), point on the diagonal 1 beyond the arc.
        let s = std::f64::consts::FRAC_1_SQRT_2;
        assert!((c.signed_distance_rz(4.0 + 2.0 * s, 1.0 - 2.0 * s) - 1.0).abs() < 1e-12);
        assert!((c.signed_distance_rz(2.0, 0.5) + 0.5).abs() < 1e-12);
        assert!((c.signed_distance_rz(4.5, 5.0) + 0.5).abs() < 1e-12);
        assert!(CutterShape::from_tool(&Tool::Belt {
            width: 10.0,
            wheel_radius: 50.0
        })
        .is_err());
    }
}
