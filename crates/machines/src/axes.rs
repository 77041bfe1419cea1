//! A machine's axes in joint order, in internal units: mm for linear axes,
//! radians for rotary ones (the YAML's degrees are converted at the config).

/// One axis (joint) of a machine: its name, type, travel and limits.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// The axis letter (X Y Z A B C) or, for a machine read from a robot
    /// description, the joint's name.
    pub name: String,
    /// Rotary (rad) or linear (mm).
    pub rotary: bool,
    pub min: f64,
    pub max: f64,
    /// mm/s or rad/s.
    pub max_velocity: f64,
    /// mm/s^2 or rad/s^2.
    pub max_acceleration: f64,
    /// mm/s^3 or rad/s^3; `None`: no jerk limit.
    pub max_jerk: Option<f64>,
}

impl Axis {
    /// A value of this axis and its travel in the unit of messages:
    /// degrees for rotary axes, mm for linear ones.
    pub fn shown(&self, x: f64) -> (f64, f64, f64, &'static str) {
        if self.rotary {
            (
                x.to_degrees(),
                self.min.to_degrees(),
                self.max.to_degrees(),
                "deg",
            )
        } else {
            (x, self.min, self.max, "mm")
        }
    }

    /// Whether `x` lies in the travel, with `slack` (mm or rad) either side.
    pub fn holds(&self, x: f64, slack: f64) -> bool {
        x >= self.min - slack && x <= self.max + slack
    }
}

/// The axes of a machine in joint order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AxisSet {
    axes: Vec<Axis>,
}

impl AxisSet {
    pub fn new(axes: Vec<Axis>) -> Self {
        Self { axes }
    }

    pub fn len(&self) -> usize {
        self.axes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.axes.is_empty()
    }

    pub fn iter(&self) -> std::slice::Iter<'_, Axis> {
        self.axes.iter()
    }

    pub fn as_slice(&self) -> &[Axis] {
        &self.axes
    }

    pub fn into_vec(self) -> Vec<Axis> {
        self.axes
    }

    /// The axis names in joint order.
    pub fn names(&self) -> Vec<String> {
        self.axes.iter().map(|a| a.name.clone()).collect()
    }

    /// Per axis: rotary (true) or linear.
    pub fn rotary(&self) -> Vec<bool> {
        self.axes.iter().map(|a| a.rotary).collect()
    }

    /// How many axes are rotary.
    pub fn rotary_count(&self) -> usize {
        self.axes.iter().filter(|a| a.rotary).count()
    }

    /// Velocity, acceleration and (when every axis has one) jerk limits,
    /// for the time parameterisation.
    pub fn motion_limits(&self) -> toolpath_motion::Limits {
        let limits = toolpath_motion::Limits::new(
            self.axes.iter().map(|a| a.max_velocity).collect(),
            self.axes.iter().map(|a| a.max_acceleration).collect(),
        );
        match self
            .axes
            .iter()
            .map(|a| a.max_jerk)
            .collect::<Option<Vec<f64>>>()
        {
            Some(jerk) if !jerk.is_empty() => limits.with_jerk(jerk),
            _ => limits,
        }
    }
}

impl std::ops::Deref for AxisSet {
    type Target = [Axis];

    fn deref(&self) -> &[Axis] {
        &self.axes
    }
}

impl From<AxisSet> for Vec<Axis> {
    fn from(a: AxisSet) -> Self {
        a.axes
    }
}
