//! Messages <-> the crate's formats: incoming surfaces, pockets and jobs are
//! validated with the same checks and reasons as the CLI's files; results
//! become Toolpath, PoseArray, JointTrajectory and MarkerArray messages.

use crate as msgs;
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};
use toolpath_formats::job::{GrindingParams, DEFAULT_TOOL_CATALOGUE};
use toolpath_formats::shape::{BsplineCurveFile, TrimCurveFile};
use toolpath_formats::{
    FeedDirection, Job, JobFile, Machine, PlanResult, Shape, Strategy, TrimFile,
};
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::{NurbsSurface, Pocket};
use toolpath_kernel::tools::Tool;
use toolpath_machines::{self as machines, JointTrajectory};

/// A surface message as a validated surface. Errors name `surface "<id>".<field>`.
pub fn surface_from_msg(m: &msgs::Surface) -> Result<NurbsSurface> {
    let ctx = format!("surface \"{}\"", m.surface_id);
    let inner = || -> Result<NurbsSurface> {
        if m.surface_id.trim().is_empty() {
            return Err(Error::invalid("surface_id", "must not be empty"));
        }
        let (cu, cv) = (m.count_u as usize, m.count_v as usize);
        if cu.checked_mul(cv) != Some(m.control_points.len()) {
            return Err(Error::invalid(
                "control_points",
                format!(
                    "has {} points, but count_u x count_v = {} x {} needs {}",
                    m.control_points.len(),
                    cu,
                    cv,
                    cu.saturating_mul(cv)
                ),
            ));
        }
        if cu == 0 || cv == 0 {
            return Err(Error::invalid(
                "count_u",
                "count_u and count_v must be at least 1",
            ));
        }
        if !m.weights.is_empty() && m.weights.len() != m.control_points.len() {
            return Err(Error::invalid(
                "weights",
                format!(
                    "has {} values; give none (non-rational) or one per control point ({})",
                    m.weights.len(),
                    m.control_points.len()
                ),
            ));
        }
        let grid: Vec<Vec<[f64; 3]>> = m
            .control_points
            .chunks(cv)
            .map(|row| row.iter().map(|p| p.to_array()).collect())
            .collect();
        let weights: Option<Vec<Vec<f64>>> =
            (!m.weights.is_empty()).then(|| m.weights.chunks(cv).map(|r| r.to_vec()).collect());
        let surface = NurbsSurface::new(
            m.degree_u as usize,
            m.degree_v as usize,
            m.knots_u.clone(),
            m.knots_v.clone(),
            &grid,
            weights.as_deref(),
        )?;
        match trim_from_msg(m)? {
            Some(t) => Ok(surface
                .clone()
                .with_trim(t.to_trim(&surface).map_err(|e| e.within("trim_loops"))?)),
            None => Ok(surface),
        }
    };
    inner().map_err(|e| e.within(&ctx))
}

/// The trim of a surface message in the file format's terms (validated by
/// the same `TrimFile::to_trim` as a file's): loop 0 the outer, the rest holes.
fn trim_from_msg(m: &msgs::Surface) -> Result<Option<TrimFile>> {
    if m.trim_loops.is_empty() {
        if m.trim_tolerance != 0.0 {
            return Err(Error::invalid(
                "trim_tolerance",
                "is set but trim_loops is empty",
            ));
        }
        return Ok(None);
    }
    let curve = |l: usize, c: usize, t: &msgs::TrimCurve| -> Result<TrimCurveFile> {
        let field = format!("trim_loops[{l}].curves[{c}]");
        if !t.points_uv.len().is_multiple_of(2) {
            return Err(Error::invalid(
                format!("{field}.points_uv"),
                format!("has {} values: give u, v pairs", t.points_uv.len()),
            ));
        }
        let points: Vec<[f64; 2]> = t.points_uv.chunks(2).map(|p| [p[0], p[1]]).collect();
        if t.degree == 0 {
            if !t.knots.is_empty() || !t.weights.is_empty() {
                return Err(Error::invalid(
                    field,
                    "is a polyline (degree 0) and takes no knots or weights",
                ));
            }
            return Ok(TrimCurveFile::Polyline(points));
        }
        Ok(TrimCurveFile::Bspline(BsplineCurveFile {
            degree: t.degree as usize,
            knots: t.knots.clone(),
            control_points: points,
            weights: (!t.weights.is_empty()).then(|| t.weights.clone()),
        }))
    };
    let mut loops = m.trim_loops.iter().enumerate().map(|(l, lp)| {
        lp.curves
            .iter()
            .enumerate()
            .map(|(c, t)| curve(l, c, t))
            .collect::<Result<Vec<_>>>()
    });
    let outer = loops.next().transpose()?.unwrap_or_default();
    let holes = loops.collect::<Result<Vec<_>>>()?;
    Ok(Some(TrimFile {
        tolerance: (m.trim_tolerance != 0.0).then_some(m.trim_tolerance),
        outer,
        holes,
    }))
}

/// The trim of a surface as message loops (outer first).
fn trim_to_msg(s: &NurbsSurface) -> (Vec<msgs::TrimLoop>, f64) {
    let Some(t) = s.trim() else {
        return (Vec::new(), 0.0);
    };
    let f = TrimFile::from_trim(t);
    let curve = |c: &TrimCurveFile| match c {
        TrimCurveFile::Polyline(p) => msgs::TrimCurve {
            degree: 0,
            points_uv: p.iter().flatten().copied().collect(),
            ..Default::default()
        },
        TrimCurveFile::Bspline(b) => msgs::TrimCurve {
            degree: b.degree as u32,
            knots: b.knots.clone(),
            points_uv: b.control_points.iter().flatten().copied().collect(),
            weights: b.weights.clone().unwrap_or_default(),
        },
    };
    let lp = |l: &[TrimCurveFile]| msgs::TrimLoop {
        curves: l.iter().map(curve).collect(),
    };
    let mut loops = vec![lp(&f.outer)];
    loops.extend(f.holes.iter().map(|h| lp(h)));
    (loops, f.tolerance.unwrap_or(0.0))
}

/// A surface as a message (control points row-major, i along u).
pub fn surface_to_msg(id: &str, s: &NurbsSurface, header: msgs::Header) -> msgs::Surface {
    let grid = s.control_grid();
    let (trim_loops, trim_tolerance) = trim_to_msg(s);
    msgs::Surface {
        header,
        surface_id: id.to_string(),
        degree_u: s.degree_u() as u32,
        degree_v: s.degree_v() as u32,
        knots_u: s.knots_u().to_vec(),
        knots_v: s.knots_v().to_vec(),
        count_u: s.count_u() as u32,
        count_v: s.count_v() as u32,
        control_points: grid
            .iter()
            .flatten()
            .map(|p| msgs::Point::from_array(*p))
            .collect(),
        weights: s
            .weight_grid()
            .map(|w| w.into_iter().flatten().collect())
            .unwrap_or_default(),
        trim_loops,
        trim_tolerance,
    }
}

/// A pocket message as a validated pocket.
pub fn pocket_from_msg(m: &msgs::Pocket) -> Result<Pocket> {
    let ctx = format!("pocket \"{}\"", m.pocket_id);
    if m.pocket_id.trim().is_empty() {
        return Err(Error::invalid("pocket_id", "must not be empty").within(&ctx));
    }
    let xy = |l: &msgs::PocketLoop| {
        l.points
            .iter()
            .map(|p| [p.x, p.y])
            .collect::<Vec<[f64; 2]>>()
    };
    let holes: Vec<Vec<[f64; 2]>> = m.holes.iter().map(xy).collect();
    Pocket::new(&xy(&m.outer), &holes).map_err(|e| e.within(&ctx))
}

pub fn pocket_to_msg(id: &str, p: &Pocket, header: msgs::Header) -> msgs::Pocket {
    let lp = |l: &[[f64; 2]]| msgs::PocketLoop {
        points: l
            .iter()
            .map(|q| msgs::Point {
                x: q[0],
                y: q[1],
                z: 0.0,
            })
            .collect(),
    };
    msgs::Pocket {
        header,
        pocket_id: id.to_string(),
        outer: lp(&p.outer),
        holes: p.holes.iter().map(|h| lp(h)).collect(),
    }
}

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

fn vec3(v: Option<[f64; 3]>) -> msgs::Vector3 {
    msgs::Vector3::from_array(v.unwrap_or([0.0; 3]))
}

/// The Toolpath message of a planned job (mm, as the result file).
pub fn toolpath_msg(
    job: &Job,
    surface_id: &str,
    result: &PlanResult,
    trajectory_duration_s: f64,
    header: msgs::Header,
) -> msgs::Toolpath {
    let feed = job.feed_rate;
    let mut passes: Vec<msgs::ToolpathPass> = result
        .passes
        .iter()
        .map(|p| msgs::ToolpathPass {
            region: u32::try_from(p.region).unwrap_or(u32::MAX),
            stage: String::new(),
            tool_diameter: job.tool.map_or(f64::NAN, |t| 2.0 * t.radius()),
            min_strip_width: p.min_strip_width.unwrap_or(f64::NAN),
            points: p
                .points
                .iter()
                .map(|q| msgs::ToolpathPoint {
                    cc: msgs::Point::from_array(q.cc),
                    cl: msgs::Point::from_array(q.cl),
                    axis: msgs::Vector3::from_array(q.axis),
                    normal: vec3(q.normal),
                    feed_direction: vec3(q.feed),
                    u: q.uv[0],
                    v: q.uv[1],
                    feed_rate: feed,
                    strip_width: q.strip_width.unwrap_or(f64::NAN),
                    lead_angle_deg: q.lead_deg.unwrap_or(f64::NAN),
                    gouge: q.gouge.unwrap_or(f64::NAN),
                })
                .collect(),
        })
        .collect();
    if let Some(tools) = &result.tools {
        for t in tools {
            for pass in &t.passes {
                passes.push(msgs::ToolpathPass {
                    region: 0,
                    stage: t.stage.clone(),
                    tool_diameter: t.diameter,
                    min_strip_width: f64::NAN,
                    points: pass
                        .iter()
                        .map(|q| msgs::ToolpathPoint {
                            cc: msgs::Point {
                                x: q[0],
                                y: q[1],
                                z: 0.0,
                            },
                            cl: msgs::Point {
                                x: q[0],
                                y: q[1],
                                z: 0.0,
                            },
                            axis: msgs::Vector3 {
                                x: 0.0,
                                y: 0.0,
                                z: 1.0,
                            },
                            normal: msgs::Vector3 {
                                x: 0.0,
                                y: 0.0,
                                z: 1.0,
                            },
                            feed_rate: feed,
                            strip_width: f64::NAN,
                            lead_angle_deg: f64::NAN,
                            gouge: f64::NAN,
                            ..Default::default()
                        })
                        .collect(),
                });
            }
        }
    }
    let s = &result.stats;
    let nan = |x: Option<f64>| x.unwrap_or(f64::NAN);
    msgs::Toolpath {
        header,
        job_id: result.job_id.clone(),
        surface_id: surface_id.to_string(),
        strategy: result.strategy.clone(),
        machine: job.machine.name().to_string(),
        tool: job.tool.as_ref().map(tool_to_msg).unwrap_or_default(),
        stats: msgs::ToolpathStats {
            path_length_mm: s.path_length_mm,
            passes: u32::try_from(s.passes).unwrap_or(u32::MAX),
            points: u32::try_from(passes.iter().map(|p| p.points.len()).sum::<usize>())
                .unwrap_or(u32::MAX),
            max_scallop_mm: nan(s.max_scallop_mm),
            compute_ms: s.compute_ms,
            machining_time_min: nan(s.machining_time_min),
            trajectory_duration_s,
            max_gouge_mm: nan(s.max_gouge_mm),
            uncut_area_mm2: nan(s.uncut_area_mm2),
            extra_names: s.extra.keys().cloned().collect(),
            extra_values: s.extra.values().copied().collect(),
        },
        passes,
        degenerate_points: result
            .degenerate_points
            .iter()
            .flatten()
            .map(|d| msgs::Point::from_array(d.xyz))
            .collect(),
        warnings: result.warnings.clone(),
    }
}

const MM: f64 = 1e-3;

fn quat(m: &Matrix3<f64>) -> msgs::Quaternion {
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*m));
    msgs::Quaternion {
        x: q.i,
        y: q.j,
        z: q.k,
        w: q.w,
    }
}

/// Tool poses in the workpiece frame, metres (REP 103). Mill: at the tool tip,
/// z along the tool axis, x along the feed (or the next point) where known.
/// Belt: at the wheel centre, the wheel frame (x wheel axis, z contact normal).
pub fn pose_array(job: &Job, result: &PlanResult, header: msgs::Header) -> msgs::PoseArray {
    let poses = pose_segments(job, result, header.clone())
        .into_iter()
        .flat_map(|s| s.poses)
        .collect();
    msgs::PoseArray { header, poses }
}

/// The poses of [`pose_array`], one PoseArray per pass (each with `header`).
pub fn pose_segments(job: &Job, result: &PlanResult, header: msgs::Header) -> Vec<msgs::PoseArray> {
    let mut segments = Vec::new();
    for pass in machines::tool_poses(result) {
        let mut poses = Vec::with_capacity(pass.len());
        for (k, t) in pass.iter().enumerate() {
            let m = match job.machine {
                Machine::Belt6 => machines::belt6::wheel_frame(t.axis, t.normal).ok(),
                Machine::Mill5 => {
                    let z = Vector3::from(t.axis).try_normalize(1e-12);
                    let ahead = pass
                        .get(k + 1)
                        .map(|n| Vector3::from(n.tip) - Vector3::from(t.tip));
                    let behind = k
                        .checked_sub(1)
                        .and_then(|b| pass.get(b))
                        .map(|p| Vector3::from(t.tip) - Vector3::from(p.tip));
                    z.map(|z| {
                        let dir = ahead.or(behind).unwrap_or(Vector3::x());
                        let x = (dir - z * z.dot(&dir))
                            .try_normalize(1e-12)
                            .or_else(|| {
                                let h = if z.x.abs() < 0.9 {
                                    Vector3::x()
                                } else {
                                    Vector3::y()
                                };
                                (h - z * z.dot(&h)).try_normalize(1e-12)
                            })
                            .unwrap_or(Vector3::x());
                        Matrix3::from_columns(&[x, z.cross(&x), z])
                    })
                }
            };
            poses.push(msgs::Pose {
                position: msgs::Point {
                    x: t.tip[0] * MM,
                    y: t.tip[1] * MM,
                    z: t.tip[2] * MM,
                },
                orientation: m.map(|m| quat(&m)).unwrap_or_default(),
            });
        }
        segments.push(msgs::PoseArray {
            header: header.clone(),
            poses,
        });
    }
    segments
}

/// The joint trajectory as a ROS message: metres and radians (REP 103). Its
/// stamp follows the machine's start policy: zero (JTC starts on receipt) or
/// `header`'s stamp plus the start delay.
pub fn joint_trajectory_msg(t: &JointTrajectory, header: msgs::Header) -> msgs::JointTrajectory {
    let header = msgs::Header {
        stamp: match t.stamp {
            machines::Stamp::Zero => msgs::Time::ZERO,
            machines::Stamp::At(delay_s) => header.stamp.plus_secs(delay_s),
        },
        ..header
    };
    let scale: Vec<f64> = t.rotary.iter().map(|r| if *r { 1.0 } else { MM }).collect();
    let points = t
        .timed
        .times
        .iter()
        .enumerate()
        .map(|(k, time)| msgs::JointTrajectoryPoint {
            positions: t.timed.positions[k]
                .iter()
                .zip(&scale)
                .map(|(x, s)| x * s)
                .collect(),
            velocities: t.timed.velocities[k]
                .iter()
                .zip(&scale)
                .map(|(x, s)| x * s)
                .collect(),
            accelerations: Vec::new(),
            effort: Vec::new(),
            time_from_start: msgs::Duration::from_secs_f64(*time),
        })
        .collect();
    msgs::JointTrajectory {
        header,
        joint_names: t.joint_names.iter().map(|s| s.to_string()).collect(),
        points,
    }
}

/// The trajectory message cut into one trajectory per pass, for a controller
/// that executes each when the previous one succeeded: each runs from a
/// pass's approach to its retract (at rest at both), its times counted from
/// the end of the previous pass, so its first point comes after the link
/// from where the previous pass left the machine.
pub fn trajectory_chunks(
    t: &JointTrajectory,
    m: &msgs::JointTrajectory,
) -> Vec<msgs::JointTrajectory> {
    let mut starts = t.pass_starts.clone();
    if starts.first() != Some(&0) {
        starts.insert(0, 0);
    }
    starts.push(m.points.len());
    starts
        .windows(2)
        .filter(|w| w[1] > w[0])
        .map(|w| {
            let origin = if w[0] == 0 {
                0.0
            } else {
                t.timed.times[w[0] - 1]
            };
            msgs::JointTrajectory {
                header: m.header.clone(),
                joint_names: m.joint_names.clone(),
                points: m.points[w[0]..w[1]]
                    .iter()
                    .zip(&t.timed.times[w[0]..w[1]])
                    .map(|(p, time)| msgs::JointTrajectoryPoint {
                        time_from_start: msgs::Duration::from_secs_f64(time - origin),
                        ..p.clone()
                    })
                    .collect(),
            }
        })
        .collect()
}

/// A JointTrajectory message in internal units (mm, rad), for the joints
/// `names` with `limits` (a joint not among them is left unscaled; the
/// controller rules reject it by name).
pub fn trajectory_points(
    m: &msgs::JointTrajectory,
    names: &[String],
    limits: &[machines::Axis],
) -> machines::jtc::Points {
    let scale: Vec<f64> = m
        .joint_names
        .iter()
        .map(|n| match names.iter().position(|x| x == n) {
            Some(j) if !limits[j].rotary => 1.0 / MM,
            _ => 1.0,
        })
        .collect();
    let rows = |r: &[f64]| -> Vec<f64> {
        r.iter()
            .zip(scale.iter().chain(std::iter::repeat(&1.0)))
            .map(|(x, s)| x * s)
            .collect()
    };
    let accelerations: Vec<Vec<f64>> = m.points.iter().map(|p| rows(&p.accelerations)).collect();
    machines::jtc::Points {
        joint_names: m.joint_names.clone(),
        times: m
            .points
            .iter()
            .map(|p| p.time_from_start.as_secs_f64())
            .collect(),
        positions: m.points.iter().map(|p| rows(&p.positions)).collect(),
        velocities: m.points.iter().map(|p| rows(&p.velocities)).collect(),
        accelerations: if accelerations.iter().all(|a| a.is_empty()) {
            Vec::new()
        } else {
            accelerations
        },
    }
}

/// Region colours (a qualitative palette), cycled.
const PALETTE: [[f32; 3]; 8] = [
    [0.12, 0.47, 0.71],
    [1.0, 0.5, 0.05],
    [0.17, 0.63, 0.17],
    [0.84, 0.15, 0.16],
    [0.58, 0.4, 0.74],
    [0.55, 0.34, 0.29],
    [0.89, 0.47, 0.76],
    [0.5, 0.5, 0.5],
];

/// RViz markers: a DELETEALL, then the passes as line strips coloured by region
/// (cl points), degenerate points as spheres, separatrices as line strips. Metres.
pub fn markers(result: &PlanResult, header: msgs::Header) -> msgs::MarkerArray {
    let p = |x: [f64; 3]| msgs::Point {
        x: x[0] * MM,
        y: x[1] * MM,
        z: x[2] * MM,
    };
    let base = |ns: &str, id: i32, marker_type: i32, color: [f32; 3], width: f64| msgs::Marker {
        header: header.clone(),
        ns: ns.into(),
        id,
        marker_type,
        action: msgs::Marker::ADD,
        scale: msgs::Vector3 {
            x: width,
            y: width,
            z: width,
        },
        color: msgs::ColorRGBA {
            r: color[0],
            g: color[1],
            b: color[2],
            a: 1.0,
        },
        ..Default::default()
    };
    let mut out = vec![msgs::Marker {
        header: header.clone(),
        action: msgs::Marker::DELETEALL,
        ..Default::default()
    }];
    for (id, pass) in machines::tool_poses(result).into_iter().enumerate() {
        let region = result.passes.get(id).map_or(0, |q| q.region);
        let mut m = base(
            "passes",
            i32::try_from(id).unwrap_or(i32::MAX),
            msgs::Marker::LINE_STRIP,
            PALETTE[region % PALETTE.len()],
            0.0005,
        );
        m.points = pass.iter().map(|t| p(t.tip)).collect();
        out.push(m);
    }
    if let Some(d) = &result.degenerate_points {
        let mut m = base(
            "degenerate_points",
            0,
            msgs::Marker::SPHERE_LIST,
            [0.0, 0.0, 0.0],
            0.003,
        );
        m.points = d.iter().map(|q| p(q.xyz)).collect();
        out.push(m);
    }
    for (k, s) in result.separatrices.iter().flatten().enumerate() {
        let mut m = base(
            "separatrices",
            k as i32,
            msgs::Marker::LINE_STRIP,
            [0.0, 0.0, 0.0],
            0.001,
        );
        m.points = s.iter().map(|q| p(*q)).collect();
        out.push(m);
    }
    msgs::MarkerArray { markers: out }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn surface_msg() -> msgs::Surface {
        surface_to_msg(
            "plane",
            &toolpath_samples::surfaces::plane(),
            msgs::Header::default(),
        )
    }

    #[test]
    fn surface_round_trips_through_its_message() {
        let s = toolpath_samples::surfaces::plane();
        assert_eq!(surface_from_msg(&surface_msg()).unwrap(), s);
    }

    #[test]
    fn a_trimmed_surface_round_trips_through_its_message() {
        let Shape::Surface(s) = toolpath_samples::shape("trimmed_saddle").unwrap() else {
            panic!("trimmed_saddle is a surface");
        };
        let t = s.trim().unwrap();
        let m = surface_to_msg("trimmed_saddle", &s, msgs::Header::default());
        assert_eq!(m.trim_loops.len(), 1 + t.holes.len());
        let back = surface_from_msg(&m).unwrap();
        assert_eq!(back, s);
        assert_eq!(back.trim().unwrap().outer, t.outer);
        // The trim is checked as a file's: a hole outside the outer loop.
        let mut bad = m.clone();
        bad.trim_loops[1] = msgs::TrimLoop {
            curves: vec![msgs::TrimCurve {
                degree: 0,
                points_uv: vec![5.0, 5.0, 6.0, 5.0, 6.0, 6.0, 5.0, 5.0],
                ..Default::default()
            }],
        };
        let e = surface_from_msg(&bad).unwrap_err().to_string();
        assert!(e.contains("surface \"trimmed_saddle\".trim_loops"), "{e}");
        let mut odd = m.clone();
        odd.trim_loops[0].curves[0].points_uv.push(0.5);
        let e = surface_from_msg(&odd).unwrap_err().to_string();
        assert!(e.contains("trim_loops[0].curves[0].points_uv"), "{e}");
    }

    #[test]
    fn bad_surfaces_name_the_field() {
        let mut m = surface_msg();
        m.control_points[5].y = f64::NAN;
        let e = surface_from_msg(&m).unwrap_err().to_string();
        assert_eq!(
            e,
            "invalid input: surface \"plane\".control_points[1][1]: has a coordinate that is not a finite number"
        );
        let mut m = surface_msg();
        m.control_points.pop();
        let e = surface_from_msg(&m).unwrap_err().to_string();
        assert!(
            e.contains("has 15 points, but count_u x count_v = 4 x 4 needs 16"),
            "{e}"
        );
        let mut m = surface_msg();
        m.weights = vec![1.0; 3];
        assert!(surface_from_msg(&m)
            .unwrap_err()
            .to_string()
            .contains("weights"));
    }

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
