//! NC programs from milling results (`toolpath post`): APT CLDATA, G-code
//! for controllers that do the five-axis kinematics themselves (TCP: the tool
//! tip is programmed), and joint-space G-code from the machine's own inverse
//! kinematics with inverse-time feed. docs/formats.md shows each format.
//!
//! The motion is planned once for all formats ([`motion`]: poses, rotary
//! branch and limits, links between passes) and then written in each
//! dialect ([`emit`]). The same result and machine give the same bytes: the
//! header carries no date.

pub mod emit;
pub mod machine;
pub mod motion;

pub use machine::{NcWords, PostMachine};

use motion::{Motion, Step};
use std::path::{Path, PathBuf};
use toolpath_formats::{Job, PlanResult};
use toolpath_kernel::error::{Error, Result};

/// The program formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    /// APT CLDATA (ISO 4343 style): GOTO/x,y,z,i,j,k in the workpiece frame.
    Apt,
    /// LinuxCNC with switchable TCP kinematics (tool tip and A/B C).
    LinuxcncTcp,
    /// Fanuc tool centre point control (G43.4).
    FanucTcp,
    /// Siemens Sinumerik with TRAORI.
    SinumerikTraori,
    /// Heidenhain plain language with FUNCTION TCPM.
    HeidenhainTcpm,
    /// LinuxCNC, machine joints, G93 inverse-time feed.
    LinuxcncJoint,
    /// Fanuc, machine joints, G93 inverse-time feed.
    FanucJoint,
}

impl Format {
    pub const ALL: [Format; 7] = [
        Format::Apt,
        Format::LinuxcncTcp,
        Format::FanucTcp,
        Format::SinumerikTraori,
        Format::HeidenhainTcpm,
        Format::LinuxcncJoint,
        Format::FanucJoint,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Format::Apt => "apt",
            Format::LinuxcncTcp => "linuxcnc-tcp",
            Format::FanucTcp => "fanuc-tcp",
            Format::SinumerikTraori => "sinumerik-traori",
            Format::HeidenhainTcpm => "heidenhain-tcpm",
            Format::LinuxcncJoint => "linuxcnc-joint",
            Format::FanucJoint => "fanuc-joint",
        }
    }

    pub fn parse(name: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|f| f.name() == name)
            .ok_or_else(|| {
                let names: Vec<_> = Self::ALL.iter().map(|f| f.name()).collect();
                Error::invalid(
                    "format",
                    format!(
                        "unknown format \"{name}\": expected one of {}",
                        names.join(", ")
                    ),
                )
            })
    }

    /// Programs the machine's joints (else the tool tip).
    pub fn is_joint(self) -> bool {
        matches!(self, Format::LinuxcncJoint | Format::FanucJoint)
    }

    /// The usual file extension.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Apt => "apt",
            Format::LinuxcncTcp | Format::LinuxcncJoint => "ngc",
            Format::FanucTcp | Format::FanucJoint => "nc",
            Format::SinumerikTraori => "mpf",
            Format::HeidenhainTcpm => "h",
        }
    }
}

/// What a post did, for the user and the tests.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    pub format: Format,
    pub machine: String,
    pub passes: usize,
    pub cut_points: usize,
    /// Motion blocks written.
    pub blocks: usize,
    /// Blocks written with G93 inverse-time feed (joint formats).
    pub inverse_time_blocks: usize,
    /// Largest rotary change between two consecutive blocks, degrees, its
    /// axis and where; the same over the cutting moves alone.
    pub max_rotary_step_deg: f64,
    pub max_rotary_step_axis: &'static str,
    pub max_rotary_step_at: String,
    pub max_cut_rotary_step_deg: f64,
    /// Cutting blocks that, run at the job's feed along the tip, would turn a
    /// rotary axis faster than its velocity limit (the controller slows the
    /// feed there; typically near tilt 0, where C swings).
    pub rotary_speed_limited_blocks: usize,
}

impl Report {
    /// One line for the program header and the command's output.
    pub fn rotary_line(&self) -> String {
        format!(
            "largest rotary step {:.3} deg ({} at {}); largest while cutting {:.3} deg; {} cutting blocks ask a rotary axis for more than its velocity limit at the feed",
            self.max_rotary_step_deg,
            self.max_rotary_step_axis,
            self.max_rotary_step_at,
            self.max_cut_rotary_step_deg,
            self.rotary_speed_limited_blocks
        )
    }
}

/// A written program and its report.
#[derive(Clone, Debug, PartialEq)]
pub struct Program {
    pub text: String,
    pub report: Report,
}

fn rotary_steps(motion: &Motion, pm: &PostMachine, format: Format, feed: f64) -> Report {
    let names = pm.machine.joint_names();
    let mut report = Report {
        format,
        machine: pm.machine.name.clone(),
        passes: motion.passes,
        cut_points: motion.cut_points,
        blocks: 0,
        inverse_time_blocks: 0,
        max_rotary_step_deg: 0.0,
        max_rotary_step_axis: names[4],
        max_rotary_step_at: "the start".into(),
        max_cut_rotary_step_deg: 0.0,
        rotary_speed_limited_blocks: 0,
    };
    let limits = &pm.machine.limits;
    let mut prev: Option<([f64; 5], [f64; 3])> = None;
    for step in &motion.steps {
        match step {
            Step::ToolStart { rotaries, .. } => {
                prev = prev.map(|(mut q, tip)| {
                    q[3] = rotaries[0];
                    q[4] = rotaries[1];
                    (q, tip)
                });
            }
            Step::Move(w) => {
                if let Some((p, tip)) = prev {
                    let d = w
                        .tip
                        .iter()
                        .zip(&tip)
                        .map(|(a, b)| (a - b) * (a - b))
                        .sum::<f64>()
                        .sqrt();
                    let seconds = 60.0 * d / feed;
                    if w.is_cut()
                        && [3, 4]
                            .iter()
                            .any(|&j| (w.q[j] - p[j]).abs() > limits[j].max_velocity * seconds)
                    {
                        report.rotary_speed_limited_blocks += 1;
                    }
                    for j in [3, 4] {
                        let d = (w.q[j] - p[j]).abs().to_degrees();
                        if d > report.max_rotary_step_deg {
                            report.max_rotary_step_deg = d;
                            report.max_rotary_step_axis = names[j];
                            report.max_rotary_step_at = w.origin.to_string();
                        }
                        if w.is_cut() && d > report.max_cut_rotary_step_deg {
                            report.max_cut_rotary_step_deg = d;
                        }
                    }
                }
                prev = Some((w.q, w.tip));
            }
            _ => {}
        }
    }
    report
}

/// Posts `result` (planned from `job`) for machine `pm` in `format`.
pub fn post(job: &Job, result: &PlanResult, pm: &PostMachine, format: Format) -> Result<Program> {
    motion::reject_belt(job, result)?;
    toolpath_formats::result::check_belongs(job, result)?;
    let motion = motion::plan(job, result, pm)?;
    let mut report = rotary_steps(&motion, pm, format, job.feed_rate);
    let written = emit::write(format, &motion, job, result, pm, &report.rotary_line());
    report.blocks = written.motion_blocks;
    report.inverse_time_blocks = written.inverse_time_blocks;
    Ok(Program {
        text: written.text,
        report,
    })
}

/// Writes the program of `result` to `dir/<job_id>.<extension>` (in the job
/// id, anything but ASCII letters, digits, '-' and '_' becomes '_') and
/// returns the path; `dir` is created when missing.
pub fn write_program_file(
    dir: &Path,
    job: &Job,
    result: &PlanResult,
    pm: &PostMachine,
    format: Format,
) -> Result<PathBuf> {
    let program = post(job, result, pm, format)?;
    let stem: String = job
        .job_id
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir.display().to_string(), e))?;
    let path = dir.join(format!("{stem}.{}", format.extension()));
    std::fs::write(&path, program.text).map_err(|e| Error::io(path.display().to_string(), e))?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use toolpath_formats::{Pass, PathPoint};

    #[test]
    fn a_program_file_is_named_after_the_job() {
        let mut job = toolpath_samples::job("plane").unwrap();
        job.job_id = "cell a/job 7".into();
        let mut result = PlanResult::new(&job.job_id, job.strategy.name());
        result.passes.push(Pass {
            region: 0,
            points: (0..3)
                .map(|k| PathPoint {
                    cl: [k as f64, 0.0, 0.0],
                    axis: [0.0, 0.0, 1.0],
                    ..Default::default()
                })
                .collect(),
            min_strip_width: None,
        });
        let dir = std::env::temp_dir().join(format!("post_file_test_{}", std::process::id()));
        let pm = PostMachine::builtin_mill5();
        let path = write_program_file(&dir, &job, &result, &pm, Format::FanucTcp).unwrap();
        assert_eq!(path, dir.join("cell_a_job_7.nc"));
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(
            text,
            post(&job, &result, &pm, Format::FanucTcp).unwrap().text
        );
        // Three points on the part at z = 0, tool vertical: three cutting blocks.
        assert!(
            text.contains("\nG1 Z0.0000 F2000.0\nX1.0000\nX2.0000\n"),
            "{text}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(Format::parse("okuma")
            .unwrap_err()
            .to_string()
            .contains("unknown format \"okuma\""));
    }
}
