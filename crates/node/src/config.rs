//! The node's configuration: one YAML file per cell (launch_configs/*.yaml).

use serde::{Deserialize, Serialize};
use std::net::IpAddr;
use std::path::Path;
use toolpath_kernel::error::{Error, Result};
use toolpath_machines::{Belt6Config, Machines, Mill5Config};
use toolpath_messages::frames::Frames;

/// Node settings (the `node:` section).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NodeSettings {
    /// ROS node name.
    pub name: String,
    /// Namespace pushed in front of every (relative) topic name.
    pub namespace: String,
    /// DDS domain; `null` = the ROS_DOMAIN_ID environment variable, else 0.
    pub domain_id: Option<u16>,
    /// IP addresses of the network interfaces DDS may use. Default: loopback
    /// only. `["all"]` lets DDS use every interface (a real cell network).
    pub interfaces: Vec<String>,
    /// frame_id of every output: the workpiece frame.
    pub frame_id: String,
    /// The mill's base frame (its machine coordinates), parent of the
    /// workpiece frame on `/tf_static`.
    pub mill5_frame: String,
    /// The grinder's base frame, a child of the workpiece frame on `/tf_static`.
    pub belt6_frame: String,
    /// Publish the frames' tree on `/tf_static` (off when the cell publishes
    /// these frames itself).
    pub tf_static: bool,
    /// How requests and replies of the node's services and actions (and its
    /// controller clients) travel: as the cell's RMW frames them.
    pub service_mapping: ServiceMappingSetting,
    /// How long a job waits for its surface (or pocket) to arrive, s.
    pub surface_timeout_s: f64,
    /// Planning worker threads; 0 (the default) = one per available core
    /// ([`NodeSettings::worker_count`]). Each job is planned on one worker, and
    /// its result does not depend on how many there are.
    pub workers: usize,
    /// Run the simulator check after planning (fills max_scallop_mm).
    pub verify: bool,
    /// A job still planning after this many seconds FAILS (stopped), which
    /// frees its worker for the jobs queued behind it; 0 = no limit
    /// (docs/limits.md).
    pub job_time_limit_s: f64,
    /// Jobs estimated to need more than this are refused before planning.
    pub budget: toolpath_pipeline::Budget,
}

/// The request/reply mapping of services and actions on DDS (`node.service_mapping`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ServiceMappingSetting {
    /// The request id as the DDS related-sample-identity (rmw_fastrtps,
    /// ROS 2's default RMW; rmw_connextdds).
    Enhanced,
    /// A 16-byte request header in the payload (rmw_cyclonedds).
    Cyclone,
}

impl From<ServiceMappingSetting> for ros2_client::ServiceMapping {
    fn from(s: ServiceMappingSetting) -> Self {
        match s {
            ServiceMappingSetting::Enhanced => ros2_client::ServiceMapping::Enhanced,
            ServiceMappingSetting::Cyclone => ros2_client::ServiceMapping::Cyclone,
        }
    }
}

/// Default `node.job_time_limit_s`: ten minutes, about a hundred times what
/// the samples take, so only a runaway job meets it.
pub const DEFAULT_JOB_TIME_LIMIT_S: f64 = 600.0;

/// Most planning workers a config may ask for.
pub const MAX_WORKERS: usize = 256;

impl NodeSettings {
    /// The time limit of every job, if any.
    pub fn time_limit(&self) -> Option<toolpath_pipeline::TimeLimit> {
        (self.job_time_limit_s > 0.0).then_some(toolpath_pipeline::TimeLimit {
            seconds: self.job_time_limit_s,
            parameter: "node.job_time_limit_s",
        })
    }

    /// Planning threads the node starts: `workers`, or the machine's available
    /// cores when it is 0.
    pub fn worker_count(&self) -> usize {
        if self.workers == 0 {
            std::thread::available_parallelism().map_or(1, |n| n.get())
        } else {
            self.workers
        }
    }
}

impl Default for NodeSettings {
    fn default() -> Self {
        Self {
            name: "toolpath_planner".into(),
            namespace: "/".into(),
            domain_id: None,
            interfaces: vec!["127.0.0.1".into()],
            frame_id: "workpiece".into(),
            mill5_frame: "mill5_base".into(),
            belt6_frame: "belt6_base".into(),
            tf_static: true,
            service_mapping: ServiceMappingSetting::Enhanced,
            surface_timeout_s: 10.0,
            workers: 0,
            verify: true,
            job_time_limit_s: DEFAULT_JOB_TIME_LIMIT_S,
            budget: toolpath_pipeline::Budget::DEFAULT,
        }
    }
}

/// The three frame names: TF names (no leading slash, no spaces), distinct.
fn check_frames(n: &NodeSettings) -> Result<()> {
    let frames = [
        ("node.frame_id", &n.frame_id),
        ("node.mill5_frame", &n.mill5_frame),
        ("node.belt6_frame", &n.belt6_frame),
    ];
    for (k, (field, name)) in frames.iter().enumerate() {
        if name.is_empty() || name.starts_with('/') || name.chars().any(char::is_whitespace) {
            return Err(Error::invalid(
                *field,
                format!("\"{name}\" is not a TF frame name (not empty, no leading '/', no spaces)"),
            ));
        }
        if let Some((other, _)) = frames[..k].iter().find(|(_, o)| o == name) {
            return Err(Error::invalid(
                *field,
                format!("\"{name}\" is already {other}: the three frames must differ"),
            ));
        }
    }
    Ok(())
}

/// Recording of the node's runs as rosbag2 bags (the `recording:` section).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RecordingSettings {
    /// Record every run: all input and output topics, one bag per run.
    pub enabled: bool,
    /// Directory the bags go into (created when missing).
    pub directory: String,
    /// Name of the bag directory; `null` = `<node name>_<UTC start time>_<pid>`.
    pub bag_name: Option<String>,
    /// Target uncompressed chunk size, KiB (a chunk is also closed after every
    /// job's final status, so a killed node keeps its finished jobs).
    pub chunk_size_kib: u64,
    /// zstd level of the chunks (1 fast .. 19 small); 0 = no compression.
    pub zstd_level: u32,
}

impl Default for RecordingSettings {
    fn default() -> Self {
        Self {
            enabled: false,
            directory: "recorded_runs".into(),
            bag_name: None,
            chunk_size_kib: 256,
            zstd_level: 3,
        }
    }
}

impl RecordingSettings {
    pub fn validate(&self) -> Result<()> {
        if self.directory.trim().is_empty() {
            return Err(Error::invalid("recording.directory", "must not be empty"));
        }
        if let Some(name) = &self.bag_name {
            if name.is_empty() || name.contains('/') || name == "." || name == ".." {
                return Err(Error::invalid(
                    "recording.bag_name",
                    format!("\"{name}\" is not a plain directory name"),
                ));
            }
        }
        if self.chunk_size_kib == 0 {
            return Err(Error::invalid(
                "recording.chunk_size_kib",
                "must be at least 1",
            ));
        }
        if self.zstd_level > 19 {
            return Err(Error::invalid(
                "recording.zstd_level",
                format!("{} is above zstd's maximum 19", self.zstd_level),
            ));
        }
        Ok(())
    }
}

/// The job journal (the `journal:` section): every accepted job is written
/// to it durably before ACCEPTED is published, and its final status before
/// that is published, so a node that restarts after a crash finds the jobs
/// it had not finished (docs/node.md, "Job journal and restarts").
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct JournalSettings {
    /// The journal file; `null` = no journal (a crash loses the queue).
    pub path: Option<String>,
    /// Finished jobs kept in the journal (the oldest are removed first).
    pub keep_finished: usize,
    /// What a restart does with the jobs the journal holds unfinished.
    pub on_restart: OnRestart,
}

/// What a node that restarts does with the jobs it had not finished.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OnRestart {
    /// Plans them again in their order, under their job_id.
    Replan,
    /// Ends each FAILED: "node restarted before finishing".
    Fail,
}

impl Default for JournalSettings {
    fn default() -> Self {
        Self {
            path: None,
            keep_finished: 1000,
            on_restart: OnRestart::Replan,
        }
    }
}

impl JournalSettings {
    pub fn validate(&self) -> Result<()> {
        if self.path.as_deref().is_some_and(|p| p.trim().is_empty()) {
            return Err(Error::invalid(
                "journal.path",
                "must not be empty (null = no journal)",
            ));
        }
        if self.keep_finished == 0 {
            return Err(Error::invalid(
                "journal.keep_finished",
                "must be at least 1",
            ));
        }
        Ok(())
    }
}

/// Zero-copy toolpath output over iceoryx2 (the `ipc:` section; payload
/// layout in docs/formats.md).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IpcSettings {
    /// Also publish every toolpath on the iceoryx2 service.
    pub enabled: bool,
    /// iceoryx2 service name.
    pub service: String,
    /// iceoryx2 file-name prefix; `null` = iceoryx2's own (tests isolate themselves with one).
    pub prefix: Option<String>,
}

impl Default for IpcSettings {
    fn default() -> Self {
        Self {
            enabled: false,
            service: toolpath_ipc::SERVICE_NAME.into(),
            prefix: None,
        }
    }
}

/// NC programs of the node's milling results (the `post:` section; formats
/// in docs/formats.md).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PostSettings {
    /// Write an NC program of every mill5 result, one file per job.
    pub enabled: bool,
    /// Program format, as `toolpath post --format`.
    pub format: String,
    /// Where the programs go; `null` = the recording directory (next to the
    /// bags) when recording, else `nc_programs`.
    pub directory: Option<String>,
}

impl Default for PostSettings {
    fn default() -> Self {
        Self {
            enabled: false,
            format: "linuxcnc-joint".into(),
            directory: None,
        }
    }
}

impl PostSettings {
    pub fn format(&self) -> Result<toolpath_post::Format> {
        toolpath_post::Format::parse(&self.format).map_err(|e| e.within("post"))
    }

    /// The programs' directory for a node recording (or not) into `recording`.
    pub fn directory(&self, recording: &RecordingSettings) -> std::path::PathBuf {
        match &self.directory {
            Some(d) => d.into(),
            None if recording.enabled => (&recording.directory).into(),
            None => "nc_programs".into(),
        }
    }
}

/// A cell: node settings and the geometry and limits of both machines.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NodeConfig {
    pub node: NodeSettings,
    pub recording: RecordingSettings,
    pub journal: JournalSettings,
    pub ipc: IpcSettings,
    pub post: PostSettings,
    pub mill5: Mill5Config,
    pub belt6: Belt6Config,
}

impl NodeConfig {
    /// Reads and validates a YAML config; errors name the file and the field.
    pub fn read(path: &Path) -> Result<Self> {
        let text = toolpath_formats::read_text(path)?;
        Self::parse(&text).map_err(|e| e.in_file(path))
    }

    pub fn parse(text: &str) -> Result<Self> {
        Self::deserialize_checked(serde_yaml_ng::Deserializer::from_str(text))
    }

    /// Reads a config from YAML text or a YAML tree, with the config's
    /// checks; errors name the dotted setting.
    pub fn deserialize_checked<'de, D>(de: D) -> Result<Self>
    where
        D: serde::Deserializer<'de, Error = serde_yaml_ng::Error>,
    {
        let cfg: NodeConfig = serde_path_to_error::deserialize(de).map_err(|e| {
            let path = e.path().to_string();
            let path = if path == "." { String::new() } else { path };
            Error::invalid(path, e.into_inner().to_string())
        })?;
        cfg.validate()?;
        Ok(cfg)
    }

    pub fn validate(&self) -> Result<()> {
        let n = &self.node;
        if n.name.is_empty() {
            return Err(Error::invalid("node.name", "must not be empty"));
        }
        check_frames(n)?;
        if !n.surface_timeout_s.is_finite() || n.surface_timeout_s < 0.0 {
            return Err(Error::invalid(
                "node.surface_timeout_s",
                "must be a finite number >= 0",
            ));
        }
        if n.job_time_limit_s != 0.0 {
            toolpath_pipeline::TimeLimit::validate(n.job_time_limit_s, "node.job_time_limit_s")
                .map_err(|e| match e {
                    Error::Invalid { field, message } => {
                        Error::invalid(field, format!("{message} (0 = no limit)"))
                    }
                    e => e,
                })?;
        }
        n.budget.validate("node.budget")?;
        if n.workers > MAX_WORKERS {
            return Err(Error::invalid(
                "node.workers",
                format!(
                    "{} is above the limit {MAX_WORKERS} (0 = one per available core)",
                    n.workers
                ),
            ));
        }
        if let Some(d) = n.domain_id {
            if d > 232 {
                return Err(Error::invalid(
                    "node.domain_id",
                    format!("{d} is above the ROS 2 maximum 232"),
                ));
            }
        }
        self.interfaces()?;
        self.recording.validate()?;
        self.journal.validate()?;
        self.post.format()?;
        if self.ipc.service.trim().is_empty() {
            return Err(Error::invalid("ipc.service", "must not be empty"));
        }
        self.machines().validate()
    }

    /// The workpiece frame and the machines' base frames with their poses.
    pub fn frames(&self) -> Frames {
        Frames {
            workpiece: self.node.frame_id.clone(),
            mill5: (self.node.mill5_frame.clone(), self.mill5.placement()),
            belt6: (self.node.belt6_frame.clone(), self.belt6.placement()),
        }
    }

    pub fn machines(&self) -> Machines {
        Machines {
            mill5: self.mill5.clone(),
            belt6: self.belt6.clone(),
        }
    }

    /// The interface addresses; `None` = all interfaces.
    pub fn interfaces(&self) -> Result<Option<Vec<IpAddr>>> {
        let list = &self.node.interfaces;
        if list.iter().any(|s| s == "all") {
            return Ok(None);
        }
        if list.is_empty() {
            return Err(Error::invalid(
                "node.interfaces",
                "is empty: list interface IP addresses (e.g. 127.0.0.1) or \"all\"",
            ));
        }
        list.iter()
            .enumerate()
            .map(|(k, s)| {
                s.parse::<IpAddr>().map_err(|_| {
                    Error::invalid(
                        format!("node.interfaces[{k}]"),
                        format!("\"{s}\" is not an IP address (or \"all\")"),
                    )
                })
            })
            .collect::<Result<Vec<_>>>()
            .map(Some)
    }

    /// The DDS domain: the config's, else ROS_DOMAIN_ID, else 0.
    pub fn domain_id(&self) -> Result<u16> {
        if let Some(d) = self.node.domain_id {
            return Ok(d);
        }
        match std::env::var("ROS_DOMAIN_ID") {
            Ok(s) if !s.trim().is_empty() => s
                .trim()
                .parse::<u16>()
                .ok()
                .filter(|d| *d <= 232)
                .ok_or_else(|| {
                    Error::invalid(
                        "ROS_DOMAIN_ID",
                        format!("\"{s}\" is not a domain id 0..232"),
                    )
                }),
            _ => Ok(0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use toolpath_formats::Machine;

    #[test]
    fn every_launch_config_parses() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../launch_configs");
        let mut n = 0;
        for entry in std::fs::read_dir(&dir).unwrap() {
            let p = entry.unwrap().path();
            let name = p.file_name().unwrap().to_string_lossy().to_string();
            if name.ends_with("_params.yaml") {
                // A ROS 2 parameter file, applied onto the defaults.
                let args = crate::ros_args::RosArgs {
                    params_files: vec![p.clone()],
                    ..Default::default()
                };
                crate::parameters::resolve(&NodeConfig::default(), &args)
                    .unwrap_or_else(|e| panic!("{e}"));
            } else if name.ends_with(".yaml") {
                NodeConfig::read(&p).unwrap_or_else(|e| panic!("{e}"));
                n += 1;
            }
        }
        assert!(n >= 2);
    }

    #[test]
    fn defaults_equal_the_default_config_file() {
        let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../launch_configs/default.yaml");
        assert_eq!(NodeConfig::read(&p).unwrap(), NodeConfig::default());
    }

    #[test]
    fn frame_names_are_tf_names_and_distinct() {
        for (yaml, field, why) in [
            (
                "node:\n  frame_id: ''\n",
                "node.frame_id",
                "not a TF frame name",
            ),
            (
                "node:\n  mill5_frame: /mill\n",
                "node.mill5_frame",
                "not a TF frame name",
            ),
            (
                "node:\n  belt6_frame: mill5_base\n",
                "node.belt6_frame",
                "is already node.mill5_frame",
            ),
            (
                "node:\n  mill5_frame: workpiece\n",
                "node.mill5_frame",
                "is already node.frame_id",
            ),
        ] {
            let e = NodeConfig::parse(yaml).unwrap_err().to_string();
            assert!(e.contains(field) && e.contains(why), "{yaml}: {e}");
        }
        let turned = NodeConfig::parse("mill5:\n  workpiece_rpy_deg: [0, 0, .nan]\n");
        let e = turned.unwrap_err().to_string();
        assert!(e.contains("mill5.workpiece_rpy_deg[2]"), "{e}");
    }

    #[test]
    fn two_executing_machines_need_their_own_joint_names() {
        let both =
            "mill5:\n  controller:\n    execute: true\nbelt6:\n  controller:\n    execute: true\n";
        let e = NodeConfig::parse(both).unwrap_err().to_string();
        assert!(
            e.contains("belt6.controller.joint_names")
                && e.contains("shares the joints X Y Z A C with mill5"),
            "{e}"
        );
        let apart = format!("{both}    joint_names: [b_X, b_Y, b_Z, b_A, b_B, b_C]\n");
        NodeConfig::parse(&apart).unwrap();
        // One machine executing alone reads its own joints only.
        let mill = NodeConfig::parse("mill5:\n  controller:\n    execute: true\n").unwrap();
        // A job asking belt6 to execute beside it is refused the same way;
        // mill5 itself, or belt6 with joints of its own, may.
        let machines = mill.machines();
        machines.check_job_may_execute(Machine::Mill5).unwrap();
        let e = machines
            .check_job_may_execute(Machine::Belt6)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "invalid input: execute: belt6 cannot execute while mill5 executes by default: they \
             share the joints X Y Z A C and /joint_states cannot tell them apart; give one \
             machine its controller's own joint names (controller.joint_names)"
        );
        let apart = NodeConfig::parse(
            "mill5:\n  controller:\n    execute: true\nbelt6:\n  controller:\n    joint_names: [b_X, b_Y, b_Z, b_A, b_B, b_C]\n",
        )
        .unwrap();
        apart
            .machines()
            .check_job_may_execute(Machine::Belt6)
            .unwrap();
        // Nothing executes by default: any job may.
        let none = NodeConfig::default().machines();
        none.check_job_may_execute(Machine::Belt6).unwrap();
        none.check_job_may_execute(Machine::Mill5).unwrap();
    }

    #[test]
    fn a_partial_controller_section_keeps_the_other_defaults() {
        let c =
            NodeConfig::parse("mill5:\n  controller:\n    execute: true\n    stamp: at\n").unwrap();
        let mut want = toolpath_machines::ControllerConfig::new();
        want.execute = true;
        want.stamp = toolpath_machines::StampPolicy::At;
        assert_eq!(c.mill5.controller, want);
        assert_eq!(
            c.belt6.controller,
            toolpath_machines::ControllerConfig::new()
        );
        let e = NodeConfig::parse("belt6:\n  controller:\n    stamp: later\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("belt6.controller.stamp"), "{e}");
    }

    #[test]
    fn errors_name_the_field() {
        let e = NodeConfig::parse("mill5:\n  a:\n    min_deg: 10\n    max_deg: -10\n    max_velocity_deg_s: 1\n    max_acceleration_deg_s2: 1\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("mill5.a.max_deg"), "{e}");
        let e = NodeConfig::parse("node:\n  interfaces: [eth0]\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("node.interfaces[0]") && e.contains("not an IP address"),
            "{e}"
        );
        let e = NodeConfig::parse("mill5:\n  pivot_lenght_mm: 3\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("pivot_lenght_mm"), "{e}");
        let e = NodeConfig::parse("post:\n  enabled: true\n  format: okuma\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("post.format: unknown format \"okuma\""), "{e}");
        let e = NodeConfig::parse("node:\n  workers: 100000\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("node.workers") && e.contains("100000"), "{e}");
    }

    #[test]
    fn default_workers_are_one_per_available_core() {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        assert_eq!(NodeConfig::default().node.worker_count(), cores);
        let two = NodeConfig::parse("node:\n  workers: 2\n").unwrap();
        assert_eq!(two.node.worker_count(), 2);
    }
}
