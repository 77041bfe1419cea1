//! A machine: a tool chain and a part chain from a common base link.
//!
//! - A head machine or a robot holding the tool: the tool chain has the
//!   joints, the part chain none (the workpiece sits fixed in the cell).
//! - A table-table machine: the part chain has the rotaries, the tool chain
//!   the linear axes (or some of them).
//! - A robot holding the part against a fixed tool (a belt's contact frame in
//!   the cell): the part chain has the joints, the tool chain none.
//!
//! Poses are the TCP in the workpiece frame (what the planners produce);
//! joint vectors follow the machine's joint order (the URDF's document order
//! unless the definition names one), in mm and rad.

use crate::chain::{Chain, JointKind, JointLimits};
use crate::error::{Error, Result};
use crate::relchain::RelChain;
use crate::solve::Solver;
use crate::urdf::UrdfModel;
use nalgebra::{DMatrix, Isometry3};

/// Values that override or complete the URDF's limits of one joint (mm or
/// rad, per s, per s^2).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LimitOverride {
    pub joint: String,
    pub lower: Option<f64>,
    pub upper: Option<f64>,
    pub velocity: Option<f64>,
    pub acceleration: Option<f64>,
}

/// Which links make the machine and where its TCP and workpiece frames sit.
#[derive(Clone, Debug, PartialEq)]
pub struct MachineDef {
    pub base_link: String,
    /// The link that carries the tool; the TCP frame sits on it at `tcp`.
    pub tool_link: String,
    pub tcp: Isometry3<f64>,
    /// The link that carries the workpiece (the base link when the part is
    /// fixed in the cell); the workpiece frame sits on it at `workpiece`.
    pub part_link: String,
    pub workpiece: Isometry3<f64>,
    /// The joint vector's order; `None` = the URDF's document order.
    pub joint_order: Option<Vec<String>>,
    pub limits: Vec<LimitOverride>,
}

impl MachineDef {
    /// A machine carrying the tool on `tool_link` (TCP at `tcp` on it), the
    /// workpiece fixed at `workpiece` in the base link.
    pub fn holds_tool(
        base_link: &str,
        tool_link: &str,
        tcp: Isometry3<f64>,
        workpiece: Isometry3<f64>,
    ) -> Self {
        Self {
            base_link: base_link.into(),
            tool_link: tool_link.into(),
            tcp,
            part_link: base_link.into(),
            workpiece,
            joint_order: None,
            limits: Vec::new(),
        }
    }

    /// A robot carrying the part on `flange_link` (workpiece frame at
    /// `part_on_flange`) against a tool fixed at `tool_in_base` in the base
    /// link (e.g. a belt's contact frame, z into the part).
    pub fn holds_part(
        base_link: &str,
        flange_link: &str,
        part_on_flange: Isometry3<f64>,
        tool_in_base: Isometry3<f64>,
    ) -> Self {
        Self {
            base_link: base_link.into(),
            tool_link: base_link.into(),
            tcp: tool_in_base,
            part_link: flange_link.into(),
            workpiece: part_on_flange,
            joint_order: None,
            limits: Vec::new(),
        }
    }
}

/// Tolerances and the choices the pass solvers make.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Every solution reproduces its pose within these (mm, rad) by forward kinematics.
    pub tol_position: f64,
    pub tol_rotation: f64,
    /// Largest step of a rotary joint (rad) / linear joint (mm) between two
    /// consecutive points of a pass; larger means a configuration change.
    pub max_rotary_step: f64,
    pub max_linear_step: f64,
    /// Angles tried about the tool axis when a 5-axis pose meets a 6-axis arm.
    pub psi_samples: usize,
    /// Largest change of that angle between consecutive points (rad).
    pub max_psi_step: f64,
    /// Conditioning (0 = singular, 1 = far from it) below which an arm's pose
    /// is refused as singular, and below which it is penalised.
    pub singular_min: f64,
    pub singular_margin: f64,
    /// Distance to a joint limit (rad, mm) below which a pose is penalised.
    pub limit_margin_rad: f64,
    pub limit_margin_mm: f64,
    /// Numerical solver: starting points tried and iterations per start.
    pub seeds: usize,
    pub max_iterations: usize,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            tol_position: 1e-6,
            tol_rotation: 1e-9,
            max_rotary_step: 0.5,
            max_linear_step: f64::INFINITY,
            psi_samples: 72,
            max_psi_step: 0.35,
            singular_min: 0.02,
            singular_margin: 0.15,
            limit_margin_rad: 10f64.to_radians(),
            limit_margin_mm: 10.0,
            seeds: 32,
            max_iterations: 100,
        }
    }
}

/// Which inverse kinematics a machine gets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SolverChoice {
    /// The closed form the structure allows, else the numerical solver.
    Auto,
    Numeric,
}

/// A machine ready for forward and inverse kinematics.
#[derive(Clone, Debug)]
pub struct Machine {
    pub(crate) names: Vec<String>,
    pub(crate) kinds: Vec<JointKind>,
    pub(crate) limits: Vec<JointLimits>,
    pub(crate) tool: Chain,
    pub(crate) tool_index: Vec<usize>,
    pub(crate) part: Chain,
    pub(crate) part_index: Vec<usize>,
    pub(crate) tcp: Isometry3<f64>,
    pub(crate) workpiece: Isometry3<f64>,
    pub(crate) rel: RelChain,
    pub(crate) solver: Solver,
    pub(crate) choice: SolverChoice,
    pub options: Options,
}

/// The machine's joint order: `order` if given (a permutation of the chains'
/// joints), else the URDF document order.
fn joint_order(
    model: &UrdfModel,
    tool: &Chain,
    part: &Chain,
    order: &Option<Vec<String>>,
) -> Result<Vec<String>> {
    let in_chains: Vec<&str> = tool
        .joints
        .iter()
        .chain(&part.joints)
        .map(|j| j.name.as_str())
        .collect();
    let Some(order) = order else {
        return Ok(model
            .joint_names()
            .into_iter()
            .filter(|n| in_chains.contains(&n.as_str()))
            .collect());
    };
    for n in order {
        if !in_chains.contains(&n.as_str()) {
            return Err(Error::Input(format!(
                "joint_order names {n:?}, which is not a joint of the machine's chains (they have {})",
                in_chains.join(", ")
            )));
        }
    }
    for n in &in_chains {
        if order.iter().filter(|o| o == n).count() != 1 {
            return Err(Error::Input(format!(
                "joint_order must name joint {n:?} exactly once (it names {})",
                order.join(", ")
            )));
        }
    }
    Ok(order.clone())
}

fn apply_override(l: &mut JointLimits, o: &LimitOverride, kind: JointKind) -> Result<()> {
    for (what, v) in [
        ("lower", o.lower),
        ("upper", o.upper),
        ("velocity", o.velocity),
        ("acceleration", o.acceleration),
    ] {
        if let Some(x) = v {
            let bad = !x.is_finite() || (matches!(what, "velocity" | "acceleration") && x <= 0.0);
            if bad {
                return Err(Error::Input(format!(
                    "limit override of joint {:?}: {what} = {x} is not a {}finite number",
                    o.joint,
                    if what == "lower" || what == "upper" {
                        ""
                    } else {
                        "positive "
                    }
                )));
            }
        }
    }
    if kind == JointKind::Continuous && (o.lower.is_some() || o.upper.is_some()) {
        // A continuous joint given a range becomes a limited one.
        l.lower = o.lower.unwrap_or(f64::NEG_INFINITY);
        l.upper = o.upper.unwrap_or(f64::INFINITY);
    } else {
        l.lower = o.lower.unwrap_or(l.lower);
        l.upper = o.upper.unwrap_or(l.upper);
    }
    l.velocity = o.velocity.or(l.velocity);
    l.acceleration = o.acceleration.or(l.acceleration);
    if l.lower.partial_cmp(&l.upper) != Some(std::cmp::Ordering::Less) {
        return Err(Error::Input(format!(
            "limit override of joint {:?} leaves no travel ({} .. {})",
            o.joint, l.lower, l.upper
        )));
    }
    Ok(())
}

impl Machine {
    /// The machine `def` describes in `model`.
    pub fn from_urdf(model: &UrdfModel, def: &MachineDef) -> Result<Self> {
        let tool = model.chain(&def.base_link, &def.tool_link)?;
        let part = model.chain(&def.base_link, &def.part_link)?;
        let names = joint_order(model, &tool, &part, &def.joint_order)?;
        Self::new(tool, def.tcp, part, def.workpiece, names, &def.limits)
    }

    /// The machine of two chains from one base; `names` is the joint order
    /// (every joint of both chains once).
    pub fn new(
        tool: Chain,
        tcp: Isometry3<f64>,
        part: Chain,
        workpiece: Isometry3<f64>,
        names: Vec<String>,
        overrides: &[LimitOverride],
    ) -> Result<Self> {
        if tool.base_link != part.base_link {
            return Err(Error::Model(format!(
                "the tool chain starts at {:?} and the part chain at {:?}: they need one base",
                tool.base_link, part.base_link
            )));
        }
        let index_of = |c: &Chain| -> Result<Vec<usize>> {
            c.joints
                .iter()
                .map(|j| {
                    names.iter().position(|n| *n == j.name).ok_or_else(|| {
                        Error::Input(format!("joint order lacks joint {:?}", j.name))
                    })
                })
                .collect()
        };
        let (tool_index, part_index) = (index_of(&tool)?, index_of(&part)?);
        if tool_index.len() + part_index.len() != names.len() {
            return Err(Error::Model(format!(
                "joint order {names:?} does not match the chains' joints one to one (a joint shared by the tool and the part chain?)"
            )));
        }
        let mut kinds = vec![JointKind::Revolute; names.len()];
        let mut limits = vec![JointLimits::UNLIMITED; names.len()];
        for (c, idx) in [(&tool, &tool_index), (&part, &part_index)] {
            for (j, &i) in c.joints.iter().zip(idx) {
                kinds[i] = j.kind;
                limits[i] = j.limits;
            }
        }
        for o in overrides {
            let i = names.iter().position(|n| *n == o.joint).ok_or_else(|| {
                Error::Input(format!(
                    "limit override names joint {:?}, which is not one of the machine's joints ({})",
                    o.joint,
                    names.join(", ")
                ))
            })?;
            apply_override(&mut limits[i], o, kinds[i])?;
        }
        let rel = RelChain::new(
            &part,
            &part_index,
            &workpiece,
            &tool,
            &tool_index,
            &tcp,
            names.len(),
        );
        let mut m = Self {
            names,
            kinds,
            limits,
            tool,
            tool_index,
            part,
            part_index,
            tcp,
            workpiece,
            rel,
            solver: Solver::Numeric,
            choice: SolverChoice::Auto,
            options: Options::default(),
        };
        m.solver = Solver::detect(&m, SolverChoice::Auto);
        Ok(m)
    }

    /// The same machine with another solver choice (e.g. to check a closed
    /// form against the numerical solver).
    pub fn with_solver(mut self, choice: SolverChoice) -> Self {
        self.choice = choice;
        self.solver = Solver::detect(&self, choice);
        self
    }

    /// The same machine with another TCP on the tool link (e.g. a job's tool length).
    pub fn with_tcp(mut self, tcp: Isometry3<f64>) -> Self {
        self.tcp = tcp;
        self.rebuild();
        self
    }

    /// The same machine with the workpiece frame elsewhere on the part link.
    pub fn with_workpiece(mut self, workpiece: Isometry3<f64>) -> Self {
        self.workpiece = workpiece;
        self.rebuild();
        self
    }

    fn rebuild(&mut self) {
        self.rel = RelChain::new(
            &self.part,
            &self.part_index,
            &self.workpiece,
            &self.tool,
            &self.tool_index,
            &self.tcp,
            self.names.len(),
        );
        self.solver = Solver::detect(self, self.choice);
    }

    pub fn dof(&self) -> usize {
        self.names.len()
    }
    pub fn joint_names(&self) -> &[String] {
        &self.names
    }
    pub fn joint_kinds(&self) -> &[JointKind] {
        &self.kinds
    }
    pub fn limits(&self) -> &[JointLimits] {
        &self.limits
    }
    pub fn tool_chain(&self) -> &Chain {
        &self.tool
    }
    pub fn part_chain(&self) -> &Chain {
        &self.part
    }
    /// The name of the inverse kinematics in use.
    pub fn solver_name(&self) -> &'static str {
        self.solver.name()
    }

    /// Whether joint `j` is rotary with a travel of more than a turn: its
    /// values along a pass are unwrapped (steps taken modulo a turn) and the
    /// pass fitted into the travel by whole turns. A rotary joint of a turn
    /// or less has one value in its travel per angle, and a pass cannot cross
    /// the ends of the travel.
    pub(crate) fn wraps(&self, j: usize) -> bool {
        self.kinds[j].is_rotary() && self.limits[j].travel() > crate::angles::TURN + 1e-9
    }

    pub(crate) fn check_joints(&self, q: &[f64]) -> Result<()> {
        if q.len() != self.dof() {
            return Err(Error::Input(format!(
                "{} joint values given, the machine has {} joints ({})",
                q.len(),
                self.dof(),
                self.names.join(", ")
            )));
        }
        if let Some(k) = q.iter().position(|x| !x.is_finite()) {
            return Err(Error::Input(format!(
                "joint {} = {} is not finite",
                self.names[k], q[k]
            )));
        }
        Ok(())
    }

    /// The TCP in the workpiece frame for joints `q` (machine order, mm/rad).
    pub fn forward(&self, q: &[f64]) -> Result<Isometry3<f64>> {
        self.check_joints(q)?;
        Ok(self.rel.forward(q))
    }

    /// The TCP and the geometric Jacobian (6 x dof: linear mm, angular rad
    /// per joint unit) in the workpiece frame at the TCP.
    pub fn jacobian(&self, q: &[f64]) -> Result<(Isometry3<f64>, DMatrix<f64>)> {
        self.check_joints(q)?;
        Ok(self.rel.jacobian(q))
    }

    /// The tool link's and the part link's poses in the base link.
    pub fn link_poses(&self, q: &[f64]) -> Result<(Isometry3<f64>, Isometry3<f64>)> {
        self.check_joints(q)?;
        let pick = |idx: &[usize]| idx.iter().map(|&i| q[i]).collect::<Vec<f64>>();
        Ok((
            self.tool.forward(&pick(&self.tool_index)),
            self.part.forward(&pick(&self.part_index)),
        ))
    }
}
