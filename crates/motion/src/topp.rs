//! Time-optimal path parameterisation by reachability analysis (TOPP-RA,
//! docs/methods.md, "Time-optimal path parameterisation").
//!
//! On a grid s_0 < ... < s_N of one piece (at rest at both ends), with
//! x = s_dot^2 and u = s_ddot constant on each grid interval
//! (x_{i+1} = x_i + 2 (s_{i+1} - s_i) u_i):
//! - joint velocity |q_j'(s)| s_dot <= v_j and the tip speed cap
//!   |p'(s)| s_dot <= feed bound x at every grid point;
//! - joint acceleration |q_j''(s) x + q_j'(s) u| <= a_j holds at both ends of
//!   each interval with that interval's u (the "interpolation" scheme), so the
//!   acceleration is checked wherever the profile changes;
//! - a backward pass computes the controllable sets K_i = [0, k_i] (the x at
//!   s_i from which the end can still be reached at rest), a forward pass
//!   takes the largest u that stays in them. The result is the time-optimal
//!   profile on the grid (Pham & Pham 2018).

use crate::error::{Error, Result};
use crate::lp::{u_range, x_interval, Row};
use crate::path::{Limits, Piece, Segment, Tips};
use crate::spline::Spline;

/// How the grid is laid and how much headroom the limits keep.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Grid intervals per piece at least: long spline intervals (a two-point
    /// link) are subdivided evenly until the piece has this many.
    pub min_intervals: usize,
    /// Fraction by which the optimisation tightens every limit, so that the
    /// motion between grid points (and the controller's interpolation of it)
    /// stays within the true limits.
    pub margin: f64,
    /// The controller's period, s: the checker samples at it.
    pub sample_period: f64,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            min_intervals: 1000,
            margin: 2e-3,
            sample_period: 1e-3,
        }
    }
}

/// The timed profile of one piece on its grid.
#[derive(Clone, Debug, PartialEq)]
pub struct PieceProfile {
    /// First and last waypoint of the piece.
    pub first: usize,
    pub last: usize,
    /// Grid of the path parameter.
    pub s: Vec<f64>,
    /// s_dot^2 at each grid point.
    pub x: Vec<f64>,
    /// s_ddot on each grid interval (one fewer than `s`).
    pub u: Vec<f64>,
    /// Time of each grid point from the start of the whole path, s.
    pub t: Vec<f64>,
    /// Index in `s` of each waypoint of the piece (first..=last).
    pub knot_index: Vec<usize>,
}

impl PieceProfile {
    pub fn duration(&self) -> f64 {
        self.t[self.t.len() - 1] - self.t[0]
    }

    /// (s, s_dot, s_ddot) at time `t` (clamped to the piece).
    pub fn state(&self, t: f64) -> (f64, f64, f64) {
        let n = self.t.len();
        let i = self.t.partition_point(|&x| x <= t).clamp(1, n - 1) - 1;
        let tau = (t - self.t[i]).clamp(0.0, self.t[i + 1] - self.t[i]);
        let v0 = self.x[i].sqrt();
        let u = self.u[i];
        let s = (self.s[i] + v0 * tau + 0.5 * u * tau * tau).min(self.s[i + 1]);
        (s, (v0 + u * tau).max(0.0), u)
    }
}

/// Grid data of one piece: parameter, per-point derivatives, caps.
struct Grid {
    s: Vec<f64>,
    knot_index: Vec<usize>,
    /// q' and q'' per grid point, point-major.
    d1: Vec<f64>,
    d2: Vec<f64>,
    /// Upper bound on x from velocity limits and the tip speed cap.
    xmax: Vec<f64>,
}

/// Where the grid points lie: the parameter, the spline interval of each
/// grid interval, and the grid index of each knot.
struct Layout {
    s: Vec<f64>,
    interval: Vec<usize>,
    knot_index: Vec<usize>,
}

impl Layout {
    /// The piece's knots, each interval split evenly so that no grid
    /// interval is longer than the piece over `min_intervals`.
    fn new(knots: &[f64], min_intervals: usize) -> Self {
        let len = knots[knots.len() - 1] - knots[0];
        let h_max = len / min_intervals.max(1) as f64;
        let mut s = vec![knots[0]];
        let mut interval = Vec::new();
        let mut knot_index = vec![0];
        for (k, w) in knots.windows(2).enumerate() {
            let m = ((w[1] - w[0]) / h_max).ceil().max(1.0) as usize;
            for i in 1..=m {
                interval.push(k);
                s.push(if i == m {
                    w[1]
                } else {
                    w[0] + (w[1] - w[0]) * i as f64 / m as f64
                });
            }
            knot_index.push(s.len() - 1);
        }
        Layout {
            s,
            interval,
            knot_index,
        }
    }

    /// Splits the grid intervals `bad` (sorted) at their middles.
    fn split(&mut self, bad: &[usize]) {
        let mut s = Vec::with_capacity(self.s.len() + bad.len());
        let mut interval = Vec::with_capacity(s.capacity());
        let mut next = bad.iter().peekable();
        for i in 0..self.s.len() - 1 {
            s.push(self.s[i]);
            interval.push(self.interval[i]);
            if next.peek() == Some(&&i) {
                next.next();
                s.push(0.5 * (self.s[i] + self.s[i + 1]));
                interval.push(self.interval[i]);
            }
        }
        s.push(self.s[self.s.len() - 1]);
        let mut shift = 0;
        let mut b = bad.iter().peekable();
        for ki in self.knot_index.iter_mut() {
            while b.peek().is_some_and(|&&i| i < *ki) {
                b.next();
                shift += 1;
            }
            *ki += shift;
        }
        self.s = s;
        self.interval = interval;
    }
}

/// |p'(s)| of the tool tip in spline interval `k`; with kinematics by a
/// central difference along the joint tangent, |fk(q + e q') - fk(q - e q')| / 2e
/// (the chain rule p' = J q', exact to O(e^2)). `buf` holds 2 x joints.
fn tip_rate(piece: &Piece, tips: &Tips, s: f64, k: usize, buf: &mut [f64]) -> f64 {
    match (tips, &piece.tips) {
        (_, Some(sp)) => {
            let kt = sp.interval(s);
            (0..3)
                .map(|c| sp.jet_in(kt, c, s).d1.powi(2))
                .sum::<f64>()
                .sqrt()
        }
        (Tips::Kinematics(fk), None) => {
            let sp = &piece.joints;
            let n = sp.dim();
            let eps = 1e-6;
            let (qa, qb) = buf.split_at_mut(n);
            for j in 0..n {
                let jet = sp.jet_in(k, j, s);
                qa[j] = jet.value - eps * jet.d1;
                qb[j] = jet.value + eps * jet.d1;
            }
            crate::path::dist(fk(qa).tip, fk(qb).tip) / (2.0 * eps)
        }
        _ => 0.0,
    }
}

fn build_grid(
    piece: &Piece,
    tips: &Tips,
    segments: &[Segment],
    limits: &Limits,
    options: &Options,
    layout: &Layout,
) -> Grid {
    let sp: &Spline = &piece.joints;
    let n = sp.dim();
    let (s, interval, knot_index) = (
        layout.s.clone(),
        &layout.interval,
        layout.knot_index.clone(),
    );
    let scale = 1.0 - options.margin;
    let cap = |seg: usize| segments[piece.first + seg].tip_speed_cap;
    let mut d1 = Vec::with_capacity(s.len() * n);
    let mut d2 = Vec::with_capacity(s.len() * n);
    let mut xmax = Vec::with_capacity(s.len());
    let mut buf = vec![0.0; 2 * n];
    let last_interval = sp.knots().len() - 2;
    let mut knot_of = vec![None; s.len()];
    for (kn, &i) in knot_index.iter().enumerate() {
        knot_of[i] = Some(kn);
    }
    for (i, &si) in s.iter().enumerate() {
        // The spline intervals meeting at grid point i: two at an inner knot.
        let (lo, hi) = match knot_of[i] {
            Some(kn) => (kn.saturating_sub(1), kn.min(last_interval)),
            None => (interval[i - 1], interval[i - 1]),
        };
        let mut bound = f64::INFINITY;
        for j in 0..n {
            let jet = sp.jet_in(hi, j, si);
            d1.push(jet.d1);
            d2.push(jet.d2);
            let v = limits.velocity[j] * scale;
            if jet.d1 != 0.0 {
                bound = bound.min((v / jet.d1).powi(2));
            }
        }
        let feed = [lo, hi]
            .into_iter()
            .filter_map(cap)
            .fold(f64::INFINITY, f64::min);
        if feed.is_finite() {
            let rate = tip_rate(piece, tips, si, hi, &mut buf);
            if rate > 0.0 {
                bound = bound.min((feed * scale / rate).powi(2));
            }
        }
        xmax.push(bound);
    }
    Grid {
        s,
        knot_index,
        d1,
        d2,
        xmax,
    }
}

/// The acceleration rows of grid point `i`, in the variables (x_i, u) of
/// the stage starting `delta` before it (0: the point's own stage).
fn push_acc_rows(g: &Grid, limits: &Limits, scale: f64, i: usize, delta: f64, rows: &mut Vec<Row>) {
    let n = limits.joints();
    for j in 0..n {
        let (a, b) = (g.d2[i * n + j], g.d1[i * n + j]);
        let c = limits.acceleration[j] * scale;
        // q'' x_i + q' u at point i, with x_i = x + 2 delta u.
        let bb = b + 2.0 * delta * a;
        rows.push(Row { a, b: bb, c });
        rows.push(Row { a: -a, b: -bb, c });
    }
}

fn stage_rows(g: &Grid, limits: &Limits, scale: f64, i: usize, k_next: f64, rows: &mut Vec<Row>) {
    rows.clear();
    let delta = g.s[i + 1] - g.s[i];
    push_acc_rows(g, limits, scale, i, 0.0, rows);
    push_acc_rows(g, limits, scale, i + 1, delta, rows);
    // 0 <= x + 2 delta u <= k_next.
    rows.push(Row {
        a: 1.0,
        b: 2.0 * delta,
        c: k_next,
    });
    rows.push(Row {
        a: -1.0,
        b: -2.0 * delta,
        c: 0.0,
    });
}

/// Times one piece; `t0` is the time at its first point. The constraints
/// hold at the grid points; where the motion between two of them breaks a
/// true limit (the margin did not cover how fast the path's derivatives
/// change there), that grid interval is split and the piece solved again.
pub(crate) fn time_piece(
    piece: &Piece,
    tips: &Tips,
    segments: &[Segment],
    limits: &Limits,
    options: &Options,
    t0: f64,
) -> Result<PieceProfile> {
    let mut layout = Layout::new(piece.joints.knots(), options.min_intervals);
    let mut rounds = 0;
    loop {
        let g = build_grid(piece, tips, segments, limits, options, &layout);
        let (x, u) = solve(&g, limits, 1.0 - options.margin);
        let bad = between_points(piece, tips, segments, limits, &layout, &x, &u);
        rounds += 1;
        if bad.is_empty() || rounds >= MAX_ROUNDS {
            return profile(piece, g, x, u, t0);
        }
        layout.split(&bad);
    }
}

/// Grid refinements per piece at most.
const MAX_ROUNDS: usize = 8;

/// Backward pass (controllable sets) and forward pass (largest u).
fn solve(g: &Grid, limits: &Limits, scale: f64) -> (Vec<f64>, Vec<f64>) {
    let m = g.s.len();
    let mut k = vec![0.0; m];
    let mut rows = Vec::with_capacity(4 * limits.joints() + 2);
    for i in (0..m - 1).rev() {
        stage_rows(g, limits, scale, i, k[i + 1], &mut rows);
        k[i] = x_interval(&rows, 0.0, g.xmax[i]).map_or(0.0, |(_, hi)| hi.max(0.0));
    }
    let mut x = vec![0.0; m];
    let mut u = vec![0.0; m - 1];
    for i in 0..m - 1 {
        stage_rows(g, limits, scale, i, k[i + 1], &mut rows);
        let delta = g.s[i + 1] - g.s[i];
        // x_i lies in K_i, so some u exists; on K_i's boundary rounding can
        // cross the bounds, and the middle of the crossed pair is the vertex.
        let (lo, hi) = u_range(&rows, x[i]);
        let u_best = if lo <= hi { hi } else { 0.5 * (lo + hi) };
        let next = x[i] + 2.0 * delta * u_best;
        x[i + 1] = next.clamp(0.0, k[i + 1]);
        u[i] = (x[i + 1] - x[i]) / (2.0 * delta);
    }
    (x, u)
}

/// Grid intervals inside which the planned motion (x linear in s, u
/// constant) breaks a true limit at its middle (the ends hold by
/// construction; the velocity and acceleration are smooth in between).
fn between_points(
    piece: &Piece,
    tips: &Tips,
    segments: &[Segment],
    limits: &Limits,
    layout: &Layout,
    x: &[f64],
    u: &[f64],
) -> Vec<usize> {
    let sp = &piece.joints;
    let n = sp.dim();
    let slack = 1.0 + 1e-9;
    let mut buf = vec![0.0; 2 * n];
    let mut over = |i: usize, w: f64| {
        let k = layout.interval[i];
        let s = layout.s[i] + w * (layout.s[i + 1] - layout.s[i]);
        let xs = (x[i] + 2.0 * u[i] * (s - layout.s[i])).max(0.0);
        let joint_over = (0..n).any(|j| {
            let jet = sp.jet_in(k, j, s);
            jet.d1.abs() * xs.sqrt() > limits.velocity[j] * slack
                || (jet.d2 * xs + jet.d1 * u[i]).abs() > limits.acceleration[j] * slack
        });
        joint_over
            || segments[piece.first + k]
                .tip_speed_cap
                .is_some_and(|cap| tip_rate(piece, tips, s, k, &mut buf) * xs.sqrt() > cap * slack)
    };
    (0..layout.s.len() - 1).filter(|&i| over(i, 0.5)).collect()
}

fn profile(piece: &Piece, g: Grid, x: Vec<f64>, u: Vec<f64>, t0: f64) -> Result<PieceProfile> {
    let m = g.s.len();
    let mut t = Vec::with_capacity(m);
    t.push(t0);
    for i in 0..m - 1 {
        let speed = x[i].sqrt() + x[i + 1].sqrt();
        if speed <= 0.0 {
            return Err(Error::infeasible(
                format!("positions[{}..={}]", piece.first, piece.last),
                format!(
                    "the path cannot move at s = {:.6} within the limits",
                    g.s[i]
                ),
            ));
        }
        t.push(t[i] + 2.0 * (g.s[i + 1] - g.s[i]) / speed);
    }
    Ok(PieceProfile {
        first: piece.first,
        last: piece.last,
        s: g.s,
        x,
        u,
        t,
        knot_index: g.knot_index,
    })
}
