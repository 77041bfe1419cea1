//! One configuration per pass on a 6-axis machine with a closed form, and
//! the free rotation about the tool axis of 5-axis poses chosen over the
//! whole pass (docs/methods.md, "Machine kinematics from URDF").
//!
//! Dynamic programming over the points of the pass and a grid of angles
//! about the tool axis (one angle for full frames): a state is (angle,
//! configuration), feasible when its joints fit the limits and its
//! conditioning is above `singular_min`; it costs its penalty near limits
//! and singularities; a step to the next point keeps the configuration,
//! changes the angle by at most `max_psi_step` and every joint by at most the
//! step limits, and costs the squared joint steps. The cheapest path over all
//! configurations wins; its angles are then smoothed within one grid step
//! (where the smoothed pose stays feasible) and solved exactly.

use crate::angles::{unwrap_near, TURN};
use crate::error::{At, Error, Result};
use crate::machine::Machine;
use crate::pose::{reference_frames, Target};
use crate::solve::{turned, Candidate};
use nalgebra::{Isometry3, UnitQuaternion};

/// Weight of the squared change of the angle about the tool axis (per rad^2)
/// against the squared joint steps: a tie-breaker that keeps the angle still.
const PSI_WEIGHT: f64 = 0.01;
/// Weight of the squared distance of the first point from the start joints.
const START_WEIGHT: f64 = 0.01;
/// Linear joint steps count as rotary ones of this many mm per rad.
const MM_PER_RAD: f64 = 100.0;
/// Branch labels are below this (three bits: shoulder, elbow, wrist).
const CONFIGS: usize = 8;

/// How a joint's step is measured: (modulo a turn, scale, largest step).
type StepKind = (bool, f64, f64);

/// Squared joint step (linear scaled), or `None` over a step limit.
fn step_cost(kinds: &[StepKind], a: &[f64], b: &[f64]) -> Option<f64> {
    let mut c = 0.0;
    for (j, &(wraps, scale, max)) in kinds.iter().enumerate() {
        let raw = b[j] - a[j];
        let d = if wraps { crate::angles::wrap(raw) } else { raw } / scale;
        if d.abs() > max {
            return None;
        }
        c += d * d;
    }
    Some(c)
}

/// The poses of a pass as frames at grid angle `k`.
struct Frames {
    tips: Vec<nalgebra::Point3<f64>>,
    refs: Vec<UnitQuaternion<f64>>,
    /// `None`: full frames, one "angle".
    fixed: Option<Vec<Isometry3<f64>>>,
    n_psi: usize,
}

impl Frames {
    fn new(m: &Machine, targets: &[Target]) -> Self {
        if let Some(Target::Frame(_)) = targets.first() {
            let f = targets
                .iter()
                .map(|t| match t {
                    Target::Frame(x) => *x,
                    Target::Axis { .. } => unreachable!("passes are checked to hold one kind"),
                })
                .collect();
            return Self {
                tips: Vec::new(),
                refs: Vec::new(),
                fixed: Some(f),
                n_psi: 1,
            };
        }
        let axes: Vec<_> = targets.iter().map(|t| t.tool_axis()).collect();
        Self {
            tips: targets.iter().map(Target::tip).collect(),
            refs: reference_frames(&axes),
            fixed: None,
            n_psi: m.options.psi_samples.max(1),
        }
    }
    fn psi(&self, k: f64) -> f64 {
        if self.fixed.is_some() {
            0.0
        } else {
            -std::f64::consts::PI + TURN * k / self.n_psi as f64
        }
    }
    fn at(&self, i: usize, psi: f64) -> Isometry3<f64> {
        match &self.fixed {
            Some(f) => f[i],
            None => turned(&self.tips[i], &self.refs[i], psi),
        }
    }
    fn target(&self, i: usize, psi: f64) -> Target {
        Target::Frame(self.at(i, psi))
    }
}

/// A feasible state of one point.
struct State {
    k: usize,
    config: u8,
    q: Vec<f64>,
    penalty: f64,
}

/// Why the states of a point were dropped (the first of each kind).
#[derive(Default)]
struct Dropped {
    unreachable: Option<String>,
    limit: Option<(usize, f64)>,
    singular: Option<(f64, &'static str)>,
}

impl Machine {
    fn states(&self, frames: &Frames, i: usize, zero: &[f64], why: &mut Dropped) -> Vec<State> {
        let mut out = Vec::new();
        for k in 0..frames.n_psi {
            let x = frames.at(i, frames.psi(k as f64));
            let list = match self.frame_candidates(&x, zero) {
                Ok(l) => l,
                Err(w) => {
                    why.unreachable.get_or_insert(w);
                    continue;
                }
            };
            for Candidate {
                mut q,
                config,
                conditioning,
                weakest,
            } in list
            {
                if let Err(j) = self.fit(&mut q, None) {
                    why.limit.get_or_insert((j, q[j]));
                    continue;
                }
                if conditioning < self.options.singular_min {
                    why.singular.get_or_insert((conditioning, weakest));
                    continue;
                }
                let penalty = self.penalty(&q, conditioning);
                out.push(State {
                    k,
                    config,
                    q,
                    penalty,
                });
            }
        }
        out
    }

    /// Squared distance between two joint vectors (linear scaled).
    fn distance2(&self, a: &[f64], b: &[f64]) -> f64 {
        (0..a.len())
            .map(|j| {
                let d = if self.kinds[j].is_rotary() {
                    self.joint_delta(j, a[j], b[j])
                } else {
                    (b[j] - a[j]) / MM_PER_RAD
                };
                d * d
            })
            .sum()
    }

    fn dropped_error(&self, at: At, why: Dropped) -> Error {
        if let Some((c, what)) = why.singular {
            return Error::Singular {
                at: Some(at),
                why: format!("every solution that fits the limits is at the {what} singularity or within the margin (conditioning {c:.3} < {:.3})", self.options.singular_min),
            };
        }
        if let Some((j, v)) = why.limit {
            return self.limit_error(j, v).placed(at);
        }
        Error::Unreachable {
            at: Some(at),
            why: why.unreachable.unwrap_or_else(|| "no solution".into()),
        }
    }

    /// The dynamic programme: the configuration and grid angle of every point.
    fn best_path(
        &self,
        pass: usize,
        frames: &Frames,
        n: usize,
        start: Option<&[f64]>,
    ) -> Result<(u8, Vec<usize>)> {
        let zero = vec![0.0; self.dof()];
        let dk = (frames.n_psi as f64 * self.options.max_psi_step / TURN).floor() as i64;
        let kinds: Vec<StepKind> = (0..self.dof())
            .map(|j| {
                if self.kinds[j].is_rotary() {
                    (self.wraps(j), 1.0, self.options.max_rotary_step)
                } else {
                    (false, MM_PER_RAD, self.options.max_linear_step / MM_PER_RAD)
                }
            })
            .collect();
        let mut layers: Vec<Vec<(usize, u8)>> = Vec::with_capacity(n);
        let mut back: Vec<Vec<usize>> = Vec::with_capacity(n);
        let mut prev: Vec<State> = Vec::new();
        let mut cost: Vec<f64> = Vec::new();
        for i in 0..n {
            let at = At { pass, point: i };
            let mut why = Dropped::default();
            let cur = self.states(frames, i, &zero, &mut why);
            if cur.is_empty() {
                return Err(self.dropped_error(at, why));
            }
            let mut c2 = vec![f64::INFINITY; cur.len()];
            let mut b2 = vec![usize::MAX; cur.len()];
            let mut smallest_jump: Option<(f64, usize, usize)> = None;
            // The previous point's states by (configuration, grid angle).
            let mut index = vec![usize::MAX; CONFIGS * frames.n_psi];
            for (p, st) in prev.iter().enumerate() {
                index[usize::from(st.config) * frames.n_psi + st.k] = p;
            }
            for (s, st) in cur.iter().enumerate() {
                if i == 0 {
                    c2[s] = st.penalty
                        + START_WEIGHT * start.map_or(0.0, |q0| self.distance2(q0, &st.q));
                    continue;
                }
                let n_psi = frames.n_psi as i64;
                for d in -dk.min(n_psi / 2)..=dk.min((n_psi - 1) / 2) {
                    let k = (st.k as i64 + d).rem_euclid(n_psi) as usize;
                    let p = index[usize::from(st.config) * frames.n_psi + k];
                    if p == usize::MAX || !cost[p].is_finite() {
                        continue;
                    }
                    match step_cost(&kinds, &prev[p].q, &st.q) {
                        Some(sc) => {
                            let dp = frames.psi(d.unsigned_abs() as f64) - frames.psi(0.0);
                            let total = cost[p] + sc + PSI_WEIGHT * dp * dp + st.penalty;
                            if total < c2[s] {
                                (c2[s], b2[s]) = (total, p);
                            }
                        }
                        None => {
                            smallest_jump.get_or_insert((0.0, p, s));
                        }
                    }
                }
            }
            if c2.iter().all(|c| !c.is_finite()) {
                return Err(self.jump_error(at, &prev, &cur, smallest_jump));
            }
            layers.push(cur.iter().map(|s| (s.k, s.config)).collect());
            back.push(b2);
            prev = cur;
            cost = c2;
        }
        let (mut s, _) = cost
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(b.1))
            .expect("a non-empty last layer");
        let config = layers[n - 1][s].1;
        let mut ks = vec![0; n];
        for i in (0..n).rev() {
            ks[i] = layers[i][s].0;
            if i > 0 {
                s = back[i][s];
            }
        }
        Ok((config, ks))
    }

    /// The error when no state of a point can be reached from the last:
    /// the largest step of the first blocked pair, by joint.
    fn jump_error(
        &self,
        at: At,
        prev: &[State],
        cur: &[State],
        first: Option<(f64, usize, usize)>,
    ) -> Error {
        let Some((_, p, s)) = first else {
            return Error::Unreachable {
                at: Some(at),
                why: "no solution keeps the previous point's configuration".into(),
            };
        };
        match self.check_step(at, &prev[p].q, &cur[s].q) {
            Err(e) => e,
            Ok(()) => Error::Unreachable {
                at: Some(at),
                why: format!(
                    "the rotation about the tool axis would have to change by more than {:.1} deg",
                    self.options.max_psi_step.to_degrees()
                ),
            },
        }
    }

    /// The exact joints of configuration `config` at angle `psi` of point
    /// `i`, inside the limits (rotary joints of a travel of a turn or more
    /// unwrapped next to `reference`).
    fn joints_at(
        &self,
        frames: &Frames,
        i: usize,
        psi: f64,
        config: u8,
        hold: &[f64],
        reference: Option<&[f64]>,
    ) -> Option<Vec<f64>> {
        let x = frames.at(i, psi);
        let c = self
            .frame_candidates(&x, hold)
            .ok()?
            .into_iter()
            .find(|c| c.config == config)?;
        if c.conditioning < self.options.singular_min {
            return None;
        }
        let mut q = self.finish(c, &frames.target(i, psi))?.q;
        self.fit(&mut q, None).ok()?;
        if let Some(r) = reference {
            for j in 0..self.dof() {
                if self.wraps(j) {
                    q[j] = unwrap_near(q[j], r[j]);
                }
            }
        }
        Some(q)
    }

    /// A pass on a 6-axis machine with a closed form: one configuration,
    /// the free angle chosen over the pass, rotaries unwrapped and fitted.
    pub(crate) fn configured_pass(
        &self,
        pass: usize,
        targets: &[Target],
        start: Option<&[f64]>,
    ) -> Result<Vec<Vec<f64>>> {
        let n = targets.len();
        if n == 0 {
            return Ok(Vec::new());
        }
        let frames = Frames::new(self, targets);
        let (config, ks) = self.best_path(pass, &frames, n, start)?;
        // The grid angles, continuous along the pass, smoothed within one grid step.
        let step = TURN / frames.n_psi as f64;
        let mut grid: Vec<f64> = Vec::with_capacity(n);
        for &k in &ks {
            let p = frames.psi(k as f64);
            grid.push(grid.last().map_or(p, |&l| unwrap_near(p, l)));
        }
        let psi = if frames.fixed.is_some() {
            grid.clone()
        } else {
            smooth(&grid, step)
        };
        let zero = vec![0.0; self.dof()];
        let mut rows: Vec<Vec<f64>> = Vec::with_capacity(n);
        for i in 0..n {
            let at = At { pass, point: i };
            let hold = rows.last().map_or(zero.as_slice(), |r| r.as_slice());
            let reference = rows.last().map(|r| r.as_slice()).or(start);
            let q = self
                .joints_at(&frames, i, psi[i], config, hold, reference)
                .or_else(|| self.joints_at(&frames, i, grid[i], config, hold, reference))
                .ok_or_else(|| Error::Unreachable {
                    at: Some(at),
                    why: "the chosen configuration's solution does not reproduce the pose within tolerance".into(),
                })?;
            if let Some(r) = rows.last() {
                self.check_step(at, r, &q)?;
            }
            rows.push(q);
        }
        self.fit_pass(pass, &mut rows)?;
        Ok(rows)
    }
}

/// Laplacian smoothing of the angles, each kept within `step` of its grid value.
fn smooth(grid: &[f64], step: f64) -> Vec<f64> {
    let n = grid.len();
    let mut psi = grid.to_vec();
    if n < 3 {
        return psi;
    }
    for _ in 0..50 {
        let old = psi.clone();
        for i in 0..n {
            let avg = match i {
                0 => old[1],
                _ if i == n - 1 => old[n - 2],
                _ => 0.5 * (old[i - 1] + old[i + 1]),
            };
            let v = old[i] + 0.5 * (avg - old[i]);
            psi[i] = v.clamp(grid[i] - step, grid[i] + step);
        }
    }
    psi
}
