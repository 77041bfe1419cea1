//! The interface the trajectory code needs of a machine, whatever its build:
//! [`Kinematics`] (the axes and how the joints pose the tool on the part)
//! and [`Machine`] (a cell's machine: its name, controller, home pose,
//! retract and feed limits). mill5 and belt6 of a cell config implement
//! both, the five-axis definitions of the posts ([`crate::FiveAxis`])
//! implement [`Kinematics`]; a machine read from a robot description (a
//! kinematic chain with a tool chain and a part chain, numeric or
//! closed-form inverse kinematics) plugs in by implementing the same two
//! traits, with no change to the trajectory code.

use crate::axes::AxisSet;
use crate::controller::ControllerConfig;
use crate::{belt6, mill5, normalise, Belt6Config, FiveAxis, Mill5Config, ToolPose};
use toolpath_kernel::error::Result;

/// The tool tip (belt: wheel centre) and unit tool axis (belt: wheel axis)
/// of a joint position, in the workpiece frame (mm).
pub type TipAxis = toolpath_motion::ToolPose;

/// Two rotary axes (tilt, turn) of a head whose other solution, tilt
/// negated and turn + pi, poses the same tool with every other axis
/// unchanged (indices in joint order).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BranchFlip {
    pub tilt: usize,
    pub turn: usize,
}

/// A machine's kinematics. Joint vectors hold one value per axis of
/// [`Kinematics::axes`], mm and rad (a shorter one is a caller's bug and
/// panics).
pub trait Kinematics {
    /// The axes in joint order: names, linear or rotary, travel, velocity,
    /// acceleration and jerk limits.
    fn axes(&self) -> AxisSet;

    /// The tool pose of joints `q` in the workpiece frame. `tool_length` is
    /// the tool's length beyond the spindle gauge line; a machine that poses
    /// the tool's own frame (belt6: the wheel centre) ignores it.
    fn forward(&self, tool_length: f64, q: &[f64]) -> TipAxis;

    /// Joints of consecutive tool poses, continuous along them: of the
    /// solutions of each pose the branch nearest the previous joints, rotary
    /// axes unwrapped next to their previous values, free axes (at a
    /// singularity) held. Errors say which pose cannot be reached.
    fn inverse_path(&self, tool_length: f64, poses: &[ToolPose]) -> Result<Vec<Vec<f64>>>;

    /// A head's other solution (see [`BranchFlip`]), which a whole pass may
    /// take when no whole-turn shift of its rotaries fits the travel;
    /// `None` when the machine has none of this form.
    fn branch_flip(&self) -> Option<BranchFlip> {
        None
    }
}

/// A machine of a cell: [`Kinematics`] plus what a trajectory needs to
/// start, leave the part and be executed.
pub trait Machine: Kinematics {
    /// The name in messages and errors ("mill5").
    fn name(&self) -> &str;

    /// Its trajectory controller (joint names, action, start policy, home).
    fn controller(&self) -> &ControllerConfig;

    /// The pose a trajectory starts from when no joint state is known
    /// (mm, rad).
    fn home(&self) -> Vec<f64>;

    /// How far each pass is entered and left along
    /// [`Machine::retract_direction`], mm.
    fn retract_mm(&self) -> f64;

    /// Jobs asking for a faster feed are refused, mm/min.
    fn max_feed_rate_mm_min(&self) -> f64;

    /// The unit direction (workpiece frame) in which the tool leaves the
    /// part at `pose`.
    fn retract_direction(&self, pose: &ToolPose) -> [f64; 3];

    /// The controller's joint names, in axis order.
    fn joint_names(&self) -> Vec<String> {
        self.controller().joint_names(&self.axes())
    }
}

fn joints<const N: usize>(q: &[f64]) -> [f64; N] {
    std::array::from_fn(|j| q[j])
}

impl Kinematics for Mill5Config {
    fn axes(&self) -> AxisSet {
        self.cell().axis_set()
    }

    fn forward(&self, tool_length: f64, q: &[f64]) -> TipAxis {
        let (tip, axis) = mill5::forward(self, self.pivot_length_mm + tool_length, &joints(q));
        TipAxis { tip, axis }
    }

    fn inverse_path(&self, tool_length: f64, poses: &[ToolPose]) -> Result<Vec<Vec<f64>>> {
        let input: Vec<([f64; 3], [f64; 3])> = poses.iter().map(|t| (t.tip, t.axis)).collect();
        let q = mill5::inverse_path(self, self.pivot_length_mm + tool_length, &input)?;
        Ok(q.into_iter().map(|r| r.to_vec()).collect())
    }

    fn branch_flip(&self) -> Option<BranchFlip> {
        Some(BranchFlip { tilt: 3, turn: 4 })
    }
}

impl Machine for Mill5Config {
    fn name(&self) -> &str {
        "mill5"
    }

    fn controller(&self) -> &ControllerConfig {
        &self.controller
    }

    fn home(&self) -> Vec<f64> {
        Mill5Config::home(self)
    }

    fn retract_mm(&self) -> f64 {
        self.retract_mm
    }

    fn max_feed_rate_mm_min(&self) -> f64 {
        self.max_feed_rate_mm_min
    }

    /// Along the tool axis.
    fn retract_direction(&self, pose: &ToolPose) -> [f64; 3] {
        normalise(pose.axis).unwrap_or([0.0, 0.0, 1.0])
    }
}

impl Kinematics for Belt6Config {
    fn axes(&self) -> AxisSet {
        self.cell().axis_set()
    }

    fn forward(&self, _tool_length: f64, q: &[f64]) -> TipAxis {
        let (tip, axis, _) = belt6::forward(self, &joints(q));
        TipAxis { tip, axis }
    }

    fn inverse_path(&self, _tool_length: f64, poses: &[ToolPose]) -> Result<Vec<Vec<f64>>> {
        let input: Vec<([f64; 3], [f64; 3], [f64; 3])> =
            poses.iter().map(|t| (t.tip, t.axis, t.normal)).collect();
        let q = belt6::inverse_path(self, &input)?;
        Ok(q.into_iter().map(|r| r.to_vec()).collect())
    }
}

impl Machine for Belt6Config {
    fn name(&self) -> &str {
        "belt6"
    }

    fn controller(&self) -> &ControllerConfig {
        &self.controller
    }

    fn home(&self) -> Vec<f64> {
        Belt6Config::home(self)
    }

    fn retract_mm(&self) -> f64 {
        self.retract_mm
    }

    fn max_feed_rate_mm_min(&self) -> f64 {
        self.max_feed_rate_mm_min
    }

    /// Along the contact normal.
    fn retract_direction(&self, pose: &ToolPose) -> [f64; 3] {
        pose.normal
    }
}

impl Kinematics for FiveAxis {
    fn axes(&self) -> AxisSet {
        AxisSet::new(self.limits.to_vec())
    }

    fn forward(&self, tool_length: f64, q: &[f64]) -> TipAxis {
        let (tip, axis) = FiveAxis::forward(self, tool_length, &joints(q));
        TipAxis { tip, axis }
    }

    fn inverse_path(&self, tool_length: f64, poses: &[ToolPose]) -> Result<Vec<Vec<f64>>> {
        let input: Vec<([f64; 3], [f64; 3])> = poses.iter().map(|t| (t.tip, t.axis)).collect();
        let q = FiveAxis::inverse_path(self, tool_length, &input)?;
        Ok(q.into_iter().map(|r| r.to_vec()).collect())
    }

    /// A head's; a table's other branch turns the part about the tool axis,
    /// which moves X Y Z.
    fn branch_flip(&self) -> Option<BranchFlip> {
        (!self.kinematics.is_table()).then_some(BranchFlip { tilt: 3, turn: 4 })
    }
}

#[cfg(test)]
mod tests {
    //! The traits as the trajectory code sees them, through `dyn`: forward
    //! against the closed form, inverse against forward on seeded random
    //! joints, the head's other branch against forward, and what each cell
    //! machine reports against its config fields.
    use super::*;
    use crate::{FiveAxisConfig, Machines};
    use toolpath_kernel::rng::XorShift;

    /// Joints inside each axis's travel, rotaries also inside (-pi, pi) and
    /// a tilt (index 3, 4 on belt6's B) kept 0.05 rad off the singular
    /// positions (tool vertical, B = +-90 deg).
    fn random_joints(axes: &AxisSet, rng: &mut XorShift) -> Vec<f64> {
        axes.iter()
            .enumerate()
            .map(|(j, a)| {
                let (lo, hi) = if a.rotary {
                    (a.min.max(-3.0), a.max.min(3.0))
                } else {
                    (a.min, a.max)
                };
                let x = lo + (hi - lo) * rng.unit();
                let sign = if x < 0.0 { -1.0 } else { 1.0 };
                match (j, axes.len()) {
                    (3, 5) => sign * x.abs().max(0.05),
                    (4, 6) => sign * x.abs().clamp(0.05, std::f64::consts::FRAC_PI_2 - 0.05),
                    _ => x,
                }
            })
            .collect()
    }

    fn near(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
        (0..3).all(|k| (a[k] - b[k]).abs() <= tol)
    }

    /// Every five-axis kinematics the posts know, as trait objects.
    fn five_axis_machines() -> Vec<(String, Box<dyn Kinematics>)> {
        let mill5 = Mill5Config::default();
        let mut out: Vec<(String, Box<dyn Kinematics>)> = vec![
            ("mill5".into(), Box::new(mill5.clone())),
            (
                "ac_head".into(),
                Box::new(FiveAxisConfig::from_mill5("m", &mill5).build().unwrap()),
            ),
        ];
        for (kind, name) in [
            (crate::FiveAxisKind::AcTable, "ac_table"),
            (crate::FiveAxisKind::BcTable, "bc_table"),
        ] {
            let mut cfg = FiveAxisConfig::from_mill5(name, &mill5);
            cfg.kinematics = kind;
            cfg.pivot_length_mm = None;
            cfg.tilt_axis_point_mm = Some([0.0, 15.0, 80.0]);
            cfg.c_axis_point_mm = Some([5.0, -7.0, 0.0]);
            if kind == crate::FiveAxisKind::BcTable {
                (cfg.a, cfg.b) = (None, cfg.a);
            }
            out.push((name.into(), Box::new(cfg.build().unwrap())));
        }
        out
    }

    #[test]
    fn mill5_forward_is_the_head_formula() {
        let cfg = Mill5Config::default();
        assert_eq!(cfg.workpiece_rpy_deg, [0.0; 3]);
        let k: &dyn Kinematics = &cfg;
        let mut rng = XorShift(0x5eed_0041);
        for _ in 0..200 {
            let q = random_joints(&k.axes(), &mut rng);
            let (a, c) = (q[3], q[4]);
            let axis = [a.sin() * c.sin(), -a.sin() * c.cos(), a.cos()];
            let l = cfg.pivot_length_mm + 30.0;
            let o = cfg.workpiece_origin_mm;
            let tip: [f64; 3] = std::array::from_fn(|i| q[i] - o[i] - l * axis[i]);
            let got = k.forward(30.0, &q);
            assert!(
                near(got.tip, tip, 1e-9) && near(got.axis, axis, 1e-12),
                "{q:?}"
            );
        }
    }

    #[test]
    fn inverse_path_poses_what_forward_gives_on_every_machine() {
        let mut rng = XorShift(0x0b5e_55ed);
        for (name, k) in five_axis_machines() {
            for _ in 0..200 {
                let q = random_joints(&k.axes(), &mut rng);
                let t = k.forward(30.0, &q);
                let pose = ToolPose {
                    tip: t.tip,
                    axis: t.axis,
                    normal: t.axis,
                };
                let back = k.inverse_path(30.0, &[pose]).unwrap();
                assert_eq!(back.len(), 1);
                let u = k.forward(30.0, &back[0]);
                assert!(
                    near(u.tip, t.tip, 1e-6) && near(u.axis, t.axis, 1e-9),
                    "{name} {q:?} -> {:?}",
                    back[0]
                );
            }
        }
        let belt = Belt6Config::default();
        let k: &dyn Kinematics = &belt;
        for _ in 0..200 {
            let q = random_joints(&k.axes(), &mut rng);
            let (tip, axis, normal) = belt6::forward(&belt, &std::array::from_fn(|j| q[j]));
            let back = k
                .inverse_path(0.0, &[ToolPose { tip, axis, normal }])
                .unwrap();
            let u = k.forward(0.0, &back[0]);
            let n = belt6::forward(&belt, &std::array::from_fn(|j| back[0][j])).2;
            assert!(
                near(u.tip, tip, 1e-6) && near(u.axis, axis, 1e-9) && near(n, normal, 1e-9),
                "belt6 {q:?} -> {:?}",
                back[0]
            );
        }
    }

    #[test]
    fn the_other_head_branch_poses_the_same_tool() {
        let mut rng = XorShift(0xf11b);
        for (name, k) in five_axis_machines() {
            let Some(BranchFlip { tilt, turn }) = k.branch_flip() else {
                assert!(name.ends_with("table"), "{name} has no other branch");
                continue;
            };
            assert!(!name.ends_with("table"), "{name}");
            for _ in 0..100 {
                let q = random_joints(&k.axes(), &mut rng);
                let mut flipped = q.clone();
                flipped[tilt] = -q[tilt];
                flipped[turn] = q[turn] + std::f64::consts::PI;
                let (a, b) = (k.forward(30.0, &q), k.forward(30.0, &flipped));
                assert!(
                    near(a.tip, b.tip, 1e-9) && near(a.axis, b.axis, 1e-12),
                    "{name}"
                );
            }
        }
        assert_eq!(Belt6Config::default().branch_flip(), None);
    }

    #[test]
    fn cell_machines_report_their_config() {
        let m = Machines::default();
        let mill: &dyn Machine = m.machine(toolpath_formats::Machine::Mill5);
        let belt: &dyn Machine = m.machine(toolpath_formats::Machine::Belt6);
        assert_eq!((mill.name(), belt.name()), ("mill5", "belt6"));
        assert_eq!(mill.axes().names(), ["X", "Y", "Z", "A", "C"]);
        assert_eq!(belt.axes().names(), ["X", "Y", "Z", "A", "B", "C"]);
        assert_eq!(mill.axes().rotary(), [false, false, false, true, true]);
        assert_eq!(
            (mill.axes().rotary_count(), belt.axes().rotary_count()),
            (2, 3)
        );
        let a = &mill.axes()[3];
        assert_eq!(
            (a.min, a.max),
            (
                m.mill5.a.min_deg.to_radians(),
                m.mill5.a.max_deg.to_radians()
            )
        );
        assert_eq!(a.max_velocity, m.mill5.a.max_velocity_deg_s.to_radians());
        let z = &belt.axes()[2];
        assert_eq!(
            (z.min, z.max, z.max_acceleration),
            (
                m.belt6.z.min_mm,
                m.belt6.z.max_mm,
                m.belt6.z.max_acceleration_mm_s2
            )
        );
        for (cfg_feed, cfg_retract, machine) in [
            (m.mill5.max_feed_rate_mm_min, m.mill5.retract_mm, mill),
            (m.belt6.max_feed_rate_mm_min, m.belt6.retract_mm, belt),
        ] {
            assert_eq!(machine.max_feed_rate_mm_min(), cfg_feed);
            assert_eq!(machine.retract_mm(), cfg_retract);
            let axes = machine.axes();
            let home = machine.home();
            assert_eq!(home.len(), axes.len());
            assert!(
                axes.iter().zip(&home).all(|(a, x)| a.holds(*x, 0.0)),
                "{home:?}"
            );
            assert_eq!(machine.joint_names(), axes.names());
            let limits = axes.motion_limits();
            assert_eq!(
                limits.velocity,
                axes.iter().map(|a| a.max_velocity).collect::<Vec<_>>()
            );
            assert_eq!(limits.jerk, None);
        }
        // Default home: above the workpiece origin at the top of Z.
        let o = m.mill5.workpiece_origin_mm;
        assert_eq!(mill.home()[..3], [o[0], o[1], m.mill5.z.max_mm]);
        let pose = ToolPose {
            tip: [0.0; 3],
            axis: [0.0, 3.0, 4.0],
            normal: [1.0, 0.0, 0.0],
        };
        assert_eq!(mill.retract_direction(&pose), [0.0, 0.6, 0.8]);
        assert_eq!(belt.retract_direction(&pose), [1.0, 0.0, 0.0]);
    }
}
