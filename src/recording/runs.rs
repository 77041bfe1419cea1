//! Bags of planner runs with the node's topics and messages: recording a job
//! run (`toolpath record`), and replaying a bag's jobs with a comparison of
//! the new outputs against the recorded ones (`toolpath replay --check`).
//!
//! Planning is deterministic, so a replay reproduces every recorded output
//! except header stamps and `stats.compute_ms`, which are not compared.

use super::{read_bag, ros2_type_name, Bag, BagWriter, Qos, TopicSpec, WriterOptions};
use crate::error::{Error, Result};
use crate::formats::{Job, Machine, Shape};
use crate::machines::Machines;
use crate::pipeline::{self, RunOptions};
use crate::planners::NoProgress;
use crate::ros::convert;
use crate::ros::msgs::{self, RosMessage};
use std::collections::BTreeMap;
use std::path::Path;

pub const SURFACE: &str = "/surface";
pub const POCKET: &str = "/pocket";
pub const JOB: &str = "/job";
pub const TOOLPATH: &str = "/toolpath";
pub const TOOL_POSES: &str = "/tool_poses";
pub const MILL5_TRAJECTORY: &str = "/mill5/joint_trajectory";
pub const BELT6_TRAJECTORY: &str = "/belt6/joint_trajectory";
pub const JOB_STATUS: &str = "/job_status";
pub const MARKERS: &str = "/markers";

/// Positions (mm) may differ by this much in a replay before it is a difference.
pub const POSITION_TOLERANCE_MM: f64 = 1e-6;
/// Unit vectors, times and other values: absolute tolerance.
pub const VALUE_TOLERANCE: f64 = 1e-9;

fn spec<M: RosMessage>(topic: &str, qos: Qos) -> TopicSpec {
    let full = M::full_name();
    TopicSpec::new(
        topic,
        &ros2_type_name(&full),
        &msgs::schema_text(&full).unwrap_or_else(|| M::definition().to_string()),
        qos,
    )
}

/// Every topic of the node, with the QoS it offers (inputs: as the clients publish them).
pub fn topic_specs() -> Vec<TopicSpec> {
    let results = Qos::reliable_transient_local(10);
    vec![
        spec::<msgs::Surface>(SURFACE, Qos::reliable_transient_local(100)),
        spec::<msgs::Pocket>(POCKET, Qos::reliable_transient_local(100)),
        spec::<msgs::Job>(JOB, Qos::reliable_volatile(100)),
        spec::<msgs::Toolpath>(TOOLPATH, results),
        spec::<msgs::PoseArray>(TOOL_POSES, results),
        spec::<msgs::JointTrajectory>(MILL5_TRAJECTORY, results),
        spec::<msgs::JointTrajectory>(BELT6_TRAJECTORY, results),
        spec::<msgs::JobStatus>(JOB_STATUS, Qos::reliable_transient_local(1000)),
        spec::<msgs::MarkerArray>(MARKERS, results),
    ]
}

fn spec_of(topic: &str) -> Result<TopicSpec> {
    topic_specs()
        .into_iter()
        .find(|s| s.topic == topic)
        .ok_or_else(|| Error::invalid(topic, "not a topic of the node"))
}

/// The outputs of one planned job, as the node publishes them.
#[derive(Clone, Debug, PartialEq)]
pub struct JobOutputs {
    pub toolpath: msgs::Toolpath,
    pub poses: msgs::PoseArray,
    pub machine: Machine,
    pub trajectory: msgs::JointTrajectory,
    pub markers: msgs::MarkerArray,
    pub summary: String,
}

/// Plans `job_msg` on `shape` as the node does and builds its output messages.
pub fn plan_outputs(
    job_msg: &msgs::Job,
    shape: &Shape,
    machines: &Machines,
    header: &msgs::Header,
) -> Result<JobOutputs> {
    let file = convert::job_file_from_msg(job_msg)?;
    let job = Job::new(file, shape.clone())?;
    let result = pipeline::run(&job, &NoProgress, RunOptions::default())?;
    let trajectory = crate::machines::trajectory(&job, &result, machines)?;
    let toolpath = convert::toolpath_msg(
        &job,
        &job_msg.surface_id,
        &result,
        trajectory.duration(),
        header.clone(),
    );
    let summary = format!(
        "{} passes, {} points, {:.1} mm, trajectory {:.1} s",
        toolpath.stats.passes,
        toolpath.stats.points,
        toolpath.stats.path_length_mm,
        trajectory.duration()
    );
    Ok(JobOutputs {
        poses: convert::pose_array(&job, &result, header.clone()),
        machine: job.machine,
        trajectory: convert::joint_trajectory_msg(&trajectory, header.clone()),
        markers: convert::markers(&result, header.clone()),
        toolpath,
        summary,
    })
}

fn status(
    header: &msgs::Header,
    job_id: &str,
    state: u8,
    progress: f32,
    message: String,
) -> msgs::JobStatus {
    msgs::JobStatus {
        header: header.clone(),
        job_id: job_id.to_string(),
        state,
        progress,
        message,
    }
}

fn header_now() -> msgs::Header {
    msgs::Header {
        stamp: msgs::Time::now(),
        frame_id: "workpiece".into(),
    }
}

/// Records a run of `job` into a new bag at `directory`: its shape and job on
/// the input topics, then ACCEPTED, RUNNING, the outputs and the final status.
/// A job that cannot be planned is recorded with its FAILED/REJECTED status.
pub fn record_job(job: &Job, directory: &Path, machines: &Machines) -> Result<super::BagSummary> {
    let mut w = BagWriter::create(directory, WriterOptions::default())?;
    for s in topic_specs() {
        w.add_topic(&s)?;
    }
    record_job_into(&mut w, job, machines)?;
    w.finish()
}

/// Records one job run into an open bag (several jobs may share a bag).
pub fn record_job_into(w: &mut BagWriter, job: &Job, machines: &Machines) -> Result<()> {
    let header = header_now();
    let t = |w: &BagWriter| super::now_ns().max(w.metadata().duration.nanoseconds);
    let shape_id = format!("{}_shape", job.job_id);
    match &job.shape {
        Shape::Surface(s) => w.write(
            SURFACE,
            t(w),
            &convert::surface_to_msg(&shape_id, s, header.clone()),
        )?,
        Shape::Pocket(p) => w.write(
            POCKET,
            t(w),
            &convert::pocket_to_msg(&shape_id, p, header.clone()),
        )?,
    }
    let job_msg = convert::job_to_msg(job, &shape_id, header.clone());
    w.write(JOB, t(w), &job_msg)?;
    w.write(
        JOB_STATUS,
        t(w),
        &status(
            &header,
            &job.job_id,
            msgs::JobStatus::ACCEPTED,
            0.0,
            String::new(),
        ),
    )?;
    w.write(
        JOB_STATUS,
        t(w),
        &status(
            &header,
            &job.job_id,
            msgs::JobStatus::RUNNING,
            0.0,
            String::new(),
        ),
    )?;
    match plan_outputs(&job_msg, &job.shape, machines, &header) {
        Ok(out) => {
            w.write(TOOLPATH, t(w), &out.toolpath)?;
            w.write(TOOL_POSES, t(w), &out.poses)?;
            let traj_topic = match out.machine {
                Machine::Mill5 => MILL5_TRAJECTORY,
                Machine::Belt6 => BELT6_TRAJECTORY,
            };
            w.write(traj_topic, t(w), &out.trajectory)?;
            w.write(MARKERS, t(w), &out.markers)?;
            w.write(
                JOB_STATUS,
                t(w),
                &status(
                    &header,
                    &job.job_id,
                    msgs::JobStatus::SUCCEEDED,
                    1.0,
                    out.summary,
                ),
            )?;
        }
        Err(e) => {
            let state = match e {
                Error::Invalid { .. } => msgs::JobStatus::REJECTED,
                _ => msgs::JobStatus::FAILED,
            };
            w.write(
                JOB_STATUS,
                t(w),
                &status(&header, &job.job_id, state, 0.0, e.to_string()),
            )?;
        }
    }
    // The job's messages form a unit: put them on disk now.
    w.flush()
}

/// One replayed job.
#[derive(Clone, Debug, PartialEq)]
pub struct JobReplay {
    pub job_id: String,
    pub strategy: String,
    pub machine: String,
    pub points: usize,
    /// Human-readable differences from the recording (empty: identical).
    pub differences: Vec<String>,
}

/// What a replay found.
#[derive(Clone, Debug, PartialEq)]
pub struct ReplayReport {
    pub jobs: Vec<JobReplay>,
    pub truncated: Option<String>,
}

impl ReplayReport {
    pub fn differences(&self) -> usize {
        self.jobs.iter().map(|j| j.differences.len()).sum()
    }
}

fn decode_all<M: RosMessage>(bag: &Bag, topic: &str) -> Result<Vec<M>> {
    let spec = spec_of(topic)?;
    bag.messages
        .iter()
        .enumerate()
        .filter(|(_, m)| m.topic == topic)
        .map(|(i, _)| bag.decode::<M>(i, &spec))
        .collect()
}

/// Re-plans every job of the bag at `path` and compares the outputs with the
/// recorded ones.
pub fn replay(path: &Path, machines: &Machines) -> Result<ReplayReport> {
    let bag = read_bag(path)?;
    bag.check_types(&topic_specs())?;
    let mut shapes: BTreeMap<String, Shape> = BTreeMap::new();
    for m in decode_all::<msgs::Surface>(&bag, SURFACE)? {
        shapes.insert(
            m.surface_id.clone(),
            Shape::Surface(convert::surface_from_msg(&m)?),
        );
    }
    for m in decode_all::<msgs::Pocket>(&bag, POCKET)? {
        let id = m.pocket_id.clone();
        shapes.insert(id, Shape::Pocket(convert::pocket_from_msg(&m)?));
    }
    let jobs = decode_all::<msgs::Job>(&bag, JOB)?;
    if jobs.is_empty() {
        return Err(Error::invalid(
            path.display().to_string(),
            "the bag holds no job on /job",
        ));
    }
    let toolpaths = decode_all::<msgs::Toolpath>(&bag, TOOLPATH)?;
    let poses = decode_all::<msgs::PoseArray>(&bag, TOOL_POSES)?;
    let statuses = decode_all::<msgs::JobStatus>(&bag, JOB_STATUS)?;
    let mut traj_mill = decode_all::<msgs::JointTrajectory>(&bag, MILL5_TRAJECTORY)?.into_iter();
    let mut traj_belt = decode_all::<msgs::JointTrajectory>(&bag, BELT6_TRAJECTORY)?.into_iter();
    let header = header_now();
    let mut report = ReplayReport {
        jobs: Vec::new(),
        truncated: bag.truncated.clone(),
    };
    for (k, job_msg) in jobs.iter().enumerate() {
        let mut d = Vec::new();
        let recorded_final = statuses
            .iter()
            .rev()
            .find(|s| s.job_id == job_msg.job_id && s.is_final());
        let recorded_tp = toolpaths.iter().find(|t| t.job_id == job_msg.job_id);
        let recorded_poses = recorded_tp.and_then(|_| {
            // Outputs of the k-th succeeded job, in recording order.
            let idx = toolpaths.iter().position(|t| t.job_id == job_msg.job_id)?;
            poses.get(idx)
        });
        let new = match shapes.get(&job_msg.surface_id) {
            Some(shape) => plan_outputs(job_msg, shape, machines, &header),
            None => Err(Error::invalid(
                "surface_id",
                format!(
                    "\"{}\" is not recorded on /surface or /pocket",
                    job_msg.surface_id
                ),
            )),
        };
        let new_state = match &new {
            Ok(_) => msgs::JobStatus::SUCCEEDED,
            Err(Error::Invalid { .. }) => msgs::JobStatus::REJECTED,
            Err(_) => msgs::JobStatus::FAILED,
        };
        match recorded_final {
            Some(s) if s.state != new_state => d.push(format!(
                "status: recorded {} ({}), now {}{}",
                msgs::JobStatus::state_name(s.state),
                s.message,
                msgs::JobStatus::state_name(new_state),
                new.as_ref()
                    .err()
                    .map(|e| format!(" ({e})"))
                    .unwrap_or_default()
            )),
            None => d.push("status: no final status recorded".into()),
            _ => {}
        }
        let mut points = 0;
        match (&new, recorded_tp) {
            (Ok(out), Some(rec)) => {
                points = out.toolpath.passes.iter().map(|p| p.points.len()).sum();
                compare_toolpath(rec, &out.toolpath, &mut d);
                if let Some(rp) = recorded_poses {
                    compare_poses(rp, &out.poses, &mut d);
                }
                let rec_traj = match out.machine {
                    Machine::Mill5 => traj_mill.next(),
                    Machine::Belt6 => traj_belt.next(),
                };
                match rec_traj {
                    Some(rt) => compare_trajectory(&rt, &out.trajectory, &mut d),
                    None => d.push(format!(
                        "trajectory: none recorded for machine {}",
                        out.machine.name()
                    )),
                }
            }
            (Ok(_), None) => {
                d.push("toolpath: the job now succeeds but no toolpath was recorded".into())
            }
            (Err(_), Some(_)) => d.push("toolpath: recorded, but the job now fails".into()),
            (Err(_), None) => {}
        }
        let _ = k;
        report.jobs.push(JobReplay {
            job_id: job_msg.job_id.clone(),
            strategy: job_msg.strategy.clone(),
            machine: job_msg.machine.clone(),
            points,
            differences: d,
        });
    }
    Ok(report)
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol || (a.is_nan() && b.is_nan())
}

fn cmp_vec(what: &str, a: [f64; 3], b: [f64; 3], tol: f64, d: &mut Vec<String>) {
    if !(0..3).all(|k| close(a[k], b[k], tol)) {
        d.push(format!(
            "{what}: recorded ({:.9}, {:.9}, {:.9}), now ({:.9}, {:.9}, {:.9})",
            a[0], a[1], a[2], b[0], b[1], b[2]
        ));
    }
}

fn cmp_num(what: &str, a: f64, b: f64, tol: f64, d: &mut Vec<String>) {
    if !close(a, b, tol) {
        d.push(format!("{what}: recorded {a}, now {b}"));
    }
}

/// At most this many point differences per pass are listed (then a count).
const MAX_LISTED: usize = 5;

fn compare_toolpath(rec: &msgs::Toolpath, new: &msgs::Toolpath, d: &mut Vec<String>) {
    if rec.strategy != new.strategy {
        d.push(format!(
            "strategy: recorded {}, now {}",
            rec.strategy, new.strategy
        ));
    }
    if rec.machine != new.machine {
        d.push(format!(
            "machine: recorded {}, now {}",
            rec.machine, new.machine
        ));
    }
    if rec.passes.len() != new.passes.len() {
        d.push(format!(
            "passes: recorded {}, now {}",
            rec.passes.len(),
            new.passes.len()
        ));
    }
    for (i, (a, b)) in rec.passes.iter().zip(&new.passes).enumerate() {
        if a.points.len() != b.points.len() {
            d.push(format!(
                "pass {i}: recorded {} points, now {}",
                a.points.len(),
                b.points.len()
            ));
            continue;
        }
        if a.region != b.region {
            d.push(format!(
                "pass {i}: region recorded {}, now {}",
                a.region, b.region
            ));
        }
        let before = d.len();
        let mut extra = 0;
        for (j, (p, q)) in a.points.iter().zip(&b.points).enumerate() {
            let mut local = Vec::new();
            cmp_vec(
                &format!("pass {i} point {j} cc"),
                p.cc.to_array(),
                q.cc.to_array(),
                POSITION_TOLERANCE_MM,
                &mut local,
            );
            cmp_vec(
                &format!("pass {i} point {j} cl"),
                p.cl.to_array(),
                q.cl.to_array(),
                POSITION_TOLERANCE_MM,
                &mut local,
            );
            cmp_vec(
                &format!("pass {i} point {j} axis"),
                p.axis.to_array(),
                q.axis.to_array(),
                VALUE_TOLERANCE,
                &mut local,
            );
            cmp_num(
                &format!("pass {i} point {j} strip_width"),
                p.strip_width,
                q.strip_width,
                POSITION_TOLERANCE_MM,
                &mut local,
            );
            if d.len() - before + local.len() > MAX_LISTED {
                extra += local.len();
            } else {
                d.extend(local);
            }
        }
        if extra > 0 {
            d.push(format!("pass {i}: {extra} more point differences"));
        }
    }
    let (a, b) = (&rec.stats, &new.stats);
    cmp_num(
        "stats.path_length_mm",
        a.path_length_mm,
        b.path_length_mm,
        POSITION_TOLERANCE_MM,
        d,
    );
    if a.passes != b.passes || a.points != b.points {
        d.push(format!(
            "stats: recorded {} passes / {} points, now {} / {}",
            a.passes, a.points, b.passes, b.points
        ));
    }
    cmp_num(
        "stats.max_scallop_mm",
        a.max_scallop_mm,
        b.max_scallop_mm,
        POSITION_TOLERANCE_MM,
        d,
    );
    cmp_num(
        "stats.max_gouge_mm",
        a.max_gouge_mm,
        b.max_gouge_mm,
        POSITION_TOLERANCE_MM,
        d,
    );
    cmp_num(
        "stats.trajectory_duration_s",
        a.trajectory_duration_s,
        b.trajectory_duration_s,
        VALUE_TOLERANCE,
        d,
    );
}

fn compare_poses(rec: &msgs::PoseArray, new: &msgs::PoseArray, d: &mut Vec<String>) {
    if rec.poses.len() != new.poses.len() {
        d.push(format!(
            "tool_poses: recorded {} poses, now {}",
            rec.poses.len(),
            new.poses.len()
        ));
        return;
    }
    let bad = rec
        .poses
        .iter()
        .zip(&new.poses)
        .filter(|(a, b)| {
            let pa = a.position.to_array();
            let pb = b.position.to_array();
            !(0..3).all(|k| close(pa[k], pb[k], POSITION_TOLERANCE_MM))
        })
        .count();
    if bad > 0 {
        d.push(format!(
            "tool_poses: {bad} positions moved by more than {POSITION_TOLERANCE_MM} mm"
        ));
    }
}

fn compare_trajectory(
    rec: &msgs::JointTrajectory,
    new: &msgs::JointTrajectory,
    d: &mut Vec<String>,
) {
    if rec.joint_names != new.joint_names {
        d.push(format!(
            "trajectory joints: recorded {:?}, now {:?}",
            rec.joint_names, new.joint_names
        ));
    }
    if rec.points.len() != new.points.len() {
        d.push(format!(
            "trajectory: recorded {} points, now {}",
            rec.points.len(),
            new.points.len()
        ));
        return;
    }
    let bad = rec
        .points
        .iter()
        .zip(&new.points)
        .filter(|(a, b)| {
            a.positions.len() != b.positions.len()
                || a.positions
                    .iter()
                    .zip(&b.positions)
                    .any(|(x, y)| !close(*x, *y, POSITION_TOLERANCE_MM))
                || !close(
                    a.time_from_start.as_secs_f64(),
                    b.time_from_start.as_secs_f64(),
                    1e-6,
                )
        })
        .count();
    if bad > 0 {
        d.push(format!(
            "trajectory: {bad} points differ (positions or times)"
        ));
    }
}
