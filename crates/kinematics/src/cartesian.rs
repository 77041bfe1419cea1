//! Closed form of machines with three linear axes and two or three rotary
//! axes, in any arrangement between the tool and the part (head-head,
//! table-table, head-table; a gantry with a three-axis wrist).
//!
//! Linear axes never turn anything, so the TCP's rotation is the rotaries'
//! product of exponentials, `R(q) = Rot(w1, q1) Rot(w2, q2) [Rot(w3, q3)] R0`
//! (`w` the rotary axes at zero in the workpiece frame, in chain order from
//! the workpiece, the part's own rotaries counted negative), and the TCP's
//! position is affine in the linear axes once the rotaries are fixed.
//! - 5-axis pose (two rotaries): `Rot(w1, q1) Rot(w2, q2) t0 = axis` is
//!   subproblem 2 (`t0` the tool axis at zero): two solutions, or one with
//!   `q1` free when the axis lies along `w1` (it keeps the previous value).
//! - 6-D pose (three rotaries): subproblem 2 on `w3`, then subproblem 1 for
//!   `q3`; when `w3` is carried onto `w1` (gimbal lock) `q3` keeps the
//!   previous value and the other two follow.
//! - Then the linear axes: a 3x3 linear system.

use crate::chain::JointKind;
use crate::machine::Machine;
use crate::solve::Candidate;
use crate::subproblems::{sp2, three_rotations};
use nalgebra::{Isometry3, Matrix3, Point3, Unit, UnitQuaternion, Vector3};

#[derive(Clone, Debug, PartialEq)]
pub struct CartesianSolver {
    /// Rotary machine joints in chain order from the workpiece.
    pub rotary: Vec<usize>,
    /// Their axes at zero in the workpiece frame (sign included).
    axes: Vec<Unit<Vector3<f64>>>,
    linear: [usize; 3],
    /// The TCP's rotation and tool axis with every joint at zero.
    r0: UnitQuaternion<f64>,
    tool0: Vector3<f64>,
}

impl CartesianSolver {
    /// The solver when the machine has three linear and two or three rotary
    /// joints, no two consecutive rotaries parallel.
    pub fn detect(m: &Machine) -> Option<Self> {
        let order: Vec<(usize, JointKind)> = m.rel.joints().map(|(i, k, _)| (i, k)).collect();
        let rotary: Vec<usize> = order
            .iter()
            .filter(|(_, k)| k.is_rotary())
            .map(|(i, _)| *i)
            .collect();
        let linear: Vec<usize> = order
            .iter()
            .filter(|(_, k)| !k.is_rotary())
            .map(|(i, _)| *i)
            .collect();
        if linear.len() != 3 || !(2..=3).contains(&rotary.len()) {
            return None;
        }
        let zero = vec![0.0; m.dof()];
        let (t, j) = m.rel.jacobian(&zero);
        let axes: Vec<Unit<Vector3<f64>>> = rotary
            .iter()
            .map(|&i| Unit::new_normalize(Vector3::new(j[(3, i)], j[(4, i)], j[(5, i)])))
            .collect();
        if axes.windows(2).any(|w| w[0].cross(&w[1]).norm() < 1e-6) {
            return None;
        }
        let g = Matrix3::from_fn(|r, c| j[(r, linear[c])]);
        if g.determinant().abs() < 1e-9 {
            return None;
        }
        Some(Self {
            rotary,
            axes,
            linear: [linear[0], linear[1], linear[2]],
            r0: t.rotation,
            tool0: crate::pose::tool_axis_of(&t),
        })
    }

    pub fn name(&self) -> &'static str {
        if self.rotary.len() == 2 {
            "closed form, 3 linear + 2 rotary axes"
        } else {
            "closed form, 3 linear + 3 rotary axes"
        }
    }

    /// Sets the linear axes of `q` (rotaries already set) so the TCP is at `tip`.
    fn place(&self, m: &Machine, q: &mut [f64], tip: &Point3<f64>) -> Result<(), String> {
        for &i in &self.linear {
            q[i] = 0.0;
        }
        let (t, j) = m.rel.jacobian(q);
        let g = Matrix3::from_fn(|r, c| j[(r, self.linear[c])]);
        let d = g
            .lu()
            .solve(&(tip.coords - t.translation.vector))
            .ok_or_else(|| {
                "the linear axes do not span space at these rotary angles".to_string()
            })?;
        for (c, &i) in self.linear.iter().enumerate() {
            q[i] = d[c];
        }
        Ok(())
    }

    fn candidate(
        &self,
        m: &Machine,
        angles: &[f64],
        cond: f64,
        config: u8,
        tip: &Point3<f64>,
    ) -> Result<Candidate, String> {
        let mut q = vec![0.0; m.dof()];
        for (&i, &a) in self.rotary.iter().zip(angles) {
            q[i] = a;
        }
        self.place(m, &mut q, tip)?;
        Ok(Candidate {
            q,
            config,
            conditioning: cond,
            weakest: "rotary axes",
        })
    }

    /// Every solution for the tool at `tip` along `axis` (two rotaries);
    /// `hold` gives the rotaries' previous values for a free angle.
    pub fn axis_candidates(
        &self,
        m: &Machine,
        tip: &Point3<f64>,
        axis: &Unit<Vector3<f64>>,
        hold: &[f64],
    ) -> Result<Vec<Candidate>, String> {
        let (w1, w2) = (&self.axes[0], &self.axes[1]);
        let sols = sp2(
            w1,
            w2,
            &self.tool0,
            &axis.into_inner(),
            hold[self.rotary[0]],
            hold[self.rotary[1]],
        );
        if sols.is_empty() {
            return Err(format!(
                "no angles of the rotary axes {} turn the tool to axis {:?}",
                self.rotary
                    .iter()
                    .map(|&i| m.names[i].as_str())
                    .collect::<Vec<_>>()
                    .join(" and "),
                axis.as_slice()
            ));
        }
        sols.iter()
            .enumerate()
            .map(|(k, s)| self.candidate(m, &[s.t1, s.t2], s.conditioning, k as u8, tip))
            .collect()
    }

    /// Every solution for a full TCP frame (three rotaries); in gimbal lock
    /// the last rotary keeps its `hold` value.
    pub fn frame_candidates(
        &self,
        m: &Machine,
        frame: &Isometry3<f64>,
        hold: &[f64],
    ) -> Result<Vec<Candidate>, String> {
        let g = frame.rotation * self.r0.inverse();
        let tip = Point3::from(frame.translation.vector);
        let w = [&self.axes[0], &self.axes[1], &self.axes[2]];
        let sols = three_rotations(w, &g, hold[self.rotary[2]]);
        if sols.is_empty() {
            return Err("no angles of the three rotary axes give this frame".to_string());
        }
        sols.iter()
            .enumerate()
            .map(|(k, (t, c))| self.candidate(m, t, *c, k as u8, &tip))
            .collect()
    }
}
