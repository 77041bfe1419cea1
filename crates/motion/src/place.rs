//! Waypoint placement: which states of the timed path go to the controller,
//! so that what it interpolates between them (JTC's cubic, or its quintic
//! for a jerk-limited profile) keeps every limit and the tool on the cut.
//!
//! Every waypoint of the path is sent. An interval between two sent points
//! whose interpolation, sampled at the controller's period (and at least at
//! both ends and three inner points), breaks a limit or leaves the chord or axis tolerance
//! on a cut is split, at the profile's knot nearest the middle of the
//! interval (a switch of s_ddot must be a point: no cubic follows a kink of
//! the velocity), or in the middle within one profile piece, until it holds
//! or is shorter than [`MIN_INTERVAL`].

use crate::check::{check, measure, segment_of, Planned, Report, Tolerance};
use crate::error::{Error, Result};
use crate::jtc::{cubic, quintic, JointState, Trajectory};
use crate::path::{Limits, Path, Tips, ToolPose};
use crate::timing::{parameterise, PathState, Timing};
use crate::topp::Options;

/// Intervals are not split below this, s.
pub const MIN_INTERVAL: f64 = 1e-5;

/// Splits inside one polynomial piece of the profile at most.
const MAX_SMOOTH_SPLITS: usize = 4;

/// What the tool must follow: forward kinematics, the planned poses (one per
/// waypoint; `None`: the kinematics of the waypoints) and the tolerance.
#[derive(Clone, Copy)]
pub struct Follow<'a> {
    pub kinematics: crate::path::Kinematics<'a>,
    pub poses: Option<&'a [ToolPose]>,
    pub tolerance: Tolerance,
}

/// A timed path, the trajectory sent for it and its sampled check.
pub struct Plan {
    pub timing: Timing,
    pub trajectory: Trajectory,
    pub report: Report,
}

/// Times `path`, places the trajectory's points and checks it sampled at the
/// controller's period; a piece whose samples still break a limit (the
/// motion between grid points, the jerk filter's curvature terms) is
/// stretched in time by the factor that brings it within every limit, which
/// holds exactly because the controller's interpolation is covariant under a
/// time scaling.
pub fn plan(
    path: &Path,
    limits: &Limits,
    options: &Options,
    follow: Option<Follow>,
) -> Result<Plan> {
    let timing = parameterise(path, limits, options)?;
    plan_timed(timing, path, limits, options, follow)
}

/// [`plan`] from a timing of `path` the caller has made (with
/// [`parameterise`]) and perhaps stretched piece by piece (a shortest
/// duration of its own, say).
pub fn plan_timed(
    mut timing: Timing,
    path: &Path,
    limits: &Limits,
    options: &Options,
    follow: Option<Follow>,
) -> Result<Plan> {
    if timing.s.len() != path.positions.len() {
        return Err(Error::invalid(
            "timing",
            format!(
                "times {} waypoints, the path has {}",
                timing.s.len(),
                path.positions.len()
            ),
        ));
    }
    let s_wp = timing.s.clone();
    // The tip is checked wherever kinematics are known: the follow's, else
    // the path's own (then for the tip speed caps; no tolerance applies).
    let kinematics = match (follow, path.tips) {
        (Some(f), _) => Some(f.kinematics),
        (None, Tips::Kinematics(fk)) => Some(fk),
        _ => None,
    };
    let given = follow.and_then(|f| f.poses);
    let own_poses: Vec<ToolPose> = match (kinematics, given) {
        (Some(fk), None) => path.positions.iter().map(|q| fk(q)).collect(),
        _ => Vec::new(),
    };
    let planned = kinematics.map(|fk| Planned {
        s: &s_wp,
        segments: path.segments,
        poses: given.unwrap_or(&own_poses),
        kinematics: fk,
    });
    let tol = follow.map(|f| f.tolerance);
    let placed = |timing: &Timing| {
        let traj = place(
            timing,
            limits,
            path,
            planned.as_ref(),
            tol.as_ref(),
            options,
        );
        let report = check(
            &traj,
            limits,
            path.segments,
            &s_wp,
            planned.as_ref(),
            options.sample_period,
        );
        (traj, report)
    };
    for _ in 0..4 {
        let (traj, report) = placed(&timing);
        let over = pieces_over(&timing, &report);
        if over.is_empty() {
            return Ok(Plan {
                timing,
                trajectory: traj,
                report,
            });
        }
        for (p, k) in over {
            timing.stretch_piece(p, k * (1.0 + 1e-6));
        }
    }
    let (traj, report) = placed(&timing);
    Ok(Plan {
        timing,
        trajectory: traj,
        report,
    })
}

/// Pieces whose sampled stretch exceeds 1, with that stretch.
fn pieces_over(timing: &Timing, report: &Report) -> Vec<(usize, f64)> {
    (0..timing.profiles().len())
        .filter_map(|p| {
            let (a, b) = timing.piece_waypoints(p);
            let k = report.segment_stretch[a..b]
                .iter()
                .copied()
                .fold(0.0, f64::max);
            (k > 1.0).then_some((p, k))
        })
        .collect()
}

/// The trajectory's points for `timing`, placed as the module says.
pub fn place(
    timing: &Timing,
    limits: &Limits,
    path: &Path,
    planned: Option<&Planned>,
    tol: Option<&Tolerance>,
    options: &Options,
) -> Trajectory {
    let times = timing.waypoint_times();
    let quintic = timing.smoothed();
    let mut out = Trajectory::default();
    let pieces = timing.profiles().len();
    for p in 0..pieces {
        let (first, last) = timing.piece_waypoints(p);
        let ctx = Ctx {
            timing,
            limits,
            path,
            planned,
            tol,
            p,
            span: (first, last),
            knots: timing.knot_times(p),
            quintic,
            period: options.sample_period,
        };
        let mut prev = ctx.at(times[first]);
        push(&mut out, &prev, timing, quintic);
        for &tb in &times[first + 1..=last] {
            let next = ctx.at(tb);
            ctx.refine(&prev, &next, &mut out, 0);
            if tb < times[last] || p + 1 == pieces {
                push(&mut out, &next, timing, quintic);
            }
            prev = next;
        }
    }
    if !quintic {
        out.accelerations.clear();
    }
    out
}

/// A planned state at a time.
struct At {
    t: f64,
    state: PathState,
}

fn push(out: &mut Trajectory, at: &At, timing: &Timing, quintic: bool) {
    let seg = segment_of(&timing.s, at.state.s, 0, timing.s.len() - 1);
    out.times.push(at.t);
    out.positions
        .push(at.state.joints.iter().map(|j| j.q).collect());
    out.velocities
        .push(at.state.joints.iter().map(|j| j.v).collect());
    if quintic {
        out.accelerations
            .push(at.state.joints.iter().map(|j| j.a).collect());
    }
    out.s.push(at.state.s);
    out.segment.push(seg);
}

struct Ctx<'a> {
    timing: &'a Timing,
    limits: &'a Limits,
    path: &'a Path<'a>,
    planned: Option<&'a Planned<'a>>,
    tol: Option<&'a Tolerance>,
    p: usize,
    span: (usize, usize),
    knots: Vec<f64>,
    quintic: bool,
    period: f64,
}

impl Ctx<'_> {
    fn at(&self, t: f64) -> At {
        At {
            t,
            state: self.timing.state_in(self.p, t),
        }
    }

    /// Splits (a, b) until its interpolation holds, pushing the inner points.
    /// `smooth_splits` counts the splits already made inside one piece of
    /// the profile (no knot inside): there the plan is smooth and the
    /// interpolation converges in a few, so more would only chase the plan.
    fn refine(&self, a: &At, b: &At, out: &mut Trajectory, smooth_splits: usize) {
        let h = b.t - a.t;
        if smooth_splits > MAX_SMOOTH_SPLITS || h < MIN_INTERVAL || !self.breaks(a, b) {
            return;
        }
        let (mid, at_knot) = self.split_time(a.t, b.t);
        let next = if at_knot { 0 } else { smooth_splits + 1 };
        let m = self.at(mid);
        self.refine(a, &m, out, next);
        push(out, &m, self.timing, self.quintic);
        self.refine(&m, b, out, next);
    }

    /// The profile knot nearest the middle of (ta, tb), else the middle
    /// (and whether it is a knot).
    fn split_time(&self, ta: f64, tb: f64) -> (f64, bool) {
        let mid = 0.5 * (ta + tb);
        let guard = 1e-3 * (tb - ta);
        let i = self.knots.partition_point(|&t| t < mid);
        [i.checked_sub(1), Some(i)]
            .into_iter()
            .flatten()
            .filter_map(|k| self.knots.get(k).copied())
            .filter(|&t| t > ta + guard && t < tb - guard)
            .min_by(|x, y| (x - mid).abs().total_cmp(&(y - mid).abs()))
            .map_or((mid, false), |t| (t, true))
    }

    /// Whether the controller's interpolation between `a` and `b` breaks a
    /// limit or the tolerance at any of its samples.
    fn breaks(&self, a: &At, b: &At) -> bool {
        let h = b.t - a.t;
        let m = ((h / self.period).ceil() as usize).max(4);
        let (first, last) = self.span;
        // The ends too: the cubic's acceleration is extreme there.
        for i in 0..=m {
            let tau = h * i as f64 / m as f64;
            let js: Vec<JointState> = a
                .state
                .joints
                .iter()
                .zip(&b.state.joints)
                .map(|(x, y)| {
                    if self.quintic {
                        quintic([x.q, x.v, x.a], [y.q, y.v, y.a], h, tau)
                    } else {
                        cubic(x.q, x.v, y.q, y.v, h, tau)
                    }
                })
                .collect();
            let plan = self.timing.state_in(self.p, a.t + tau);
            let seg = segment_of(&self.timing.s, plan.s, first, last);
            let span = (first, last);
            let meas = measure(&js, self.limits, self.planned, plan.s, seg, span);
            let kind = self.path.segments[seg].kind;
            if meas.breaks(kind, self.tol) {
                // Where the plan itself breaks as much, more points cannot
                // help (the piece's stretch will).
                let own = measure(&plan.joints, self.limits, self.planned, plan.s, seg, span);
                let worse = meas.stretch() > own.stretch().max(1.0) + 1e-9
                    || meas.deviation
                        > own
                            .deviation
                            .max(self.tol.map_or(f64::INFINITY, |t| t.chord))
                    || meas.axis > own.axis.max(self.tol.map_or(f64::INFINITY, |t| t.axis));
                if worse {
                    return true;
                }
            }
        }
        false
    }
}
