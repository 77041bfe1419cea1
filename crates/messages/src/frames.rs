//! The coordinate frames of the node's messages: the workpiece frame every
//! output is in, the base frames of the two machines, the `/tf_static` that
//! relates them (tf2_msgs/TFMessage) and the rule for inputs given in another
//! frame.
//!
//! The tree is `mill5 base -> workpiece -> belt6 base`: the workpiece hangs
//! from the mill's base at the mill's placement, and the grinder's base hangs
//! from the workpiece at the inverse of the grinder's placement, so one tree
//! holds both machines with every pose from the config (a frame has one
//! parent in TF).
//!
//! Inputs: a message whose `header.frame_id` is empty or the workpiece frame
//! is taken as it is; a surface or job in a machine's base frame is moved into
//! the workpiece frame (control points, section normal); anything else is
//! refused naming the frame and the frames the node knows. A pocket is an
//! outline in the workpiece's xy plane, so it must be given in the workpiece
//! frame.

use super::follow_joint_trajectory::Transform;
use super::msgs::{ros_message, Header, Job, Pocket, Point, Quaternion, Surface, Vector3};
use serde::{Deserialize, Serialize};
use toolpath_kernel::error::{Error, Result};
use toolpath_machines::Placement;

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    pub header: Header,
    pub child_frame_id: String,
    pub transform: Transform,
}
ros_message!(TransformStamped, "geometry_msgs", "TransformStamped");

/// tf2_msgs/TFMessage, the type of `/tf` and `/tf_static`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TfMessage {
    pub transforms: Vec<TransformStamped>,
}
ros_message!(TfMessage, "tf2_msgs", "TFMessage");

/// TF carries metres (REP 103); the crate works in mm.
const M_PER_MM: f64 = 1e-3;

/// The workpiece frame and the machines' base frames with their placements.
#[derive(Clone, Debug, PartialEq)]
pub struct Frames {
    pub workpiece: String,
    /// The mill's base frame and the workpiece's pose in it.
    pub mill5: (String, Placement),
    /// The grinder's base frame and the workpiece's pose in it.
    pub belt6: (String, Placement),
}

impl Frames {
    /// The placement of the workpiece in `frame` when it is a machine base.
    fn machine(&self, frame: &str) -> Option<&Placement> {
        [&self.mill5, &self.belt6]
            .into_iter()
            .find(|(name, _)| name == frame)
            .map(|(_, p)| p)
    }

    fn is_workpiece(&self, frame: &str) -> bool {
        frame.is_empty() || frame == self.workpiece
    }

    fn unknown(&self, field: &str, frame: &str) -> Error {
        Error::invalid(
            field,
            format!(
                "frame \"{frame}\" is not known here: give the workpiece frame \"{}\" (node.frame_id) or a machine base frame (\"{}\", \"{}\")",
                self.workpiece, self.mill5.0, self.belt6.0
            ),
        )
    }

    /// The surface in the workpiece frame (its control points moved when it
    /// is given in a machine's base frame; weights and trims are frame-free).
    pub fn surface_in_workpiece(&self, m: Surface) -> Result<Surface> {
        let frame = &m.header.frame_id;
        if self.is_workpiece(frame) {
            return Ok(m);
        }
        let Some(p) = self.machine(frame) else {
            return Err(self.unknown("surface.header.frame_id", frame));
        };
        let p = *p;
        let mut m = m;
        for c in &mut m.control_points {
            *c = Point::from_array(p.point_to_workpiece(c.to_array()));
        }
        m.header.frame_id = self.workpiece.clone();
        Ok(m)
    }

    /// The job in the workpiece frame (its section normal turned when it is
    /// given in a machine's base frame).
    pub fn job_in_workpiece(&self, m: &Job) -> Result<Option<Job>> {
        let frame = &m.header.frame_id;
        if self.is_workpiece(frame) {
            return Ok(None);
        }
        let Some(p) = self.machine(frame) else {
            return Err(self.unknown("job.header.frame_id", frame));
        };
        let mut m = m.clone();
        m.section_normal = Vector3::from_array(p.vector_to_workpiece(m.section_normal.to_array()));
        m.header.frame_id = self.workpiece.clone();
        Ok(Some(m))
    }

    /// A pocket must be in the workpiece frame.
    pub fn check_pocket(&self, m: &Pocket) -> Result<()> {
        let frame = &m.header.frame_id;
        if self.is_workpiece(frame) {
            return Ok(());
        }
        Err(Error::invalid(
            "pocket.header.frame_id",
            format!(
                "\"{frame}\": a pocket is an outline in the workpiece's xy plane; give it in the workpiece frame \"{}\" (node.frame_id)",
                self.workpiece
            ),
        ))
    }

    /// The static transforms of the tree, stamped `stamp`.
    pub fn tf_static(&self, stamp: &Header) -> TfMessage {
        let (mill_frame, mill) = &self.mill5;
        let (belt_frame, belt) = &self.belt6;
        // The grinder's base in the workpiece frame: origin R^T (0 - o), turn R^T.
        let belt_origin = belt.point_to_workpiece([0.0; 3]);
        let q = belt.quaternion_xyzw();
        let stamped = |parent: &str, child: &str, t: [f64; 3], q: [f64; 4]| TransformStamped {
            header: Header {
                stamp: stamp.stamp,
                frame_id: parent.to_string(),
            },
            child_frame_id: child.to_string(),
            transform: Transform {
                translation: Vector3::from_array(t.map(|x| x * M_PER_MM)),
                rotation: Quaternion {
                    x: q[0],
                    y: q[1],
                    z: q[2],
                    w: q[3],
                },
            },
        };
        TfMessage {
            transforms: vec![
                stamped(
                    mill_frame,
                    &self.workpiece,
                    mill.origin(),
                    mill.quaternion_xyzw(),
                ),
                stamped(
                    &self.workpiece,
                    belt_frame,
                    belt_origin,
                    [-q[0], -q[1], -q[2], q[3]],
                ),
            ],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    fn frames() -> Frames {
        Frames {
            workpiece: "workpiece".into(),
            mill5: (
                "mill5_base".into(),
                Placement::new([2500.0, 1000.0, 300.0], [0.0, 0.0, FRAC_PI_2]),
            ),
            belt6: (
                "belt6_base".into(),
                Placement::new([1500.0, 1000.0, 400.0], [0.0, 0.0, FRAC_PI_2]),
            ),
        }
    }

    fn header(frame: &str) -> Header {
        Header {
            frame_id: frame.into(),
            ..Header::default()
        }
    }

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        (0..3).all(|k| (a[k] - b[k]).abs() < 1e-9)
    }

    #[test]
    fn the_tree_hangs_the_workpiece_from_the_mill_and_the_grinder_from_the_workpiece() {
        let tf = frames().tf_static(&header(""));
        let t: Vec<(&str, &str)> = tf
            .transforms
            .iter()
            .map(|t| (t.header.frame_id.as_str(), t.child_frame_id.as_str()))
            .collect();
        assert_eq!(
            t,
            [("mill5_base", "workpiece"), ("workpiece", "belt6_base")]
        );
        assert!(close(
            tf.transforms[0].transform.translation.to_array(),
            [2.5, 1.0, 0.3]
        ));
        // The grinder's base origin, seen from the workpiece turned 90 deg
        // about z at (1500, 1000, 400): machine -x is workpiece +y.
        assert!(close(
            tf.transforms[1].transform.translation.to_array(),
            [-1.0, 1.5, -0.4]
        ));
        let r = tf.transforms[1].transform.rotation;
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert!((r.z + h).abs() < 1e-12 && (r.w - h).abs() < 1e-12, "{r:?}");
    }

    #[test]
    fn a_surface_in_a_machine_frame_is_moved_onto_the_workpiece() {
        let m = Surface {
            header: header("mill5_base"),
            control_points: vec![Point::from_array([2500.0, 1010.0, 305.0])],
            ..Surface::default()
        };
        let w = frames().surface_in_workpiece(m).unwrap();
        assert_eq!(w.header.frame_id, "workpiece");
        assert!(close(w.control_points[0].to_array(), [10.0, 0.0, 5.0]));
        let same = Surface {
            header: header("workpiece"),
            control_points: vec![Point::from_array([1.0, 2.0, 3.0])],
            ..Surface::default()
        };
        assert_eq!(frames().surface_in_workpiece(same.clone()).unwrap(), same);
    }

    #[test]
    fn unknown_frames_and_pockets_off_the_workpiece_are_refused_by_name() {
        let m = Surface {
            header: header("fixture"),
            ..Surface::default()
        };
        let e = frames().surface_in_workpiece(m).unwrap_err().to_string();
        assert!(
            e.contains("surface.header.frame_id") && e.contains("\"fixture\""),
            "{e}"
        );
        let job = Job {
            header: header("world"),
            ..Job::default()
        };
        let e = frames().job_in_workpiece(&job).unwrap_err().to_string();
        assert!(
            e.contains("job.header.frame_id") && e.contains("mill5_base"),
            "{e}"
        );
        let pocket = Pocket {
            header: header("mill5_base"),
            ..Pocket::default()
        };
        let e = frames().check_pocket(&pocket).unwrap_err().to_string();
        assert!(e.contains("pocket.header.frame_id"), "{e}");
    }

    #[test]
    fn a_job_in_a_machine_frame_has_its_section_normal_turned() {
        let job = Job {
            header: header("belt6_base"),
            section_normal: Vector3::from_array([0.0, 1.0, 0.0]),
            ..Job::default()
        };
        let w = frames().job_in_workpiece(&job).unwrap().unwrap();
        assert!(close(w.section_normal.to_array(), [1.0, 0.0, 0.0]));
        assert_eq!(w.header.frame_id, "workpiece");
    }
}
