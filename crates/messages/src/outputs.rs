//! What a job publishes once it is planned: the same messages whether the
//! node sends them over DDS, `toolpath record` writes them into a bag or
//! replay compares them with a recording.

use super::{convert, topics};
use super::{Header, JobStatus, MarkerArray, PoseArray, ToolPoseSegments, Toolpath};
use toolpath_formats::{Job, Machine, PlanResult};
use toolpath_kernel::error::Error;
use toolpath_machines::JointTrajectory;

/// The output messages of one planned job, all stamped with one header (so
/// that clients can match them to their Toolpath by stamp), except the
/// trajectory, whose stamp is its start time for the controller (zero by
/// default: start on receipt).
#[derive(Clone, Debug, PartialEq)]
pub struct JobOutputs {
    pub toolpath: Toolpath,
    pub poses: PoseArray,
    /// The same poses, one PoseArray per pass.
    pub segments: ToolPoseSegments,
    /// The machine the trajectory drives: it goes out on that machine's topic.
    pub machine: Machine,
    pub trajectory: super::JointTrajectory,
    pub markers: MarkerArray,
}

impl JobOutputs {
    /// The (relative) topic of [`Self::trajectory`].
    pub fn trajectory_topic(&self) -> &'static str {
        topics::trajectory(self.machine)
    }

    /// The SUCCEEDED status text: passes, points, length and trajectory time.
    pub fn summary(&self) -> String {
        let s = &self.toolpath.stats;
        format!(
            "{} passes, {} points, {:.1} mm, trajectory {:.1} s",
            s.passes, s.points, s.path_length_mm, s.trajectory_duration_s
        )
    }
}

/// The output messages of `job` planned into `result` and timed into
/// `trajectory`; `surface_id` is the shape id the job message named.
pub fn job_outputs(
    job: &Job,
    surface_id: &str,
    result: &PlanResult,
    trajectory: &JointTrajectory,
    header: &Header,
) -> JobOutputs {
    JobOutputs {
        toolpath: convert::toolpath_msg(
            job,
            surface_id,
            result,
            trajectory.duration(),
            header.clone(),
        ),
        poses: convert::pose_array(job, result, header.clone()),
        segments: ToolPoseSegments {
            header: header.clone(),
            job_id: job.job_id.clone(),
            segments: convert::pose_segments(job, result, header.clone()),
        },
        machine: job.machine,
        trajectory: convert::joint_trajectory_msg(trajectory, header.clone()),
        markers: convert::markers(result, header.clone()),
    }
}

/// The final state of a job that ends with `e`: REJECTED when its input is
/// bad (the client must change it), CANCELED when its client stopped it,
/// FAILED otherwise.
pub fn final_state(e: &Error) -> u8 {
    match e {
        Error::Invalid { .. } => JobStatus::REJECTED,
        Error::Stopped { canceled: true, .. } => JobStatus::CANCELED,
        _ => JobStatus::FAILED,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use toolpath_machines::Machines;
    use toolpath_pipeline::{self as pipeline, RunOptions};
    use toolpath_planners::NoProgress;

    #[test]
    fn outputs_share_the_header_and_name_the_job() {
        let job = toolpath_samples::job("plane").unwrap();
        let options = RunOptions {
            skip_verify: true,
            no_timing: true,
            ..RunOptions::default()
        };
        let result = pipeline::run(&job, &NoProgress, options).unwrap();
        let trajectory =
            toolpath_machines::trajectory(&job, &result, &Machines::default()).unwrap();
        let header = Header {
            stamp: super::super::Time { sec: 7, nanosec: 9 },
            frame_id: "workpiece".into(),
        };
        let out = job_outputs(&job, "plane_shape", &result, &trajectory, &header);
        assert_eq!(out.toolpath.header, header);
        assert_eq!(out.poses.header, header);
        // The trajectory's stamp is zero (JTC starts it on receipt), or the
        // planning stamp plus the start delay.
        assert_eq!(out.trajectory.header.stamp, crate::Time::ZERO);
        assert_eq!(out.trajectory.header.frame_id, header.frame_id);
        let mut at = trajectory.clone();
        at.stamp = toolpath_machines::Stamp::At(1.999_999_999_5);
        let m = convert::joint_trajectory_msg(&at, header.clone());
        assert_eq!(m.header.stamp, super::super::Time { sec: 9, nanosec: 9 });
        assert!(out.trajectory.points[0].time_from_start.as_secs_f64() > 0.0);
        assert!(out.markers.markers.iter().all(|m| m.header == header));
        assert_eq!(out.toolpath.job_id, job.job_id);
        assert_eq!(out.toolpath.surface_id, "plane_shape");
        // One pose per point of every pass, one trajectory point per timed sample.
        let points: usize = result.passes.iter().map(|p| p.points.len()).sum();
        assert_eq!(out.poses.poses.len(), points);
        // Segments: one per pass with that pass's points, the poses of
        // tool_poses in order, every one with the job's header.
        let seg = &out.segments;
        assert_eq!(
            (&seg.header, seg.job_id.as_str()),
            (&header, job.job_id.as_str())
        );
        let lens: Vec<usize> = seg.segments.iter().map(|s| s.poses.len()).collect();
        let pass_lens: Vec<usize> = result.passes.iter().map(|p| p.points.len()).collect();
        assert_eq!(lens, pass_lens);
        assert!(seg.segments.iter().all(|s| s.header == header));
        let joined: Vec<_> = seg.segments.iter().flat_map(|s| s.poses.clone()).collect();
        assert_eq!(joined, out.poses.poses);
        assert_eq!(out.trajectory.points.len(), trajectory.timed.times.len());
        assert_eq!(out.trajectory_topic(), topics::MILL5_TRAJECTORY);
        assert_eq!(
            out.summary(),
            format!(
                "{} passes, {points} points, {:.1} mm, trajectory {:.1} s",
                result.passes.len(),
                result.cl_path_length(),
                trajectory.duration()
            )
        );
    }

    #[test]
    fn bad_input_is_rejected_and_everything_else_failed() {
        assert_eq!(
            final_state(&Error::invalid("tool.radius", "must be positive")),
            JobStatus::REJECTED
        );
        assert_eq!(
            final_state(&Error::planning("no passes")),
            JobStatus::FAILED
        );
        assert_eq!(
            final_state(&Error::canceled("by its client")),
            JobStatus::CANCELED
        );
        let time_limit = Error::Stopped {
            message: "time budget spent".into(),
            canceled: false,
        };
        assert_eq!(final_state(&time_limit), JobStatus::FAILED);
    }

    #[test]
    fn per_pass_chunks_each_meet_the_controller_rules_from_where_the_last_left() {
        let m = Machines::default();
        for name in ["plane", "sine_wave"] {
            let job = toolpath_samples::job(name).unwrap();
            let options = RunOptions {
                skip_verify: true,
                no_timing: true,
                ..RunOptions::default()
            };
            let result = pipeline::run(&job, &NoProgress, options).unwrap();
            let t = toolpath_machines::trajectory(&job, &result, &m).unwrap();
            let whole = convert::joint_trajectory_msg(&t, Header::default());
            let chunks = convert::trajectory_chunks(&t, &whole);
            assert_eq!(chunks.len(), result.passes.len(), "{name}");
            let mut start = t.start.clone();
            let mut end = 0.0;
            let mut points = 0;
            for c in &chunks {
                let p = convert::trajectory_points(c, &t.joint_names, &t.limits);
                toolpath_machines::jtc::check(&p, &t.joint_names, &t.limits, Some(&start))
                    .unwrap_or_else(|e| panic!("{name}: {e}"));
                // Chunk times plus where the previous chunk ended give the
                // whole trajectory's times.
                for (k, time) in p.times.iter().enumerate() {
                    let want = t.timed.times[points + k];
                    assert!(
                        (end + time - want).abs() < 2e-9,
                        "{name}: {} vs {want}",
                        end + time
                    );
                }
                points += p.times.len();
                end = t.timed.times[points - 1];
                start = p.positions.last().unwrap().clone();
            }
            assert_eq!(points, whole.points.len());
        }
    }
}
