//! Machine geometry and joint limits as written in launch_configs/*.yaml.
//! Lengths in mm, angles in degrees at this edge (`_deg` fields); converted to
//! mm and radians by [`JointLimit`].

use super::controller::ControllerConfig;
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

/// Limits of one joint in internal units (mm or rad).
#[derive(Clone, Debug, PartialEq)]
pub struct JointLimit {
    pub name: &'static str,
    pub rotary: bool,
    pub min: f64,
    pub max: f64,
    pub max_velocity: f64,
    pub max_acceleration: f64,
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
    pub fn limit(&self, name: &'static str) -> JointLimit {
        JointLimit {
            name,
            rotary: false,
            min: self.min_mm,
            max: self.max_mm,
            max_velocity: self.max_velocity_mm_s,
            max_acceleration: self.max_acceleration_mm_s2,
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
    pub fn limit(&self, name: &'static str) -> JointLimit {
        JointLimit {
            name,
            rotary: true,
            min: self.min_deg.to_radians(),
            max: self.max_deg.to_radians(),
            max_velocity: self.max_velocity_deg_s.to_radians(),
            max_acceleration: self.max_acceleration_deg_s2.to_radians(),
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
    /// The pose of the workpiece frame in the machine frame.
    pub fn placement(&self) -> Placement {
        Placement::new(
            self.workpiece_origin_mm,
            self.workpiece_rpy_deg.map(f64::to_radians),
        )
    }

    pub fn validate(&self) -> Result<()> {
        positive("mill5.pivot_length_mm", self.pivot_length_mm)?;
        for (k, v) in self.workpiece_origin_mm.iter().enumerate() {
            finite(&format!("mill5.workpiece_origin_mm[{k}]"), *v)?;
        }
        for (k, v) in self.workpiece_rpy_deg.iter().enumerate() {
            finite(&format!("mill5.workpiece_rpy_deg[{k}]"), *v)?;
        }
        positive("mill5.max_feed_rate_mm_min", self.max_feed_rate_mm_min)?;
        if !self.retract_mm.is_finite() || self.retract_mm < 0.0 {
            return Err(Error::invalid(
                "mill5.retract_mm",
                "must be a finite number >= 0",
            ));
        }
        self.x.validate("mill5.x")?;
        self.y.validate("mill5.y")?;
        self.z.validate("mill5.z")?;
        self.a.validate("mill5.a")?;
        self.c.validate("mill5.c")?;
        self.controller.validate_with_home(
            "mill5.controller",
            &self.limits(),
            self.default_home_mm(),
        )
    }
    /// The controller's joint names, in axis order.
    pub fn joint_names(&self) -> Vec<String> {
        self.controller.joint_names(&self.limits())
    }
    /// The home pose (mm, rad); by default above the workpiece origin at the
    /// top of Z, tool vertical.
    pub fn home(&self) -> Vec<f64> {
        self.controller.home(&self.limits(), self.default_home_mm())
    }
    /// X Y Z of the home pose when none is configured: above the workpiece
    /// origin at the top of Z.
    fn default_home_mm(&self) -> [f64; 3] {
        let o = self.workpiece_origin_mm;
        [o[0], o[1], self.z.max_mm]
    }
    pub fn limits(&self) -> Vec<JointLimit> {
        vec![
            self.x.limit("X"),
            self.y.limit("Y"),
            self.z.limit("Z"),
            self.a.limit("A"),
            self.c.limit("C"),
        ]
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
    /// The pose of the workpiece frame in the machine frame.
    pub fn placement(&self) -> Placement {
        Placement::new(
            self.workpiece_origin_mm,
            self.workpiece_rpy_deg.map(f64::to_radians),
        )
    }

    pub fn validate(&self) -> Result<()> {
        for (k, v) in self.workpiece_origin_mm.iter().enumerate() {
            finite(&format!("belt6.workpiece_origin_mm[{k}]"), *v)?;
        }
        for (k, v) in self.workpiece_rpy_deg.iter().enumerate() {
            finite(&format!("belt6.workpiece_rpy_deg[{k}]"), *v)?;
        }
        positive("belt6.max_feed_rate_mm_min", self.max_feed_rate_mm_min)?;
        if !self.retract_mm.is_finite() || self.retract_mm < 0.0 {
            return Err(Error::invalid(
                "belt6.retract_mm",
                "must be a finite number >= 0",
            ));
        }
        self.x.validate("belt6.x")?;
        self.y.validate("belt6.y")?;
        self.z.validate("belt6.z")?;
        self.a.validate("belt6.a")?;
        self.b.validate("belt6.b")?;
        self.c.validate("belt6.c")?;
        self.controller.validate_with_home(
            "belt6.controller",
            &self.limits(),
            self.default_home_mm(),
        )
    }
    /// The controller's joint names, in axis order.
    pub fn joint_names(&self) -> Vec<String> {
        self.controller.joint_names(&self.limits())
    }
    /// The home pose (mm, rad); by default above the workpiece origin at the
    /// top of Z, wheel frame parallel to the machine's.
    pub fn home(&self) -> Vec<f64> {
        self.controller.home(&self.limits(), self.default_home_mm())
    }
    /// X Y Z of the home pose when none is configured: above the workpiece
    /// origin at the top of Z.
    fn default_home_mm(&self) -> [f64; 3] {
        let o = self.workpiece_origin_mm;
        [o[0], o[1], self.z.max_mm]
    }
    pub fn limits(&self) -> Vec<JointLimit> {
        vec![
            self.x.limit("X"),
            self.y.limit("Y"),
            self.z.limit("Z"),
            self.a.limit("A"),
            self.b.limit("B"),
            self.c.limit("C"),
        ]
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
    pub limits: Vec<JointLimit>,
    /// The start pose when no joint state is known.
    pub home: Vec<f64>,
    pub controller: &'a ControllerConfig,
}

impl Machines {
    /// The joint names, limits, home pose and controller of `machine`.
    pub fn axes(&self, machine: toolpath_formats::Machine) -> MachineAxes<'_> {
        match machine {
            toolpath_formats::Machine::Mill5 => MachineAxes {
                joint_names: self.mill5.joint_names(),
                limits: self.mill5.limits(),
                home: self.mill5.home(),
                controller: &self.mill5.controller,
            },
            toolpath_formats::Machine::Belt6 => MachineAxes {
                joint_names: self.belt6.joint_names(),
                limits: self.belt6.limits(),
                home: self.belt6.home(),
                controller: &self.belt6.controller,
            },
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
        match machine {
            toolpath_formats::Machine::Mill5 => self.mill5.controller.execute,
            toolpath_formats::Machine::Belt6 => self.belt6.controller.execute,
        }
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
