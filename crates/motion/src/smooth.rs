//! Jerk limiting by a moving average of the path parameter in time (the FIR
//! feed-profile filter of CNC interpolators, docs/methods.md,
//! "Time-optimal path parameterisation").
//!
//! TOPP-RA's profile s*(t) switches s_ddot abruptly. Its moving average
//! s_f(t) = (1/tau) * integral of s* over [t - tau, t] stays on the same
//! geometric path (only the timing changes), lasts tau longer, and has
//! - s_f' = (s*(t) - s*(t - tau)) / tau: an average of s*', never faster than
//!   the fastest s*' in the window;
//! - s_f'' = (s*'(t) - s*'(t - tau)) / tau: an average of s*'', within its
//!   range, and continuous;
//! - s_f''' = (s*''(t) - s*''(t - tau)) / tau: bounded by the range of s*''
//!   over tau.
//!
//! So the joint jerk q''' s'^3 + 3 q'' s' s'' + q' s''' is bounded, and tau
//! is the time a joint needs to swing its acceleration through its range at
//! its jerk limit. The bounds hold up to the curvature terms, so the caller
//! verifies the sampled motion and stretches time where it must (jerk falls
//! with the cube of a time scaling).

use crate::topp::PieceProfile;

/// A piece's TOPP-RA profile filtered by a moving average of length `tau`.
#[derive(Clone, Debug, PartialEq)]
pub struct Filtered {
    pub base: PieceProfile,
    pub tau: f64,
    /// Integral of s* from the piece's start to each grid time.
    prefix: Vec<f64>,
}

impl Filtered {
    pub fn new(base: PieceProfile, tau: f64) -> Self {
        let m = base.s.len();
        let mut prefix = Vec::with_capacity(m);
        prefix.push(0.0);
        for i in 0..m - 1 {
            let h = base.t[i + 1] - base.t[i];
            let add = stage_integral(&base, i, h);
            prefix.push(prefix[i] + add);
        }
        Filtered { base, tau, prefix }
    }

    pub fn duration(&self) -> f64 {
        self.base.duration() + self.tau
    }

    /// s*, s*', s*'' at local time t (at rest outside the piece).
    fn base_state(&self, t: f64) -> (f64, f64, f64) {
        let b = &self.base;
        let (t0, t1) = (b.t[0], b.t[b.t.len() - 1]);
        if t <= t0 {
            (b.s[0], 0.0, 0.0)
        } else if t >= t1 {
            (b.s[b.s.len() - 1], 0.0, 0.0)
        } else {
            b.state(t)
        }
    }

    /// Integral of s* from the piece's start to local time t.
    fn integral(&self, t: f64) -> f64 {
        let b = &self.base;
        let m = b.t.len();
        let (t0, t1) = (b.t[0], b.t[m - 1]);
        if t <= t0 {
            return b.s[0] * (t - t0);
        }
        if t >= t1 {
            return self.prefix[m - 1] + b.s[m - 1] * (t - t1);
        }
        let i = b.t.partition_point(|&x| x <= t).clamp(1, m - 1) - 1;
        self.prefix[i] + stage_integral(b, i, t - b.t[i])
    }

    /// (s, s', s'', s''') at local time t in [t0, t0 + duration].
    pub fn state(&self, t: f64) -> (f64, f64, f64, f64) {
        let tau = self.tau;
        let s = (self.integral(t) - self.integral(t - tau)) / tau;
        let (sa, va, aa) = self.base_state(t);
        let (sb, vb, ab) = self.base_state(t - tau);
        let s_min = self.base.s[0];
        let s_max = self.base.s[self.base.s.len() - 1];
        (
            s.clamp(s_min, s_max),
            ((sa - sb) / tau).max(0.0),
            (va - vb) / tau,
            (aa - ab) / tau,
        )
    }

    /// Times where the filtered profile's polynomial pieces change.
    pub fn knot_times(&self) -> Vec<f64> {
        let b = &self.base;
        let mut t: Vec<f64> = b.t.to_vec();
        t.extend(b.t.iter().map(|x| x + self.tau));
        t.sort_by(f64::total_cmp);
        t.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * b.abs().max(1.0));
        t
    }
}

/// Integral of s* over the first `h` seconds of stage i.
fn stage_integral(b: &PieceProfile, i: usize, h: f64) -> f64 {
    let v0 = b.x[i].sqrt();
    b.s[i] * h + 0.5 * v0 * h * h + b.u[i] * h * h * h / 6.0
}
