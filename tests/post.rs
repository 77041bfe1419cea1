//! `toolpath post` replayed. Every program is read back by a small G-code,
//! Heidenhain and APT reader written here (not the writers' code) and run
//! through forward kinematics composed here from the machine definition's
//! YAML (4x4 transforms), then compared block by block with the result:
//! - every cutting point of the result is one block, in order, with no other
//!   block between two points of a pass: joint formats within 0.001 mm and
//!   0.001 deg, TCP formats and APT exact to the printed decimals;
//! - in G93 blocks the tool tip, followed along the joints' linear
//!   interpolation, moves at the job's feed within 0.5 %; G94 feed blocks
//!   turn no rotary axis and run at the job's feed;
//! - no rapid move, followed along the controller's interpolation (joint
//!   formats: joints linear; TCP: tip and rotaries linear), brings the tip
//!   closer than the retract distance above the highest corner of the part's
//!   box (surface control net, or pocket outline at z = 0) as the part sits
//!   at that moment (APT rapids are checked on the head, where the part
//!   stands still);
//! - no rotary step exceeds 180 deg and every programmed axis stays within
//!   its travel;
//!
//! and bad input exits with 2 and a message naming what is wrong.

use nalgebra::{Matrix4, Rotation3, Translation3, Vector3, Vector4};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use toolpath_planner::formats::{self, Job, Pass, PathPoint, PlanResult, Shape, Strategy};
use toolpath_planner::pipeline::{self, RunOptions};
use toolpath_planner::planners::NoProgress;
use toolpath_planner::post::{self, Format, PostMachine};
use toolpath_planner::samples;

const FORMATS: [&str; 7] = [
    "apt",
    "linuxcnc-tcp",
    "fanuc-tcp",
    "sinumerik-traori",
    "heidenhain-tcpm",
    "linuxcnc-joint",
    "fanuc-joint",
];

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap()
}

/// A B/C table machine written here (B about +y, offset axes).
const BC_TABLE: &str = "name: bc_test
kinematics: bc_table
workpiece_origin_mm: [15.0, -10.0, 60.0]
tilt_axis_point_mm: [0.0, 0.0, 150.0]
c_axis_point_mm: [20.0, 5.0, 0.0]
retract_mm: 8.0
max_feed_rate_mm_min: 8000.0
x: {min_mm: -800.0, max_mm: 800.0, max_velocity_mm_s: 500.0, max_acceleration_mm_s2: 3000.0}
y: {min_mm: -800.0, max_mm: 800.0, max_velocity_mm_s: 500.0, max_acceleration_mm_s2: 3000.0}
z: {min_mm: -400.0, max_mm: 1000.0, max_velocity_mm_s: 400.0, max_acceleration_mm_s2: 3000.0}
b: {min_deg: -45.0, max_deg: 110.0, max_velocity_deg_s: 60.0, max_acceleration_deg_s2: 300.0}
c: {min_deg: -720.0, max_deg: 720.0, max_velocity_deg_s: 120.0, max_acceleration_deg_s2: 600.0}
nc:
  line_numbers: 5
";

/// The shipped mill5 with 3 decimals and block numbers (TCP formats and APT only:
/// 3 decimals cannot hold a joint program's tip within 0.001 mm).
fn mill5_3_decimals() -> String {
    read(&repo("launch_configs/machines/mill5.yaml"))
        .replace("decimals: 4", "decimals: 3")
        .replace("line_numbers: 0", "line_numbers: 10")
}

// ---------------------------------------------------------------------------
// The machine, read from its YAML, and its forward kinematics.

#[derive(Clone, Debug)]
struct Mach {
    kind: String,
    pivot: f64,
    origin: [f64; 3],
    tilt_point: [f64; 3],
    c_point: [f64; 3],
    retract: f64,
    /// X Y Z (mm) tilt C (deg).
    limits: [(f64, f64); 5],
    decimals: usize,
    tilt: char,
}

fn mach(yaml: &str) -> Mach {
    let v: serde_yaml_ng::Value = serde_yaml_ng::from_str(yaml).unwrap();
    let p3 = |k: &str| -> [f64; 3] {
        match v[k].as_sequence() {
            Some(s) => [
                s[0].as_f64().unwrap(),
                s[1].as_f64().unwrap(),
                s[2].as_f64().unwrap(),
            ],
            None => [0.0; 3],
        }
    };
    let kind = v["kinematics"].as_str().unwrap().to_string();
    let tilt = if kind == "bc_table" { 'b' } else { 'a' };
    let lim = |axis: &str, unit: &str| {
        (
            v[axis][format!("min_{unit}").as_str()].as_f64().unwrap(),
            v[axis][format!("max_{unit}").as_str()].as_f64().unwrap(),
        )
    };
    Mach {
        pivot: v["pivot_length_mm"].as_f64().unwrap_or(0.0),
        origin: p3("workpiece_origin_mm"),
        tilt_point: p3("tilt_axis_point_mm"),
        c_point: p3("c_axis_point_mm"),
        retract: v["retract_mm"].as_f64().unwrap(),
        limits: [
            lim("x", "mm"),
            lim("y", "mm"),
            lim("z", "mm"),
            lim(&tilt.to_string(), "deg"),
            lim("c", "deg"),
        ],
        decimals: v["nc"]["decimals"].as_u64().unwrap_or(4) as usize,
        tilt,
        kind,
    }
}

fn tr(p: [f64; 3]) -> Matrix4<f64> {
    Translation3::new(p[0], p[1], p[2]).to_homogeneous()
}

fn rot(axis: char, deg: f64) -> Matrix4<f64> {
    let a = match axis {
        'x' => Vector3::x_axis(),
        'y' => Vector3::y_axis(),
        _ => Vector3::z_axis(),
    };
    Rotation3::from_axis_angle(&a, deg.to_radians()).to_homogeneous()
}

fn neg(p: [f64; 3]) -> [f64; 3] {
    [-p[0], -p[1], -p[2]]
}

fn pt(m: &Matrix4<f64>, p: [f64; 3]) -> [f64; 3] {
    let v = m * Vector4::new(p[0], p[1], p[2], 1.0);
    [v.x, v.y, v.z]
}

fn dir(m: &Matrix4<f64>, d: [f64; 3]) -> [f64; 3] {
    let v = m * Vector4::new(d[0], d[1], d[2], 0.0);
    [v.x, v.y, v.z]
}

impl Mach {
    fn is_head(&self) -> bool {
        self.kind == "ac_head"
    }

    /// Part -> machine with the rotaries at (tilt, C) degrees.
    fn part(&self, t: f64, c: f64) -> Matrix4<f64> {
        if self.is_head() {
            return tr(self.origin);
        }
        let axis = if self.tilt == 'b' { 'y' } else { 'x' };
        tr(self.tilt_point)
            * rot(axis, t)
            * tr(neg(self.tilt_point))
            * tr(self.c_point)
            * rot('z', c)
            * tr(neg(self.c_point))
            * tr(self.origin)
    }

    /// Joints (mm, deg) -> tip and axis in the part, tip in the machine.
    fn fk(&self, l: f64, q: [f64; 5]) -> ([f64; 3], [f64; 3], [f64; 3]) {
        if self.is_head() {
            let m = tr([q[0], q[1], q[2]])
                * rot('z', q[4])
                * rot('x', q[3])
                * tr([0.0, 0.0, -(self.pivot + l)]);
            let tip_m = pt(&m, [0.0; 3]);
            let axis = dir(&m, [0.0, 0.0, 1.0]);
            let o = self.origin;
            return (
                [tip_m[0] - o[0], tip_m[1] - o[1], tip_m[2] - o[2]],
                axis,
                tip_m,
            );
        }
        let tip_m = [q[0], q[1], q[2] - l];
        let inv = self.part(q[3], q[4]).try_inverse().unwrap();
        (pt(&inv, tip_m), dir(&inv, [0.0, 0.0, 1.0]), tip_m)
    }

    fn axis_of(&self, t: f64, c: f64) -> [f64; 3] {
        self.fk(0.0, [0.0, 0.0, 0.0, t, c]).1
    }

    /// How far the machine tip `tip_m` is above the clearance (retract above
    /// the highest box corner) with the rotaries at (t, c).
    fn gap(&self, corners: &[[f64; 3]], t: f64, c: f64, tip_m: [f64; 3]) -> f64 {
        let p = self.part(t, c);
        let top = corners
            .iter()
            .map(|k| pt(&p, *k)[2])
            .fold(f64::NEG_INFINITY, f64::max);
        tip_m[2] - top - self.retract
    }
}

// ---------------------------------------------------------------------------
// The reader.

#[derive(Clone, Copy, Debug, PartialEq)]
enum Mo {
    Rapid,
    Feed,
}

#[derive(Clone, Debug)]
struct Blk {
    line: usize,
    mo: Mo,
    /// X Y Z tilt C after the block (None: not known in program coordinates).
    pos: [Option<f64>; 5],
    /// APT tool axis.
    ijk: Option<[f64; 3]>,
    /// Modal F, and whether the block carries one.
    f: Option<f64>,
    f_here: bool,
    g93: bool,
}

/// The GOTO blocks of an APT program, with the feed and RAPID before them.
fn read_apt(text: &str) -> Vec<Blk> {
    let mut out = Vec::new();
    let mut f: Option<f64> = None;
    let mut rapid_next = false;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let l = raw.trim();
        if l == "RAPID" {
            rapid_next = true;
        } else if let Some(v) = l.strip_prefix("FEDRAT/") {
            f = Some(v.split(',').next().unwrap().parse().unwrap());
        } else if let Some(v) = l.strip_prefix("GOTO/") {
            let n: Vec<f64> = v.split(',').map(|s| s.parse().unwrap()).collect();
            assert_eq!(n.len(), 6, "line {line_no}: {l}");
            out.push(Blk {
                line: line_no,
                mo: if rapid_next { Mo::Rapid } else { Mo::Feed },
                pos: [Some(n[0]), Some(n[1]), Some(n[2]), None, None],
                ijk: Some([n[3], n[4], n[5]]),
                f,
                f_here: false,
                g93: false,
            });
            rapid_next = false;
        }
    }
    out
}

/// A block without its comments: ( ... ) and ; to the end of the line.
fn code_of(raw: &str) -> String {
    let mut code = String::new();
    let mut depth = 0;
    for ch in raw.chars() {
        match ch {
            ';' if depth == 0 => break,
            '(' => depth += 1,
            ')' => depth -= 1,
            c if depth == 0 => code.push(c),
            _ => {}
        }
    }
    code
}

/// The blocks of a G-code program (or of an APT one, by `read_apt`), with
/// the modal state carried from block to block; one loop, as a control
/// reads it, because the modal state spans every block.
fn read_program(text: &str, format: &str, tilt: char) -> Vec<Blk> {
    if format == "apt" {
        return read_apt(text);
    }
    let tilt = tilt.to_ascii_uppercase();
    let mut out = Vec::new();
    let mut pos: [Option<f64>; 5] = [None; 5];
    let mut mo = Mo::Rapid;
    let mut f: Option<f64> = None;
    let mut g93 = false;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let code = code_of(raw);
        let mut tokens: Vec<&str> = code.split_whitespace().collect();
        if format == "heidenhain-tcpm" {
            assert!(
                tokens.first().is_none_or(|t| t.parse::<u64>().is_ok()),
                "line {line_no}: a Heidenhain block starts with its number: {raw}"
            );
            if !tokens.is_empty() {
                tokens.remove(0);
            }
            let rest = tokens.join(" ");
            if rest.starts_with("FUNCTION") {
                // TCPM on or off: X Y Z change meaning.
                pos[0] = None;
                pos[1] = None;
                pos[2] = None;
                continue;
            }
            if tokens.first() != Some(&"L") {
                continue;
            }
            tokens.remove(0);
        } else if tokens
            .first()
            .is_some_and(|t| t.starts_with('O') || *t == "%")
        {
            continue;
        }
        let mut machine = false;
        let mut axis_word = false;
        let mut f_here = false;
        let mut block_mo = None;
        let mut tcp_switch = false;
        for tok in tokens {
            match tok {
                "SUPA" => machine = true,
                "TRAORI" | "TRAFOOF" => tcp_switch = true,
                "FMAX" => block_mo = Some(Mo::Rapid),
                "R0" => {}
                _ => {
                    let (letter, rest) = tok.split_at(1);
                    match letter {
                        "N" | "T" | "S" | "D" | "H" => {}
                        "G" => match rest {
                            "0" => mo = Mo::Rapid,
                            "1" => mo = Mo::Feed,
                            "93" => g93 = true,
                            "94" => g93 = false,
                            "53" => machine = true,
                            "43.4" | "49" => tcp_switch = true,
                            _ => {}
                        },
                        "M" => match rest {
                            "91" => machine = true,
                            "428" | "429" => tcp_switch = true,
                            _ => {}
                        },
                        "F" => {
                            f = Some(rest.parse().unwrap());
                            f_here = true;
                        }
                        _ => {
                            let c = letter.chars().next().unwrap();
                            let k = match c {
                                'X' => 0,
                                'Y' => 1,
                                'Z' => 2,
                                'C' => 4,
                                c if c == tilt => 3,
                                _ => panic!("line {line_no}: unexpected word {tok} in {raw}"),
                            };
                            pos[k] =
                                Some(rest.parse().unwrap_or_else(|_| {
                                    panic!("line {line_no}: bad number {tok}")
                                }));
                            axis_word = true;
                        }
                    }
                }
            }
        }
        if tcp_switch {
            pos[0] = None;
            pos[1] = None;
            pos[2] = None;
        }
        if format == "heidenhain-tcpm" {
            mo = block_mo.unwrap_or(Mo::Feed);
        }
        if machine {
            // A move in machine coordinates: the program position is unknown after it.
            pos[0] = None;
            pos[1] = None;
            pos[2] = None;
            continue;
        }
        if axis_word {
            out.push(Blk {
                line: line_no,
                mo,
                pos,
                ijk: None,
                f,
                f_here,
                g93,
            });
        }
    }
    out
}

// ---------------------------------------------------------------------------
// The replay.

#[derive(Clone, Debug)]
struct Pose {
    line: usize,
    mo: Mo,
    tip: [f64; 3],
    axis: [f64; 3],
    /// Printed values: joints, or tip and rotaries (APT: rotaries 0).
    q: [f64; 5],
    has_angles: bool,
    f: Option<f64>,
    f_here: bool,
    g93: bool,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

fn unit(a: [f64; 3]) -> [f64; 3] {
    let n = norm(a);
    [a[0] / n, a[1] / n, a[2] / n]
}

fn angle_deg(a: [f64; 3], b: [f64; 3]) -> f64 {
    let (a, b) = (unit(a), unit(b));
    let c = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    norm(c)
        .atan2(a[0] * b[0] + a[1] * b[1] + a[2] * b[2])
        .to_degrees()
}

fn lerp5(a: &[f64; 5], b: &[f64; 5], t: f64) -> [f64; 5] {
    std::array::from_fn(|j| a[j] + t * (b[j] - a[j]))
}

/// The part's box corners from the job: control net or pocket outline at z = 0.
fn corners(job: &Job) -> Vec<[f64; 3]> {
    let pts: Vec<[f64; 3]> = match &job.shape {
        Shape::Surface(s) => s.control_grid().into_iter().flatten().collect(),
        Shape::Pocket(p) => p.outer.iter().map(|q| [q[0], q[1], 0.0]).collect(),
    };
    let lo: [f64; 3] =
        std::array::from_fn(|k| pts.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min));
    let hi: [f64; 3] =
        std::array::from_fn(|k| pts.iter().map(|p| p[k]).fold(f64::NEG_INFINITY, f64::max));
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

/// The result's passes as (tip, unit axis) lists.
fn result_passes(result: &PlanResult) -> Vec<Vec<([f64; 3], [f64; 3])>> {
    if let Some(tools) = &result.tools {
        return tools
            .iter()
            .flat_map(|t| &t.passes)
            .map(|p| {
                p.iter()
                    .map(|xy| ([xy[0], xy[1], 0.0], [0.0, 0.0, 1.0]))
                    .collect()
            })
            .collect();
    }
    result
        .passes
        .iter()
        .map(|p| p.points.iter().map(|q| (q.cl, unit(q.axis))).collect())
        .collect()
}

/// Replays `text` and returns what is wrong with it (empty: nothing): the
/// axis limits and rotary steps of every block, rapids against the
/// clearance, feeds (G93 by the tip's length), then the result's points.
fn replay(text: &str, format: &str, m: &Mach, job: &Job, result: &PlanResult) -> Vec<String> {
    let mut bad = Vec::new();
    let l = job.tool_length();
    let feed = job.feed_rate;
    let joint = format.ends_with("-joint");
    let apt = format == "apt";
    let d = m.decimals as i32;
    let half = 0.5 * 10f64.powi(-d) + 1e-9;
    let blocks = read_program(text, format, m.tilt);
    let poses: Vec<Option<Pose>> = blocks
        .iter()
        .map(|b| pose_of(b, m, l, joint, apt))
        .collect();
    let corners = corners(job);
    // The machine tip and rotaries at parameter t of the move a -> b.
    let at = |a: &Pose, b: &Pose, t: f64| -> ([f64; 3], f64, f64) {
        let q = lerp5(&a.q, &b.q, t);
        if joint {
            let (_, _, tip_m) = m.fk(l, q);
            (tip_m, q[3], q[4])
        } else {
            let tip_m = pt(&m.part(q[3], q[4]), [q[0], q[1], q[2]]);
            (tip_m, q[3], q[4])
        }
    };
    for w in 0..poses.len() {
        let Some(b) = &poses[w] else { continue };
        if b.has_angles {
            for (j, &(lo, hi)) in m.limits.iter().enumerate() {
                if (j >= 3 || joint) && (b.q[j] < lo - 1e-9 || b.q[j] > hi + 1e-9) {
                    bad.push(format!(
                        "line {}: axis {j} = {} outside {lo}..{hi}",
                        b.line, b.q[j]
                    ));
                }
            }
        }
        let Some(Some(a)) = w.checked_sub(1).map(|k| &poses[k]) else {
            continue;
        };
        if b.has_angles {
            for j in [3, 4] {
                if (b.q[j] - a.q[j]).abs() > 180.0 {
                    bad.push(format!(
                        "line {}: rotary step {} deg",
                        b.line,
                        b.q[j] - a.q[j]
                    ));
                }
            }
        }
        match b.mo {
            Mo::Rapid => {
                if apt && !m.is_head() {
                    continue;
                }
                for i in 0..=64 {
                    let (tip_m, t, c) = at(a, b, i as f64 / 64.0);
                    let g = m.gap(&corners, t, c, tip_m);
                    if g < -1e-3 {
                        bad.push(format!(
                            "line {}: a rapid passes {:.4} mm below the clearance",
                            b.line, -g
                        ));
                        break;
                    }
                }
            }
            Mo::Feed if joint && b.g93 => {
                if !b.f_here {
                    bad.push(format!("line {}: a G93 block without F", b.line));
                    continue;
                }
                let n = 256;
                let mut length = 0.0;
                let mut prev = m.fk(l, a.q).0;
                for i in 1..=n {
                    let p = m.fk(l, lerp5(&a.q, &b.q, i as f64 / n as f64)).0;
                    length += norm(sub(p, prev));
                    prev = p;
                }
                let minutes = 1.0 / b.f.unwrap();
                if length > 2e-3 && (length / minutes / feed - 1.0).abs() > 0.005 {
                    bad.push(format!(
                        "line {}: the tip moves at {:.2} mm/min in a G93 block, not {feed}",
                        b.line,
                        length / minutes
                    ));
                }
            }
            Mo::Feed => {
                if b.f != Some(feed) {
                    bad.push(format!("line {}: feed {:?}, not {feed}", b.line, b.f));
                }
                if joint && (b.q[3] != a.q[3] || b.q[4] != a.q[4]) {
                    bad.push(format!("line {}: a G94 block turns a rotary axis", b.line));
                }
            }
        }
    }
    // Every result point, in order, one block each.
    let matches = |p: &Pose, (tip, axis): &([f64; 3], [f64; 3])| -> bool {
        if p.mo != Mo::Feed {
            return false;
        }
        if joint {
            norm(sub(p.tip, *tip)) <= 1e-3 && angle_deg(p.axis, *axis) <= 1e-3
        } else {
            let tip_ok = (0..3).all(|k| (p.tip[k] - tip[k]).abs() <= half);
            let axis_ok = if apt {
                let h = 0.5 * 10f64.powi(-(d + 2)) + 1e-12;
                (0..3).all(|k| (p.axis[k] - axis[k]).abs() <= h)
            } else {
                angle_deg(p.axis, *axis) <= 2.0 * half + 1e-9
            };
            tip_ok && axis_ok
        }
    };
    let known: Vec<&Pose> = poses.iter().flatten().collect();
    follow_passes(&known, &result_passes(result), matches, &mut bad);
    bad
}

/// The tool pose a block commands: tip and unit axis in the workpiece (by
/// the machine's forward kinematics for joint formats); None while the
/// program position is unknown.
fn pose_of(b: &Blk, m: &Mach, l: f64, joint: bool, apt: bool) -> Option<Pose> {
    if apt {
        let (Some(x), Some(y), Some(z)) = (b.pos[0], b.pos[1], b.pos[2]) else {
            return None;
        };
        return Some(Pose {
            line: b.line,
            mo: b.mo,
            tip: [x, y, z],
            // As printed: compared with the result's unit axis component by component.
            axis: b.ijk.unwrap(),
            q: [x, y, z, 0.0, 0.0],
            has_angles: false,
            f: b.f,
            f_here: b.f_here,
            g93: b.g93,
        });
    }
    let q: Vec<f64> = b.pos.iter().copied().collect::<Option<Vec<f64>>>()?;
    let q = [q[0], q[1], q[2], q[3], q[4]];
    let (tip, axis) = if joint {
        let (tip, axis, _) = m.fk(l, q);
        (tip, axis)
    } else {
        ([q[0], q[1], q[2]], m.axis_of(q[3], q[4]))
    };
    Some(Pose {
        line: b.line,
        mo: b.mo,
        tip,
        axis,
        q,
        has_angles: true,
        f: b.f,
        f_here: b.f_here,
        g93: b.g93,
    })
}

/// Every result point, in order, matches a block: the same or the next one.
fn follow_passes(
    known: &[&Pose],
    passes: &[Vec<([f64; 3], [f64; 3])>],
    matches: impl Fn(&Pose, &([f64; 3], [f64; 3])) -> bool,
    bad: &mut Vec<String>,
) {
    let mut k = 0;
    'passes: for (p, pass) in passes.iter().enumerate() {
        while k < known.len() && !matches(known[k], &pass[0]) {
            k += 1;
        }
        if k == known.len() {
            bad.push(format!(
                "pass {p}: its first point {:?} is in no block",
                pass[0]
            ));
            break;
        }
        for (j, point) in pass.iter().enumerate().skip(1) {
            if k + 1 < known.len() && matches(known[k + 1], point) {
                k += 1;
            } else if !matches(known[k], point) {
                bad.push(format!(
                    "pass {p} point {j} {point:?}: the block after line {} is line {} at {:?} {:?}",
                    known[k].line,
                    known.get(k + 1).map_or(0, |b| b.line),
                    known.get(k + 1).map(|b| b.tip),
                    known.get(k + 1).map(|b| b.axis),
                ));
                break 'passes;
            }
        }
        k += 1;
    }
}

// ---------------------------------------------------------------------------
// Cases.

struct Case {
    name: &'static str,
    job: Job,
    result: PlanResult,
}

fn plan(sample: &'static str, strategy: Option<Strategy>) -> Case {
    let mut job = samples::job(sample).unwrap();
    if let Some(s) = strategy {
        job.strategy = s;
    }
    let result = pipeline::run(&job, &NoProgress, RunOptions::PLAN_ONLY).unwrap();
    Case {
        name: sample,
        job,
        result,
    }
}

fn cases() -> &'static [Case] {
    static CASES: OnceLock<Vec<Case>> = OnceLock::new();
    CASES.get_or_init(|| {
        std::thread::scope(|s| {
            let h = [
                s.spawn(|| plan("plane", None)),
                s.spawn(|| plan("concave_cylinder", Some(Strategy::IsoScallop))),
                s.spawn(|| plan("monkey_saddle", Some(Strategy::IsoParametric))),
                s.spawn(|| plan("die_saddle", None)),
                s.spawn(|| plan("pocket_with_hole", None)),
            ];
            h.into_iter().map(|h| h.join().unwrap()).collect()
        })
    })
}

fn post_text(case: &Case, machine_yaml: &str, format: &str) -> Result<String, String> {
    let pm = PostMachine::parse(machine_yaml).map_err(|e| e.to_string())?;
    post::post(&case.job, &case.result, &pm, Format::parse(format).unwrap())
        .map(|p| p.text)
        .map_err(|e| e.to_string())
}

fn check_all(machines: &[(&str, String)], formats: &[&str], samples: &[&str]) {
    let mut failures = Vec::new();
    let mut programs = 0;
    for case in cases().iter().filter(|c| samples.contains(&c.name)) {
        for (mname, yaml) in machines {
            let m = mach(yaml);
            for &f in formats {
                match post_text(case, yaml, f) {
                    Err(e) => failures.push(format!("{} / {mname} / {f}: {e}", case.name)),
                    Ok(text) => {
                        programs += 1;
                        for e in replay(&text, f, &m, &case.job, &case.result)
                            .into_iter()
                            .take(5)
                        {
                            failures.push(format!("{} / {mname} / {f}: {e}", case.name));
                        }
                    }
                }
            }
        }
    }
    assert!(programs > 0);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

const ALL_SAMPLES: [&str; 5] = [
    "plane",
    "concave_cylinder",
    "monkey_saddle",
    "die_saddle",
    "pocket_with_hole",
];

#[test]
fn every_format_replays_on_the_mill5_head() {
    let head = read(&repo("launch_configs/machines/mill5.yaml"));
    check_all(&[("mill5", head)], &FORMATS, &ALL_SAMPLES);
}

#[test]
fn every_format_replays_on_the_a_c_trunnion() {
    let table = read(&repo("launch_configs/machines/trunnion_ac.yaml"));
    check_all(&[("trunnion_ac", table)], &FORMATS, &ALL_SAMPLES);
}

#[test]
fn every_format_replays_on_a_b_c_table_with_offset_axes() {
    check_all(&[("bc_test", BC_TABLE.to_string())], &FORMATS, &ALL_SAMPLES);
}

#[test]
fn tcp_formats_hold_to_three_printed_decimals_with_block_numbers() {
    let formats: Vec<&str> = FORMATS
        .iter()
        .copied()
        .filter(|f| !f.ends_with("-joint"))
        .collect();
    check_all(
        &[("mill5 3 decimals", mill5_3_decimals())],
        &formats,
        &["plane", "monkey_saddle"],
    );
    let text = post_text(&cases()[0], &mill5_3_decimals(), "fanuc-tcp").unwrap();
    assert!(
        text.contains("\nN10 G21 ") && text.contains(" Z0.218\n"),
        "{}",
        &text[..800]
    );
}

/// A result written here: a pass whose axis precesses through 330 deg of
/// azimuth at 30 deg tilt, one that tilts from +x through vertical to -x, and
/// one that starts vertical and then tilts towards +y.
fn rotary_result() -> (Job, PlanResult) {
    let job = samples::job("plane").unwrap();
    let mut r = PlanResult::new(&job.job_id, job.strategy.name());
    let point = |cl: [f64; 3], axis: [f64; 3]| PathPoint {
        cc: cl,
        cl,
        axis,
        ..Default::default()
    };
    let tilt = 30f64.to_radians();
    let precess = (0..=165)
        .map(|k| {
            let az = (120.0 + 2.0 * k as f64).to_radians();
            point(
                [50.0 + 20.0 * az.cos(), 50.0 + 20.0 * az.sin(), 5.0],
                [tilt.sin() * az.cos(), tilt.sin() * az.sin(), tilt.cos()],
            )
        })
        .collect();
    let through_vertical = (-20..=20)
        .map(|k| {
            let s = (k as f64 * 1.5).to_radians();
            point([50.0 + k as f64, 20.0, 3.0], [s.sin(), 0.0, s.cos()])
        })
        .collect();
    let from_vertical = (0..=20)
        .map(|k| {
            let s = (k.max(5) as f64 - 5.0).to_radians() * 2.0;
            point([20.0, 10.0 + 3.0 * k as f64, 2.0], [0.0, s.sin(), s.cos()])
        })
        .collect();
    for points in [precess, through_vertical, from_vertical] {
        r.passes.push(Pass {
            region: 0,
            points,
            min_strip_width: None,
        });
    }
    (job, r)
}

#[test]
fn rotaries_unwrap_hold_c_at_vertical_and_keep_one_branch_per_pass() {
    let (job, result) = rotary_result();
    let yaml = read(&repo("launch_configs/machines/mill5.yaml"));
    let m = mach(&yaml);
    let case = Case {
        name: "rotary",
        job,
        result,
    };
    for f in FORMATS {
        let text = post_text(&case, &yaml, f).unwrap();
        let bad = replay(&text, f, &m, &case.job, &case.result);
        assert!(bad.is_empty(), "{f}: {}", bad.join("\n"));
    }
    // Joint values of the cutting blocks, pass by pass (3 passes).
    let text = post_text(&case, &yaml, "linuxcnc-joint").unwrap();
    let blocks = read_program(&text, "linuxcnc-joint", 'a');
    let passes = result_passes(&case.result);
    let cut: Vec<[f64; 5]> = blocks
        .iter()
        .filter(|b| b.mo == Mo::Feed)
        .filter_map(|b| {
            let q: Option<Vec<f64>> = b.pos.iter().copied().collect();
            q.map(|q| [q[0], q[1], q[2], q[3], q[4]])
        })
        .filter(|q| {
            let (tip, axis, _) = m.fk(case.job.tool_length(), *q);
            passes
                .iter()
                .flatten()
                .any(|p| norm(sub(p.0, tip)) < 1e-3 && angle_deg(p.1, axis) < 1e-3)
        })
        .collect();
    assert_eq!(cut.len(), 166 + 41 + 21);
    // Pass 0: C runs 330 deg (across +-180) without a jump, A stays on one branch.
    let c: Vec<f64> = cut[..166].iter().map(|q| q[4]).collect();
    assert!(
        (c[165] - c[0]).abs() > 329.9 && (c[165] - c[0]).abs() < 330.1,
        "{c:?}"
    );
    assert!(c.windows(2).all(|w| (w[1] - w[0]).abs() < 2.01));
    assert!(cut[..166]
        .iter()
        .all(|q| (q[3].abs() - 30.0).abs() < 1e-3 && q[3].signum() == cut[0][3].signum()));
    // Pass 1: A goes through 0 and changes sign; C holds.
    let p1 = &cut[166..207];
    assert!(p1.iter().all(|q| q[4] == p1[0][4]), "C moves: {p1:?}");
    assert!(p1[0][3] * p1[40][3] < 0.0 && p1[20][3] == 0.0);
    // Pass 2 starts vertical with C already where its first tilted pose needs it.
    let p2 = &cut[207..];
    assert!(p2.iter().all(|q| q[4] == p2[0][4]), "C moves: {p2:?}");
    assert_eq!(p2[0][3], 0.0);
}

// ---------------------------------------------------------------------------
// The command line.

fn toolpath() -> Command {
    Command::new(env!("CARGO_BIN_EXE_toolpath"))
}

fn write_case(dir: &Path, job: &Job, result: &PlanResult) -> (PathBuf, PathBuf) {
    let job_path = dir.join("job.json");
    let file = formats::JobFile {
        surface: job.shape.to_json(),
        scallop: job.scallop,
        tolerance: job.tolerance,
        lead_angle_deg: job.lead_angle_deg,
        side_tilt_deg: job.side_tilt_deg,
        feed_direction: job.feed_direction,
        feed_rate: Some(job.feed_rate),
        ..formats::JobFile::new(&job.job_id, job.strategy, job.tool)
    };
    std::fs::write(&job_path, serde_json::to_string(&file).unwrap()).unwrap();
    let result_path = dir.join("result.json");
    formats::write_json(&result_path, result).unwrap();
    (job_path, result_path)
}

fn run(args: &[&str]) -> (i32, String, String) {
    let out = toolpath().args(args).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn the_command_writes_the_same_bytes_twice_and_reports_the_largest_rotary_step() {
    let dir = tempfile::tempdir().unwrap();
    let case = &cases()[2];
    let (job, result) = write_case(dir.path(), &case.job, &case.result);
    let (a, b) = (dir.path().join("a.nc"), dir.path().join("b.nc"));
    let machine = repo("launch_configs/machines/trunnion_ac.yaml");
    let mut outputs = Vec::new();
    for out in [&a, &b] {
        let (code, stdout, stderr) = run(&[
            "post",
            result.to_str().unwrap(),
            "--job",
            job.to_str().unwrap(),
            "--machine",
            machine.to_str().unwrap(),
            "--format",
            "fanuc-joint",
            "-o",
            out.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{stderr}");
        assert!(stdout.contains("largest rotary step"), "{stdout}");
        outputs.push(std::fs::read(out).unwrap());
    }
    assert_eq!(outputs[0], outputs[1]);
    let text = String::from_utf8(outputs.remove(0)).unwrap();
    assert_eq!(
        text,
        post_text(case, &read(&machine), "fanuc-joint").unwrap()
    );
    assert!(
        text.starts_with("%\nO2000 (MONKEY_SADDLE_JOB)\n"),
        "{}",
        &text[..200]
    );
    assert!(text.contains("\nG93 ") && text.contains("\nG94 "));
    // The cell config reads as its mill5 head.
    let (code, stdout, stderr) = run(&[
        "post",
        result.to_str().unwrap(),
        "--job",
        job.to_str().unwrap(),
        "--machine",
        repo("launch_configs/cell_b.yaml").to_str().unwrap(),
        "--format",
        "heidenhain-tcpm",
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.starts_with("0 BEGIN PGM MONKEY_SADDLE_JOB MM\n"),
        "{}",
        &stdout[..100]
    );
    assert!(stderr.contains("for machine mill5"), "{stderr}");
}

#[test]
fn bad_input_exits_2_with_a_message_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let case = &cases()[0];
    let (job, result) = write_case(dir.path(), &case.job, &case.result);
    let (job, result) = (job.to_str().unwrap(), result.to_str().unwrap());
    let post = |extra: &[&str]| {
        let mut args = vec!["post"];
        args.extend_from_slice(extra);
        run(&args)
    };
    // Unknown format.
    let (code, _, err) = post(&[result, "--job", job, "--format", "mazak"]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("unknown format \"mazak\": expected one of apt, linuxcnc-tcp"),
        "{err}"
    );
    // A machine definition without its C axis.
    let yaml = read(&repo("launch_configs/machines/trunnion_ac.yaml"));
    let no_c: String = yaml
        .lines()
        .filter(|l| !l.starts_with("c:"))
        .map(|l| format!("{l}\n"))
        .collect();
    let machine = dir.path().join("no_c.yaml");
    std::fs::write(&machine, no_c).unwrap();
    let (code, _, err) = post(&[
        result,
        "--job",
        job,
        "--machine",
        machine.to_str().unwrap(),
        "--format",
        "apt",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("no_c.yaml: c: missing: ac_table kinematics needs the axes x, y, z, a, c"),
        "{err}"
    );
    // A belt result.
    let belt_dir = dir.path().join("belt");
    std::fs::create_dir(&belt_dir).unwrap();
    let belt_job = samples::job("sine_wave").unwrap();
    let mut belt_result = PlanResult::new(&belt_job.job_id, belt_job.strategy.name());
    belt_result.machine = Some("belt6".into());
    belt_result.passes.push(Pass {
        region: 0,
        points: vec![PathPoint {
            axis: [1.0, 0.0, 0.0],
            ..Default::default()
        }],
        min_strip_width: None,
    });
    let (bj, br) = write_case(&belt_dir, &belt_job, &belt_result);
    let (code, _, err) = post(&[
        br.to_str().unwrap(),
        "--job",
        bj.to_str().unwrap(),
        "--format",
        "linuxcnc-tcp",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("a belt_iso_planar result drives the belt6 grinder, not a mill"),
        "{err}"
    );
    // A pose outside the travel: 100 deg of tilt on the head (A within +-95),
    // 125 deg on the trunnion (A -120..30).
    let mut steep = case.result.clone();
    let t = 100f64.to_radians();
    steep.passes[3].points[7].axis = [t.sin(), 0.0, t.cos()];
    let (job2, result2) = write_case(dir.path(), &case.job, &steep);
    let (code, _, err) = post(&[
        result2.to_str().unwrap(),
        "--job",
        job2.to_str().unwrap(),
        "--format",
        "linuxcnc-joint",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("result.json: passes[3].points[7]: machine mill5: the pose needs A = ")
            && err.contains("100.000"),
        "{err}"
    );
    assert!(
        err.contains("outside machine mill5's range -95..95 deg"),
        "{err}"
    );
    let mut both = case.result.clone();
    let t = 125f64.to_radians();
    both.passes[2].points[9].axis = [0.0, t.sin(), t.cos()];
    let (job3, result3) = write_case(dir.path(), &case.job, &both);
    let (code, _, err) = post(&[
        result3.to_str().unwrap(),
        "--job",
        job3.to_str().unwrap(),
        "--machine",
        repo("launch_configs/machines/trunnion_ac.yaml")
            .to_str()
            .unwrap(),
        "--format",
        "sinumerik-traori",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("passes[2].points[9]: machine trunnion_ac: the pose needs A = "),
        "{err}"
    );
    assert!(
        err.contains("outside machine trunnion_ac's range -120..30 deg"),
        "{err}"
    );
}
