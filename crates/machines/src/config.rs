//! Machine geometry and joint limits as written in launch_configs/*.yaml.
//! Lengths in mm, angles in degrees at this edge (`_deg` fields); converted to
//! mm and radians in [`Axis`].

use super::axes::{Axis, AxisSet};
use super::controller::ControllerConfig;
use super::machine::Machine;
use super::placement::Placement;
use serde::{Deserialize, Serialize};
use toolpath_kernel::error::{Error, Result};

/// A linear axis: travel, velocity and acceleration limits.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearAxis {
    pub min_mm: f64,
    pub max_mm: f64,
    pub max_velocity_mm_s: f64,
    pub max_acceleration_mm_s2: f64,
}

/// A rotary axis: travel, velocity and acceleration limits in degrees.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RotaryAxis {
    pub min_deg: f64,
    pub max_deg: f64,
    pub max_velocity_deg_s: f64,
    pub max_acceleration_deg_s2: f64,
}

impl LinearAxis {
    pub const fn new(
        min_mm: f64,
        max_mm: f64,
        max_velocity_mm_s: f64,
        max_acceleration_mm_s2: f64,
    ) -> Self {
        Self {
            min_mm,
            max_mm,
            max_velocity_mm_s,
            max_acceleration_mm_s2,
        }
    }
    /// The axis `name` in internal units (mm).
    pub fn axis(&self, name: &str) -> Axis {
        Axis {
            name: name.to_string(),
            rotary: false,
            min: self.min_mm,
            max: self.max_mm,
            max_velocity: self.max_velocity_mm_s,
            max_acceleration: self.max_acceleration_mm_s2,
            max_jerk: None,
        }
    }
    pub(super) fn validate(&self, field: &str) -> Result<()> {
        check_range(field, "min_mm", self.min_mm, "max_mm", self.max_mm)?;
        positive(
            &format!("{field}.max_velocity_mm_s"),
            self.max_velocity_mm_s,
        )?;
        positive(
            &format!("{field}.max_acceleration_mm_s2"),
            self.max_acceleration_mm_s2,
        )
    }
}

impl RotaryAxis {
    pub const fn new(
        min_deg: f64,
        max_deg: f64,
        max_velocity_deg_s: f64,
        max_acceleration_deg_s2: f64,
    ) -> Self {
        Self {
            min_deg,
            max_deg,
            max_velocity_deg_s,
            max_acceleration_deg_s2,
        }
    }
    /// The axis `name` in internal units (rad).
    pub fn axis(&self, name: &str) -> Axis {
        Axis {
            name: name.to_string(),
            rotary: true,
            min: self.min_deg.to_radians(),
            max: self.max_deg.to_radians(),
            max_velocity: self.max_velocity_deg_s.to_radians(),
            max_acceleration: self.max_acceleration_deg_s2.to_radians(),
            max_jerk: None,
        }
    }
    pub(super) fn validate(&self, field: &str) -> Result<()> {
        check_range(field, "min_deg", self.min_deg, "max_deg", self.max_deg)?;
        positive(
            &format!("{field}.max_velocity_deg_s"),
            self.max_velocity_deg_s,
        )?;
        positive(
            &format!("{field}.max_acceleration_deg_s2"),
            self.max_acceleration_deg_s2,
        )
    }
}

/// One axis of a config as written: linear (mm) or rotary (degrees).
#[derive(Clone, Copy, Debug)]
pub(crate) enum AxisConfig<'a> {
    Linear(&'a LinearAxis),
    Rotary(&'a RotaryAxis),
}

impl AxisConfig<'_> {
    pub(crate) fn axis(&self, name: &str) -> Axis {
        match self {
            AxisConfig::Linear(a) => a.axis(name),
            AxisConfig::Rotary(a) => a.axis(name),
        }
    }

    pub(crate) fn validate(&self, field: &str) -> Result<()> {
        match self {
            AxisConfig::Linear(a) => a.validate(field),
            AxisConfig::Rotary(a) => a.validate(field),
        }
    }
}

pub(super) fn positive(field: &str, x: f64) -> Result<()> {
    if !x.is_finite() || x <= 0.0 {
        return Err(Error::invalid(
            field,
            format!("must be a positive finite number, got {x}"),
        ));
    }
    Ok(())
}

pub(crate) fn finite(field: &str, x: f64) -> Result<()> {
    if !x.is_finite() {
        return Err(Error::invalid(field, format!("{x} is not a finite number")));
    }
    Ok(())
}

fn check_range(field: &str, lo_name: &str, lo: f64, hi_name: &str, hi: f64) -> Result<()> {
    finite(&format!("{field}.{lo_name}"), lo)?;
    finite(&format!("{field}.{hi_name}"), hi)?;
    if lo >= hi {
        return Err(Error::invalid(
            format!("{field}.{hi_name}"),
            format!("{hi} must be greater than {lo_name} {lo}"),
        ));
    }
    Ok(())
}

/// What a machine section of a cell config holds besides its geometry, read
/// from its named fields: the axes in joint order (by YAML key; the axis
/// name is the key in capitals), the workpiece placement, feed and retract
/// limits and the controller. Validation, the axis set and the home pose are
/// written once here for every such section.
pub(crate) struct CellMachine<'a> {
    /// The section's key, "mill5" or "belt6".
    pub key: &'static str,
    pub axes: Vec<(&'static str, AxisConfig<'a>)>,
    pub workpiece_origin_mm: [f64; 3],
    pub workpiece_rpy_deg: [f64; 3],
    pub max_feed_rate_mm_min: f64,
    pub retract_mm: f64,
    pub controller: &'a ControllerConfig,
}

impl CellMachine<'_> {
    pub fn axis_set(&self) -> AxisSet {
        AxisSet::new(
            self.axes
                .iter()
                .map(|(key, a)| a.axis(&key.to_uppercase()))
                .collect(),
        )
    }

    /// The pose of the workpiece frame in the machine frame.
    pub fn placement(&self) -> Placement {
        Placement::new(
            self.workpiece_origin_mm,
            self.workpiece_rpy_deg.map(f64::to_radians),
        )
    }

    /// X Y Z of the home pose when none is configured: above the workpiece
    /// origin at the top of the third (Z) axis.
    pub fn default_home_mm(&self) -> [f64; 3] {
        let o = self.workpiece_origin_mm;
        let top = match self.axes.get(2) {
            Some((_, AxisConfig::Linear(z))) => z.max_mm,
            _ => o[2],
        };
        [o[0], o[1], top]
    }

    /// The home pose (mm, rad).
    pub fn home(&self) -> Vec<f64> {
        self.controller
            .home(&self.axis_set(), self.default_home_mm())
    }

    /// The shared fields, every axis and the controller (with its home
    /// pose inside the travel); errors name the dotted field.
    pub fn validate(&self) -> Result<()> {
        let key = self.key;
        for (k, v) in self.workpiece_origin_mm.iter().enumerate() {
            finite(&format!("{key}.workpiece_origin_mm[{k}]"), *v)?;
        }
        for (k, v) in self.workpiece_rpy_deg.iter().enumerate() {
            finite(&format!("{key}.workpiece_rpy_deg[{k}]"), *v)?;
        }
        positive(
            &format!("{key}.max_feed_rate_mm_min"),
            self.max_feed_rate_mm_min,
        )?;
        if !self.retract_mm.is_finite() || self.retract_mm < 0.0 {
            return Err(Error::invalid(
                format!("{key}.retract_mm"),
                "must be a finite number >= 0",
            ));
        }
        for (axis_key, a) in &self.axes {
            a.validate(&format!("{key}.{axis_key}"))?;
        }
        self.controller.validate_with_home(
            &format!("{key}.controller"),
            &self.axis_set(),
            self.default_home_mm(),
        )
    }
}

/// The 5-axis gantry mill with an A/C swivel head (joints X Y Z A C).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Mill5Config {
    /// Distance from the A/C pivot to the spindle gauge line, mm; the tool's
    /// length is added per job.
    pub pivot_length_mm: f64,
    /// Machine X Y Z of the pivot when the tool tip is at the workpiece origin
    /// with the tool vertical, minus the pivot length: i.e. the machine
    /// coordinates of the workpiece frame's origin.
    pub workpiece_origin_mm: [f64; 3],
    /// Orientation of the workpiece frame in the machine frame: ROS roll,
    /// pitch, yaw (fixed x, y, z axes), degrees; zero = frames parallel.
    pub workpiece_rpy_deg: [f64; 3],
    pub max_feed_rate_mm_min: f64,
    /// Retract along the tool axis before and after each pass, mm.
    pub retract_mm: f64,
    pub x: LinearAxis,
    pub y: LinearAxis,
    pub z: LinearAxis,
    pub a: RotaryAxis,
    pub c: RotaryAxis,
    /// Its trajectory controller (joint names, action, start policy, home).
    pub controller: ControllerConfig,
}

impl Default for Mill5Config {
    fn default() -> Self {
        Self {
            pivot_length_mm: 250.0,
            workpiece_origin_mm: [2500.0, 1000.0, 300.0],
            workpiece_rpy_deg: [0.0; 3],
            max_feed_rate_mm_min: 4000.0,
            retract_mm: 10.0,
            x: LinearAxis::new(0.0, 6000.0, 500.0, 2000.0),
            y: LinearAxis::new(0.0, 3000.0, 500.0, 2000.0),
            z: LinearAxis::new(0.0, 1500.0, 300.0, 1500.0),
            a: RotaryAxis::new(-95.0, 95.0, 90.0, 360.0),
            c: RotaryAxis::new(-220.0, 220.0, 180.0, 720.0),
            controller: ControllerConfig::new(),
        }
    }
}

impl Mill5Config {
    pub(crate) fn cell(&self) -> CellMachine<'_> {
        use AxisConfig::{Linear, Rotary};
        CellMachine {
            key: "mill5",
            axes: vec![
                ("x", Linear(&self.x)),
                ("y", Linear(&self.y)),
                ("z", Linear(&self.z)),
                ("a", Rotary(&self.a)),
                ("c", Rotary(&self.c)),
            ],
            workpiece_origin_mm: self.workpiece_origin_mm,
            workpiece_rpy_deg: self.workpiece_rpy_deg,
            max_feed_rate_mm_min: self.max_feed_rate_mm_min,
            retract_mm: self.retract_mm,
            controller: &self.controller,
        }
    }

    /// The pose of the workpiece frame in the machine frame.
    pub fn placement(&self) -> Placement {
        self.cell().placement()
    }

    pub fn validate(&self) -> Result<()> {
        positive("mill5.pivot_length_mm", self.pivot_length_mm)?;
        self.cell().validate()
    }
    /// The controller's joint names, in axis order.
    pub fn joint_names(&self) -> Vec<String> {
        self.controller.joint_names(&self.limits())
    }
    /// The home pose (mm, rad); by default above the workpiece origin at the
    /// top of Z, tool vertical.
    pub fn home(&self) -> Vec<f64> {
        self.cell().home()
    }
    /// The axes X Y Z A C.
    pub fn limits(&self) -> Vec<Axis> {
        self.cell().axis_set().into_vec()
    }
}

/// The 6-axis gantry belt grinder posing the contact wheel (joints X Y Z A B C).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Belt6Config {
    /// Machine X Y Z of the workpiece frame's origin; the joints X Y Z place
    /// the contact-wheel centre.
    pub workpiece_origin_mm: [f64; 3],
    /// Orientation of the workpiece frame in the machine frame: ROS roll,
    /// pitch, yaw (fixed x, y, z axes), degrees; zero = frames parallel.
    pub workpiece_rpy_deg: [f64; 3],
    pub max_feed_rate_mm_min: f64,
    /// Lift-off along the contact normal before and after each pass, mm.
    pub retract_mm: f64,
    pub x: LinearAxis,
    pub y: LinearAxis,
    pub z: LinearAxis,
    pub a: RotaryAxis,
    pub b: RotaryAxis,
    pub c: RotaryAxis,
    /// Its trajectory controller (joint names, action, start policy, home).
    pub controller: ControllerConfig,
}

impl Default for Belt6Config {
    fn default() -> Self {
        Self {
            workpiece_origin_mm: [1500.0, 1000.0, 400.0],
            workpiece_rpy_deg: [0.0; 3],
            max_feed_rate_mm_min: 6000.0,
            retract_mm: 10.0,
            x: LinearAxis::new(0.0, 4000.0, 400.0, 1500.0),
            y: LinearAxis::new(0.0, 2000.0, 400.0, 1500.0),
            z: LinearAxis::new(0.0, 1500.0, 250.0, 1000.0),
            a: RotaryAxis::new(-200.0, 200.0, 90.0, 360.0),
            b: RotaryAxis::new(-90.0, 90.0, 90.0, 360.0),
            c: RotaryAxis::new(-270.0, 270.0, 120.0, 480.0),
            controller: ControllerConfig::new(),
        }
    }
}

impl Belt6Config {
    pub(crate) fn cell(&self) -> CellMachine<'_> {
        use AxisConfig::{Linear, Rotary};
        CellMachine {
            key: "belt6",
            axes: vec![
                ("x", Linear(&self.x)),
                ("y", Linear(&self.y)),
                ("z", Linear(&self.z)),
                ("a", Rotary(&self.a)),
                ("b", Rotary(&self.b)),
                ("c", Rotary(&self.c)),
            ],
            workpiece_origin_mm: self.workpiece_origin_mm,
            workpiece_rpy_deg: self.workpiece_rpy_deg,
            max_feed_rate_mm_min: self.max_feed_rate_mm_min,
            retract_mm: self.retract_mm,
            controller: &self.controller,
        }
    }

    /// The pose of the workpiece frame in the machine frame.
    pub fn placement(&self) -> Placement {
        self.cell().placement()
    }

    pub fn validate(&self) -> Result<()> {
        self.cell().validate()
    }
    /// The controller's joint names, in axis order.
    pub fn joint_names(&self) -> Vec<String> {
        self.controller.joint_names(&self.limits())
    }
    /// The home pose (mm, rad); by default above the workpiece origin at the
    /// top of Z, wheel frame parallel to the machine's.
    pub fn home(&self) -> Vec<f64> {
        self.cell().home()
    }
    /// The axes X Y Z A B C.
    pub fn limits(&self) -> Vec<Axis> {
        self.cell().axis_set().into_vec()
    }
}

/// Both machines of a cell.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Machines {
    pub mill5: Mill5Config,
    pub belt6: Belt6Config,
}

/// What a controller and the start-pose logic need of one machine.
pub struct MachineAxes<'a> {
    /// The controller's joint names, in axis order.
    pub joint_names: Vec<String>,
    pub limits: Vec<Axis>,
    /// The start pose when no joint state is known.
    pub home: Vec<f64>,
    pub controller: &'a ControllerConfig,
}

impl Machines {
    /// The machine a job names.
    pub fn machine(&self, machine: toolpath_formats::Machine) -> &dyn Machine {
        match machine {
            toolpath_formats::Machine::Mill5 => &self.mill5,
            toolpath_formats::Machine::Belt6 => &self.belt6,
        }
    }

    /// The joint names, limits, home pose and controller of `machine`.
    pub fn axes(&self, machine: toolpath_formats::Machine) -> MachineAxes<'_> {
        let m = self.machine(machine);
        MachineAxes {
            joint_names: m.joint_names(),
            limits: m.axes().into_vec(),
            home: m.home(),
            controller: m.controller(),
        }
    }

    pub fn validate(&self) -> Result<()> {
        self.mill5.validate()?;
        self.belt6.validate()?;
        self.check_joint_names_apart()
    }

    /// Whether `machine`'s trajectories go to its controller by default
    /// (`controller.execute`; a job may say otherwise).
    pub fn executes_by_default(&self, machine: toolpath_formats::Machine) -> bool {
        self.machine(machine).controller().execute
    }

    /// Checks that a job may execute on `machine` (the job asks for it): when
    /// the other machine executes by default their joint names must differ,
    /// as for two machines executing by default.
    pub fn check_job_may_execute(&self, machine: toolpath_formats::Machine) -> Result<()> {
        let other = match machine {
            toolpath_formats::Machine::Mill5 => toolpath_formats::Machine::Belt6,
            toolpath_formats::Machine::Belt6 => toolpath_formats::Machine::Mill5,
        };
        if !self.executes_by_default(other) {
            return Ok(());
        }
        let shared = self.shared_joint_names();
        if shared.is_empty() {
            return Ok(());
        }
        Err(Error::invalid(
            "execute",
            format!(
                "{} cannot execute while {} executes by default: they share the joints {} and \
                 /joint_states cannot tell them apart; give one machine its controller's own \
                 joint names (controller.joint_names)",
                machine.name(),
                other.name(),
                shared.join(" ")
            ),
        ))
    }

    /// Both machines executing in one cell read one `/joint_states`, which
    /// names joints only: a joint name both use would give each machine the
    /// other's position as its start pose.
    fn check_joint_names_apart(&self) -> Result<()> {
        if !(self.mill5.controller.execute && self.belt6.controller.execute) {
            return Ok(());
        }
        let shared = self.shared_joint_names();
        if shared.is_empty() {
            return Ok(());
        }
        Err(Error::invalid(
            "belt6.controller.joint_names",
            format!(
                "shares the joints {} with mill5 while both machines execute: /joint_states \
                 cannot tell them apart; give one machine its controller's own joint names \
                 (e.g. belt6_{})",
                shared.join(" "),
                shared[0]
            ),
        ))
    }

    /// The joint names both machines use.
    fn shared_joint_names(&self) -> Vec<String> {
        let mill = self.mill5.joint_names();
        self.belt6
            .joint_names()
            .into_iter()
            .filter(|n| mill.contains(n))
            .collect()
    }
}
