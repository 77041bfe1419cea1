//! Jobs and tools as messages and back, checked as job files are.

use super::vec3;
use crate as msgs;
use toolpath_formats::job::{GrindingParams, DEFAULT_TOOL_CATALOGUE};
use toolpath_formats::{FeedDirection, Job, JobFile, Machine, Shape, Strategy};
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::tools::Tool;

fn opt_nonzero(x: f64) -> Option<f64> {
    (x != 0.0).then_some(x)
}

/// The job message as a job file (shape left empty). Zero means "not given"
/// for scallop, tolerance, lead angle and feed rate, and for the tool length.
pub fn job_file_from_msg(m: &msgs::Job) -> Result<JobFile> {
    if m.job_id.trim().is_empty() {
        return Err(Error::invalid("job_id", "must not be empty"));
    }
    if m.surface_id.trim().is_empty() {
        return Err(Error::invalid(
            "surface_id",
            "must name a surface or pocket",
        ));
    }
    let strategy = Strategy::parse(&m.strategy)?;
    let t = &m.tool;
    let length = opt_nonzero(t.length);
    // An empty kind means no tool: pocket_mat takes its tools from the catalogue.
    let tool = match t.kind.as_str() {
        "" => None,
        "flat_end" => Some(Tool::FlatEnd {
            radius: t.radius,
            length,
        }),
        "ball" => Some(Tool::Ball {
            radius: t.radius,
            length,
        }),
        "torus" => Some(Tool::Torus {
            radius: t.radius,
            corner_radius: t.corner_radius,
            length,
        }),
        "belt" => Some(Tool::Belt {
            width: t.width,
            wheel_radius: t.radius,
        }),
        other => {
            return Err(Error::invalid(
                "tool.kind",
                format!(
                    "unknown tool kind \"{other}\": expected one of flat_end, ball, torus, belt"
                ),
            ))
        }
    };
    let machine = match m.machine.as_str() {
        "" => None,
        "mill5" => Some(Machine::Mill5),
        "belt6" => Some(Machine::Belt6),
        other => {
            return Err(Error::invalid(
                "machine",
                format!("unknown machine \"{other}\": expected mill5, belt6 or empty (the strategy's default)"),
            ))
        }
    };
    let feed_direction = match m.feed_direction.as_str() {
        "" => None,
        "u" => Some(FeedDirection::U),
        "v" => Some(FeedDirection::V),
        other => {
            return Err(Error::invalid(
                "feed_direction",
                format!("unknown feed direction \"{other}\": expected u, v or empty"),
            ))
        }
    };
    Ok(JobFile {
        job_id: m.job_id.clone(),
        surface: serde_json::Value::Null,
        strategy,
        tool,
        machine,
        scallop: opt_nonzero(m.scallop),
        tolerance: opt_nonzero(m.tolerance),
        lead_angle_deg: opt_nonzero(m.lead_angle_deg),
        side_tilt_deg: opt_nonzero(m.side_tilt_deg),
        feed_direction,
        feed_rate: opt_nonzero(m.feed_rate),
        tool_catalogue: (!m.tool_catalogue.is_empty()).then(|| m.tool_catalogue.clone()),
        section_normal: {
            let n = m.section_normal.to_array();
            (n != [0.0; 3]).then_some(n)
        },
        simulation_resolution: opt_nonzero(m.simulation_resolution),
        grinding: grinding_from_msg(&m.grinding),
        time_limit_s: opt_nonzero(m.time_limit_s),
        execute: match m.execute {
            msgs::Job::EXECUTE_MACHINE_DEFAULT => None,
            msgs::Job::EXECUTE => Some(true),
            msgs::Job::PLAN_ONLY => Some(false),
            other => {
                return Err(Error::invalid(
                    "execute",
                    format!(
                        "{other} is not 0 (the machine's default), 1 (execute) or 2 (plan only)"
                    ),
                ))
            }
        },
    })
}

/// The grinding parameters of a job message: `None` when every field is zero
/// (not given), else each zero field takes its default.
fn grinding_from_msg(g: &msgs::GrindingParams) -> Option<GrindingParams> {
    if *g == msgs::GrindingParams::default() {
        return None;
    }
    let d = GrindingParams::default();
    let or = |x: f64, default: f64| if x == 0.0 { default } else { x };
    Some(GrindingParams {
        c_a: or(g.c_a, d.c_a),
        k_a: or(g.k_a, d.k_a),
        k_t: or(g.k_t, d.k_t),
        belt_speed: or(g.belt_speed, d.belt_speed),
        force: or(g.force, d.force),
        feed_speed: or(g.feed_speed, d.feed_speed),
    })
}

/// Checks everything about a job message that does not need its shape, with
/// the CLI's reasons: every field, and that it names a shape. Whether the
/// shape is of the kind the strategy needs is checked once it has arrived
/// ([`job_from_msg`]).
pub fn prevalidate_job(m: &msgs::Job) -> Result<JobFile> {
    let file = job_file_from_msg(m)?;
    file.validate()?;
    Ok(file)
}

/// The job message on its shape as a validated job. A shape of the wrong kind
/// for the strategy is named by the message's `surface_id`.
pub fn job_from_msg(m: &msgs::Job, shape: &Shape) -> Result<Job> {
    let file = job_file_from_msg(m)?;
    Job::new(file, shape.clone()).map_err(|e| match e {
        Error::Invalid { field, message } if field == "surface" => {
            Error::invalid("surface_id", format!("\"{}\": {message}", m.surface_id))
        }
        e => e,
    })
}

/// The message form of a job (for clients: the demo, tests).
pub fn job_to_msg(job: &Job, surface_id: &str, header: msgs::Header) -> msgs::Job {
    msgs::Job {
        header,
        job_id: job.job_id.clone(),
        surface_id: surface_id.to_string(),
        machine: job.machine.name().to_string(),
        strategy: job.strategy.name().to_string(),
        tool: job.tool.as_ref().map(tool_to_msg).unwrap_or_default(),
        scallop: job.scallop.unwrap_or(0.0),
        tolerance: job.tolerance.unwrap_or(0.0),
        lead_angle_deg: job.lead_angle_deg.unwrap_or(0.0),
        feed_rate: job.feed_rate,
        feed_direction: match job.feed_direction {
            Some(FeedDirection::U) => "u".into(),
            Some(FeedDirection::V) => "v".into(),
            None => String::new(),
        },
        side_tilt_deg: job.side_tilt_deg.unwrap_or(0.0),
        // The standard catalogue is the default: sent as "not given".
        tool_catalogue: if job.tool_catalogue == DEFAULT_TOOL_CATALOGUE {
            Vec::new()
        } else {
            job.tool_catalogue.clone()
        },
        section_normal: vec3(job.section_normal),
        simulation_resolution: job.simulation_resolution.unwrap_or(0.0),
        grinding: if job.grinding == GrindingParams::default() {
            msgs::GrindingParams::default()
        } else {
            let g = job.grinding;
            msgs::GrindingParams {
                c_a: g.c_a,
                k_a: g.k_a,
                k_t: g.k_t,
                belt_speed: g.belt_speed,
                force: g.force,
                feed_speed: g.feed_speed,
            }
        },
        // Any node: a client addresses a job by setting this.
        node: String::new(),
        execute: match job.execute {
            None => msgs::Job::EXECUTE_MACHINE_DEFAULT,
            Some(true) => msgs::Job::EXECUTE,
            Some(false) => msgs::Job::PLAN_ONLY,
        },
        time_limit_s: job.time_limit_s.unwrap_or(0.0),
    }
}

pub fn tool_to_msg(t: &Tool) -> msgs::Tool {
    let length = |l: &Option<f64>| l.unwrap_or(0.0);
    match t {
        Tool::FlatEnd { radius, length: l } | Tool::Ball { radius, length: l } => msgs::Tool {
            kind: t.kind().into(),
            radius: *radius,
            length: length(l),
            ..Default::default()
        },
        Tool::Torus {
            radius,
            corner_radius,
            length: l,
        } => msgs::Tool {
            kind: t.kind().into(),
            radius: *radius,
            corner_radius: *corner_radius,
            length: length(l),
            ..Default::default()
        },
        Tool::Belt {
            width,
            wheel_radius,
        } => msgs::Tool {
            kind: t.kind().into(),
            radius: *wheel_radius,
            width: *width,
            ..Default::default()
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use toolpath_kernel::geometry::Pocket;

    fn job_msg() -> msgs::Job {
        msgs::Job {
            job_id: "j".into(),
            surface_id: "plane".into(),
            strategy: "iso_parametric".into(),
            tool: msgs::Tool {
                kind: "flat_end".into(),
                radius: 2.5,
                ..Default::default()
            },
            scallop: 0.05,
            ..Default::default()
        }
    }

    #[test]
    fn job_messages_are_checked_like_job_files() {
        prevalidate_job(&job_msg()).unwrap();
        let mut m = job_msg();
        m.strategy = "spiral".into();
        let e = prevalidate_job(&m).unwrap_err().to_string();
        assert!(
            e.starts_with("invalid input: strategy: unknown strategy \"spiral\""),
            "{e}"
        );
        let mut m = job_msg();
        m.tool.radius = -1.0;
        assert_eq!(
            prevalidate_job(&m).unwrap_err().to_string(),
            "invalid input: tool.radius: must be positive, got -1"
        );
        let mut m = job_msg();
        m.tool.kind = "belt".into();
        m.tool.width = 10.0;
        assert!(prevalidate_job(&m)
            .unwrap_err()
            .to_string()
            .contains("cannot use a belt tool"));
        let mut m = job_msg();
        m.scallop = f64::NAN;
        assert!(prevalidate_job(&m)
            .unwrap_err()
            .to_string()
            .contains("scallop: NaN is not a finite number"));
        let mut m = job_msg();
        m.machine = "lathe".into();
        assert!(prevalidate_job(&m)
            .unwrap_err()
            .to_string()
            .contains("unknown machine \"lathe\""));
    }

    #[test]
    fn jobs_are_checked_without_a_shape_then_against_the_shape_that_arrives() {
        let mut m = job_msg();
        m.strategy = "pocket_mat".into();
        m.surface_id = "plate".into();
        assert_eq!(prevalidate_job(&m).unwrap().strategy, Strategy::PocketMat);
        let plane = Shape::Surface(toolpath_samples::surfaces::plane());
        assert_eq!(
            job_from_msg(&m, &plane).unwrap_err().to_string(),
            "invalid input: surface_id: \"plate\": strategy pocket_mat needs a pocket, got a NURBS surface"
        );
        let square =
            Pocket::new(&[[0.0, 0.0], [40.0, 0.0], [40.0, 40.0], [0.0, 40.0]], &[]).unwrap();
        let job = job_from_msg(&m, &Shape::Pocket(square)).unwrap();
        assert_eq!(
            (job.job_id.as_str(), job.strategy),
            ("j", Strategy::PocketMat)
        );
        m.tool.kind = "ball".into();
        assert_eq!(
            prevalidate_job(&m).unwrap_err().to_string(),
            "invalid input: tool.kind: strategy pocket_mat cannot use a ball tool (it plans flat-end cutters)"
        );
        m.surface_id = " ".into();
        assert_eq!(
            prevalidate_job(&m).unwrap_err().to_string(),
            "invalid input: surface_id: must name a surface or pocket"
        );
    }

    #[test]
    fn job_round_trips_through_its_message() {
        let job = toolpath_samples::job("plane").unwrap();
        let m = job_to_msg(&job, "plane", msgs::Header::default());
        let back = Job::new(job_file_from_msg(&m).unwrap(), job.shape.clone()).unwrap();
        assert_eq!(back, job);
    }

    /// Every field of the JSON job format survives the message: a job file
    /// giving every optional field, read as the CLI reads it, equals the job
    /// made from its message.
    #[test]
    fn every_job_file_field_round_trips_through_the_message() {
        let mut file: JobFile = serde_json::from_value(serde_json::json!({
            "job_id": "all",
            "surface": serde_json::Value::Null,
            "strategy": "belt_iso_planar",
            "tool": {"kind": "belt", "width": 12.0, "wheel_radius": 40.0},
            "machine": "belt6",
            "scallop": 0.07,
            "tolerance": 0.02,
            "lead_angle_deg": 3.5,
            "side_tilt_deg": -2.25,
            "feed_direction": "v",
            "feed_rate": 1800.0,
            "tool_catalogue": [6.0, 3.0, 10.0],
            "section_normal": [0.0, 0.6, 0.8],
            "simulation_resolution": 0.4,
            "grinding": {"c_a": 0.003, "k_a": 1.1, "k_t": 0.9, "belt_speed": 25.0,
                         "force": 15.0, "feed_speed": 12.0},
            "time_limit_s": 42.5,
            "execute": true
        }))
        .unwrap();
        let shape = Shape::Surface(toolpath_samples::surfaces::plane());
        file.surface = serde_json::Value::Null;
        let job = Job::new(file, shape.clone()).unwrap();
        let m = job_to_msg(&job, "plane", msgs::Header::default());
        assert_eq!(m.tool_catalogue, [3.0, 6.0, 10.0]);
        assert_eq!(m.section_normal.to_array(), [0.0, 0.6, 0.8]);
        assert_eq!((m.grinding.c_a, m.grinding.feed_speed), (0.003, 12.0));
        assert_eq!(m.side_tilt_deg, -2.25);
        assert_eq!(m.simulation_resolution, 0.4);
        assert_eq!(m.execute, msgs::Job::EXECUTE);
        assert_eq!(m.time_limit_s, 42.5);
        let back = job_from_msg(&m, &shape).unwrap();
        assert_eq!(back, job);
        // Plan only, and the machine's default, round-trip too.
        for (execute, code) in [
            (Some(false), msgs::Job::PLAN_ONLY),
            (None, msgs::Job::EXECUTE_MACHINE_DEFAULT),
        ] {
            let j = Job {
                execute,
                ..job.clone()
            };
            let m = job_to_msg(&j, "plane", msgs::Header::default());
            assert_eq!(m.execute, code);
            assert_eq!(job_from_msg(&m, &shape).unwrap().execute, execute);
        }
        let bad = msgs::Job {
            execute: 3,
            ..m.clone()
        };
        assert_eq!(
            prevalidate_job(&bad).unwrap_err().to_string(),
            "invalid input: execute: 3 is not 0 (the machine's default), 1 (execute) or 2 (plan only)"
        );
        let bad = msgs::Job {
            time_limit_s: -1.0,
            ..m.clone()
        };
        let e = prevalidate_job(&bad).unwrap_err().to_string();
        assert!(e.starts_with("invalid input: time_limit_s: "), "{e}");
        // Zero grinding fields take their defaults, one by one.
        let mut m = m;
        m.grinding.force = 0.0;
        let back = job_from_msg(&m, &shape).unwrap();
        assert_eq!(back.grinding.force, GrindingParams::default().force);
        assert_eq!(back.grinding.c_a, 0.003);
        // Bad values are refused with the job file's reasons.
        m.tool_catalogue = vec![3.0, 500.0];
        assert_eq!(
            prevalidate_job(&m).unwrap_err().to_string(),
            "invalid input: tool_catalogue[1]: 500 mm is outside the valid range 0.1..100 mm of end-mill diameters"
        );
        m.tool_catalogue.clear();
        m.grinding.k_a = -1.0;
        assert_eq!(
            prevalidate_job(&m).unwrap_err().to_string(),
            "invalid input: grinding.k_a: must be positive, got -1"
        );
    }
}
