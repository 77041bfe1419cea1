//! ROS 2 message structs of the node's topics, serialised as CDR by serde.
//!
//! Field order = field order of the .msg definition (CDR has no field names).
//! The definitions themselves are embedded ([`definition`], [`schema_text`]) so
//! that the recorder can write `ros2msg` schemas. Our own package is
//! `toolpath_msgs` (msg/msg/*.msg); the standard ROS 2 types we use are copied
//! verbatim (without comments) into src/messages/defs/.
//!
//! Units: `toolpath_msgs` carries mm and degrees (as the result files do); the
//! standard messages (PoseArray, JointTrajectory, MarkerArray) carry metres and
//! radians as REP 103 requires.

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

/// A ROS 2 message type: its `pkg/msg/Type` name and .msg text.
pub trait RosMessage:
    Serialize + DeserializeOwned + Clone + std::fmt::Debug + Send + Sync + 'static
{
    const PACKAGE: &'static str;
    const NAME: &'static str;
    /// `msg`, or `action` for the messages rosidl derives from a .action
    /// file (the action's topics carry them).
    const INTERFACE: &'static str = "msg";
    /// `pkg/Type`, the name used in schemas and `MSG:` lines.
    fn full_name() -> String {
        format!("{}/{}", Self::PACKAGE, Self::NAME)
    }
    /// `pkg/msg/Type` (or `pkg/action/Type`): the name in bags' schemas and metadata.
    fn type_name() -> String {
        format!("{}/{}/{}", Self::PACKAGE, Self::INTERFACE, Self::NAME)
    }
    /// DDS type name as rmw writes it: `pkg::msg::dds_::Type_`.
    fn dds_type_name() -> String {
        format!(
            "{}::{}::dds_::{}_",
            Self::PACKAGE,
            Self::INTERFACE,
            Self::NAME
        )
    }
    /// The .msg text of this type alone.
    fn definition() -> &'static str {
        definition(&Self::full_name()).unwrap_or("")
    }
}

/// `impl RosMessage` for a message struct: its package and type name.
macro_rules! ros_message {
    ($ty:ident, $pkg:literal, $name:literal) => {
        impl $crate::RosMessage for $ty {
            const PACKAGE: &'static str = $pkg;
            const NAME: &'static str = $name;
        }
    };
    ($ty:ident, $pkg:literal, $interface:literal, $name:literal) => {
        impl $crate::RosMessage for $ty {
            const PACKAGE: &'static str = $pkg;
            const INTERFACE: &'static str = $interface;
            const NAME: &'static str = $name;
        }
    };
}
pub(crate) use ros_message;

/// Every .msg text this crate knows, by `pkg/Type`, sorted by name.
pub const DEFINITIONS: &[(&str, &str)] = &[
    (
        "action_msgs/GoalInfo",
        include_str!("defs/action_msgs/GoalInfo.msg"),
    ),
    (
        "action_msgs/GoalStatus",
        include_str!("defs/action_msgs/GoalStatus.msg"),
    ),
    (
        "action_msgs/GoalStatusArray",
        include_str!("defs/action_msgs/GoalStatusArray.msg"),
    ),
    (
        "builtin_interfaces/Duration",
        include_str!("defs/builtin_interfaces/Duration.msg"),
    ),
    (
        "builtin_interfaces/Time",
        include_str!("defs/builtin_interfaces/Time.msg"),
    ),
    (
        "control_msgs/JointComponentTolerance",
        include_str!("defs/control_msgs/JointComponentTolerance.msg"),
    ),
    (
        "control_msgs/JointTolerance",
        include_str!("defs/control_msgs/JointTolerance.msg"),
    ),
    (
        "diagnostic_msgs/DiagnosticArray",
        include_str!("defs/diagnostic_msgs/DiagnosticArray.msg"),
    ),
    (
        "diagnostic_msgs/DiagnosticStatus",
        include_str!("defs/diagnostic_msgs/DiagnosticStatus.msg"),
    ),
    (
        "diagnostic_msgs/KeyValue",
        include_str!("defs/diagnostic_msgs/KeyValue.msg"),
    ),
    (
        "geometry_msgs/Point",
        include_str!("defs/geometry_msgs/Point.msg"),
    ),
    (
        "geometry_msgs/Pose",
        include_str!("defs/geometry_msgs/Pose.msg"),
    ),
    (
        "geometry_msgs/PoseArray",
        include_str!("defs/geometry_msgs/PoseArray.msg"),
    ),
    (
        "geometry_msgs/Quaternion",
        include_str!("defs/geometry_msgs/Quaternion.msg"),
    ),
    (
        "geometry_msgs/Transform",
        include_str!("defs/geometry_msgs/Transform.msg"),
    ),
    (
        "geometry_msgs/TransformStamped",
        include_str!("defs/geometry_msgs/TransformStamped.msg"),
    ),
    (
        "geometry_msgs/Twist",
        include_str!("defs/geometry_msgs/Twist.msg"),
    ),
    (
        "geometry_msgs/Vector3",
        include_str!("defs/geometry_msgs/Vector3.msg"),
    ),
    (
        "sensor_msgs/CompressedImage",
        include_str!("defs/sensor_msgs/CompressedImage.msg"),
    ),
    (
        "sensor_msgs/JointState",
        include_str!("defs/sensor_msgs/JointState.msg"),
    ),
    (
        "std_msgs/ColorRGBA",
        include_str!("defs/std_msgs/ColorRGBA.msg"),
    ),
    ("std_msgs/Header", include_str!("defs/std_msgs/Header.msg")),
    ("std_msgs/String", include_str!("defs/std_msgs/String.msg")),
    (
        "tf2_msgs/TFMessage",
        include_str!("defs/tf2_msgs/TFMessage.msg"),
    ),
    (
        "toolpath_msgs/GrindingParams",
        include_str!("../../../msg/msg/GrindingParams.msg"),
    ),
    (
        "toolpath_msgs/Job",
        include_str!("../../../msg/msg/Job.msg"),
    ),
    (
        "toolpath_msgs/JobStatus",
        include_str!("../../../msg/msg/JobStatus.msg"),
    ),
    (
        "toolpath_msgs/Pocket",
        include_str!("../../../msg/msg/Pocket.msg"),
    ),
    (
        "toolpath_msgs/PocketLoop",
        include_str!("../../../msg/msg/PocketLoop.msg"),
    ),
    (
        "toolpath_msgs/TrimCurve",
        include_str!("../../../msg/msg/TrimCurve.msg"),
    ),
    (
        "toolpath_msgs/TrimLoop",
        include_str!("../../../msg/msg/TrimLoop.msg"),
    ),
    (
        "toolpath_msgs/Surface",
        include_str!("../../../msg/msg/Surface.msg"),
    ),
    (
        "toolpath_msgs/Tool",
        include_str!("../../../msg/msg/Tool.msg"),
    ),
    (
        "toolpath_msgs/ToolPoseSegments",
        include_str!("../../../msg/msg/ToolPoseSegments.msg"),
    ),
    (
        "toolpath_msgs/Toolpath",
        include_str!("../../../msg/msg/Toolpath.msg"),
    ),
    (
        "toolpath_msgs/ToolpathPass",
        include_str!("../../../msg/msg/ToolpathPass.msg"),
    ),
    (
        "toolpath_msgs/ToolpathPoint",
        include_str!("../../../msg/msg/ToolpathPoint.msg"),
    ),
    (
        "toolpath_msgs/ToolpathStats",
        include_str!("../../../msg/msg/ToolpathStats.msg"),
    ),
    (
        "trajectory_msgs/JointTrajectory",
        include_str!("defs/trajectory_msgs/JointTrajectory.msg"),
    ),
    (
        "trajectory_msgs/JointTrajectoryPoint",
        include_str!("defs/trajectory_msgs/JointTrajectoryPoint.msg"),
    ),
    (
        "trajectory_msgs/MultiDOFJointTrajectory",
        include_str!("defs/trajectory_msgs/MultiDOFJointTrajectory.msg"),
    ),
    (
        "trajectory_msgs/MultiDOFJointTrajectoryPoint",
        include_str!("defs/trajectory_msgs/MultiDOFJointTrajectoryPoint.msg"),
    ),
    (
        "unique_identifier_msgs/UUID",
        include_str!("defs/unique_identifier_msgs/UUID.msg"),
    ),
    (
        "visualization_msgs/Marker",
        include_str!("defs/visualization_msgs/Marker.msg"),
    ),
    (
        "visualization_msgs/MarkerArray",
        include_str!("defs/visualization_msgs/MarkerArray.msg"),
    ),
    (
        "visualization_msgs/MeshFile",
        include_str!("defs/visualization_msgs/MeshFile.msg"),
    ),
    (
        "visualization_msgs/UVCoordinate",
        include_str!("defs/visualization_msgs/UVCoordinate.msg"),
    ),
];

/// The .msg text of `pkg/Type` (the action's derived types included).
pub fn definition(full_name: &str) -> Option<&'static str> {
    DEFINITIONS
        .iter()
        .find(|(n, _)| *n == full_name)
        .map(|(_, d)| *d)
        .or_else(|| super::plan_toolpath::derived_definition(full_name))
}

const PRIMITIVES: &[&str] = &[
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32",
    "uint32", "int64", "uint64", "string", "wstring",
];

/// The nested message types a definition uses directly (`pkg/Type`), in field order.
pub fn nested_types(full_name: &str) -> Vec<String> {
    let pkg = full_name.split('/').next().unwrap_or("");
    let mut out = Vec::new();
    for line in definition(full_name).unwrap_or("").lines() {
        let line = line.split('#').next().unwrap_or("").trim();
        let Some(ty) = line.split_whitespace().next() else {
            continue;
        };
        if line.contains('=') && !line.contains(' ') {
            continue;
        }
        // Constants (`uint8 X=1`) have primitive types and are skipped below.
        let base = ty.split('[').next().unwrap_or(ty);
        let base = base.split("<=").next().unwrap_or(base);
        if PRIMITIVES.contains(&base) {
            continue;
        }
        let name = if base.contains('/') {
            base.to_string()
        } else if base == "Header" {
            "std_msgs/Header".to_string()
        } else {
            format!("{pkg}/{base}")
        };
        if !out.contains(&name) {
            out.push(name);
        }
    }
    out
}

/// The `ros2msg` schema text rosbag2 writes: the type's definition followed by
/// every nested type (depth-first, each once) after a line of 80 `=` and
/// `MSG: pkg/Type`.
pub fn schema_text(full_name: &str) -> Option<String> {
    let mut text = definition(full_name)?.to_string();
    let mut seen = vec![full_name.to_string()];
    let mut stack: Vec<String> = nested_types(full_name).into_iter().rev().collect();
    while let Some(name) = stack.pop() {
        if seen.contains(&name) {
            continue;
        }
        let def = definition(&name)?;
        if !text.ends_with('\n') {
            text.push('\n');
        }
        text.push_str(&"=".repeat(80));
        text.push_str(&format!("\nMSG: {name}\n"));
        text.push_str(def);
        for n in nested_types(&name).into_iter().rev() {
            stack.push(n);
        }
        seen.push(name);
    }
    Some(text)
}

// ---------------------------------------------------------------- standard types

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Time {
    pub sec: i32,
    pub nanosec: u32,
}
ros_message!(Time, "builtin_interfaces", "Time");

impl Time {
    /// Wall-clock time now.
    pub fn now() -> Self {
        let d = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap_or_default();
        Self {
            sec: i32::try_from(d.as_secs()).unwrap_or(i32::MAX),
            nanosec: d.subsec_nanos(),
        }
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Duration {
    pub sec: i32,
    pub nanosec: u32,
}
ros_message!(Duration, "builtin_interfaces", "Duration");

impl Duration {
    /// From seconds (>= 0), rounded to the nanosecond.
    pub fn from_secs_f64(s: f64) -> Self {
        let total = (s.max(0.0) * 1e9).round() as i64;
        Self {
            sec: i32::try_from(total / 1_000_000_000).unwrap_or(i32::MAX),
            nanosec: (total % 1_000_000_000) as u32,
        }
    }
    pub fn as_secs_f64(&self) -> f64 {
        self.sec as f64 + self.nanosec as f64 * 1e-9
    }
}

/// unique_identifier_msgs/UUID: an action's goal id.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Uuid {
    pub uuid: [u8; 16],
}
ros_message!(Uuid, "unique_identifier_msgs", "UUID");

/// action_msgs/GoalInfo.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GoalInfo {
    pub goal_id: Uuid,
    /// When the goal was accepted.
    pub stamp: Time,
}
ros_message!(GoalInfo, "action_msgs", "GoalInfo");

/// action_msgs/GoalStatus: one goal's state.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GoalStatus {
    pub goal_info: GoalInfo,
    pub status: i8,
}
ros_message!(GoalStatus, "action_msgs", "GoalStatus");

impl GoalStatus {
    pub const STATUS_UNKNOWN: i8 = 0;
    pub const STATUS_ACCEPTED: i8 = 1;
    pub const STATUS_EXECUTING: i8 = 2;
    pub const STATUS_CANCELING: i8 = 3;
    pub const STATUS_SUCCEEDED: i8 = 4;
    pub const STATUS_CANCELED: i8 = 5;
    pub const STATUS_ABORTED: i8 = 6;
}

/// action_msgs/GoalStatusArray: what an action server publishes on
/// `_action/status` at every state change of its goals.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GoalStatusArray {
    pub status_list: Vec<GoalStatus>,
}
ros_message!(GoalStatusArray, "action_msgs", "GoalStatusArray");

impl Time {
    pub const ZERO: Time = Time { sec: 0, nanosec: 0 };

    /// This time plus `s` (>= 0) seconds, rounded to the nanosecond.
    pub fn plus_secs(&self, s: f64) -> Self {
        let d = Duration::from_secs_f64(s);
        let ns = u64::from(self.nanosec) + u64::from(d.nanosec);
        Self {
            sec: self
                .sec
                .saturating_add(d.sec)
                .saturating_add((ns / 1_000_000_000) as i32),
            nanosec: (ns % 1_000_000_000) as u32,
        }
    }

    pub fn as_secs_f64(&self) -> f64 {
        self.sec as f64 + self.nanosec as f64 * 1e-9
    }
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    pub stamp: Time,
    pub frame_id: String,
}
ros_message!(Header, "std_msgs", "Header");

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ColorRGBA {
    pub r: f32,
    pub g: f32,
    pub b: f32,
    pub a: f32,
}
ros_message!(ColorRGBA, "std_msgs", "ColorRGBA");

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Point {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}
ros_message!(Point, "geometry_msgs", "Point");

impl Point {
    pub fn from_array(p: [f64; 3]) -> Self {
        Self {
            x: p[0],
            y: p[1],
            z: p[2],
        }
    }
    pub fn to_array(self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}
ros_message!(Vector3, "geometry_msgs", "Vector3");

impl Vector3 {
    pub fn from_array(p: [f64; 3]) -> Self {
        Self {
            x: p[0],
            y: p[1],
            z: p[2],
        }
    }
    pub fn to_array(self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}
ros_message!(Quaternion, "geometry_msgs", "Quaternion");

impl Default for Quaternion {
    fn default() -> Self {
        Self {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        }
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    pub position: Point,
    pub orientation: Quaternion,
}
ros_message!(Pose, "geometry_msgs", "Pose");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseArray {
    pub header: Header,
    pub poses: Vec<Pose>,
}
ros_message!(PoseArray, "geometry_msgs", "PoseArray");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JointTrajectoryPoint {
    pub positions: Vec<f64>,
    pub velocities: Vec<f64>,
    pub accelerations: Vec<f64>,
    pub effort: Vec<f64>,
    pub time_from_start: Duration,
}
ros_message!(
    JointTrajectoryPoint,
    "trajectory_msgs",
    "JointTrajectoryPoint"
);

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JointTrajectory {
    pub header: Header,
    pub joint_names: Vec<String>,
    pub points: Vec<JointTrajectoryPoint>,
}
ros_message!(JointTrajectory, "trajectory_msgs", "JointTrajectory");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CompressedImage {
    pub header: Header,
    pub format: String,
    pub data: Vec<u8>,
}
ros_message!(CompressedImage, "sensor_msgs", "CompressedImage");

/// Measured joint positions (m, rad), velocities and efforts, by name.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JointState {
    pub header: Header,
    pub name: Vec<String>,
    pub position: Vec<f64>,
    pub velocity: Vec<f64>,
    pub effort: Vec<f64>,
}
ros_message!(JointState, "sensor_msgs", "JointState");

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct UVCoordinate {
    pub u: f32,
    pub v: f32,
}
ros_message!(UVCoordinate, "visualization_msgs", "UVCoordinate");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MeshFile {
    pub filename: String,
    pub data: Vec<u8>,
}
ros_message!(MeshFile, "visualization_msgs", "MeshFile");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Marker {
    pub header: Header,
    pub ns: String,
    pub id: i32,
    #[serde(rename = "type")]
    pub marker_type: i32,
    pub action: i32,
    pub pose: Pose,
    pub scale: Vector3,
    pub color: ColorRGBA,
    pub lifetime: Duration,
    pub frame_locked: bool,
    pub points: Vec<Point>,
    pub colors: Vec<ColorRGBA>,
    pub texture_resource: String,
    pub texture: CompressedImage,
    pub uv_coordinates: Vec<UVCoordinate>,
    pub text: String,
    pub mesh_resource: String,
    pub mesh_file: MeshFile,
    pub mesh_use_embedded_materials: bool,
}
ros_message!(Marker, "visualization_msgs", "Marker");

impl Marker {
    pub const LINE_STRIP: i32 = 4;
    pub const SPHERE_LIST: i32 = 7;
    pub const ADD: i32 = 0;
    pub const DELETEALL: i32 = 3;
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MarkerArray {
    pub markers: Vec<Marker>,
}
ros_message!(MarkerArray, "visualization_msgs", "MarkerArray");

// ---------------------------------------------------------------- toolpath_msgs

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Tool {
    pub kind: String,
    pub radius: f64,
    pub corner_radius: f64,
    pub width: f64,
    pub length: f64,
}
ros_message!(Tool, "toolpath_msgs", "Tool");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Surface {
    pub header: Header,
    pub surface_id: String,
    pub degree_u: u32,
    pub degree_v: u32,
    pub knots_u: Vec<f64>,
    pub knots_v: Vec<f64>,
    pub count_u: u32,
    pub count_v: u32,
    pub control_points: Vec<Point>,
    pub weights: Vec<f64>,
    pub trim_loops: Vec<TrimLoop>,
    pub trim_tolerance: f64,
}
ros_message!(Surface, "toolpath_msgs", "Surface");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TrimCurve {
    pub degree: u32,
    pub knots: Vec<f64>,
    pub points_uv: Vec<f64>,
    pub weights: Vec<f64>,
}
ros_message!(TrimCurve, "toolpath_msgs", "TrimCurve");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TrimLoop {
    pub curves: Vec<TrimCurve>,
}
ros_message!(TrimLoop, "toolpath_msgs", "TrimLoop");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PocketLoop {
    pub points: Vec<Point>,
}
ros_message!(PocketLoop, "toolpath_msgs", "PocketLoop");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pocket {
    pub header: Header,
    pub pocket_id: String,
    pub outer: PocketLoop,
    pub holes: Vec<PocketLoop>,
}
ros_message!(Pocket, "toolpath_msgs", "Pocket");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Job {
    pub header: Header,
    pub job_id: String,
    pub surface_id: String,
    pub machine: String,
    pub strategy: String,
    pub tool: Tool,
    pub scallop: f64,
    pub tolerance: f64,
    pub lead_angle_deg: f64,
    pub feed_rate: f64,
    pub feed_direction: String,
    pub side_tilt_deg: f64,
    pub tool_catalogue: Vec<f64>,
    pub section_normal: Vector3,
    pub simulation_resolution: f64,
    pub grinding: GrindingParams,
    /// The fully qualified name of the node that should plan the job; empty:
    /// any node. Other nodes ignore it.
    pub node: String,
    /// Whether the node executes the trajectory ([`Job::EXECUTE`]...).
    pub execute: u8,
    /// The job's own time limit, s; 0: not given.
    pub time_limit_s: f64,
}
ros_message!(Job, "toolpath_msgs", "Job");

impl Job {
    /// `execute`: as the machine's `controller.execute` says.
    pub const EXECUTE_MACHINE_DEFAULT: u8 = 0;
    /// `execute`: send the trajectory to the controller.
    pub const EXECUTE: u8 = 1;
    /// `execute`: publish the trajectory only.
    pub const PLAN_ONLY: u8 = 2;
}

/// The tool poses of one job, one PoseArray per pass.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ToolPoseSegments {
    pub header: Header,
    pub job_id: String,
    pub segments: Vec<PoseArray>,
}
ros_message!(ToolPoseSegments, "toolpath_msgs", "ToolPoseSegments");

/// Belt-grinding removal model; zero in a field = its default.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GrindingParams {
    pub c_a: f64,
    pub k_a: f64,
    pub k_t: f64,
    pub belt_speed: f64,
    pub force: f64,
    pub feed_speed: f64,
}
ros_message!(GrindingParams, "toolpath_msgs", "GrindingParams");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JobStatus {
    pub header: Header,
    pub job_id: String,
    pub state: u8,
    pub progress: f32,
    pub message: String,
    /// RUNNING: estimated seconds left; negative: not known.
    pub eta_s: f32,
}
ros_message!(JobStatus, "toolpath_msgs", "JobStatus");

impl JobStatus {
    pub const ACCEPTED: u8 = 0;
    pub const RUNNING: u8 = 1;
    pub const SUCCEEDED: u8 = 2;
    pub const FAILED: u8 = 3;
    pub const REJECTED: u8 = 4;
    pub const CANCELED: u8 = 5;

    /// Name of a state constant, for tables and logs.
    pub fn state_name(state: u8) -> &'static str {
        match state {
            Self::ACCEPTED => "ACCEPTED",
            Self::RUNNING => "RUNNING",
            Self::SUCCEEDED => "SUCCEEDED",
            Self::FAILED => "FAILED",
            Self::REJECTED => "REJECTED",
            Self::CANCELED => "CANCELED",
            _ => "UNKNOWN",
        }
    }
    pub fn is_final(&self) -> bool {
        self.state >= Self::SUCCEEDED
    }
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ToolpathPoint {
    pub cc: Point,
    pub cl: Point,
    pub axis: Vector3,
    pub normal: Vector3,
    pub feed_direction: Vector3,
    pub u: f64,
    pub v: f64,
    pub feed_rate: f64,
    pub strip_width: f64,
    pub lead_angle_deg: f64,
    pub gouge: f64,
}
ros_message!(ToolpathPoint, "toolpath_msgs", "ToolpathPoint");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ToolpathPass {
    pub region: u32,
    pub stage: String,
    pub tool_diameter: f64,
    pub min_strip_width: f64,
    pub points: Vec<ToolpathPoint>,
}
ros_message!(ToolpathPass, "toolpath_msgs", "ToolpathPass");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ToolpathStats {
    pub path_length_mm: f64,
    pub passes: u32,
    pub points: u32,
    pub max_scallop_mm: f64,
    pub compute_ms: f64,
    pub machining_time_min: f64,
    pub trajectory_duration_s: f64,
    pub max_gouge_mm: f64,
    pub uncut_area_mm2: f64,
    pub extra_names: Vec<String>,
    pub extra_values: Vec<f64>,
}
ros_message!(ToolpathStats, "toolpath_msgs", "ToolpathStats");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Toolpath {
    pub header: Header,
    pub job_id: String,
    pub surface_id: String,
    pub strategy: String,
    pub machine: String,
    pub tool: Tool,
    pub passes: Vec<ToolpathPass>,
    pub stats: ToolpathStats,
    pub degenerate_points: Vec<Point>,
    pub warnings: Vec<String>,
}
ros_message!(Toolpath, "toolpath_msgs", "Toolpath");

#[cfg(test)]
mod tests {
    use super::*;

    /// The field names of a definition, in order (constants skipped).
    fn fields(full_name: &str) -> Vec<String> {
        fields_of(definition(full_name).unwrap())
    }

    fn fields_of(text: &str) -> Vec<String> {
        text.lines()
            .map(|l| l.split('#').next().unwrap().trim())
            .filter(|l| !l.is_empty())
            // A constant has `=` after its type (`uint8 FAILED=3`); a bounded
            // sequence has one inside it (`Surface[<=1] surface`).
            .filter_map(|l| l.split_once(char::is_whitespace))
            .filter(|(_, rest)| !rest.contains('='))
            .map(|(_, rest)| rest.split_whitespace().next().unwrap().to_string())
            .collect()
    }

    /// Field names of a struct, in serialisation order, through serde_json.
    fn struct_fields<T: Serialize>(value: &T) -> Vec<String> {
        // serde_json without preserve_order sorts keys; serialise to a
        // sequence-preserving format instead: our own tiny key recorder.
        let v = serde_yaml_ng::to_string(value).unwrap();
        v.lines()
            .filter(|l| !l.starts_with(' ') && !l.starts_with('-'))
            .filter_map(|l| l.split(':').next())
            .map(|s| s.to_string())
            .collect()
    }

    #[test]
    fn struct_field_order_matches_msg_files() {
        fn check<T: RosMessage + Default>() {
            assert_eq!(
                struct_fields(&T::default()),
                fields(&T::full_name()),
                "{}",
                T::full_name()
            );
        }
        check::<Tool>();
        check::<Surface>();
        check::<TrimCurve>();
        check::<TrimLoop>();
        check::<PocketLoop>();
        check::<Pocket>();
        check::<Job>();
        check::<GrindingParams>();
        check::<ToolPoseSegments>();
        check::<JobStatus>();
        check::<ToolpathPoint>();
        check::<ToolpathPass>();
        check::<ToolpathStats>();
        check::<Toolpath>();
        check::<Header>();
        check::<Time>();
        check::<Duration>();
        check::<Pose>();
        check::<PoseArray>();
        check::<Quaternion>();
        check::<JointTrajectory>();
        check::<JointTrajectoryPoint>();
        check::<Marker>();
        check::<MarkerArray>();
        check::<ColorRGBA>();
        check::<CompressedImage>();
        check::<JointState>();
        use super::super::follow_joint_trajectory as fjt;
        check::<fjt::Transform>();
        check::<fjt::Twist>();
        check::<fjt::MultiDOFJointTrajectory>();
        check::<fjt::MultiDOFJointTrajectoryPoint>();
        check::<fjt::JointTolerance>();
        check::<fjt::JointComponentTolerance>();
        check::<fjt::StringMsg>();
        check::<MeshFile>();
        check::<UVCoordinate>();
        use super::super::diagnostics as diag;
        check::<diag::DiagnosticArray>();
        check::<diag::DiagnosticStatus>();
        check::<diag::KeyValue>();
        use super::super::frames;
        check::<frames::TransformStamped>();
        check::<frames::TfMessage>();
    }

    #[test]
    fn plan_toolpath_structs_follow_the_action_and_service_files() {
        use super::super::plan_toolpath::{self as pt, Feedback, Goal, GoalResult};
        let action = pt::sections(pt::ACTION_DEFINITION);
        let service = pt::sections(pt::SERVICE_DEFINITION);
        assert_eq!((action.len(), service.len()), (3, 2));
        let goal = struct_fields(&Goal::default());
        let result = struct_fields(&GoalResult::default());
        assert_eq!(goal, ["job", "surface", "pocket"]);
        assert_eq!(goal, fields_of(&action[0]));
        assert_eq!(result, fields_of(&action[1]));
        assert_eq!(struct_fields(&Feedback::default()), fields_of(&action[2]));
        assert_eq!(goal, fields_of(&service[0]));
        assert_eq!(result, fields_of(&service[1]));
        // Every type the action names is known (for schemas and clients).
        for section in action.iter().chain(&service) {
            for line in section.lines() {
                let line = line.split('#').next().unwrap().trim();
                let Some(ty) = line.split_whitespace().next() else {
                    continue;
                };
                let base = ty.split('[').next().unwrap();
                if !PRIMITIVES.contains(&base) {
                    assert!(
                        definition(&format!("toolpath_msgs/{base}")).is_some(),
                        "{base}"
                    );
                }
            }
        }
    }

    #[test]
    fn schema_text_appends_every_nested_type_once() {
        let s = schema_text("toolpath_msgs/Toolpath").unwrap();
        let msgs: Vec<&str> = s.lines().filter(|l| l.starts_with("MSG: ")).collect();
        for want in [
            "MSG: std_msgs/Header",
            "MSG: builtin_interfaces/Time",
            "MSG: toolpath_msgs/Tool",
            "MSG: toolpath_msgs/ToolpathPass",
            "MSG: toolpath_msgs/ToolpathPoint",
            "MSG: geometry_msgs/Point",
            "MSG: geometry_msgs/Vector3",
            "MSG: toolpath_msgs/ToolpathStats",
        ] {
            assert_eq!(
                msgs.iter().filter(|m| **m == want).count(),
                1,
                "{want} in\n{s}"
            );
        }
        assert_eq!(msgs.len(), 8);
        assert!(s.contains(&format!("{}\nMSG: std_msgs/Header\n", "=".repeat(80))));
        // Every nested type of every known message resolves.
        for (name, _) in DEFINITIONS {
            assert!(schema_text(name).is_some(), "{name}");
        }
    }

    #[test]
    fn cdr_layout_of_a_job_status_is_what_rclpy_sends() {
        // Hand-assembled little-endian XCDR1 body of JobStatus{stamp 1.2, "w", "j", RUNNING, 0.5, "ok", 4.25}.
        let msg = JobStatus {
            header: Header {
                stamp: Time { sec: 1, nanosec: 2 },
                frame_id: "w".into(),
            },
            job_id: "j".into(),
            state: JobStatus::RUNNING,
            progress: 0.5,
            message: "ok".into(),
            eta_s: 4.25,
        };
        let bytes = cdr_encoding::to_vec::<_, byteorder::LittleEndian>(&msg).unwrap();
        let mut want = Vec::new();
        want.extend(1i32.to_le_bytes());
        want.extend(2u32.to_le_bytes());
        want.extend(2u32.to_le_bytes());
        want.extend(b"w\0");
        want.extend([0, 0]); // pad to 4
        want.extend(2u32.to_le_bytes());
        want.extend(b"j\0");
        want.push(1); // state
        want.push(0); // pad to 4 for the float32
        want.extend(0.5f32.to_le_bytes());
        want.extend(3u32.to_le_bytes());
        want.extend(b"ok\0");
        want.push(0); // pad to 4 for the float32
        want.extend(4.25f32.to_le_bytes());
        assert_eq!(bytes, want);
        let back: JobStatus = cdr_encoding::from_bytes::<_, byteorder::LittleEndian>(&bytes)
            .unwrap()
            .0;
        assert_eq!(back, msg);
    }
}
