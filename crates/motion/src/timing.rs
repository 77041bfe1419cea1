//! A timed path: the profile of every piece, one after another, and the
//! planned joint motion it gives at any time.

use crate::error::Result;
use crate::jtc::JointState;
use crate::path::{check, Limits, Path, Piece};
use crate::smooth::Filtered;
use crate::topp::{time_piece, Options, PieceProfile};

/// The profile of one piece: TOPP-RA's, or its jerk-limiting filter.
#[derive(Clone, Debug, PartialEq)]
pub enum Profile {
    Optimal(PieceProfile),
    Smoothed(Filtered),
}

impl Profile {
    /// The TOPP-RA profile underneath.
    pub fn optimal(&self) -> &PieceProfile {
        match self {
            Profile::Optimal(p) => p,
            Profile::Smoothed(f) => &f.base,
        }
    }

    fn duration(&self) -> f64 {
        match self {
            Profile::Optimal(p) => p.duration(),
            Profile::Smoothed(f) => f.duration(),
        }
    }

    /// (s, s', s'', s''') at local time t (0 = the piece's start).
    fn state(&self, t: f64) -> (f64, f64, f64, f64) {
        match self {
            Profile::Optimal(p) => {
                let (s, v, a) = p.state(t);
                (s, v, a, 0.0)
            }
            Profile::Smoothed(f) => f.state(t),
        }
    }

    fn knot_times(&self) -> Vec<f64> {
        match self {
            Profile::Optimal(p) => p.t.clone(),
            Profile::Smoothed(f) => f.knot_times(),
        }
    }
}

/// The planned motion along the path at one time.
#[derive(Clone, Debug, PartialEq)]
pub struct PathState {
    pub piece: usize,
    pub s: f64,
    pub s_dot: f64,
    pub s_ddot: f64,
    pub s_dddot: f64,
    /// Per joint: position, velocity, acceleration, jerk.
    pub joints: Vec<JointState>,
}

/// A sample of the optimal profile on its grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridPoint {
    pub s: f64,
    pub s_dot: f64,
    /// Time from the start of the path, s.
    pub time: f64,
}

/// A timed path.
pub struct Timing {
    /// Path parameter of every waypoint.
    pub s: Vec<f64>,
    pieces: Vec<Piece>,
    profiles: Vec<Profile>,
    /// Time stretch of each piece (1: as optimised).
    stretch: Vec<f64>,
    start: Vec<f64>,
}

/// Times `path` under `limits`: TOPP-RA on every piece, then, with jerk
/// limits, the moving-average filter of [`crate::smooth`].
pub fn parameterise(path: &Path, limits: &Limits, options: &Options) -> Result<Timing> {
    let checked = check(path, limits)?;
    let mut profiles = Vec::with_capacity(checked.pieces.len());
    for piece in &checked.pieces {
        let p = time_piece(piece, &path.tips, path.segments, limits, options, 0.0)?;
        profiles.push(match &limits.jerk {
            Some(jerk) => {
                let tau = filter_length(piece, &p, limits, jerk);
                Profile::Smoothed(Filtered::new(p, tau))
            }
            None => Profile::Optimal(p),
        });
    }
    let mut timing = Timing {
        s: checked.s,
        pieces: checked.pieces,
        stretch: vec![1.0; profiles.len()],
        start: Vec::new(),
        profiles,
    };
    timing.restart();
    Ok(timing)
}

/// The moving-average length for jerk limits: long enough that each joint,
/// at its jerk limit, swings q' s'' through the largest change of it over one
/// window (at most its whole acceleration range). The change over a window
/// grows with the window, so the length is iterated from the largest single
/// step of s'' until it settles.
fn filter_length(piece: &Piece, p: &PieceProfile, limits: &Limits, jerk: &[f64]) -> f64 {
    let n = limits.joints();
    let rates: Vec<f64> = (0..n)
        .map(|j| {
            p.s.iter()
                .map(|&s| {
                    let k = piece.joints.interval(s);
                    piece.joints.jet_in(k, j, s).d1.abs()
                })
                .fold(0.0, f64::max)
        })
        .collect();
    let length = |change: f64| {
        (0..n)
            .map(|j| (rates[j] * change).min(2.0 * limits.acceleration[j]) / jerk[j])
            .fold(1e-6, f64::max)
    };
    // s'' in time: u on each stage, 0 outside the piece.
    let u_at = |t: f64| {
        let m = p.t.len();
        if t <= p.t[0] || t >= p.t[m - 1] {
            return 0.0;
        }
        p.u[p.t.partition_point(|&x| x <= t).clamp(1, m - 1) - 1]
    };
    let first_step = std::iter::once(0.0)
        .chain(p.u.iter().copied())
        .chain(std::iter::once(0.0))
        .collect::<Vec<f64>>()
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .fold(0.0, f64::max);
    let mut tau = length(first_step);
    for _ in 0..6 {
        let end = p.t[p.t.len() - 1] + tau;
        let change =
            p.t.iter()
                .chain(std::iter::once(&end))
                .map(|&t| {
                    (u_at(t) - u_at(t - tau))
                        .abs()
                        .max((u_at(t + 1e-12) - u_at(t - tau + 1e-12)).abs())
                })
                .fold(0.0, f64::max);
        let next = length(change);
        if next <= tau * (1.0 + 1e-9) {
            break;
        }
        tau = next;
    }
    tau
}

impl Timing {
    fn restart(&mut self) {
        let mut t = 0.0;
        self.start.clear();
        for (p, k) in self.profiles.iter().zip(&self.stretch) {
            self.start.push(t);
            t += p.duration() * k;
        }
        self.start.push(t);
    }

    pub fn duration(&self) -> f64 {
        self.start[self.start.len() - 1]
    }

    pub fn profiles(&self) -> &[Profile] {
        &self.profiles
    }

    /// Start time and end time of piece `p`.
    pub fn piece_span(&self, p: usize) -> (f64, f64) {
        (self.start[p], self.start[p + 1])
    }

    /// First and last waypoint of piece `p`.
    pub fn piece_waypoints(&self, p: usize) -> (usize, usize) {
        (self.pieces[p].first, self.pieces[p].last)
    }

    pub fn stretch(&self) -> &[f64] {
        &self.stretch
    }

    /// Stretches piece `p`'s time by `k` (velocities / k, accelerations
    /// / k^2, jerks / k^3); later pieces move on.
    pub fn stretch_piece(&mut self, p: usize, k: f64) {
        self.stretch[p] *= k;
        self.restart();
    }

    /// The piece running at time `t` (the earlier one at a shared stop).
    pub fn piece_at(&self, t: f64) -> usize {
        let n = self.profiles.len();
        self.start[1..n].partition_point(|&x| x < t)
    }

    /// The optimal profile's grid, all pieces, in time order.
    pub fn grid(&self) -> Vec<GridPoint> {
        let mut out = Vec::new();
        for (p, prof) in self.profiles.iter().enumerate() {
            let o = prof.optimal();
            let k = self.stretch[p];
            let skip = usize::from(p > 0);
            for i in skip..o.s.len() {
                out.push(GridPoint {
                    s: o.s[i],
                    s_dot: o.x[i].sqrt() / k,
                    time: self.start[p] + o.t[i] * k,
                });
            }
        }
        out
    }

    /// Time of every waypoint.
    pub fn waypoint_times(&self) -> Vec<f64> {
        let mut out = vec![0.0; self.s.len()];
        for (p, prof) in self.profiles.iter().enumerate() {
            let o = prof.optimal();
            let first = self.pieces[p].first;
            for (k, &i) in o.knot_index.iter().enumerate() {
                out[first + k] = self.waypoint_time(p, o.t[i]);
            }
        }
        out
    }

    /// Global time at which piece `p` passes the grid point at local TOPP
    /// time `t`: the same for an optimal profile; for a filtered one, which
    /// lags s* by between 0 and its window, found by bisection.
    fn waypoint_time(&self, p: usize, t: f64) -> f64 {
        let local = match &self.profiles[p] {
            Profile::Optimal(_) => t,
            Profile::Smoothed(f) => {
                let target = f.base.state(t).0;
                let (mut lo, mut hi) = (t, t + f.tau);
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    if f.state(mid).0 < target {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                hi
            }
        };
        self.start[p] + local * self.stretch[p]
    }

    /// Times where piece `p`'s profile changes polynomial piece (global).
    pub fn knot_times(&self, p: usize) -> Vec<f64> {
        let k = self.stretch[p];
        self.profiles[p]
            .knot_times()
            .into_iter()
            .map(|t| self.start[p] + t * k)
            .collect()
    }

    /// The planned motion at time `t` within piece `p`.
    pub fn state_in(&self, p: usize, t: f64) -> PathState {
        let k = self.stretch[p];
        let local = ((t - self.start[p]) / k).clamp(0.0, self.profiles[p].duration());
        let (s, v, a, j) = self.profiles[p].state(local);
        let (v, a, j) = (v / k, a / (k * k), j / (k * k * k));
        let sp = &self.pieces[p].joints;
        let i = sp.interval(s);
        let joints = (0..sp.dim())
            .map(|c| {
                let q = sp.jet_in(i, c, s);
                JointState {
                    q: q.value,
                    v: q.d1 * v,
                    a: q.d2 * v * v + q.d1 * a,
                    j: q.d3 * v * v * v + 3.0 * q.d2 * v * a + q.d1 * j,
                }
            })
            .collect();
        PathState {
            piece: p,
            s,
            s_dot: v,
            s_ddot: a,
            s_dddot: j,
            joints,
        }
    }

    /// The planned motion at time `t`.
    pub fn state(&self, t: f64) -> PathState {
        self.state_in(self.piece_at(t), t)
    }

    /// Whether the profile carries a continuous acceleration (jerk-limited):
    /// then the controller gets accelerations too (quintic).
    pub fn smoothed(&self) -> bool {
        matches!(self.profiles.first(), Some(Profile::Smoothed(_)))
    }
}
