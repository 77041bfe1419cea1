//! The Toolpath message of a plan and its tool poses.

use super::{tool_to_msg, vec3, MM};
use crate as msgs;
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};
use toolpath_formats::{Job, Machine, PlanResult};
use toolpath_machines as machines;

/// The Toolpath message of a planned job (mm, as the result file).
pub fn toolpath_msg(
    job: &Job,
    surface_id: &str,
    result: &PlanResult,
    trajectory_duration_s: f64,
    header: msgs::Header,
) -> msgs::Toolpath {
    let passes = toolpath_passes(job, result);
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

/// The passes of a plan as messages: the surface passes, then each pocket
/// tool's passes (in the plane z = 0, axis +z) with its stage.
fn toolpath_passes(job: &Job, result: &PlanResult) -> Vec<msgs::ToolpathPass> {
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
    passes
}

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
