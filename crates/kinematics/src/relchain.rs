//! The TCP relative to the workpiece as one serial chain.
//!
//! A machine is two chains from a common base: base -> tool link (then the
//! TCP) and base -> part link (then the workpiece frame). The tool in the
//! workpiece frame is `X(q) = (P(q) W)^-1 T(q) C`: the part chain walked
//! backwards (each of its joints moving by minus its value) and then the tool
//! chain forwards. Every solver works on this one chain, so a head, a table,
//! a head-table machine or a robot holding the part are the same to it.

use crate::chain::{motion, Chain, JointKind};
use nalgebra::{DMatrix, Isometry3, Unit, Vector3};

#[derive(Clone, Debug, PartialEq)]
pub enum Element {
    Fixed(Isometry3<f64>),
    /// Machine joint `index` moving by `sign * q` about/along `axis`.
    Joint {
        index: usize,
        kind: JointKind,
        axis: Unit<Vector3<f64>>,
        sign: f64,
    },
}

#[derive(Clone, Debug, PartialEq)]
pub struct RelChain {
    pub elements: Vec<Element>,
    /// Number of machine joints (the length of a joint vector).
    pub dof: usize,
}

fn push_fixed(out: &mut Vec<Element>, t: Isometry3<f64>) {
    if let Some(Element::Fixed(prev)) = out.last_mut() {
        *prev *= t;
    } else {
        out.push(Element::Fixed(t));
    }
}

impl RelChain {
    /// The chain `(P W)^-1 T C`; `part_index` / `tool_index` give each chain
    /// joint's place in the machine's joint vector.
    pub fn new(
        part: &Chain,
        part_index: &[usize],
        workpiece: &Isometry3<f64>,
        tool: &Chain,
        tool_index: &[usize],
        tcp: &Isometry3<f64>,
        dof: usize,
    ) -> Self {
        let mut out = Vec::new();
        push_fixed(&mut out, (part.tip * workpiece).inverse());
        for (j, &index) in part.joints.iter().zip(part_index).rev() {
            out.push(Element::Joint {
                index,
                kind: j.kind,
                axis: j.axis,
                sign: -1.0,
            });
            push_fixed(&mut out, j.origin.inverse());
        }
        for (j, &index) in tool.joints.iter().zip(tool_index) {
            push_fixed(&mut out, j.origin);
            out.push(Element::Joint {
                index,
                kind: j.kind,
                axis: j.axis,
                sign: 1.0,
            });
        }
        push_fixed(&mut out, tool.tip * tcp);
        Self { elements: out, dof }
    }

    /// The TCP in the workpiece frame for machine joints `q`.
    pub fn forward(&self, q: &[f64]) -> Isometry3<f64> {
        let mut t = Isometry3::identity();
        for e in &self.elements {
            match e {
                Element::Fixed(f) => t *= f,
                Element::Joint {
                    index,
                    kind,
                    axis,
                    sign,
                } => t *= motion(*kind, axis, sign * q[*index]),
            }
        }
        t
    }

    /// The TCP pose and the geometric Jacobian in the workpiece frame at the
    /// TCP: column j = d(linear velocity; angular velocity)/d q_j (mm/unit,
    /// rad/unit).
    pub fn jacobian(&self, q: &[f64]) -> (Isometry3<f64>, DMatrix<f64>) {
        let mut t = Isometry3::identity();
        // Each joint's axis and point in the workpiece frame.
        let mut axes: Vec<(usize, JointKind, Vector3<f64>, Vector3<f64>)> = Vec::new();
        for e in &self.elements {
            match e {
                Element::Fixed(f) => t *= f,
                Element::Joint {
                    index,
                    kind,
                    axis,
                    sign,
                } => {
                    let w = t.rotation * axis.into_inner() * *sign;
                    axes.push((*index, *kind, w, t.translation.vector));
                    t *= motion(*kind, axis, sign * q[*index]);
                }
            }
        }
        let mut j = DMatrix::zeros(6, self.dof);
        let p = t.translation.vector;
        for (index, kind, w, o) in axes {
            let (lin, ang) = match kind {
                JointKind::Prismatic => (w, Vector3::zeros()),
                _ => (w.cross(&(p - o)), w),
            };
            for r in 0..3 {
                j[(r, index)] += lin[r];
                j[(r + 3, index)] += ang[r];
            }
        }
        (t, j)
    }

    /// The joints in chain order (workpiece side first).
    pub fn joints(&self) -> impl Iterator<Item = (usize, JointKind, f64)> + '_ {
        self.elements.iter().filter_map(|e| match e {
            Element::Joint {
                index, kind, sign, ..
            } => Some((*index, *kind, *sign)),
            Element::Fixed(_) => None,
        })
    }
}
