//! The motion ros2_control's joint_trajectory_controller (JTC) interpolates
//! between trajectory points, joint by joint (its `interpolate_between_points`):
//! - positions only: linear, velocity constant, acceleration 0;
//! - positions and velocities: the cubic Hermite of both ends;
//! - positions, velocities and accelerations: the quintic Hermite of both ends.
//!
//! Before the first point it interpolates from the state the machine was in
//! (at rest here), after the last it holds the last point.

use crate::error::{check_finite, Error, Result};

/// A trajectory as sent to the controller, times from its start (s).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trajectory {
    pub times: Vec<f64>,
    pub positions: Vec<Vec<f64>>,
    /// Empty (linear interpolation) or one row per point.
    pub velocities: Vec<Vec<f64>>,
    /// Empty (cubic) or one row per point (quintic).
    pub accelerations: Vec<Vec<f64>>,
    /// The path parameter of each point (not sent; for locating samples).
    pub s: Vec<f64>,
    /// The path segment each point starts (not sent): the segment of the
    /// interval from this point to the next.
    pub segment: Vec<usize>,
}

/// What JTC interpolates with, from what the points carry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    Linear,
    Cubic,
    Quintic,
}

/// One joint's state: position, velocity, acceleration, jerk.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct JointState {
    pub q: f64,
    pub v: f64,
    pub a: f64,
    pub j: f64,
}

impl Trajectory {
    pub fn len(&self) -> usize {
        self.times.len()
    }

    pub fn is_empty(&self) -> bool {
        self.times.is_empty()
    }

    pub fn duration(&self) -> f64 {
        self.times.last().copied().unwrap_or(0.0)
    }

    pub fn joints(&self) -> usize {
        self.positions.first().map_or(0, |r| r.len())
    }

    pub fn interpolation(&self) -> Interpolation {
        match (self.velocities.is_empty(), self.accelerations.is_empty()) {
            (true, _) => Interpolation::Linear,
            (false, true) => Interpolation::Cubic,
            (false, false) => Interpolation::Quintic,
        }
    }

    /// The rules the sampler relies on: rows of one length, finite values,
    /// times strictly increasing, velocities present when accelerations are
    /// (JTC interpolates nothing from accelerations alone).
    pub fn check(&self) -> Result<()> {
        let n = self.times.len();
        if n == 0 {
            return Err(Error::invalid("trajectory", "has no points"));
        }
        let dim = self.joints();
        let lists = [
            ("positions", &self.positions, false),
            ("velocities", &self.velocities, true),
            ("accelerations", &self.accelerations, true),
        ];
        for (what, rows, optional) in lists {
            if optional && rows.is_empty() {
                continue;
            }
            if rows.len() != n {
                return Err(Error::invalid(
                    what,
                    format!("has {} rows for {n} points", rows.len()),
                ));
            }
            for (k, r) in rows.iter().enumerate() {
                if r.len() != dim {
                    return Err(Error::invalid(
                        format!("{what}[{k}]"),
                        format!("has {} values for {dim} joints", r.len()),
                    ));
                }
                check_finite(&format!("{what}[{k}]"), r)?;
            }
        }
        if self.velocities.is_empty() && !self.accelerations.is_empty() {
            return Err(Error::invalid(
                "accelerations",
                "are given without velocities: JTC would not interpolate them",
            ));
        }
        check_finite("times", &self.times)?;
        for k in 1..n {
            if self.times[k] <= self.times[k - 1] {
                return Err(Error::invalid(
                    format!("times[{k}]"),
                    format!(
                        "{} s does not come after {} s",
                        self.times[k],
                        self.times[k - 1]
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Index k of the interval [times[k], times[k + 1]) holding `t`
    /// (clamped to the first and last).
    pub fn interval(&self, t: f64) -> usize {
        let n = self.times.len();
        if n < 2 {
            return 0;
        }
        self.times.partition_point(|&x| x <= t).clamp(1, n - 1) - 1
    }

    /// Joint `j` at time `t` inside interval `k`, as JTC interpolates it.
    pub fn joint_at(&self, k: usize, j: usize, t: f64) -> JointState {
        let (t0, t1) = (self.times[k], self.times[k + 1]);
        let h = t1 - t0;
        let tau = (t - t0).clamp(0.0, h);
        let (p0, p1) = (self.positions[k][j], self.positions[k + 1][j]);
        match self.interpolation() {
            Interpolation::Linear => linear(p0, p1, h, tau),
            Interpolation::Cubic => {
                let (v0, v1) = (self.velocities[k][j], self.velocities[k + 1][j]);
                cubic(p0, v0, p1, v1, h, tau)
            }
            Interpolation::Quintic => {
                let (v0, v1) = (self.velocities[k][j], self.velocities[k + 1][j]);
                let (a0, a1) = (self.accelerations[k][j], self.accelerations[k + 1][j]);
                quintic([p0, v0, a0], [p1, v1, a1], h, tau)
            }
        }
    }

    /// Every joint at time `t` (held at the ends).
    pub fn sample(&self, t: f64) -> Vec<JointState> {
        let n = self.times.len();
        if n == 0 {
            return Vec::new();
        }
        if n < 2 || t >= self.times[n - 1] {
            // JTC holds the last point once the trajectory has played out.
            let pick = |rows: &[Vec<f64>], j: usize| rows.get(n - 1).map_or(0.0, |r| r[j]);
            return (0..self.joints())
                .map(|j| JointState {
                    q: self.positions[n - 1][j],
                    v: pick(&self.velocities, j),
                    a: pick(&self.accelerations, j),
                    j: 0.0,
                })
                .collect();
        }
        let k = self.interval(t);
        (0..self.joints()).map(|j| self.joint_at(k, j, t)).collect()
    }

    /// Samples every `period` s from 0 to the end (the end included), as a
    /// controller running at 1 / `period` Hz sees the trajectory.
    pub fn samples(&self, period: f64) -> impl Iterator<Item = (f64, Vec<JointState>)> + '_ {
        let end = self.duration();
        let count = (end / period).floor() as usize;
        (0..=count)
            .map(move |i| i as f64 * period)
            .chain((end > count as f64 * period).then_some(end))
            .map(move |t| (t, self.sample(t)))
    }
}

fn linear(p0: f64, p1: f64, h: f64, tau: f64) -> JointState {
    let v = if h != 0.0 { (p1 - p0) / h } else { 0.0 };
    JointState {
        q: p0 + v * tau,
        v,
        a: 0.0,
        j: 0.0,
    }
}

/// JTC's cubic: c0 + c1 t + c2 t^2 + c3 t^3 through (p0, v0) and (p1, v1).
pub fn cubic(p0: f64, v0: f64, p1: f64, v1: f64, h: f64, t: f64) -> JointState {
    let c2 = (-3.0 * p0 + 3.0 * p1 - 2.0 * v0 * h - v1 * h) / (h * h);
    let c3 = (2.0 * p0 - 2.0 * p1 + v0 * h + v1 * h) / (h * h * h);
    JointState {
        q: p0 + t * (v0 + t * (c2 + t * c3)),
        v: v0 + t * (2.0 * c2 + 3.0 * c3 * t),
        a: 2.0 * c2 + 6.0 * c3 * t,
        j: 6.0 * c3,
    }
}

/// JTC's quintic through (p, v, a) at both ends.
pub fn quintic(s0: [f64; 3], s1: [f64; 3], h: f64, t: f64) -> JointState {
    let ([p0, v0, a0], [p1, v1, a1]) = (s0, s1);
    let (h2, h3) = (h * h, h * h * h);
    let c2 = 0.5 * a0;
    let c3 = (-20.0 * p0 + 20.0 * p1 - 3.0 * a0 * h2 + a1 * h2 - 12.0 * v0 * h - 8.0 * v1 * h)
        / (2.0 * h3);
    let c4 =
        (30.0 * p0 - 30.0 * p1 + 3.0 * a0 * h2 - 2.0 * a1 * h2 + 16.0 * v0 * h + 14.0 * v1 * h)
            / (2.0 * h3 * h);
    let c5 = (-12.0 * p0 + 12.0 * p1 - a0 * h2 + a1 * h2 - 6.0 * v0 * h - 6.0 * v1 * h)
        / (2.0 * h3 * h2);
    JointState {
        q: p0 + t * (v0 + t * (c2 + t * (c3 + t * (c4 + t * c5)))),
        v: v0 + t * (2.0 * c2 + t * (3.0 * c3 + t * (4.0 * c4 + t * 5.0 * c5))),
        a: 2.0 * c2 + t * (6.0 * c3 + t * (12.0 * c4 + t * 20.0 * c5)),
        j: 6.0 * c3 + t * (24.0 * c4 + t * 60.0 * c5),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hermite_ends_match_their_data() {
        let h = 0.37;
        let c0 = cubic(1.0, -2.0, 3.0, 0.5, h, 0.0);
        let c1 = cubic(1.0, -2.0, 3.0, 0.5, h, h);
        assert!((c0.q - 1.0).abs() < 1e-12 && (c0.v + 2.0).abs() < 1e-12);
        assert!((c1.q - 3.0).abs() < 1e-12 && (c1.v - 0.5).abs() < 1e-12);
        let q0 = quintic([1.0, -2.0, 4.0], [3.0, 0.5, -1.0], h, 0.0);
        let q1 = quintic([1.0, -2.0, 4.0], [3.0, 0.5, -1.0], h, h);
        assert!((q0.a - 4.0).abs() < 1e-9 && (q1.a + 1.0).abs() < 1e-9);
        assert!((q1.q - 3.0).abs() < 1e-12 && (q1.v - 0.5).abs() < 1e-9);
    }

    /// Derivatives agree with central differences of the position.
    #[test]
    fn derivatives_are_those_of_the_position() {
        let h = 0.8;
        let f = |t: f64| quintic([0.2, 1.0, -3.0], [1.5, -0.4, 2.0], h, t);
        let e = 1e-5;
        for i in 1..10 {
            let t = h * i as f64 / 10.0;
            let fd_v = (f(t + e).q - f(t - e).q) / (2.0 * e);
            let fd_a = (f(t + e).v - f(t - e).v) / (2.0 * e);
            let fd_j = (f(t + e).a - f(t - e).a) / (2.0 * e);
            assert!((fd_v - f(t).v).abs() < 1e-6);
            assert!((fd_a - f(t).a).abs() < 1e-5);
            assert!((fd_j - f(t).j).abs() < 1e-4);
        }
    }

    #[test]
    fn sampling_covers_the_end_and_holds_it() {
        let tr = Trajectory {
            times: vec![0.0, 0.0105],
            positions: vec![vec![0.0], vec![1.0]],
            ..Default::default()
        };
        let ts: Vec<f64> = tr.samples(1e-3).map(|(t, _)| t).collect();
        assert_eq!(ts.len(), 12);
        assert_eq!(*ts.last().unwrap(), 0.0105);
        assert_eq!(tr.sample(5.0)[0].q, 1.0);
    }
}
