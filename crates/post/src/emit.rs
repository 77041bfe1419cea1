//! The writers: a planned [`Motion`] in the words of each format.
//!
//! TCP formats and APT program the tool tip in the workpiece frame with the
//! rotary positions (APT: the axis vector); the joint formats program the
//! machine's joints. Axis words are modal (a word is written when its
//! printed value changes) and a block that changes nothing is left out.

use super::machine::PostMachine;
use super::motion::{Kind, Motion, Step, Waypoint};
use super::Format;
use toolpath_formats::{Job, PlanResult};
use toolpath_kernel::tools::Tool;

/// What a writer counted.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Written {
    pub text: String,
    pub motion_blocks: usize,
    pub inverse_time_blocks: usize,
}

/// Feed mode of the joint formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum FeedMode {
    /// G93: F is 1/minutes of the block.
    InverseTime,
    /// G94: F is mm/min.
    PerMinute,
}

struct Writer<'a> {
    format: Format,
    pm: &'a PostMachine,
    motion: &'a Motion,
    tool_length: f64,
    feed: f64,
    decimals: usize,
    lines: Vec<String>,
    block_number: u32,
    /// Printed values of X Y Z tilt C (None: unknown, all words are written).
    last: [Option<String>; 5],
    last_kind: Option<Kind>,
    feed_mode: Option<FeedMode>,
    last_f: Option<String>,
    fedrat_written: bool,
    motion_blocks: usize,
    inverse_time_blocks: usize,
}

/// Fixed-point number without a negative zero.
fn fixed(x: f64, decimals: usize) -> String {
    let s = format!("{x:.decimals$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s
    }
}

/// A feed in mm/min: up to 3 decimals, at least one.
fn feed_text(f: f64) -> String {
    let s = format!("{f:.3}");
    let s = s.trim_end_matches('0');
    if s.ends_with('.') {
        format!("{s}0")
    } else {
        s.to_string()
    }
}

/// An inverse-time F with about seven significant digits.
fn inverse_time_text(f: f64) -> String {
    let digits = if f >= 1.0 {
        f.log10().floor() as i32 + 1
    } else {
        1
    };
    fixed(f, (7 - digits).clamp(1, 9) as usize)
}

/// A program name of letters, digits and underscores.
pub fn program_name(job_id: &str) -> String {
    let s: String = job_id
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_uppercase()
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() {
        "PROGRAM".into()
    } else {
        s
    }
}

impl<'a> Writer<'a> {
    fn num(&self, x: f64) -> String {
        let s = fixed(x, self.decimals);
        if self.format == Format::HeidenhainTcpm && !s.starts_with('-') {
            format!("+{s}")
        } else {
            s
        }
    }

    /// A numbered block (Heidenhain always; G-code when line numbers are on).
    fn block(&mut self, text: impl AsRef<str>) {
        let text = text.as_ref();
        let step = self.pm.nc.line_numbers;
        let line = match self.format {
            Format::HeidenhainTcpm => {
                let n = self.block_number;
                self.block_number += 1;
                format!("{n} {text}")
            }
            Format::Apt => text.to_string(),
            _ if step > 0 => {
                self.block_number += step;
                format!("N{} {text}", self.block_number)
            }
            _ => text.to_string(),
        };
        self.lines.push(line);
    }

    fn raw(&mut self, text: impl Into<String>) {
        self.lines.push(text.into());
    }

    fn comment(&mut self, text: &str) {
        match self.format {
            Format::Apt => self.raw(format!("$$ {text}")),
            Format::SinumerikTraori => self.raw(format!("; {text}")),
            Format::HeidenhainTcpm => self.block(format!("; {text}")),
            _ => {
                let t: String = text
                    .chars()
                    .map(|c| match c {
                        '(' => '[',
                        ')' => ']',
                        c => c,
                    })
                    .collect();
                self.raw(format!("({t})"))
            }
        }
    }

    /// Spindle and coolant words, skipping empty ones.
    fn words(list: &[&str]) -> String {
        list.iter()
            .map(|w| w.trim())
            .filter(|w| !w.is_empty())
            .collect::<Vec<_>>()
            .join(" ")
    }

    fn names(&self) -> [&'static str; 5] {
        self.pm.machine.joint_names()
    }

    /// The five printed values of a waypoint (X Y Z tilt C).
    fn values(&self, w: &Waypoint) -> [String; 5] {
        let (x, y, z) = if self.format.is_joint() {
            (w.q[0], w.q[1], w.q[2])
        } else {
            (w.tip[0], w.tip[1], w.tip[2])
        };
        [
            self.num(x),
            self.num(y),
            self.num(z),
            self.num(w.q[3].to_degrees()),
            self.num(w.q[4].to_degrees()),
        ]
    }

    fn header(&mut self, job: &Job, result: &PlanResult, report_line: &str) {
        let f = self.format;
        let name = program_name(&job.job_id);
        match f {
            Format::Apt => self.raw(format!("PARTNO/{name}")),
            Format::FanucTcp | Format::FanucJoint => {
                self.raw("%");
                self.raw(format!("O{} ({name})", self.pm.nc.program_number));
            }
            Format::HeidenhainTcpm => self.block(format!("BEGIN PGM {name} MM")),
            _ => {}
        }
        let m = &self.pm.machine;
        let version = env!("CARGO_PKG_VERSION");
        self.comment(&format!(
            "toolpath_planner {version} post, format {}",
            f.name()
        ));
        self.comment(&format!(
            "job {}: strategy {}, {} passes, {} tool positions",
            job.job_id, result.strategy, self.motion.passes, self.motion.cut_points
        ));
        let names = self.names();
        let frame = if f.is_joint() {
            match m.kinematics {
                toolpath_machines::FiveAxisKind::AcHead => {
                    "X Y Z = the A/C pivot in machine coordinates (zero work offset)"
                }
                _ => "X Y Z = the spindle gauge point in machine coordinates (zero work offset)",
            }
        } else if f == Format::Apt {
            "GOTO = tool tip and unit tool axis in the workpiece frame"
        } else {
            "X Y Z = tool tip in the workpiece frame (origin on the part, rotaries at 0)"
        };
        self.comment(&format!(
            "machine {} ({}): axes {} {} {} {} {}; {frame}",
            m.name,
            m.kinematics.name(),
            names[0],
            names[1],
            names[2],
            names[3],
            names[4],
        ));
        for t in &self.motion.tools {
            let stage = t
                .stage
                .as_ref()
                .map_or(String::new(), |s| format!(" ({s} stage)"));
            self.comment(&format!(
                "T{} {} D{} corner R{} length {}{stage}; spindle offset {} mm",
                t.number,
                t.tool.kind(),
                fixed(2.0 * t.tool.radius(), 4),
                fixed(t.tool.corner_radius(), 4),
                fixed(t.tool.length(), 4),
                fixed(m.spindle_offset(self.tool_length), 4),
            ));
        }
        let (lo, hi) = self.motion.bbox;
        self.comment(&format!(
            "feed {} mm/min along the tool tip; retract {} mm; no rapid below {} mm above the part's box x {}..{} y {}..{} z {}..{}",
            feed_text(self.feed),
            fixed(m.retract, 3),
            fixed(m.retract, 3),
            fixed(lo[0], 3),
            fixed(hi[0], 3),
            fixed(lo[1], 3),
            fixed(hi[1], 3),
            fixed(lo[2], 3),
            fixed(hi[2], 3),
        ));
        self.comment(report_line);
        if f.is_joint() {
            self.comment(
                "feed G93 inverse time on blocks that turn a rotary axis, G94 mm/min otherwise",
            );
        }
        match f {
            Format::Apt => {
                self.raw("UNITS/MM");
                self.raw("MULTAX/ON");
            }
            Format::LinuxcncTcp | Format::LinuxcncJoint | Format::FanucTcp | Format::FanucJoint => {
                self.block("G21 G90 G17 G40 G49 G80 G94")
            }
            Format::SinumerikTraori => self.block("G71 G90 G17 G40 G94"),
            Format::HeidenhainTcpm => {}
        }
    }

    fn safe_z(&mut self) {
        let z = self.num(self.motion.z_top);
        match self.format {
            Format::Apt => {}
            Format::LinuxcncTcp | Format::FanucTcp => self.block(format!("G53 G0 Z{z}")),
            Format::LinuxcncJoint | Format::FanucJoint => {
                if self.last[2].as_deref() != Some(z.as_str()) {
                    self.block(format!("G0 Z{z}"));
                    self.last[2] = Some(z);
                    self.last_kind = Some(Kind::Rapid);
                }
            }
            Format::SinumerikTraori => self.block(format!("G0 SUPA Z{z}")),
            Format::HeidenhainTcpm => self.block(format!("L Z{z} R0 FMAX M91")),
        }
    }

    fn tool_start(&mut self, tool: usize, rotaries: [f64; 2]) {
        let info = &self.motion.tools[tool];
        let n = info.number;
        let nc = self.pm.nc.clone();
        let rpm = feed_text(nc.spindle_rpm);
        let rpm = rpm.trim_end_matches(".0");
        let names = self.names();
        let (a, c) = (
            self.num(rotaries[0].to_degrees()),
            self.num(rotaries[1].to_degrees()),
        );
        self.safe_z();
        match self.format {
            Format::Apt => {
                let t = info.tool;
                let d = 2.0 * t.radius();
                let r = t.corner_radius();
                let (e, f) = match t {
                    Tool::Torus { .. } => (t.radius() - r, r),
                    _ => (0.0, r),
                };
                self.raw(format!(
                    "CUTTER/{},{},{},{},0,0,{}",
                    self.num(d),
                    self.num(r),
                    self.num(e),
                    self.num(f),
                    self.num(t.length())
                ));
                self.raw(format!("LOADTL/{n}"));
                let dir = if nc.spindle_on.trim() == "M4" {
                    "CCLW"
                } else {
                    "CLW"
                };
                self.raw(format!("SPINDL/{rpm},{dir}"));
                if !nc.coolant_on.trim().is_empty() {
                    self.raw("COOLNT/ON");
                }
            }
            Format::HeidenhainTcpm => {
                self.block(format!("TOOL CALL {n} Z S{rpm}"));
                let m = Self::words(&[&nc.spindle_on, &nc.coolant_on]);
                self.block(format!("L {}{a} C{c} R0 FMAX {m}", names[3]));
                self.block("FUNCTION TCPM F TCP AXIS POS PATHCTRL AXIS");
            }
            Format::SinumerikTraori => {
                self.block(format!("T{n}"));
                self.block("M6");
                self.block("D1");
                self.block(format!("S{rpm} {}", nc.spindle_on.trim()));
                if !nc.coolant_on.trim().is_empty() {
                    self.block(nc.coolant_on.trim());
                }
                self.block(format!("G0 {}{a} C{c}", names[3]));
                self.block("TRAORI");
            }
            _ => {
                self.block(format!("T{n} M6"));
                if self.format == Format::LinuxcncTcp {
                    self.block(format!("G43 H{n}"));
                }
                self.block(format!("S{rpm} {}", nc.spindle_on.trim()));
                if !nc.coolant_on.trim().is_empty() {
                    self.block(nc.coolant_on.trim());
                }
                self.block(format!("G0 {}{a} C{c}", names[3]));
                match self.format {
                    Format::LinuxcncTcp => self.block(nc.linuxcnc_tcp_on.trim()),
                    Format::FanucTcp => self.block(format!("G43.4 H{n}")),
                    _ => {}
                }
            }
        }
        self.last_kind = None;
        if self.format.is_joint() {
            self.last[3] = Some(a);
            self.last[4] = Some(c);
        } else {
            // Under TCP the first move writes every axis.
            self.last = Default::default();
        }
    }

    fn tool_end(&mut self) {
        let nc = self.pm.nc.clone();
        match self.format {
            Format::Apt => {
                if !nc.coolant_off.trim().is_empty() {
                    self.raw("COOLNT/OFF");
                }
                self.raw("SPINDL/OFF");
                return;
            }
            Format::LinuxcncTcp => {
                self.block(nc.linuxcnc_tcp_off.trim());
                self.block("G49");
            }
            Format::FanucTcp => self.block("G49"),
            Format::SinumerikTraori => self.block("TRAFOOF"),
            Format::HeidenhainTcpm => self.block("FUNCTION RESET TCPM"),
            Format::LinuxcncJoint | Format::FanucJoint => {}
        }
        if self.format == Format::HeidenhainTcpm {
            let z = self.num(self.motion.z_top);
            let m = Self::words(&[&nc.spindle_off, &nc.coolant_off]);
            self.block(format!("L Z{z} R0 FMAX M91 {m}"));
        } else {
            self.safe_z();
            if !nc.coolant_off.trim().is_empty() {
                self.block(nc.coolant_off.trim());
            }
            self.block(nc.spindle_off.trim());
        }
        self.last = Default::default();
        self.last_kind = None;
    }

    /// 1/minutes of a joint move from `from` to `to` (printed values): the
    /// tool tip's path under joint interpolation at the job's feed; a move that
    /// only turns the rotaries takes them at their velocity limits.
    fn inverse_time(&self, from: &[f64; 5], to: &[f64; 5]) -> f64 {
        let m = &self.pm.machine;
        let turn = (to[3] - from[3]).abs().max((to[4] - from[4]).abs());
        let n = (8 + 2 * turn.to_degrees().ceil() as usize).min(4000);
        let at = |t: f64| {
            let q: [f64; 5] = std::array::from_fn(|j| from[j] + t * (to[j] - from[j]));
            m.forward(self.tool_length, &q).0
        };
        let mut length = 0.0;
        let mut prev = at(0.0);
        for i in 1..=n {
            let p = at(i as f64 / n as f64);
            length +=
                ((p[0] - prev[0]).powi(2) + (p[1] - prev[1]).powi(2) + (p[2] - prev[2]).powi(2))
                    .sqrt();
            prev = p;
        }
        let minutes = if length > 1e-3 {
            length / self.feed
        } else {
            let (lt, lc) = (&m.limits[3], &m.limits[4]);
            ((to[3] - from[3]).abs() / lt.max_velocity)
                .max((to[4] - from[4]).abs() / lc.max_velocity)
                / 60.0
        };
        1.0 / minutes
    }

    fn parse_last(&self) -> Option<[f64; 5]> {
        let mut q = [0.0; 5];
        for (j, v) in self.last.iter().enumerate() {
            let x: f64 = v.as_ref()?.trim_start_matches('+').parse().ok()?;
            q[j] = if j >= 3 { x.to_radians() } else { x };
        }
        Some(q)
    }

    fn apt_move(&mut self, w: &Waypoint) {
        let d = self.decimals;
        let vals = [
            self.num(w.tip[0]),
            self.num(w.tip[1]),
            self.num(w.tip[2]),
            fixed(w.axis[0], d + 2),
            fixed(w.axis[1], d + 2),
            fixed(w.axis[2], d + 2),
        ];
        let text = format!("GOTO/{}", vals.join(","));
        if self.lines.last() == Some(&text) {
            return;
        }
        if self.motion_blocks == 0 {
            self.raw(format!("TLAXIS/{},{},{}", vals[3], vals[4], vals[5]));
        }
        match w.kind {
            Kind::Rapid => self.raw("RAPID"),
            Kind::Feed => {
                if !self.fedrat_written {
                    self.raw(format!("FEDRAT/{},MMPM", feed_text(self.feed)));
                    self.fedrat_written = true;
                }
            }
        }
        self.raw(text);
        self.motion_blocks += 1;
    }

    fn move_to(&mut self, w: &Waypoint) {
        if self.format == Format::Apt {
            return self.apt_move(w);
        }
        let vals = self.values(w);
        let names = self.names();
        let changed: Vec<usize> = (0..5)
            .filter(|&j| self.last[j].as_deref() != Some(vals[j].as_str()))
            .collect();
        if changed.is_empty() {
            return;
        }
        let from = self.parse_last();
        let words: Vec<String> = changed
            .iter()
            .map(|&j| format!("{}{}", names[j], vals[j]))
            .collect();
        let words = words.join(" ");
        for &j in &changed {
            self.last[j] = Some(vals[j].clone());
        }
        let to = self.parse_last();
        self.motion_blocks += 1;
        if self.format == Format::HeidenhainTcpm {
            let text = match w.kind {
                Kind::Rapid => format!("L {words} R0 FMAX"),
                Kind::Feed => {
                    let f = feed_text(self.feed);
                    if self.last_f.as_deref() == Some(f.as_str()) {
                        format!("L {words} R0")
                    } else {
                        self.last_f = Some(f.clone());
                        format!("L {words} R0 F{f}")
                    }
                }
            };
            return self.block(text);
        }
        let g = match w.kind {
            Kind::Rapid => "G0",
            Kind::Feed => "G1",
        };
        let g = if self.last_kind == Some(w.kind) {
            String::new()
        } else {
            format!("{g} ")
        };
        self.last_kind = Some(w.kind);
        if w.kind == Kind::Rapid {
            return self.block(format!("{g}{words}"));
        }
        let (mode, f) = if self.format.is_joint() && (changed.contains(&3) || changed.contains(&4))
        {
            let (Some(a), Some(b)) = (from, to) else {
                unreachable!("a joint program knows every axis before its first feed move")
            };
            self.inverse_time_blocks += 1;
            (
                FeedMode::InverseTime,
                inverse_time_text(self.inverse_time(&a, &b)),
            )
        } else {
            (FeedMode::PerMinute, feed_text(self.feed))
        };
        let mut prefix = String::new();
        if self.format.is_joint() && self.feed_mode != Some(mode) {
            prefix = match mode {
                FeedMode::InverseTime => "G93 ".into(),
                FeedMode::PerMinute => "G94 ".into(),
            };
            self.feed_mode = Some(mode);
            self.last_f = None;
        }
        let f_word = if mode == FeedMode::InverseTime || self.last_f.as_deref() != Some(f.as_str())
        {
            self.last_f = Some(f.clone());
            format!(" F{f}")
        } else {
            String::new()
        };
        self.block(format!("{prefix}{g}{words}{f_word}"));
    }

    fn end(&mut self, job: &Job) {
        match self.format {
            Format::Apt => self.raw("FINI"),
            Format::LinuxcncTcp | Format::LinuxcncJoint => self.block("M2"),
            Format::FanucTcp | Format::FanucJoint => {
                self.block("M30");
                self.raw("%");
            }
            Format::SinumerikTraori => self.block("M30"),
            Format::HeidenhainTcpm => {
                self.block(format!("END PGM {} MM", program_name(&job.job_id)))
            }
        }
    }
}

/// Writes `motion` as a program in `format`.
pub fn write(
    format: Format,
    motion: &Motion,
    job: &Job,
    result: &PlanResult,
    pm: &PostMachine,
    report_line: &str,
) -> Written {
    let mut w = Writer {
        format,
        pm,
        motion,
        tool_length: job.tool_length(),
        feed: job.feed_rate,
        decimals: pm.nc.decimals,
        lines: Vec::new(),
        block_number: 0,
        last: Default::default(),
        last_kind: None,
        feed_mode: None,
        last_f: None,
        fedrat_written: false,
        motion_blocks: 0,
        inverse_time_blocks: 0,
    };
    w.header(job, result, report_line);
    for step in &motion.steps {
        match step {
            Step::ToolStart { tool, rotaries } => w.tool_start(*tool, *rotaries),
            Step::Pass(p) => w.comment(&format!("pass {p}")),
            Step::Move(m) => w.move_to(m),
            Step::ToolEnd => w.tool_end(),
        }
    }
    w.end(job);
    let mut text = w.lines.join("\n");
    text.push('\n');
    Written {
        text,
        motion_blocks: w.motion_blocks,
        inverse_time_blocks: w.inverse_time_blocks,
    }
}
