//! The motion of a program, planned once for every format: the passes posed
//! by the machine's inverse kinematics and fitted to its limits, and the links
//! between them.
//!
//! Rotaries: C is unwrapped along each pass and the tilt branch (tilt, C) or
//! (-tilt, C + 180 deg) is kept for the whole pass; the pass is then shifted
//! by whole turns of C, or flipped to the other branch as a whole, to fit the
//! travel, nearest to where the previous pass left C. With the tool on the C
//! axis (tilt 0) C is held, and a pass that starts there takes C from its
//! first tilted pose before it starts.
//!
//! Links, in the machine frame: leave along the tool axis by the retract
//! distance, rise straight up (+z) to the clearance (the retract distance
//! above the highest corner of the part's bounding box as the part sits
//! then) at feed; then at rapid: up to the link height, turn the rotaries in
//! steps of at most [`LINK_STEP_DEG`] with X Y Z held, across to above the
//! next approach point, down to the clearance; at feed down to the approach
//! point and along the tool axis onto the pass. The link height keeps the tip
//! above the clearance throughout the turn, with a margin for the chord a
//! TCP controller takes between the steps.

use super::machine::PostMachine;
use toolpath_formats::{Job, PlanResult, Shape};
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::tools::Tool;
use toolpath_machines::FiveAxis;

/// Largest rotary step of a link's turn, degrees.
pub const LINK_STEP_DEG: f64 = 2.0;

/// Resolution at which a link's turn is searched for its highest clearance, degrees.
const TURN_SAMPLE_DEG: f64 = 0.25;

/// Clearance kept above the computed need while the rotaries turn, mm.
const TURN_MARGIN_MM: f64 = 0.5;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Rapid,
    Feed,
}

/// Where a waypoint comes from, for reports and errors.
#[derive(Clone, Debug, PartialEq)]
pub enum Origin {
    /// A point of the result: its label (`passes[3].points[7]`) and pass number.
    Point {
        label: String,
        pass: usize,
    },
    Approach(usize),
    Leave(usize),
    Link(usize),
    End,
}

impl std::fmt::Display for Origin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Origin::Point { label, .. } => write!(f, "{label}"),
            Origin::Approach(p) => write!(f, "the approach to pass {p}"),
            Origin::Leave(p) => write!(f, "the retract after pass {p}"),
            Origin::Link(p) => write!(f, "the link to pass {p}"),
            Origin::End => write!(f, "the final retract"),
        }
    }
}

/// One target pose: joints, and the tip and unit axis in the workpiece frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Waypoint {
    pub kind: Kind,
    pub q: [f64; 5],
    pub tip: [f64; 3],
    pub axis: [f64; 3],
    pub origin: Origin,
}

impl Waypoint {
    pub fn is_cut(&self) -> bool {
        matches!(self.origin, Origin::Point { .. })
    }
}

/// A tool of the program: the job's tool, or a pocket stage's flat end.
#[derive(Clone, Debug, PartialEq)]
pub struct ToolInfo {
    pub number: u32,
    pub tool: Tool,
    /// Pocket stage ("roughing", "corner", "root").
    pub stage: Option<String>,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    /// Tool change, spindle and coolant on, rotaries to `rotaries` at the top
    /// of Z travel (then TCP on).
    ToolStart {
        tool: usize,
        rotaries: [f64; 2],
    },
    /// Start of pass `k` (a comment).
    Pass(usize),
    Move(Waypoint),
    /// TCP off, up to the top of Z travel, coolant and spindle off.
    ToolEnd,
}

/// The planned program.
#[derive(Clone, Debug, PartialEq)]
pub struct Motion {
    pub steps: Vec<Step>,
    pub tools: Vec<ToolInfo>,
    /// Part's bounding box in the workpiece frame (surface control net or
    /// pocket outline, and every cc and cl), mm.
    pub bbox: ([f64; 3], [f64; 3]),
    /// Joint Z at the top of travel (the safe start and end).
    pub z_top: f64,
    pub passes: usize,
    pub cut_points: usize,
}

/// One pass to cut: its tool and tool poses with their labels.
struct PassPoses {
    tool: usize,
    poses: Vec<([f64; 3], [f64; 3])>,
    labels: Vec<String>,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// A belt result (or a belt job) is not for a mill.
pub fn reject_belt(job: &Job, result: &PlanResult) -> Result<()> {
    let belt = result.machine.as_deref() == Some("belt6") || result.strategy.starts_with("belt_");
    if belt || matches!(job.tool, Some(Tool::Belt { .. })) {
        return Err(Error::invalid(
            "strategy",
            format!(
                "a {} result drives the belt6 grinder, not a mill: NC programs are posted for milling results (tensor_regions, iso_scallop, iso_parametric, mpec, pocket_mat)",
                result.strategy
            ),
        ));
    }
    Ok(())
}

/// The passes of a milling result with their tools; a belt result or one
/// without points is an error.
fn passes_of(
    job: &Job,
    result: &PlanResult,
    first_tool: u32,
) -> Result<(Vec<ToolInfo>, Vec<PassPoses>)> {
    reject_belt(job, result)?;
    let mut tools = Vec::new();
    let mut passes = Vec::new();
    if let Some(stages) = &result.tools {
        let length = job.tool_length();
        for (s, stage) in stages.iter().enumerate() {
            if !(stage.diameter.is_finite() && stage.diameter > 0.0) {
                return Err(Error::invalid(
                    format!("tools[{s}].diameter"),
                    format!("must be a positive finite number, got {}", stage.diameter),
                ));
            }
            tools.push(ToolInfo {
                number: first_tool + s as u32,
                tool: Tool::FlatEnd {
                    radius: stage.diameter / 2.0,
                    length: Some(length),
                },
                stage: Some(stage.stage.clone()),
            });
            for (p, pass) in stage.passes.iter().enumerate() {
                passes.push(PassPoses {
                    tool: s,
                    poses: pass
                        .iter()
                        .map(|xy| ([xy[0], xy[1], 0.0], [0.0, 0.0, 1.0]))
                        .collect(),
                    labels: (0..pass.len())
                        .map(|k| format!("tools[{s}].passes[{p}][{k}]"))
                        .collect(),
                });
            }
        }
    } else {
        tools.push(ToolInfo {
            number: first_tool,
            tool: *job.tool()?,
            stage: None,
        });
        for (p, pass) in result.passes.iter().enumerate() {
            passes.push(PassPoses {
                tool: 0,
                poses: pass.points.iter().map(|pt| (pt.cl, pt.axis)).collect(),
                labels: (0..pass.points.len())
                    .map(|k| format!("passes[{p}].points[{k}]"))
                    .collect(),
            });
        }
    }
    passes.retain(|p| !p.poses.is_empty());
    if passes.is_empty() {
        return Err(Error::invalid(
            "passes",
            "the result has no tool positions to post",
        ));
    }
    for pass in &passes {
        for ((tip, axis), label) in pass.poses.iter().zip(&pass.labels) {
            if tip.iter().chain(axis.iter()).any(|x| !x.is_finite()) || norm(*axis) < 1e-9 {
                return Err(Error::invalid(
                    label.clone(),
                    format!("tip {tip:?} and axis {axis:?} do not make a tool pose (finite tip, non-zero axis)"),
                ));
            }
        }
    }
    Ok((tools, passes))
}

/// Bounding box of the part: the surface's control net (it holds the
/// surface) or the pocket outline at z = 0, and every cc and cl.
fn part_bbox(job: &Job, result: &PlanResult) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let mut add = |p: [f64; 3]| {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    };
    match &job.shape {
        Shape::Surface(s) => {
            let (a, b) = s.bounding_box();
            add([a.x, a.y, a.z]);
            add([b.x, b.y, b.z]);
        }
        Shape::Pocket(p) => p.outer.iter().for_each(|xy| add([xy[0], xy[1], 0.0])),
    }
    for pass in &result.passes {
        for pt in &pass.points {
            add(pt.cc);
            add(pt.cl);
        }
    }
    for stage in result.tools.iter().flatten() {
        for xy in stage.passes.iter().flatten() {
            add([xy[0], xy[1], 0.0]);
        }
    }
    (lo, hi)
}

/// Planning context: the machine, the tool length and the part.
struct Planner<'a> {
    m: &'a FiveAxis,
    tool_length: f64,
    corners: Vec<[f64; 3]>,
}

impl Planner<'_> {
    /// The clearance for rotaries `r`: machine z of the highest bounding-box
    /// corner plus the retract distance.
    fn clearance(&self, r: [f64; 2]) -> f64 {
        self.corners
            .iter()
            .map(|c| self.m.part_to_machine(r, *c)[2])
            .fold(f64::NEG_INFINITY, f64::max)
            + self.m.retract
    }

    /// Joint Z that puts the tip at machine height `h` with rotaries `r`.
    fn z_for_tip(&self, r: [f64; 2], h: f64) -> f64 {
        h + self.m.spindle_offset(self.tool_length) * self.m.spindle_direction(r)[2]
    }

    fn waypoint(&self, kind: Kind, q: [f64; 5], origin: Origin) -> Waypoint {
        let (tip, axis) = self.m.forward(self.tool_length, &q);
        Waypoint {
            kind,
            q,
            tip,
            axis,
            origin,
        }
    }

    /// Joints moved by `d` along the tool axis (towards the spindle).
    fn along_axis(&self, q: [f64; 5], d: f64) -> [f64; 5] {
        let s = self.m.spindle_direction([q[3], q[4]]);
        [
            q[0] + d * s[0],
            q[1] + d * s[1],
            q[2] + d * s[2],
            q[3],
            q[4],
        ]
    }

    /// Chord allowance of a TCP controller between two turn steps: the tip,
    /// carried with the part, runs the chord of an arc about each rotary axis.
    fn turn_margin(&self, q: &[f64; 5]) -> f64 {
        if !self.m.kinematics.is_table() {
            return TURN_MARGIN_MM;
        }
        let tip = self.m.tip_in_machine(self.tool_length, q);
        let reach = norm(sub(tip, self.m.tilt_axis_point)) + norm(sub(tip, self.m.c_axis_point));
        let step = LINK_STEP_DEG.to_radians();
        TURN_MARGIN_MM + reach * step * step / 8.0
    }

    /// Link from `from` (at or above the clearance) to the first pose `to` of
    /// pass `pass`: up to the link height, turn, across, down, approach.
    fn link(&self, from: [f64; 5], to: [f64; 5], pass: usize, out: &mut Vec<Step>) {
        let (r0, r1) = ([from[3], from[4]], [to[3], to[4]]);
        let turn = (r1[0] - r0[0]).abs().max((r1[1] - r0[1]).abs());
        let mut z_link = from[2];
        let mut steps = 0;
        if turn > 1e-12 {
            let samples = ((turn.to_degrees() / TURN_SAMPLE_DEG).ceil() as usize).max(1);
            let need = (0..=samples)
                .map(|i| {
                    let t = i as f64 / samples as f64;
                    let r = [r0[0] + t * (r1[0] - r0[0]), r0[1] + t * (r1[1] - r0[1])];
                    self.z_for_tip(r, self.clearance(r))
                })
                .fold(f64::NEG_INFINITY, f64::max);
            z_link = z_link.max(need + self.turn_margin(&from));
            steps = (turn.to_degrees() / LINK_STEP_DEG).ceil() as usize;
        }
        let approach = self.along_axis(to, self.m.retract);
        // The reposition at the link height must clear the part at the new orientation.
        z_link = z_link.max(self.z_for_tip(r1, self.clearance(r1)));
        let mut q = from;
        let mut last = from;
        let mut push = |q: [f64; 5], kind: Kind, origin: Origin, out: &mut Vec<Step>| {
            if q != last {
                out.push(Step::Move(self.waypoint(kind, q, origin)));
                last = q;
            }
        };
        if z_link > q[2] {
            q[2] = z_link;
            push(q, Kind::Rapid, Origin::Link(pass), out);
        }
        for i in 1..=steps {
            let t = i as f64 / steps as f64;
            q[3] = r0[0] + t * (r1[0] - r0[0]);
            q[4] = r0[1] + t * (r1[1] - r0[1]);
            push(q, Kind::Rapid, Origin::Link(pass), out);
        }
        q = [approach[0], approach[1], q[2], r1[0], r1[1]];
        push(q, Kind::Rapid, Origin::Link(pass), out);
        let z_clear = approach[2].max(self.z_for_tip(r1, self.clearance(r1)));
        if z_clear < q[2] {
            q[2] = z_clear;
            push(q, Kind::Rapid, Origin::Link(pass), out);
        }
        push(approach, Kind::Feed, Origin::Approach(pass), out);
    }

    /// Leave the end of pass `pass` along the tool axis and rise to the clearance.
    fn leave(&self, end: [f64; 5], pass: usize, out: &mut Vec<Step>) -> [f64; 5] {
        let mut q = self.along_axis(end, self.m.retract);
        out.push(Step::Move(self.waypoint(
            Kind::Feed,
            q,
            Origin::Leave(pass),
        )));
        let r = [q[3], q[4]];
        let z = self.z_for_tip(r, self.clearance(r));
        if q[2] < z {
            q[2] = z;
            out.push(Step::Move(self.waypoint(
                Kind::Feed,
                q,
                Origin::Leave(pass),
            )));
        }
        q
    }
}

/// Whole turns of C (and the branch) that bring a pass into the travel,
/// nearest to `prev` (tilt, C); `None` when no variant fits.
fn fit_pass(q: &mut [[f64; 5]], m: &FiveAxis, prev: Option<(f64, f64)>) -> Option<()> {
    let (lt, lc) = (&m.limits[3], &m.limits[4]);
    let turn = 2.0 * std::f64::consts::PI;
    let mut best: Option<(f64, bool, f64)> = None;
    for flip in [false, true] {
        let tilt = |r: &[f64; 5]| if flip { -r[3] } else { r[3] };
        let c = |r: &[f64; 5]| {
            if flip {
                r[4] + std::f64::consts::PI
            } else {
                r[4]
            }
        };
        if q.iter()
            .any(|r| tilt(r) < lt.min - 1e-9 || tilt(r) > lt.max + 1e-9)
        {
            continue;
        }
        let lo = q.iter().map(c).fold(f64::INFINITY, f64::min);
        let hi = q.iter().map(c).fold(f64::NEG_INFINITY, f64::max);
        let k_lo = ((lc.min - lo) / turn - 1e-12).ceil();
        let k_hi = ((lc.max - hi) / turn + 1e-12).floor();
        if k_lo > k_hi {
            continue;
        }
        let (t0, c0) = (tilt(&q[0]), c(&q[0]));
        let (pt, pc) = prev.unwrap_or((t0, 0.0));
        let k = ((pc - c0) / turn).round().clamp(k_lo, k_hi);
        let cost = (t0 - pt).abs() + (c0 + k * turn - pc).abs();
        if best.is_none_or(|b| cost < b.0 - 1e-12) {
            best = Some((cost, flip, k * turn));
        }
    }
    let (_, flip, shift) = best?;
    for r in q.iter_mut() {
        if flip {
            r[3] = -r[3];
            r[4] += std::f64::consts::PI;
        }
        r[4] += shift;
    }
    Some(())
}

/// The error for a pass that fits no variant: the first point outside the
/// travel (as posed), or the C span when it exceeds the travel.
fn limit_error(m: &FiveAxis, q: &[[f64; 5]], labels: &[String], what: &str) -> Error {
    let lc = &m.limits[4];
    let lo = q.iter().map(|r| r[4]).fold(f64::INFINITY, f64::min);
    let hi = q.iter().map(|r| r[4]).fold(f64::NEG_INFINITY, f64::max);
    let names = m.joint_names();
    for (r, label) in q.iter().zip(labels) {
        let t = &m.limits[3];
        if r[3] < t.min - 1e-9 || r[3] > t.max + 1e-9 {
            return Error::invalid(
                label.clone(),
                format!(
                    "{what}: the pose needs {} = {:.3} deg (or {:.3} on the other branch), outside machine {}'s range {}..{} deg",
                    names[3],
                    r[3].to_degrees(),
                    (-r[3]).to_degrees(),
                    m.name,
                    deg(t.min),
                    deg(t.max)
                ),
            );
        }
    }
    Error::invalid(
        labels[0].clone(),
        format!(
            "{what}: the pass from here turns C through {:.1} deg, which fits no whole-turn shift of machine {}'s range {}..{} deg",
            (hi - lo).to_degrees(),
            m.name,
            deg(lc.min),
            deg(lc.max)
        ),
    )
}

/// Degrees for messages, rounded off the radian round trip (-120, not -119.99999999999999).
fn deg(x: f64) -> f64 {
    (x.to_degrees() * 1e9).round() / 1e9
}

/// Every joint of every waypoint within the travel, or an error naming it.
fn check_limits(m: &FiveAxis, steps: &[Step], what: &str) -> Result<()> {
    let names = m.joint_names();
    for s in steps {
        let Step::Move(w) = s else { continue };
        for (j, l) in m.limits.iter().enumerate() {
            let x = w.q[j];
            if x >= l.min - 1e-9 && x <= l.max + 1e-9 {
                continue;
            }
            let (val, lo, hi, unit) = if l.rotary {
                (x.to_degrees(), deg(l.min), deg(l.max), "deg")
            } else {
                (x, l.min, l.max, "mm")
            };
            let field = match &w.origin {
                Origin::Point { label, .. } => label.clone(),
                _ => "passes".to_string(),
            };
            let place = match &w.origin {
                Origin::Point { .. } => "the pose".to_string(),
                o => o.to_string(),
            };
            return Err(Error::invalid(
                field,
                format!(
                    "{what}: {place} (tip {:.3?}, axis {:.4?}) needs {} = {val:.3} {unit}, outside machine {}'s range {lo}..{hi} {unit}",
                    w.tip, w.axis, names[j], m.name
                ),
            ));
        }
    }
    Ok(())
}

/// Plans the program of `result` (planned from `job`) on `pm`.
pub fn plan(job: &Job, result: &PlanResult, pm: &PostMachine) -> Result<Motion> {
    let m = &pm.machine;
    let what = format!("machine {}", m.name);
    if job.feed_rate > m.max_feed_rate_mm_min {
        return Err(Error::invalid(
            "feed_rate",
            format!(
                "{} mm/min exceeds machine {}'s maximum feed rate {} mm/min",
                job.feed_rate, m.name, m.max_feed_rate_mm_min
            ),
        ));
    }
    let (tools, passes) = passes_of(job, result, pm.nc.tool_number)?;
    let bbox = part_bbox(job, result);
    let planner = Planner {
        m,
        tool_length: job.tool_length(),
        corners: box_corners(bbox),
    };
    let z_top = m.limits[2].max;
    let mut program = Program {
        planner: &planner,
        z_top,
        steps: Vec::new(),
        current: None,
        current_tool: None,
    };
    let mut prev_rot: Option<(f64, f64)> = None;
    for (p, pass) in passes.iter().enumerate() {
        let q = planner.pose_pass(pass, prev_rot, &what)?;
        program.cut(p, pass, &q);
        let last = q[q.len() - 1];
        prev_rot = Some((last[3], last[4]));
    }
    let steps = program.finish();
    check_limits(m, &steps, &what)?;
    Ok(Motion {
        steps,
        tools,
        bbox,
        z_top,
        passes: passes.len(),
        cut_points: passes.iter().map(|p| p.poses.len()).sum(),
    })
}

/// The eight corners of a box.
fn box_corners((lo, hi): ([f64; 3], [f64; 3])) -> Vec<[f64; 3]> {
    (0..8)
        .map(|i| {
            [
                if i & 1 == 0 { lo[0] } else { hi[0] },
                if i & 2 == 0 { lo[1] } else { hi[1] },
                if i & 4 == 0 { lo[2] } else { hi[2] },
            ]
        })
        .collect()
}

impl Planner<'_> {
    /// The joints of a pass: posed by the inverse kinematics, fitted to the
    /// travel nearest to `prev_rot` (the previous pass's last tilt and C),
    /// X Y Z recomputed for the rotaries chosen.
    fn pose_pass(
        &self,
        pass: &PassPoses,
        prev_rot: Option<(f64, f64)>,
        what: &str,
    ) -> Result<Vec<[f64; 5]>> {
        let m = self.m;
        let mut q = m
            .inverse_path(self.tool_length, &pass.poses)
            .map_err(|e| Error::invalid(pass.labels[0].clone(), e.to_string()))?;
        fit_pass(&mut q, m, prev_rot).ok_or_else(|| limit_error(m, &q, &pass.labels, what))?;
        for (qk, pose) in q.iter_mut().zip(&pass.poses) {
            *qk = m.joints_at(self.tool_length, pose.0, [qk[3], qk[4]]);
        }
        Ok(q)
    }
}

/// The steps written so far and where the machine is.
struct Program<'a> {
    planner: &'a Planner<'a>,
    z_top: f64,
    steps: Vec<Step>,
    current: Option<[f64; 5]>,
    current_tool: Option<usize>,
}

impl Program<'_> {
    /// Changes to the pass's tool when it is another: the previous tool up
    /// to the top of Z travel and off, the new one on with the rotaries of
    /// the pass's first pose, above its approach at the top of Z.
    fn tool_change(&mut self, p: usize, tool: usize, first: [f64; 5]) {
        if self.current_tool == Some(tool) {
            return;
        }
        let planner = self.planner;
        if self.current_tool.is_some() {
            if let Some(c) = self.current {
                let mut top = c;
                top[2] = self.z_top;
                self.steps
                    .push(Step::Move(planner.waypoint(Kind::Rapid, top, Origin::End)));
            }
            self.steps.push(Step::ToolEnd);
        }
        self.steps.push(Step::ToolStart {
            tool,
            rotaries: [first[3], first[4]],
        });
        let approach = planner.along_axis(first, planner.m.retract);
        let start = [approach[0], approach[1], self.z_top, first[3], first[4]];
        self.steps.push(Step::Move(planner.waypoint(
            Kind::Rapid,
            start,
            Origin::Link(p),
        )));
        self.current = Some(start);
        self.current_tool = Some(tool);
    }

    /// Pass `p` with joints `q`: the tool, the link onto it, its points and
    /// the leave.
    fn cut(&mut self, p: usize, pass: &PassPoses, q: &[[f64; 5]]) {
        let (first, last) = (q[0], q[q.len() - 1]);
        self.tool_change(p, pass.tool, first);
        let from = self.current.expect("a tool start sets the position");
        self.steps.push(Step::Pass(p));
        self.planner.link(from, first, p, &mut self.steps);
        for (k, qk) in q.iter().enumerate() {
            // Cut points carry the result's own tip and unit axis.
            let (tip, axis) = pass.poses[k];
            let n = norm(axis);
            self.steps.push(Step::Move(Waypoint {
                kind: Kind::Feed,
                q: *qk,
                tip,
                axis: [axis[0] / n, axis[1] / n, axis[2] / n],
                origin: Origin::Point {
                    label: pass.labels[k].clone(),
                    pass: p,
                },
            }));
        }
        self.current = Some(self.planner.leave(last, p, &mut self.steps));
    }

    /// The final rise to the top of Z travel and the tool's end.
    fn finish(mut self) -> Vec<Step> {
        if let Some(c) = self.current {
            let mut top = c;
            top[2] = top[2].max(self.z_top);
            if top != c {
                self.steps.push(Step::Move(self.planner.waypoint(
                    Kind::Rapid,
                    top,
                    Origin::End,
                )));
            }
        }
        self.steps.push(Step::ToolEnd);
        self.steps
    }
}
