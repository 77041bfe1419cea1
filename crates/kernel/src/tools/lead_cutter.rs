//! A flat-end or ball cutter posed with a fixed lead angle and zero side tilt:
//! the cutter the strip-width planners place (docs/methods.md, "Strip width of
//! a tilted flat end"). The tilt lifts the heel, so the flat bottom's front edge
//! cuts and, seen along the feed, sweeps an ellipse of semi-axes R and
//! R sin(lambda).

use super::Tool;
use nalgebra::{Point3, Vector3};

/// A flat-end (or ball) cutter with its lead angle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeadCutter {
    pub radius: f64,
    /// Lead angle lambda, radians (0 for the ball, whose profile does not depend on it).
    pub lead: f64,
    pub ball: bool,
}

/// Why a tool cannot be posed with a lead angle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LeadCutterError {
    /// A flat end with a negative lead would cut with its heel.
    NegativeLead,
    /// Only flat-end and ball cutters have this model.
    UnsupportedKind(&'static str),
}

impl LeadCutter {
    /// The posed cutter of a flat-end or ball tool; `lead` in radians.
    pub fn from_tool(tool: &Tool, lead: f64) -> Result<Self, LeadCutterError> {
        match *tool {
            Tool::FlatEnd { radius, .. } => {
                if lead < 0.0 {
                    return Err(LeadCutterError::NegativeLead);
                }
                Ok(Self {
                    radius,
                    lead,
                    ball: false,
                })
            }
            Tool::Ball { radius, .. } => Ok(Self {
                radius,
                lead: 0.0,
                ball: true,
            }),
            other => Err(LeadCutterError::UnsupportedKind(other.kind())),
        }
    }

    /// Effective curvature of the cutting profile across the feed: sin(lambda)/R
    /// for the flat end, 1/R for the ball.
    pub fn k_b(&self) -> f64 {
        if self.ball {
            1.0 / self.radius
        } else {
            self.lead.sin() / self.radius
        }
    }

    /// Tool pose for contact `cc` with unit normal `n` and unit travel
    /// direction `t` (tangent): (cl = tool tip, unit axis). The flat end is
    /// tilted by lambda about the cross-feed so that its front bottom edge
    /// touches cc and the heel is lifted: axis = cos(l) n + sin(l) t and the
    /// centre of the bottom disc is cc - R d with d = cos(l) t - sin(l) n.
    pub fn pose(
        &self,
        cc: Point3<f64>,
        n: Vector3<f64>,
        t: Vector3<f64>,
    ) -> (Point3<f64>, Vector3<f64>) {
        if self.ball {
            // Tip = ball centre - R axis, axis along the normal.
            return (cc, n);
        }
        let (s, c) = self.lead.sin_cos();
        let axis = n * c + t * s;
        let d = t * c - n * s;
        (cc - d * self.radius, axis)
    }

    /// Edge point at parameter phi in 0..=pi/2 in the local frame of the contact:
    /// (x along the feed, |y| across it, z along the normal); `lead_sc` is
    /// (sin, cos) of the lead angle (computed once per width).
    pub fn edge(&self, phi: f64, lead_sc: (f64, f64)) -> (f64, f64, f64) {
        self.edge_sc(phi, phi.sin_cos(), lead_sc)
    }

    /// [`LeadCutter::edge`] with `phi_sc` = phi.sin_cos() given (from a
    /// table of the fixed sample angles: the same bits, no trigonometry).
    pub(crate) fn edge_sc(
        &self,
        phi: f64,
        phi_sc: (f64, f64),
        lead_sc: (f64, f64),
    ) -> (f64, f64, f64) {
        let (s, c) = phi_sc;
        let r = self.radius;
        if self.ball {
            (0.0, r * s, r * (1.0 - c))
        } else {
            let one_minus = if phi < 1e-4 { 0.5 * phi * phi } else { 1.0 - c };
            (-r * one_minus * lead_sc.1, r * s, r * lead_sc.0 * one_minus)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: f64 = 2.5;

    fn flat() -> LeadCutter {
        LeadCutter {
            radius: R,
            lead: 5f64.to_radians(),
            ball: false,
        }
    }

    #[test]
    fn pose_puts_the_lowest_disc_point_on_cc() {
        let c = flat();
        let n = Vector3::new(0.0, 0.3, 1.0).normalize();
        let t = Vector3::new(1.0, 0.0, 0.0);
        let cc = Point3::new(1.0, 2.0, 3.0);
        let (cl, axis) = c.pose(cc, n, t);
        assert!((axis.norm() - 1.0).abs() < 1e-12);
        assert!((axis.dot(&t) - 5f64.to_radians().sin()).abs() < 1e-12);
        // Disc: cl + R (cos a e1 + sin a e2), e1, e2 perpendicular to the axis.
        let e2 = axis.cross(&t).normalize();
        let e1 = e2.cross(&axis);
        let mut lowest = (f64::INFINITY, Point3::origin());
        for i in 0..3600 {
            let a = std::f64::consts::TAU * i as f64 / 3600.0;
            let p = cl + (e1 * a.cos() + e2 * a.sin()) * R;
            let hgt = (p - cc).dot(&n);
            if hgt < lowest.0 {
                lowest = (hgt, p);
            }
        }
        assert!(
            lowest.0.abs() < 1e-9 && (lowest.1 - cc).norm() < 1e-2,
            "{lowest:?}"
        );
    }
}
