//! Passes of poses -> joint vectors that a machine can follow.
//!
//! - Three linear + two/three rotary axes: each pose takes the solution
//!   nearest the previous one (rotaries unwrapped next to it; solutions
//!   within the limits first); on the rotaries' free angle (the tool axis on
//!   the first rotary axis, or gimbal lock) the held joint keeps its value,
//!   and a pass that starts there takes the turn of its first pose that is
//!   not. Each pass is then shifted by whole turns into the travel, or
//!   retracked on the other branch when no shift fits.
//! - 6-axis machines with a closed form: one configuration for the whole
//!   pass, and for 5-axis poses the rotation about the tool axis chosen over
//!   the pass (see `free_angle`).
//! - Otherwise: the numerical solver, each pose started from the last.

use crate::angles::{representative_in, turn_shift, unwrap_near, wrap};
use crate::error::{At, Error, Result};
use crate::machine::Machine;
use crate::numeric;
use crate::pose::Target;
use crate::solve::{Candidate, Solver};

impl Machine {
    /// The joint vectors of one pass (`pass` is the caller's index, for
    /// messages); `start` = the joints before it (previous pass or state).
    pub fn solve_pass(
        &self,
        pass: usize,
        targets: &[Target],
        start: Option<&[f64]>,
    ) -> Result<Vec<Vec<f64>>> {
        let mut all = self.solve_passes_at(pass, std::slice::from_ref(&targets.to_vec()), start)?;
        Ok(all.pop().unwrap_or_default())
    }

    /// The joint vectors of consecutive passes, each continuing from the
    /// last (a job); `start` = the joints before the first.
    pub fn solve_passes(
        &self,
        passes: &[Vec<Target>],
        start: Option<&[f64]>,
    ) -> Result<Vec<Vec<Vec<f64>>>> {
        self.solve_passes_at(0, passes, start)
    }

    fn solve_passes_at(
        &self,
        first: usize,
        passes: &[Vec<Target>],
        start: Option<&[f64]>,
    ) -> Result<Vec<Vec<Vec<f64>>>> {
        if let Some(s) = start {
            self.check_joints(s)?;
        }
        for (p, pass) in passes.iter().enumerate() {
            if pass.iter().any(|t| t.is_frame() != pass[0].is_frame()) {
                return Err(Error::Input(format!(
                    "pass {} mixes 5-axis poses and full frames; give one kind per pass",
                    first + p
                )));
            }
        }
        if let Solver::Cartesian(c) = &self.solver {
            if c.rotary.len() == 2 || passes.iter().flatten().all(Target::is_frame) {
                return self.tracked_passes(first, passes, start);
            }
        }
        let mut out: Vec<Vec<Vec<f64>>> = Vec::with_capacity(passes.len());
        let mut prev: Option<Vec<f64>> = start.map(<[f64]>::to_vec);
        for (p, pass) in passes.iter().enumerate() {
            let at = first + p;
            let rows = match &self.solver {
                Solver::Numeric => self.numeric_pass(at, pass, prev.as_deref())?,
                _ => self.configured_pass(at, pass, prev.as_deref())?,
            };
            if let Some(last) = rows.last() {
                prev = Some(last.clone());
            }
            out.push(rows);
        }
        Ok(out)
    }

    /// The closed form's candidates of a pose on a Cartesian machine.
    fn cartesian_candidates(
        &self,
        t: &Target,
        hold: &[f64],
    ) -> std::result::Result<Vec<Candidate>, String> {
        let Solver::Cartesian(c) = &self.solver else {
            unreachable!("cartesian_candidates on a machine without the Cartesian solver")
        };
        match (t, c.rotary.len()) {
            (Target::Axis { tip, axis }, 2) => c.axis_candidates(self, tip, axis, hold),
            (Target::Frame(x), 3) => c.frame_candidates(self, x, hold),
            _ => Err(format!(
                "a machine with {} rotary axes takes {}",
                c.rotary.len(),
                if c.rotary.len() == 2 {
                    "5-axis poses (tip and tool axis), not full frames"
                } else {
                    "full frames here"
                }
            )),
        }
    }

    /// The rotaries' values a path that starts on the free angle keeps: the
    /// first rotary of the first pose that has two solutions.
    fn turn_hint(&self, passes: &[Vec<Target>]) -> Vec<f64> {
        let zero = vec![0.0; self.dof()];
        for t in passes.iter().flatten() {
            if let Ok(c) = self.cartesian_candidates(t, &zero) {
                if c.len() > 1 {
                    return self.first_rule(c, &zero).q;
                }
            }
        }
        zero
    }

    /// Unwraps a candidate's rotaries next to `hold` (inside the travel when
    /// a representative is); whether its joints that cannot be shifted by
    /// whole turns (linear ones, rotaries of a turn or less) are within limits.
    fn unwrap_candidate(&self, c: &mut Candidate, hold: &[f64]) -> bool {
        let mut inside = true;
        for (j, h) in hold.iter().enumerate().take(self.dof()) {
            let l = &self.limits[j];
            if self.wraps(j) {
                c.q[j] = unwrap_near(c.q[j], *h);
                continue;
            }
            if self.kinds[j].is_rotary() {
                // Out of the travel whatever the turn: left as solved, in (-pi, pi].
                c.q[j] =
                    representative_in(c.q[j], l.lower, l.upper, *h).unwrap_or_else(|| wrap(c.q[j]));
            }
            inside &= l.contains(c.q[j], 1e-9);
        }
        inside
    }

    /// Of two solutions, the one whose second rotary is nearest to zero
    /// (ties: the non-negative one), solutions inside the limits first.
    fn first_rule(&self, mut c: Vec<Candidate>, hold: &[f64]) -> Candidate {
        let Solver::Cartesian(s) = &self.solver else {
            unreachable!()
        };
        let second = s.rotary[1];
        let inside: Vec<bool> = c
            .iter_mut()
            .map(|x| self.unwrap_candidate(x, hold))
            .collect();
        let key = |x: &Candidate| wrap(x.q[second]).abs();
        let mut best = 0;
        for k in 1..c.len() {
            let better = match (inside[k], inside[best]) {
                (true, false) => true,
                (false, true) => false,
                _ => {
                    let (a, b) = (key(&c[k]), key(&c[best]));
                    a < b - 1e-12
                        || ((a - b).abs() <= 1e-12
                            && wrap(c[k].q[second]) >= 0.0
                            && wrap(c[best].q[second]) < 0.0)
                }
            };
            if better {
                best = k;
            }
        }
        c.swap_remove(best)
    }

    /// Of the candidates, the one nearest to `hold` in the rotaries (sum of
    /// absolute differences); on a three-rotary machine solutions inside the
    /// limits first (a two-rotary machine changes branch only for a whole pass).
    fn nearest(&self, mut c: Vec<Candidate>, hold: &[f64]) -> Candidate {
        let two = c_two_rotaries(self);
        let inside: Vec<bool> = c
            .iter_mut()
            .map(|x| self.unwrap_candidate(x, hold) || two)
            .collect();
        let d = |x: &Candidate| -> f64 {
            (0..self.dof())
                .filter(|&j| self.kinds[j].is_rotary())
                .map(|j| (x.q[j] - hold[j]).abs())
                .sum()
        };
        let mut best = 0;
        for k in 1..c.len() {
            let better = match (inside[k], inside[best]) {
                (true, false) => true,
                (false, true) => false,
                _ => d(&c[k]) < d(&c[best]),
            };
            if better {
                best = k;
            }
        }
        c.swap_remove(best)
    }

    /// One pass tracked from `hold`: each pose's solution nearest the last
    /// (the first by `first_rule` when `rule` is set).
    fn track(
        &self,
        pass: usize,
        targets: &[Target],
        hold: &[f64],
        rule: bool,
    ) -> Result<Vec<Vec<f64>>> {
        let mut rows: Vec<Vec<f64>> = Vec::with_capacity(targets.len());
        for (k, t) in targets.iter().enumerate() {
            let at = At { pass, point: k };
            let h = rows.last().map_or(hold, |r| r.as_slice());
            let cands = self
                .cartesian_candidates(t, h)
                .map_err(|why| Error::Unreachable { at: Some(at), why })?;
            let cands: Vec<Candidate> = cands
                .into_iter()
                .filter_map(|c| self.finish(c, t))
                .collect();
            if cands.is_empty() {
                return Err(Error::Unreachable {
                    at: Some(at),
                    why: "the closed-form solutions do not reproduce the pose within tolerance"
                        .into(),
                });
            }
            let c = if rule && rows.is_empty() && cands.len() > 1 {
                self.first_rule(cands, h)
            } else {
                self.nearest(cands, h)
            };
            rows.push(c.q);
        }
        Ok(rows)
    }

    /// Cartesian machines: all passes tracked continuously, then each pass
    /// fitted into the travel (or retracked on the other branch).
    fn tracked_passes(
        &self,
        first: usize,
        passes: &[Vec<Target>],
        start: Option<&[f64]>,
    ) -> Result<Vec<Vec<Vec<f64>>>> {
        let hint = self.turn_hint(passes);
        let mut out = Vec::with_capacity(passes.len());
        let mut last: Option<Vec<f64>> = start.map(<[f64]>::to_vec);
        for (p, pass) in passes.iter().enumerate() {
            let at = first + p;
            let hold = last.clone().unwrap_or_else(|| hint.clone());
            let mut rows = self.track(at, pass, &hold, last.is_none())?;
            let raw_last = rows.last().cloned();
            if let Err(e) = self.fit_pass(at, &mut rows) {
                rows = self.fit_other_branch(at, pass, &rows).ok_or(e)??;
            }
            if raw_last.is_some() {
                last = raw_last;
            }
            out.push(rows);
        }
        Ok(out)
    }

    /// A pass that does not fit on its branch, on the other one (two-rotary
    /// machines only): `Some(Ok)` if it fits there; `Some(Err)` with the
    /// other branch's reason when only there the turn axis fits its travel;
    /// `None` to keep the first branch's reason.
    fn fit_other_branch(
        &self,
        pass: usize,
        targets: &[Target],
        rows: &[Vec<f64>],
    ) -> Option<Result<Vec<Vec<f64>>>> {
        if !c_two_rotaries(self) {
            return None;
        }
        let mut flipped = self.flipped(targets, rows)?;
        let turns = self.turns_fit(&flipped) && !self.turns_fit(rows);
        match self.fit_pass(pass, &mut flipped) {
            Ok(()) => Some(Ok(flipped)),
            Err(e) if turns => Some(Err(e)),
            Err(_) => None,
        }
    }

    /// Whether every rotary joint of more than a turn fits its travel by a
    /// whole-turn shift over the pass.
    fn turns_fit(&self, rows: &[Vec<f64>]) -> bool {
        (0..self.dof())
            .filter(|&j| self.wraps(j) && self.limits[j].travel().is_finite())
            .all(|j| {
                let l = self.limits[j];
                turn_shift(rows.iter().map(|r| r[j]), l.lower, l.upper).is_some()
            })
    }

    /// The finished candidates of pose `t`, unwrapped next to `hold`.
    fn finished(&self, t: &Target, hold: &[f64]) -> Vec<Candidate> {
        let Ok(cands) = self.cartesian_candidates(t, hold) else {
            return Vec::new();
        };
        let mut out: Vec<Candidate> = cands
            .into_iter()
            .filter_map(|c| self.finish(c, t))
            .collect();
        for c in out.iter_mut() {
            self.unwrap_candidate(c, hold);
        }
        out
    }

    /// The pass on its other branch, point by point: where a pose has two
    /// solutions the one not taken in `rows`, where it has one (the free
    /// angle) the held joint keeps the other branch's value; `None` when no
    /// pose of the pass has two solutions or one is not reached.
    fn flipped(&self, targets: &[Target], rows: &[Vec<f64>]) -> Option<Vec<Vec<f64>>> {
        let other = |k: usize, near: &[f64]| -> Option<Vec<f64>> {
            let cands = self.finished(&targets[k], &rows[k]);
            if cands.len() < 2 {
                return None;
            }
            let mut c = cands
                .into_iter()
                .find(|c| !numeric::same_joints(self, &c.q, &rows[k]))?;
            self.unwrap_candidate(&mut c, near);
            Some(c.q)
        };
        let anchor = (0..targets.len()).find_map(|k| other(k, &rows[k]))?;
        let mut out: Vec<Vec<f64>> = Vec::with_capacity(rows.len());
        for (k, t) in targets.iter().enumerate() {
            let near = out.last().cloned().unwrap_or_else(|| anchor.clone());
            let q = match other(k, &near) {
                Some(q) => q,
                None => self.finished(t, &near).into_iter().next()?.q,
            };
            out.push(q);
        }
        Some(out)
    }

    /// Shifts each rotary joint of a pass by whole turns into its travel,
    /// then checks every joint against its limits.
    pub(crate) fn fit_pass(&self, pass: usize, rows: &mut [Vec<f64>]) -> Result<()> {
        if rows.is_empty() {
            return Ok(());
        }
        for j in 0..self.dof() {
            let l = self.limits[j];
            if !self.kinds[j].is_rotary() || !l.travel().is_finite() {
                continue;
            }
            let (lo, hi) = rows
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), r| {
                    (a.min(r[j]), b.max(r[j]))
                });
            if hi - lo > l.travel() + 1e-9 {
                return Err(Error::Travel {
                    at: Some(At { pass, point: 0 }),
                    joint: self.names[j].clone(),
                    span: hi - lo,
                    lower: l.lower,
                    upper: l.upper,
                });
            }
            if let Some(s) = turn_shift(rows.iter().map(|r| r[j]), l.lower, l.upper) {
                rows.iter_mut().for_each(|r| r[j] += s);
            }
        }
        for (k, r) in rows.iter().enumerate() {
            for (j, l) in self.limits.iter().enumerate() {
                if !l.contains(r[j], 1e-9) {
                    return Err(self.limit_error(j, r[j]).placed(At { pass, point: k }));
                }
            }
        }
        Ok(())
    }

    /// The step of joint `j` from `a` to `b`: modulo a turn for a rotary
    /// joint whose travel is a turn or more (its values are unwrapped along a
    /// pass), the plain difference otherwise.
    pub(crate) fn joint_delta(&self, j: usize, a: f64, b: f64) -> f64 {
        if self.wraps(j) {
            wrap(b - a)
        } else {
            b - a
        }
    }

    /// The first joint whose step from `a` to `b` is over its limit, as an error.
    pub(crate) fn check_step(&self, at: At, a: &[f64], b: &[f64]) -> Result<()> {
        for j in 0..self.dof() {
            let rotary = self.kinds[j].is_rotary();
            let (step, max) = if rotary {
                (
                    self.joint_delta(j, a[j], b[j]),
                    self.options.max_rotary_step,
                )
            } else {
                (b[j] - a[j], self.options.max_linear_step)
            };
            if step.abs() > max {
                return Err(Error::Step {
                    at: Some(at),
                    joint: self.names[j].clone(),
                    step: step.abs(),
                    max,
                    rotary,
                });
            }
        }
        Ok(())
    }

    /// The numerical solver along a pass, each pose from the last.
    fn numeric_pass(
        &self,
        pass: usize,
        targets: &[Target],
        start: Option<&[f64]>,
    ) -> Result<Vec<Vec<f64>>> {
        let mut rows: Vec<Vec<f64>> = Vec::with_capacity(targets.len());
        for (k, t) in targets.iter().enumerate() {
            let at = At { pass, point: k };
            let seed = rows.last().map(|r| r.as_slice()).or(start);
            let from = (k > 0).then(|| &targets[k - 1]);
            let mut q = match seed {
                Some(s) => self
                    .continue_numeric(at, from, t, s)
                    .or_else(|| self.nearest_numeric(t, s)),
                None => self.best_numeric(t),
            }
            .ok_or_else(|| Error::Unreachable {
                at: Some(at),
                why: format!(
                    "the numerical solver found no joints within the limits from {} starts",
                    self.options.seeds + usize::from(seed.is_some())
                ),
            })?;
            if let Some(s) = seed {
                for j in 0..self.dof() {
                    if self.kinds[j].is_rotary() && !self.limits[j].travel().is_finite() {
                        q[j] = unwrap_near(q[j], s[j]);
                    }
                }
                if !rows.is_empty() {
                    self.check_step(at, s, &q)?;
                }
            }
            let cond = self.numeric_conditioning(&q, t);
            if cond < self.options.singular_min {
                return Err(Error::Singular {
                    at: Some(at),
                    why: format!("the Jacobian's smallest to largest singular value is {cond:.2e}, below {:.2e}", self.options.singular_min),
                });
            }
            rows.push(q);
        }
        self.fit_pass(pass, &mut rows)?;
        Ok(rows)
    }

    /// The pose `t` solved from the joints `s` of the pose `from`: directly,
    /// or when that fails or jumps, through 2, 4, ... 16 poses in between
    /// (the solver follows the path instead of leaping to another branch).
    fn continue_numeric(
        &self,
        at: At,
        from: Option<&Target>,
        t: &Target,
        s: &[f64],
    ) -> Option<Vec<f64>> {
        let iters = self.options.max_iterations;
        let (q, ok) = numeric::solve_from(self, t, s, iters);
        if ok && self.check_step(at, s, &q).is_ok() {
            return Some(q);
        }
        let from = from?;
        for m in [2, 4, 8, 16] {
            let mut x = s.to_vec();
            let reached = (1..=m).all(|i| {
                let (q, ok) =
                    numeric::solve_from(self, &between(from, t, i as f64 / m as f64), &x, iters);
                x = q;
                ok
            });
            if reached && self.check_step(at, s, &x).is_ok() {
                return Some(x);
            }
        }
        None
    }

    fn nearest_numeric(&self, t: &Target, s: &[f64]) -> Option<Vec<f64>> {
        let d = |q: &Vec<f64>| {
            q.iter()
                .zip(s)
                .map(|(a, b)| wrap(a - b).powi(2))
                .sum::<f64>()
        };
        numeric::solve_all(self, t, Some(s))
            .into_iter()
            .min_by(|a, b| d(a).total_cmp(&d(b)))
    }

    fn best_numeric(&self, t: &Target) -> Option<Vec<f64>> {
        let score = |q: &Vec<f64>| self.penalty(q, self.numeric_conditioning(q, t));
        numeric::solve_all(self, t, None)
            .into_iter()
            .min_by(|a, b| score(a).total_cmp(&score(b)))
    }

    /// Ratio of the smallest to the largest singular value of the task
    /// Jacobian (rotation rows scaled by the machine's size; for a 5-axis
    /// pose without the rotation about the tool axis).
    pub(crate) fn numeric_conditioning(&self, q: &[f64], t: &Target) -> f64 {
        let (x, j) = self.rel.jacobian(q);
        let s = numeric::length_scale(self);
        let rows: Vec<nalgebra::RowDVector<f64>> = match t {
            Target::Frame(_) => (0..6)
                .map(|r| {
                    if r < 3 {
                        j.row(r).into_owned()
                    } else {
                        j.row(r) * s
                    }
                })
                .collect(),
            Target::Axis { .. } => {
                let ex = x.rotation * nalgebra::Vector3::x();
                let ey = x.rotation * nalgebra::Vector3::y();
                let w = j.rows(3, 3);
                let mut r: Vec<nalgebra::RowDVector<f64>> =
                    (0..3).map(|r| j.row(r).into_owned()).collect();
                r.push((ex.transpose() * w) * s);
                r.push((ey.transpose() * w) * s);
                r
            }
        };
        let m = nalgebra::DMatrix::from_rows(&rows);
        let sv = m.singular_values();
        let max = sv.max();
        if max <= 0.0 {
            return 0.0;
        }
        let need = rows.len().min(self.dof());
        let mut v: Vec<f64> = sv.iter().copied().collect();
        v.sort_by(|a, b| b.total_cmp(a));
        v.get(need - 1).copied().unwrap_or(0.0) / max
    }
}

/// Whether the machine is a Cartesian one with two rotaries: its other
/// branch (the tilt negated, the turn half a turn on) is taken for a whole
/// pass when only that fits the turn axis's travel. A three-rotary wrist's
/// other branch is a wrist flip, never taken.
fn c_two_rotaries(m: &Machine) -> bool {
    matches!(&m.solver, Solver::Cartesian(c) if c.rotary.len() == 2)
}

/// The pose a fraction `f` of the way from `a` to `b` (position linear,
/// rotation or axis along the shortest arc).
fn between(a: &Target, b: &Target, f: f64) -> Target {
    let tip = a.tip().coords.lerp(&b.tip().coords, f);
    match (a, b) {
        (Target::Frame(x), Target::Frame(y)) => Target::Frame(nalgebra::Isometry3::from_parts(
            tip.into(),
            x.rotation.slerp(&y.rotation, f),
        )),
        _ => {
            let (u, v) = (a.tool_axis(), b.tool_axis());
            let axis = u.slerp(&v, f);
            Target::Axis {
                tip: tip.into(),
                axis,
            }
        }
    }
}
