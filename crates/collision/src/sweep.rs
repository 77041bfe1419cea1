//! Swept checks of straight tool motions (links, rapids, run-ins): the tip
//! moves linearly, the axis turns by spherical linear interpolation, and the
//! motion is checked by conservative advancement.
//!
//! Bound: along the motion, a face point's position in the tool's frame
//! moves by at most D ds, with D = |tip1 - tip0| + theta (reach + max(limit,
//! 0) + |tip1 - tip0|), theta the angle between the axes and reach the
//! largest distance of a tool point from the tip; so every part's signed
//! distance at a face point within reach changes by at most D ds. From a pose
//! at s whose margin over the limits is m >= 0, the next pose checked is at
//! s + (m + tol) / D, so between the two no part comes closer than its limit
//! minus `tol`: no contact deeper than the tolerance is missed. The margin
//! is the certified one where it is non-negative, else the refined distance
//! of the full query (exact near contact). The first pose found in
//! collision is then moved back by bisection to within tol / D of where the
//! motion first collides.

use crate::assembly::{Pose, ToolAssembly};
use crate::error::{positive, Error, Result};
use crate::query::{PoseReport, QueryOptions};
use crate::workpiece::Workpiece;

/// A straight motion between two poses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    pub from: Pose,
    pub to: Pose,
}

impl Motion {
    /// Refuses opposite axes (the turn between them has no unique plane).
    pub fn new(from: Pose, to: Pose) -> Result<Self> {
        if from.axis.dot(&to.axis) < -1.0 + 1e-12 {
            return Err(Error::invalid(
                "to.axis",
                "opposite to from.axis: the turn between them is not unique",
            ));
        }
        Ok(Self { from, to })
    }

    /// Angle between the two axes, radians.
    pub fn angle(&self) -> f64 {
        self.from
            .axis
            .cross(&self.to.axis)
            .norm()
            .atan2(self.from.axis.dot(&self.to.axis))
    }

    /// The pose at `s` in [0, 1]: tip linear, axis slerped.
    pub fn pose_at(&self, s: f64) -> Pose {
        let tip = self.from.tip + (self.to.tip - self.from.tip) * s;
        let theta = self.angle();
        let axis = if theta < 1e-9 {
            (self.from.axis * (1.0 - s) + self.to.axis * s).normalize()
        } else {
            let k = 1.0 / theta.sin();
            (self.from.axis * (((1.0 - s) * theta).sin() * k)
                + self.to.axis * ((s * theta).sin() * k))
                .normalize()
        };
        Pose { tip, axis }
    }

    /// D of the module's bound: the largest rate, per unit of s, at which any
    /// part's signed distance at a face point within reach can change.
    pub fn rate_bound(&self, tool: &ToolAssembly, opts: &QueryOptions) -> f64 {
        let dt = (self.to.tip - self.from.tip).norm();
        let limit = opts.cutter_limit.max(opts.holder_limit).max(0.0);
        dt + self.angle() * (tool.reach() + limit + dt)
    }
}

/// How a motion is checked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepOptions {
    pub query: QueryOptions,
    /// No contact deeper than this beyond the limits is missed, mm.
    pub tolerance: f64,
    /// A motion needing more pose checks than this is refused (a grazing
    /// motion with a tolerance far too fine).
    pub max_poses: usize,
}

/// The verdict on a motion.
#[derive(Clone, Debug, PartialEq)]
pub enum SweepOutcome {
    /// No part comes closer than its limit minus the tolerance.
    Clear { poses: usize },
    /// The first colliding parameter `s` (within tol / D after it first
    /// collides), and the pose report there.
    Collision {
        s: f64,
        pose: Pose,
        report: PoseReport,
        poses: usize,
    },
}

/// Checks `motion` (see the module's bound). Errors name `options.*`.
pub fn check_motion(
    work: &Workpiece,
    tool: &ToolAssembly,
    motion: &Motion,
    opts: &SweepOptions,
) -> Result<SweepOutcome> {
    positive("options.tolerance", opts.tolerance)?;
    opts.query
        .validate()
        .map_err(|e| e.within("options.query"))?;
    let d = motion.rate_bound(tool, &opts.query);
    let tol = opts.tolerance;
    let mut query = opts.query;
    query.search_margin = query.search_margin.max(2.0 * work.max_cover());
    let (mut s, mut last_clear, mut poses) = (0.0f64, 0.0f64, 0usize);
    loop {
        poses += 1;
        if poses > opts.max_poses {
            return Err(Error::invalid(
                "options.max_poses",
                format!(
                    "the motion needs more than {} pose checks at a tolerance of {tol} mm",
                    opts.max_poses
                ),
            ));
        }
        let pose = motion.pose_at(s);
        let cap = (1.0 - s) * d + tol;
        let mut margin = work.certified_margin(tool, &pose, &opts.query, cap);
        if margin < 0.0 {
            let report = work.query(tool, &pose, &query);
            if report.collides() {
                return Ok(first_collision(
                    work,
                    tool,
                    motion,
                    &query,
                    (last_clear, s),
                    report,
                    d,
                    tol,
                    poses,
                ));
            }
            margin = trusted_margin(&report).min(cap);
        }
        if s >= 1.0 || d == 0.0 {
            return Ok(SweepOutcome::Clear { poses });
        }
        last_clear = s;
        s = (s + (margin + tol) / d).min(1.0);
    }
}

/// Least over the parts of the trusted distance minus the limit: the refined
/// distance where a contact was refined, else the certified bound; and never
/// above the bound of the nodes the query pruned.
fn trusted_margin(report: &PoseReport) -> f64 {
    report
        .parts
        .iter()
        .map(|p| {
            let d = if p.refined { p.distance } else { p.lower_bound };
            d.min(p.pruned_bound) - p.limit
        })
        .fold(f64::INFINITY, f64::min)
}

/// Bisects between a clear `s` and a colliding one down to tol / D.
#[allow(clippy::too_many_arguments)]
fn first_collision(
    work: &Workpiece,
    tool: &ToolAssembly,
    motion: &Motion,
    query: &QueryOptions,
    (mut lo, mut hi): (f64, f64),
    mut report: PoseReport,
    d: f64,
    tol: f64,
    mut poses: usize,
) -> SweepOutcome {
    if hi > 0.0 {
        while (hi - lo) * d > tol {
            let mid = 0.5 * (lo + hi);
            poses += 1;
            let r = work.query(tool, &motion.pose_at(mid), query);
            if r.collides() {
                hi = mid;
                report = r;
            } else {
                lo = mid;
            }
        }
    }
    SweepOutcome::Collision {
        s: hi,
        pose: motion.pose_at(hi),
        report,
        poses,
    }
}
