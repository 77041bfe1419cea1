//! Single-pose inverse kinematics: the solver a machine's structure allows,
//! each solution polished and checked by forward kinematics on the chain
//! itself, then fitted into the joint limits (rotary joints by whole turns).

use crate::angles::representative_in;
use crate::arm::ArmSolver;
use crate::cartesian::CartesianSolver;
use crate::error::{Error, Result};
use crate::machine::{Machine, SolverChoice};
use crate::numeric;
use crate::pose::{pose_error, reference_frames, Target};
use nalgebra::{Isometry3, Point3, Translation3, Unit, UnitQuaternion, Vector3};

/// One joint solution of a pose.
#[derive(Clone, Debug, PartialEq)]
pub struct Candidate {
    /// Machine joint order, mm and rad.
    pub q: Vec<f64>,
    /// The closed form's branch label (same label = same configuration).
    pub config: u8,
    /// 0 at a singularity of its branch, 1 far from any.
    pub conditioning: f64,
    /// Which part of the mechanism sets the conditioning (for messages).
    pub weakest: &'static str,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Solver {
    Cartesian(CartesianSolver),
    Arm(Box<ArmSolver>),
    Numeric,
}

impl Solver {
    pub fn detect(m: &Machine, choice: SolverChoice) -> Solver {
        if choice == SolverChoice::Numeric {
            return Solver::Numeric;
        }
        if let Some(c) = CartesianSolver::detect(m) {
            return Solver::Cartesian(c);
        }
        if let Some(a) = ArmSolver::detect(m) {
            if arm_self_check(m, &a) {
                return Solver::Arm(Box::new(a));
            }
        }
        Solver::Numeric
    }

    pub fn name(&self) -> &'static str {
        match self {
            Solver::Cartesian(c) => c.name(),
            Solver::Arm(a) => a.name(),
            Solver::Numeric => "numerical (Levenberg-Marquardt)",
        }
    }
}

/// The closed form must give back the joints of poses made by forward
/// kinematics; a structure that only looks solvable falls back to the
/// numerical solver instead of giving wrong joints.
fn arm_self_check(m: &Machine, a: &ArmSolver) -> bool {
    let mut r = crate::numeric::seeds(m, 12);
    r.push(vec![0.3; m.dof()]);
    r.iter().all(|q| {
        let x = m.rel.forward(q);
        let Ok(c) = a.candidates(m, &x, q) else {
            return false;
        };
        c.iter()
            .any(|c| crate::numeric::same_joints_loose(m, &c.q, q))
    })
}

/// The frame of a 5-axis target turned by `psi` about its tool axis, from
/// its reference rotation `r0` (z = minus the axis).
pub fn turned(tip: &Point3<f64>, r0: &UnitQuaternion<f64>, psi: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::from(tip.coords),
        r0 * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), psi),
    )
}

impl Machine {
    /// The OPW parameters of a 6R spherical-wrist arm carrying the tool or
    /// the part (the other side without joints), if it is one.
    pub fn opw_parameters(&self) -> Option<crate::opw::OpwParameters> {
        match (self.tool.dof(), self.part.dof()) {
            (6, 0) => crate::opw::OpwParameters::of_chain(&self.tool, &self.tcp),
            (0, 6) => crate::opw::OpwParameters::of_chain(&self.part, &self.workpiece),
            _ => None,
        }
    }

    /// The closed form's solutions of a TCP frame (Cartesian with three
    /// rotaries, or an arm); `hold` = the joints a free angle keeps.
    pub(crate) fn frame_candidates(
        &self,
        x: &Isometry3<f64>,
        hold: &[f64],
    ) -> std::result::Result<Vec<Candidate>, String> {
        match &self.solver {
            Solver::Cartesian(c) if c.rotary.len() == 3 => c.frame_candidates(self, x, hold),
            Solver::Arm(a) => a.candidates(self, x, hold),
            _ => Err("no closed form for a full frame on this machine".into()),
        }
    }

    /// Polishes a closed-form solution on the chain (rounding near a
    /// singularity, axes parallel only to 1e-12 in the URDF) and keeps it if
    /// it reproduces the target.
    pub(crate) fn finish(&self, mut c: Candidate, target: &Target) -> Option<Candidate> {
        let t = self.rel.forward(&c.q);
        let (dp, da) = pose_error(&t, target);
        if dp <= self.options.tol_position * 0.1 && da <= self.options.tol_rotation * 0.1 {
            return Some(c);
        }
        let (q, ok) = numeric::solve_from_unclamped(self, target, &c.q, 8);
        if !ok || !numeric::same_joints_loose(self, &q, &c.q) {
            return None;
        }
        c.q = q;
        Some(c)
    }

    /// Fits `q` into the joint limits: rotary joints take the whole-turn
    /// representative in range nearest to `near` (or to themselves). On
    /// failure, the first joint out of range.
    pub(crate) fn fit(
        &self,
        q: &mut [f64],
        near: Option<&[f64]>,
    ) -> std::result::Result<(), usize> {
        for j in 0..q.len() {
            let l = &self.limits[j];
            let reference = near.map_or(q[j], |n| n[j]);
            if self.kinds[j].is_rotary() {
                match representative_in(q[j], l.lower - 1e-9, l.upper + 1e-9, reference) {
                    Some(v) => q[j] = v.clamp(l.lower, l.upper),
                    None => return Err(j),
                }
            } else if !l.contains(q[j], 1e-9) {
                return Err(j);
            } else {
                q[j] = q[j].clamp(l.lower, l.upper);
            }
        }
        Ok(())
    }

    pub(crate) fn limit_error(&self, j: usize, value: f64) -> Error {
        let l = &self.limits[j];
        let v = if self.kinds[j].is_rotary() && !self.wraps(j) {
            crate::angles::wrap(value)
        } else {
            value
        };
        Error::JointLimit {
            at: None,
            joint: self.names[j].clone(),
            value: v,
            lower: l.lower,
            upper: l.upper,
            rotary: self.kinds[j].is_rotary(),
        }
    }

    /// Every solution of one pose within the joint limits, nearest to `near`
    /// first. A 5-axis pose on a machine whose closed form needs a full
    /// frame gets, per configuration, the angle about the tool axis that
    /// keeps it farthest from limits and singularities.
    pub fn inverse(&self, target: &Target, near: Option<&[f64]>) -> Result<Vec<Vec<f64>>> {
        if let Some(n) = near {
            self.check_joints(n)?;
        }
        let hold = near.map_or_else(|| vec![0.0; self.dof()], |n| n.to_vec());
        let raw: std::result::Result<Vec<Candidate>, String> = match (&self.solver, target) {
            (Solver::Numeric, _) => Ok(numeric::solve_all(self, target, near)
                .into_iter()
                .map(|q| Candidate {
                    q,
                    config: 0,
                    conditioning: 1.0,
                    weakest: "",
                })
                .collect()),
            (Solver::Cartesian(c), Target::Axis { tip, axis }) if c.rotary.len() == 2 => c.axis_candidates(self, tip, axis, &hold),
            (Solver::Cartesian(c), Target::Frame(_)) if c.rotary.len() == 2 => {
                return Err(Error::Input(format!(
                    "a machine with two rotary axes ({}) cannot set a full 6-D frame; give a 5-axis pose (tip and tool axis)",
                    c.rotary.iter().map(|&i| self.names[i].as_str()).collect::<Vec<_>>().join(", ")
                )))
            }
            (_, Target::Frame(x)) => self.frame_candidates(x, &hold),
            (_, Target::Axis { tip, axis }) => Ok(self.psi_candidates(tip, axis, &hold)),
        };
        let raw = raw.map_err(|why| Error::Unreachable { at: None, why })?;
        self.keep_valid(raw, target, near)
    }

    /// For a 5-axis pose: per configuration, the sampled angle about the
    /// axis with the best score, as a frame solution.
    fn psi_candidates(
        &self,
        tip: &Point3<f64>,
        axis: &Unit<Vector3<f64>>,
        hold: &[f64],
    ) -> Vec<Candidate> {
        let r0 = reference_frames(&[*axis])[0];
        let n = self.options.psi_samples.max(1);
        let mut best: Vec<(f64, Candidate)> = Vec::new();
        for k in 0..n {
            let psi = -std::f64::consts::PI + crate::angles::TURN * k as f64 / n as f64;
            let Ok(list) = self.frame_candidates(&turned(tip, &r0, psi), hold) else {
                continue;
            };
            for mut c in list {
                if self.fit(&mut c.q, None).is_err() {
                    continue;
                }
                let s = self.penalty(&c.q, c.conditioning);
                match best.iter_mut().find(|(_, b)| b.config == c.config) {
                    Some(slot) if s < slot.0 => *slot = (s, c),
                    Some(_) => {}
                    None => best.push((s, c)),
                }
            }
        }
        best.sort_by_key(|(_, c)| c.config);
        best.into_iter().map(|(_, c)| c).collect()
    }

    /// Penalty of a solution near joint limits or a singularity (0 = clear of both).
    pub(crate) fn penalty(&self, q: &[f64], conditioning: f64) -> f64 {
        let o = &self.options;
        let mut p = 0.0;
        for (j, x) in q.iter().enumerate() {
            let l = &self.limits[j];
            if !(l.lower.is_finite() && l.upper.is_finite()) {
                continue;
            }
            if self.wraps(j) {
                continue;
            }
            let margin = if self.kinds[j].is_rotary() {
                o.limit_margin_rad
            } else {
                o.limit_margin_mm
            };
            let d = (x - l.lower).min(l.upper - x).max(0.0);
            if d < margin {
                p += (1.0 - d / margin).powi(2);
            }
        }
        if conditioning < o.singular_margin {
            p += (1.0 - conditioning / o.singular_margin).powi(2);
        }
        p
    }

    /// Polished, checked, in-limits solutions, nearest to `near` first; the
    /// reason when none is left.
    fn keep_valid(
        &self,
        raw: Vec<Candidate>,
        target: &Target,
        near: Option<&[f64]>,
    ) -> Result<Vec<Vec<f64>>> {
        if raw.is_empty() {
            return Err(Error::Unreachable {
                at: None,
                why: "no joint values reproduce the pose".into(),
            });
        }
        let mut out: Vec<Vec<f64>> = Vec::new();
        let mut first_limit: Option<(usize, f64)> = None;
        for c in raw {
            let Some(c) = self.finish(c, target) else {
                continue;
            };
            let mut q = c.q.clone();
            match self.fit(&mut q, near) {
                Ok(()) => {
                    if !out.iter().any(|o| numeric::same_joints(self, o, &q)) {
                        out.push(q);
                    }
                }
                Err(j) => {
                    first_limit.get_or_insert((j, c.q[j]));
                }
            }
        }
        if out.is_empty() {
            return Err(match first_limit {
                Some((j, v)) => self.limit_error(j, v),
                None => Error::Unreachable {
                    at: None,
                    why: "the closed-form solutions do not reproduce the pose within tolerance"
                        .into(),
                },
            });
        }
        if let Some(n) = near {
            let d = |q: &Vec<f64>| q.iter().zip(n).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
            out.sort_by(|a, b| d(a).total_cmp(&d(b)));
        }
        Ok(out)
    }
}
