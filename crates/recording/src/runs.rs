//! Bags of planner runs with the node's topics and messages: recording a job
//! run (`toolpath record`), and replaying a bag's jobs with a comparison of
//! the new outputs against the recorded ones (`toolpath replay --check`).
//!
//! Planning is deterministic, so a replay reproduces every recorded output
//! except header stamps and `stats.compute_ms`, which are not compared.

use super::{read_bag, ros2_type_name, Bag, BagWriter, Qos, TopicSpec, WriterOptions};
use std::collections::BTreeMap;
use std::path::Path;
use toolpath_formats::{Job, Machine, Shape};
use toolpath_kernel::error::{Error, Result};
use toolpath_machines::Machines;
use toolpath_messages::plan_toolpath::FeedbackMessage;
use toolpath_messages::{self as msgs, convert, final_state, job_outputs, topics};
use toolpath_messages::{JobOutputs, RosMessage};
use toolpath_pipeline::{self as pipeline, RunOptions};
use toolpath_planners::NoProgress;

/// Positions (mm) may differ by this much in a replay before it is a difference.
pub const POSITION_TOLERANCE_MM: f64 = 1e-6;
/// Unit vectors, times and other values: absolute tolerance.
pub const VALUE_TOLERANCE: f64 = 1e-9;

fn spec<M: RosMessage>(topic: &str, qos: Qos) -> TopicSpec {
    let full = M::full_name();
    TopicSpec::new(
        topic,
        &M::type_name(),
        &msgs::schema_text(&full).unwrap_or_else(|| M::definition().to_string()),
        qos,
    )
}

/// The name of the node topic `relative` in a bag of a node without a
/// namespace (`/job`): how every bag reads once [`strip_namespace`] has run.
fn root(relative: &str) -> String {
    topics::absolute("/", relative)
}

/// Every topic of the node, with the QoS it offers (inputs: as the clients publish them).
pub fn topic_specs() -> Vec<TopicSpec> {
    topic_specs_in("/")
}

/// [`topic_specs`] of a node in `namespace` (`/cell_b`: `/cell_b/job`, ...).
pub fn topic_specs_in(namespace: &str) -> Vec<TopicSpec> {
    let t = |relative: &str| topics::absolute(namespace, relative);
    let results = Qos::reliable_transient_local(10);
    vec![
        spec::<msgs::Surface>(&t(topics::SURFACE), Qos::reliable_transient_local(100)),
        spec::<msgs::Pocket>(&t(topics::POCKET), Qos::reliable_transient_local(100)),
        spec::<msgs::Job>(&t(topics::JOB), Qos::reliable_volatile(100)),
        spec::<msgs::Toolpath>(&t(topics::TOOLPATH), results),
        spec::<msgs::PoseArray>(&t(topics::TOOL_POSES), results),
        spec::<msgs::ToolPoseSegments>(&t(topics::TOOL_POSE_SEGMENTS), results),
        spec::<msgs::JointTrajectory>(&t(topics::MILL5_TRAJECTORY), results),
        spec::<msgs::JointTrajectory>(&t(topics::BELT6_TRAJECTORY), results),
        spec::<msgs::JobStatus>(&t(topics::JOB_STATUS), Qos::reliable_transient_local(1000)),
        spec::<msgs::MarkerArray>(&t(topics::MARKERS), results),
        // The action's topics with the QoS rcl_action gives them.
        spec::<FeedbackMessage>(&t(topics::PLAN_TOOLPATH_FEEDBACK), Qos::DEFAULT),
        spec::<msgs::GoalStatusArray>(
            &t(topics::PLAN_TOOLPATH_STATUS),
            Qos::reliable_transient_local(1),
        ),
    ]
}

/// A bag recorded by a node in a namespace (`/cell_b/job`, ...) read as if
/// the node had none, so that replay finds its topics.
fn strip_namespace(bag: &mut Bag) {
    let job_type = ros2_type_name(&msgs::Job::full_name());
    let job_topic = root(topics::JOB);
    let Some(ns) = bag
        .topics
        .values()
        .filter(|t| t.type_name == job_type)
        .find_map(|t| t.topic.strip_suffix(&job_topic).filter(|ns| !ns.is_empty()))
        .map(str::to_string)
    else {
        return;
    };
    let strip = |topic: &str| match topic.strip_prefix(&ns) {
        Some(rest) if rest.starts_with('/') => rest.to_string(),
        _ => topic.to_string(),
    };
    bag.topics = std::mem::take(&mut bag.topics)
        .into_values()
        .map(|mut t| {
            t.topic = strip(&t.topic);
            (t.topic.clone(), t)
        })
        .collect();
    for m in &mut bag.messages {
        m.topic = strip(&m.topic);
    }
}

fn spec_of(topic: &str) -> Result<TopicSpec> {
    topic_specs()
        .into_iter()
        .find(|s| s.topic == topic)
        .ok_or_else(|| Error::invalid(topic, "not a topic of the node"))
}

/// Plans `job_msg` on `shape` as the node does and builds its output messages.
pub fn plan_outputs(
    job_msg: &msgs::Job,
    shape: &Shape,
    machines: &Machines,
    header: &msgs::Header,
) -> Result<JobOutputs> {
    let job = convert::job_from_msg(job_msg, shape)?;
    let result = pipeline::run(&job, &NoProgress, RunOptions::default())?;
    pipeline::refuse_gouge(&job, &result)?;
    let trajectory = toolpath_machines::trajectory(&job, &result, machines)?;
    Ok(job_outputs(
        &job,
        &job_msg.surface_id,
        &result,
        &trajectory,
        header,
    ))
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
        eta_s: -1.0,
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
/// Returns the bag's summary and the final status recorded.
pub fn record_job(
    job: &Job,
    directory: &Path,
    machines: &Machines,
) -> Result<(super::BagSummary, msgs::JobStatus)> {
    let mut w = BagWriter::create(directory, WriterOptions::default())?;
    for s in topic_specs() {
        w.add_topic(&s)?;
    }
    let last = record_job_into(&mut w, job, machines)?;
    Ok((w.finish()?, last))
}

/// Records one job run into an open bag (several jobs may share a bag);
/// returns the final status recorded.
pub fn record_job_into(
    w: &mut BagWriter,
    job: &Job,
    machines: &Machines,
) -> Result<msgs::JobStatus> {
    let header = header_now();
    let t = |w: &BagWriter| super::now_ns().max(w.metadata().duration.nanoseconds);
    let shape_id = format!("{}_shape", job.job_id);
    match &job.shape {
        Shape::Surface(s) => w.write(
            &root(topics::SURFACE),
            t(w),
            &convert::surface_to_msg(&shape_id, s, header.clone()),
        )?,
        Shape::Pocket(p) => w.write(
            &root(topics::POCKET),
            t(w),
            &convert::pocket_to_msg(&shape_id, p, header.clone()),
        )?,
    }
    let job_msg = convert::job_to_msg(job, &shape_id, header.clone());
    w.write(&root(topics::JOB), t(w), &job_msg)?;
    w.write(
        &root(topics::JOB_STATUS),
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
        &root(topics::JOB_STATUS),
        t(w),
        &status(
            &header,
            &job.job_id,
            msgs::JobStatus::RUNNING,
            0.0,
            String::new(),
        ),
    )?;
    let last = match plan_outputs(&job_msg, &job.shape, machines, &header) {
        Ok(out) => {
            w.write(&root(topics::TOOLPATH), t(w), &out.toolpath)?;
            w.write(&root(topics::TOOL_POSES), t(w), &out.poses)?;
            w.write(&root(topics::TOOL_POSE_SEGMENTS), t(w), &out.segments)?;
            w.write(&root(out.trajectory_topic()), t(w), &out.trajectory)?;
            w.write(&root(topics::MARKERS), t(w), &out.markers)?;
            status(
                &header,
                &job.job_id,
                msgs::JobStatus::SUCCEEDED,
                1.0,
                out.summary(),
            )
        }
        Err(e) => status(&header, &job.job_id, final_state(&e), 0.0, e.to_string()),
    };
    w.write(&root(topics::JOB_STATUS), t(w), &last)?;
    // The job's messages form a unit: put them on disk now.
    w.flush()?;
    Ok(last)
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

/// Every message of the node topic `relative` in a bag without a namespace.
fn decode_all<M: RosMessage>(bag: &Bag, relative: &str) -> Result<Vec<M>> {
    let topic = root(relative);
    let spec = spec_of(&topic)?;
    bag.messages
        .iter()
        .enumerate()
        .filter(|(_, m)| m.topic == topic)
        .map(|(i, _)| bag.decode::<M>(i, &spec))
        .collect()
}

/// Everything a bag recorded, decoded (topics without the node's namespace).
#[derive(Clone, Debug)]
pub struct Recorded {
    pub surfaces: Vec<msgs::Surface>,
    pub pockets: Vec<msgs::Pocket>,
    pub jobs: Vec<msgs::Job>,
    pub toolpaths: Vec<msgs::Toolpath>,
    pub poses: Vec<msgs::PoseArray>,
    /// Empty in bags recorded before the topic existed.
    pub segments: Vec<msgs::ToolPoseSegments>,
    pub statuses: Vec<msgs::JobStatus>,
    pub mill5: Vec<msgs::JointTrajectory>,
    pub belt6: Vec<msgs::JointTrajectory>,
    pub truncated: Option<String>,
}

/// The outputs of one job of a run, as recorded or as a new run produced them.
#[derive(Clone, Debug, Default)]
pub struct RunOutputs<'a> {
    /// Final state (JobStatus constants) and its message; `None`: no final status.
    pub state: Option<(u8, String)>,
    pub toolpath: Option<&'a msgs::Toolpath>,
    pub poses: Option<&'a msgs::PoseArray>,
    pub trajectory: Option<(Machine, &'a msgs::JointTrajectory)>,
}

fn same_stamp(a: &msgs::Header, b: &msgs::Header) -> bool {
    a.stamp == b.stamp
}

/// Whether `j` is the trajectory published with toolpath `t`: its stamp is
/// the toolpath's, or the start time the controller is given (zero, or
/// later than planning), and it lasts as long as the toolpath says, to the
/// microsecond (the stamp alone no longer names the job).
pub fn is_trajectory_of(j: &msgs::JointTrajectory, t: &msgs::Toolpath) -> bool {
    if same_stamp(&j.header, &t.header) {
        return true;
    }
    let (js, ts) = (&j.header.stamp, &t.header.stamp);
    let starts = *js == msgs::Time::ZERO || (js.sec, js.nanosec) >= (ts.sec, ts.nanosec);
    let duration = j
        .points
        .last()
        .map_or(0.0, |p| p.time_from_start.as_secs_f64());
    starts && (duration - t.stats.trajectory_duration_s).abs() < 1e-6
}

/// Outputs of `job_id` among messages of one run: the last final status, the
/// toolpath naming the job, the poses published with it (the node stamps the
/// outputs of a job with one header stamp) and its trajectory
/// ([`is_trajectory_of`]).
pub fn outputs_of<'a>(
    job_id: &str,
    statuses: &'a [msgs::JobStatus],
    toolpaths: &'a [msgs::Toolpath],
    poses: &'a [msgs::PoseArray],
    mill5: &'a [msgs::JointTrajectory],
    belt6: &'a [msgs::JointTrajectory],
) -> RunOutputs<'a> {
    let state = statuses
        .iter()
        .rev()
        .find(|s| s.job_id == job_id && s.is_final())
        .map(|s| (s.state, s.message.clone()));
    let toolpath = toolpaths.iter().rev().find(|t| t.job_id == job_id);
    let poses = toolpath.and_then(|t| poses.iter().find(|p| same_stamp(&p.header, &t.header)));
    let trajectory = toolpath.and_then(|t| {
        let (machine, list) = match t.machine.as_str() {
            "belt6" => (Machine::Belt6, belt6),
            _ => (Machine::Mill5, mill5),
        };
        list.iter()
            .find(|j| is_trajectory_of(j, t))
            .map(|j| (machine, j))
    });
    RunOutputs {
        state,
        toolpath,
        poses,
        trajectory,
    }
}

impl Recorded {
    /// Reads and decodes the bag at `path` (a bag directory or its .mcap).
    pub fn read(path: &Path) -> Result<Self> {
        let mut bag = read_bag(path)?;
        strip_namespace(&mut bag);
        bag.check_types(&topic_specs())?;
        let jobs = decode_all::<msgs::Job>(&bag, topics::JOB)?;
        if jobs.is_empty() {
            return Err(Error::invalid(
                path.display().to_string(),
                "the bag holds no job on /job",
            ));
        }
        Ok(Recorded {
            surfaces: decode_all(&bag, topics::SURFACE)?,
            pockets: decode_all(&bag, topics::POCKET)?,
            jobs,
            toolpaths: decode_all(&bag, topics::TOOLPATH)?,
            poses: decode_all(&bag, topics::TOOL_POSES)?,
            segments: decode_all(&bag, topics::TOOL_POSE_SEGMENTS)?,
            statuses: decode_all(&bag, topics::JOB_STATUS)?,
            mill5: decode_all(&bag, topics::MILL5_TRAJECTORY)?,
            belt6: decode_all(&bag, topics::BELT6_TRAJECTORY)?,
            truncated: bag.truncated.clone(),
        })
    }

    /// The recorded outputs of `job_id`.
    pub fn outputs(&self, job_id: &str) -> RunOutputs<'_> {
        outputs_of(
            job_id,
            &self.statuses,
            &self.toolpaths,
            &self.poses,
            &self.mill5,
            &self.belt6,
        )
    }

    /// The recorded shapes by id (surfaces and pockets).
    pub fn shapes(&self) -> Result<BTreeMap<String, Shape>> {
        let mut shapes = BTreeMap::new();
        for m in &self.surfaces {
            shapes.insert(
                m.surface_id.clone(),
                Shape::Surface(convert::surface_from_msg(m)?),
            );
        }
        for m in &self.pockets {
            shapes.insert(
                m.pocket_id.clone(),
                Shape::Pocket(convert::pocket_from_msg(m)?),
            );
        }
        Ok(shapes)
    }
}

/// The differences of a new run of a job from its recording, readable.
pub fn compare_outputs(rec: &RunOutputs<'_>, new: &RunOutputs<'_>) -> Vec<String> {
    let mut d = Vec::new();
    match (&rec.state, &new.state) {
        (Some((a, am)), Some((b, bm))) if a != b => d.push(format!(
            "status: recorded {} ({am}), now {} ({bm})",
            msgs::JobStatus::state_name(*a),
            msgs::JobStatus::state_name(*b),
        )),
        (None, _) => d.push("status: no final status recorded".into()),
        (Some(_), None) => d.push("status: no final status now".into()),
        _ => {}
    }
    match (rec.toolpath, new.toolpath) {
        (Some(r), Some(n)) => {
            compare_toolpath(r, n, &mut d);
            match (rec.poses, new.poses) {
                (Some(a), Some(b)) => compare_poses(a, b, &mut d),
                (Some(_), None) => d.push("tool_poses: recorded, but none now".into()),
                _ => {}
            }
            match (rec.trajectory, new.trajectory) {
                (Some((ma, a)), Some((mb, b))) => {
                    if ma != mb {
                        d.push(format!(
                            "trajectory: recorded for {}, now for {}",
                            ma.name(),
                            mb.name()
                        ));
                    }
                    compare_trajectory(a, b, &mut d)
                }
                (None, Some((m, _))) => d.push(format!(
                    "trajectory: none recorded for machine {}",
                    m.name()
                )),
                (Some(_), None) => d.push("trajectory: recorded, but none now".into()),
                (None, None) => {}
            }
        }
        (None, Some(_)) => {
            d.push("toolpath: the job now succeeds but no toolpath was recorded".into())
        }
        (Some(_), None) => d.push("toolpath: recorded, but the job now fails".into()),
        (None, None) => {}
    }
    d
}

/// Re-plans every job of the bag at `path` and compares the outputs with the
/// recorded ones.
pub fn replay(path: &Path, machines: &Machines) -> Result<ReplayReport> {
    let rec = Recorded::read(path)?;
    let shapes = rec.shapes()?;
    let header = header_now();
    let mut report = ReplayReport {
        jobs: Vec::new(),
        truncated: rec.truncated.clone(),
    };
    for job_msg in &rec.jobs {
        let planned = match shapes.get(&job_msg.surface_id) {
            Some(shape) => plan_outputs(job_msg, shape, machines, &header),
            None => Err(Error::invalid(
                "surface_id",
                format!(
                    "\"{}\" is not recorded on /surface or /pocket",
                    job_msg.surface_id
                ),
            )),
        };
        let new = match &planned {
            Ok(out) => RunOutputs {
                state: Some((msgs::JobStatus::SUCCEEDED, out.summary())),
                toolpath: Some(&out.toolpath),
                poses: Some(&out.poses),
                trajectory: Some((out.machine, &out.trajectory)),
            },
            Err(e) => RunOutputs {
                state: Some((final_state(e), e.to_string())),
                ..Default::default()
            },
        };
        report.jobs.push(JobReplay {
            job_id: job_msg.job_id.clone(),
            strategy: job_msg.strategy.clone(),
            machine: job_msg.machine.clone(),
            points: new.toolpath.map_or(0, point_count),
            differences: {
                let recorded = rec.outputs(&job_msg.job_id);
                let mut d = compare_outputs(&recorded, &new);
                if let (Some(t), Ok(out)) = (recorded.toolpath, &planned) {
                    compare_segments(&rec.segments, t, &out.segments, &mut d);
                }
                d
            },
        });
    }
    Ok(report)
}

/// The recorded segments of toolpath `t` (same job, same stamp) against the
/// new ones: as many passes of as many poses, at the same places (poses
/// themselves are compared on tool_poses). Nothing when none were recorded.
fn compare_segments(
    recorded: &[msgs::ToolPoseSegments],
    t: &msgs::Toolpath,
    new: &msgs::ToolPoseSegments,
    d: &mut Vec<String>,
) {
    let Some(rec) = recorded
        .iter()
        .rev()
        .find(|s| s.job_id == t.job_id && same_stamp(&s.header, &t.header))
    else {
        return;
    };
    let lens = |s: &msgs::ToolPoseSegments| -> Vec<usize> {
        s.segments.iter().map(|p| p.poses.len()).collect()
    };
    if lens(rec) != lens(new) {
        d.push(format!(
            "tool_pose_segments: recorded {} segments of {:?} poses, now {} of {:?}",
            rec.segments.len(),
            lens(rec),
            new.segments.len(),
            lens(new)
        ));
        return;
    }
    for (k, (a, b)) in rec.segments.iter().zip(&new.segments).enumerate() {
        let before = d.len();
        compare_poses(a, b, d);
        for line in &mut d[before..] {
            *line = format!("tool_pose_segments[{k}]: {line}");
        }
    }
}

/// Number of points of a toolpath message (all passes).
pub fn point_count(t: &msgs::Toolpath) -> usize {
    t.passes.iter().map(|p| p.points.len()).sum()
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
        compare_pass(i, a, b, d);
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

/// The differences of pass `i`, its points' listed up to [`MAX_LISTED`].
fn compare_pass(i: usize, a: &msgs::ToolpathPass, b: &msgs::ToolpathPass, d: &mut Vec<String>) {
    if a.points.len() != b.points.len() {
        d.push(format!(
            "pass {i}: recorded {} points, now {}",
            a.points.len(),
            b.points.len()
        ));
        return;
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
