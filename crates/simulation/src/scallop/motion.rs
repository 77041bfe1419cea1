//! One straight tool motion between two consecutive points of a pass (tip
//! interpolated, axis interpolated and normalised), with the constants the
//! reach test and the drop need once per motion; and the motions of a
//! result, its points checked.

use nalgebra::Vector3;
use toolpath_formats::PlanResult;
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::tools::CutterShape;

/// One straight tool motion between two consecutive points of a pass.
#[derive(Clone, Copy, Debug)]
pub(super) struct Motion {
    pub(super) tip0: Vector3<f64>,
    pub(super) tip1: Vector3<f64>,
    pub(super) axis0: Vector3<f64>,
    pub(super) axis1: Vector3<f64>,
    /// Largest distance a tool point (within the reach) moves, mm.
    pub(super) travel: f64,
    /// Axis segment of the tool half-way along the motion, for quick rejection.
    pub(super) mid_tip: Vector3<f64>,
    pub(super) mid_top: Vector3<f64>,
    /// How far the swept axis strays from the mid axis, mm.
    pub(super) margin: f64,
    /// mid_top - mid_tip, its squared length and the reciprocal, and
    /// (R + margin)^2: the reach test's per-motion constants.
    pub(super) mid_d: Vector3<f64>,
    pub(super) mid_dd: f64,
    pub(super) mid_inv_dd: f64,
    pub(super) reach2: f64,
    /// The sample-independent products of [`SweepLine`]: tip1 - tip0,
    /// axis1 - axis0, |axis(s)|^2's coefficients, (tip1 - tip0) . axis0,
    /// (tip1 - tip0) . (axis1 - axis0), |tip1 - tip0|^2.
    pub(super) dt: Vector3<f64>,
    pub(super) da: Vector3<f64>,
    pub(super) q: [f64; 3],
    pub(super) dt_a0: f64,
    pub(super) dt_da: f64,
    pub(super) dt_dt: f64,
}

impl Motion {
    /// The tool's tip and unit axis at motion parameter s in [0, 1].
    pub(super) fn pose(&self, s: f64) -> (Vector3<f64>, Vector3<f64>) {
        let tip = self.tip0 + (self.tip1 - self.tip0) * s;
        let axis = (self.axis0 * (1.0 - s) + self.axis1 * s)
            .try_normalize(1e-12)
            .unwrap_or(self.axis0);
        (tip, axis)
    }

    /// The motion from (tip0, axis0) to (tip1, axis1) (unit axes) of a
    /// cutter of radius `big_r` and length `len`.
    fn new(
        (tip0, axis0): (Vector3<f64>, Vector3<f64>),
        (tip1, axis1): (Vector3<f64>, Vector3<f64>),
        big_r: f64,
        len: f64,
    ) -> Self {
        let angle = axis0.angle(&axis1);
        let reach = len.hypot(big_r);
        let travel = (tip1 - tip0).norm() + reach * angle;
        let mid = (axis0 + axis1).try_normalize(1e-12).unwrap_or(axis0);
        let mid_tip = (tip0 + tip1) * 0.5;
        let top0 = tip0 + axis0 * len;
        let top1 = tip1 + axis1 * len;
        let chord = (axis0 + axis1).norm() * 0.5;
        let margin = 0.5 * (tip1 - tip0).norm().max((top1 - top0).norm())
            + len * (1.0 - chord)
            + 1e-9 * reach;
        let mid_top = mid_tip + mid * len;
        let (dt, da) = (tip1 - tip0, axis1 - axis0);
        let mid_d = mid_top - mid_tip;
        let mid_dd = mid_d.norm_squared();
        Self {
            tip0,
            tip1,
            axis0,
            axis1,
            travel,
            mid_tip,
            mid_top,
            margin,
            mid_d,
            mid_dd,
            mid_inv_dd: 1.0 / mid_dd,
            reach2: (big_r + margin) * (big_r + margin),
            dt,
            da,
            q: [
                axis0.norm_squared(),
                2.0 * axis0.dot(&da),
                da.norm_squared(),
            ],
            dt_a0: dt.dot(&axis0),
            dt_da: dt.dot(&da),
            dt_dt: dt.norm_squared(),
        }
    }

    /// The box of the tool swept along the motion: the axis ends and the
    /// mid axis, padded by the radius (1 % over) and the margin.
    pub(super) fn swept_box(&self, big_r: f64, len: f64) -> (Vector3<f64>, Vector3<f64>) {
        let s = self;
        let pad = Vector3::repeat(big_r * 1.01 + s.margin);
        let pts = [
            s.tip0,
            s.tip1,
            s.tip0 + s.axis0 * len,
            s.tip1 + s.axis1 * len,
            s.mid_tip,
            s.mid_top,
        ];
        let mut lo = pts[0];
        let mut hi = pts[0];
        for p in &pts[1..] {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        (lo - pad, hi + pad)
    }
}

fn vec3(a: [f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}

fn finite3(a: &[f64; 3]) -> bool {
    a.iter().all(|x| x.is_finite())
}

/// The motions of `result`'s passes for `cutter`, each point's `cl` and
/// `axis` checked (finite, a non-zero axis); a pass of one point is a motion
/// that stands still.
pub(super) fn motions_of(result: &PlanResult, cutter: &CutterShape) -> Result<Vec<Motion>> {
    let (big_r, len) = (cutter.radius, cutter.length);
    let mut motions = Vec::new();
    for (i, pass) in result.passes.iter().enumerate() {
        let mut poses = Vec::with_capacity(pass.points.len());
        for (j, q) in pass.points.iter().enumerate() {
            let field = |f: &str| format!("passes[{i}].points[{j}].{f}");
            if !finite3(&q.cl) {
                return Err(Error::invalid(field("cl"), "is not a finite point"));
            }
            if !finite3(&q.axis) {
                return Err(Error::invalid(field("axis"), "is not a finite vector"));
            }
            let axis = vec3(q.axis).try_normalize(1e-12).ok_or_else(|| {
                Error::invalid(
                    field("axis"),
                    "is a zero vector: the tool axis must be a unit vector",
                )
            })?;
            poses.push((vec3(q.cl), axis));
        }
        let mut push = |a, b| motions.push(Motion::new(a, b, big_r, len));
        match poses.len() {
            0 => {}
            1 => push(poses[0], poses[0]),
            _ => {
                for w in poses.windows(2) {
                    push(w[0], w[1]);
                }
            }
        }
    }
    Ok(motions)
}
