//! The node's YAML config as ROS 2 parameters, one per setting, named by its
//! dotted path (`node.workers`, `mill5.x.max_mm`, `mill5.controller.execute`).
//!
//! The config file, parameter files (`--params-file`, the `/**:
//! ros__parameters:` layout holding the same keys) and `-p` rules are merged
//! in that order onto one YAML tree, which is read back into a
//! [`NodeConfig`] and validated: every value gets the config's own checks
//! and error texts. The result is declared through ros2-client's
//! `NodeOptions` with a validator and a set action, so `ros2 param
//! list/get/set` work through its parameter services.
//!
//! At run time only the settings a running node can honour for its next job
//! may change ([`RUNTIME`]); the others are refused with the reason.

use super::config::NodeConfig;
use super::recorder::Recorder;
use super::ros_args::RosArgs;
use ros2_client::{NodeOptions, ParameterValue};
use serde_yaml_ng::{Mapping, Value};
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::{Arc, Mutex, OnceLock, RwLock};
use toolpath_kernel::error::{Error, Result};

/// The key of a node's parameters in a parameter file.
pub const ROS_PARAMETERS: &str = "ros__parameters";

/// ros2-client's own parameter (every ROS node has it).
pub const USE_SIM_TIME: &str = "use_sim_time";

/// The settings a running node may change; each takes effect for the next
/// job (or, for `recording.enabled`, the next message recorded).
pub const RUNTIME: &[&str] = &[
    "node.workers",
    "node.verify",
    "node.surface_timeout_s",
    "node.job_time_limit_s",
    "node.budget.max_passes",
    "node.budget.max_points",
    "node.budget.max_memory_mb",
    "mill5.controller.joint_states_max_age_s",
    "belt6.controller.joint_states_max_age_s",
    "recording.enabled",
];

/// Why a setting outside [`RUNTIME`] cannot change while the node runs.
pub(crate) fn read_only_reason(name: &str) -> String {
    let why = if name.starts_with("mill5.controller.") || name.starts_with("belt6.controller.") {
        "the controller connection and joint names are set up when the node starts"
    } else if name.starts_with("mill5.") || name.starts_with("belt6.") {
        "machine geometry and limits are fixed while the node runs"
    } else if name.starts_with("recording.") {
        "the bag is opened when the node starts (only recording.enabled pauses and resumes it)"
    } else {
        "the node's name, network, outputs and files are set up when it starts"
    };
    format!(
        "parameter {name} is read-only while the node runs: {why}; give it in the config, a --params-file or -p and restart the node"
    )
}

/// The config as a YAML tree.
pub fn to_tree(config: &NodeConfig) -> Result<Value> {
    serde_yaml_ng::to_value(config)
        .map_err(|e| Error::invalid("config", format!("cannot convert the config: {e}")))
}

/// Reads a config back from a YAML tree, with the config file's checks;
/// errors name the dotted setting.
pub fn from_tree(tree: Value) -> Result<NodeConfig> {
    NodeConfig::deserialize_checked(tree)
}

/// The leaves of a YAML tree by dotted name (mappings nest; sequences,
/// scalars and null are leaves).
pub fn flatten(tree: &Value) -> Result<BTreeMap<String, Value>> {
    fn walk(prefix: &str, v: &Value, out: &mut BTreeMap<String, Value>) -> Result<()> {
        match v {
            Value::Mapping(m) => {
                for (k, v) in m {
                    let Some(k) = k.as_str() else {
                        return Err(Error::invalid(prefix, format!("key {k:?} is not a string")));
                    };
                    let name = if prefix.is_empty() {
                        k.to_string()
                    } else {
                        format!("{prefix}.{k}")
                    };
                    walk(&name, v, out)?;
                }
                Ok(())
            }
            Value::Tagged(t) => walk(prefix, &t.value, out),
            leaf => {
                out.insert(prefix.to_string(), leaf.clone());
                Ok(())
            }
        }
    }
    let mut out = BTreeMap::new();
    walk("", tree, &mut out)?;
    Ok(out)
}

/// Sets the leaf `name` (dotted) of `tree`.
fn set_leaf(tree: &mut Value, name: &str, value: Value) {
    let mut at = tree;
    for part in name.split('.') {
        if !at.is_mapping() {
            *at = Value::Mapping(Mapping::new());
        }
        let Value::Mapping(m) = at else {
            unreachable!()
        };
        at = m.entry(Value::from(part)).or_insert(Value::Null);
    }
    *at = value;
}

/// A YAML leaf as a ROS parameter value: null is NOT_SET, a sequence takes
/// the type of its elements (integers mixed with doubles are doubles).
pub fn to_parameter(v: &Value) -> std::result::Result<ParameterValue, String> {
    Ok(match v {
        Value::Null => ParameterValue::NotSet,
        Value::Bool(b) => ParameterValue::Boolean(*b),
        Value::Number(n) => match n.as_i64() {
            Some(i) => ParameterValue::Integer(i),
            None => ParameterValue::Double(n.as_f64().ok_or("not a number")?),
        },
        Value::String(s) => ParameterValue::String(s.clone()),
        Value::Sequence(items) => {
            if items.iter().all(Value::is_bool) && !items.is_empty() {
                ParameterValue::BooleanArray(items.iter().filter_map(Value::as_bool).collect())
            } else if items.iter().all(|i| i.as_i64().is_some()) && !items.is_empty() {
                ParameterValue::IntegerArray(items.iter().filter_map(Value::as_i64).collect())
            } else if items.iter().all(Value::is_number) && !items.is_empty() {
                ParameterValue::DoubleArray(items.iter().filter_map(Value::as_f64).collect())
            } else if items.iter().all(Value::is_string) {
                ParameterValue::StringArray(
                    items
                        .iter()
                        .filter_map(|s| s.as_str().map(str::to_string))
                        .collect(),
                )
            } else {
                return Err(
                    "a list must hold one type (bools, numbers or strings) to be a parameter"
                        .into(),
                );
            }
        }
        Value::Mapping(_) | Value::Tagged(_) => {
            return Err("a mapping is not a parameter value".into())
        }
    })
}

/// A ROS parameter value as a YAML leaf.
pub fn from_parameter(p: &ParameterValue) -> Value {
    let seq = |v: Vec<Value>| Value::Sequence(v);
    match p {
        ParameterValue::NotSet => Value::Null,
        ParameterValue::Boolean(b) => Value::from(*b),
        ParameterValue::Integer(i) => Value::from(*i),
        ParameterValue::Double(d) => Value::from(*d),
        ParameterValue::String(s) => Value::from(s.as_str()),
        ParameterValue::ByteArray(a) => seq(a.iter().map(|b| Value::from(*b)).collect()),
        ParameterValue::BooleanArray(a) => seq(a.iter().map(|b| Value::from(*b)).collect()),
        ParameterValue::IntegerArray(a) => seq(a.iter().map(|b| Value::from(*b)).collect()),
        ParameterValue::DoubleArray(a) => seq(a.iter().map(|b| Value::from(*b)).collect()),
        ParameterValue::StringArray(a) => seq(a.iter().map(|b| Value::from(b.as_str())).collect()),
    }
}

/// Whether the node key `pattern` of a parameter file names the node
/// `fully_qualified` (`/ns/name`): `*` matches within one name part, `**`
/// any number of parts; a key without a leading `/` is absolute all the same.
pub fn node_key_matches(pattern: &str, fully_qualified: &str) -> bool {
    fn glob(p: &str, s: &str) -> bool {
        match p.split_once('*') {
            None => p == s,
            Some((head, tail)) => {
                let Some(rest) = s.strip_prefix(head) else {
                    return false;
                };
                (0..=rest.len())
                    .filter(|k| rest.is_char_boundary(*k))
                    .any(|k| glob(tail, &rest[k..]))
            }
        }
    }
    fn parts(p: &[&str], s: &[&str]) -> bool {
        match p.split_first() {
            None => s.is_empty(),
            Some((&"**", rest)) => (0..=s.len()).any(|k| parts(rest, &s[k..])),
            Some((first, rest)) => !s.is_empty() && glob(first, s[0]) && parts(rest, &s[1..]),
        }
    }
    let split = |x: &str| -> Vec<String> {
        x.trim_start_matches('/')
            .split('/')
            .filter(|t| !t.is_empty())
            .map(str::to_string)
            .collect()
    };
    let (p, s) = (split(pattern), split(fully_qualified));
    let p: Vec<&str> = p.iter().map(String::as_str).collect();
    let s: Vec<&str> = s.iter().map(String::as_str).collect();
    parts(&p, &s)
}

/// The parameters a parameter file gives the node `fully_qualified`, in
/// file order (a later key overrides an earlier one).
pub fn read_params_file(path: &Path, fully_qualified: &str) -> Result<Vec<(String, Value)>> {
    let text =
        std::fs::read_to_string(path).map_err(|e| Error::io(path.display().to_string(), e))?;
    params_from_text(&text, fully_qualified).map_err(|e| e.in_file(path))
}

fn params_from_text(text: &str, fully_qualified: &str) -> Result<Vec<(String, Value)>> {
    let doc: Value =
        serde_yaml_ng::from_str(text).map_err(|e| Error::invalid("", e.to_string()))?;
    let Value::Mapping(nodes) = doc else {
        return Err(Error::invalid(
            "",
            "a parameter file is a mapping of node names (e.g. /**:) to ros__parameters:",
        ));
    };
    let mut out = Vec::new();
    for (key, body) in &nodes {
        let Some(key) = key.as_str() else {
            return Err(Error::invalid(
                "",
                format!("node key {key:?} is not a string"),
            ));
        };
        let params = body.as_mapping().and_then(|m| m.get(ROS_PARAMETERS));
        let Some(params) = params else {
            return Err(Error::invalid(
                key,
                format!(
                    "has no {ROS_PARAMETERS}: (the layout is NODE: {ROS_PARAMETERS}: NAME: VALUE)"
                ),
            ));
        };
        if !node_key_matches(key, fully_qualified) {
            continue;
        }
        let flat = flatten(params).map_err(|e| e.within(&format!("{key}.{ROS_PARAMETERS}")))?;
        out.extend(flat);
    }
    Ok(out)
}

/// The config after the ROS arguments, with what else the arguments say
/// about the node.
#[derive(Debug)]
pub struct Resolved {
    pub config: NodeConfig,
    /// Values of ros2-client's own parameters (`use_sim_time`).
    pub builtin: Vec<(String, ParameterValue)>,
    /// Topic remapping rules for this node.
    pub remaps: Vec<(String, String)>,
    /// Publish the log on `/rosout`.
    pub rosout: bool,
}

impl Resolved {
    /// A config without ROS arguments.
    pub fn plain(config: NodeConfig) -> Self {
        Self {
            config,
            builtin: Vec::new(),
            remaps: Vec::new(),
            rosout: true,
        }
    }
}

/// Applies `--params-file`s, then `-p` rules, then `__node` / `__ns`, to the
/// config. Files and rules are matched against the node's name after
/// `__node` / `__ns`; a setting that is not in the config is an error
/// naming where it came from.
pub fn resolve(config: &NodeConfig, args: &RosArgs) -> Result<Resolved> {
    let original = config.node.name.clone();
    let (name, namespace) = args.node_name(&original, &config.node.namespace)?;
    let fully_qualified = format!("{}/{name}", namespace.trim_end_matches('/'));
    let mut tree = to_tree(config)?;
    let known = flatten(&tree)?;
    let mut builtin = Vec::new();
    let mut apply = |tree: &mut Value, where_: &str, name: &str, value: Value| -> Result<()> {
        if name == USE_SIM_TIME {
            let v =
                to_parameter(&value).map_err(|e| Error::invalid(format!("{where_}{name}"), e))?;
            builtin.push((name.to_string(), v));
            return Ok(());
        }
        if !known.contains_key(name) {
            return Err(Error::invalid(
                format!("{where_}{name}"),
                "is not a parameter of this node (the settings of launch_configs/default.yaml, dotted, e.g. node.workers)",
            ));
        }
        set_leaf(tree, name, value);
        Ok(())
    };
    for file in &args.params_files {
        for (name, value) in read_params_file(file, &fully_qualified)? {
            apply(&mut tree, &format!("{}: ", file.display()), &name, value)?;
        }
        tree = to_tree(&from_tree(tree).map_err(|e| e.in_file(file))?)?;
    }
    for p in args
        .params
        .iter()
        .filter(|p| RosArgs::applies(&p.node, &original))
    {
        let where_ = "--ros-args -p ";
        apply(&mut tree, where_, &p.name, p.value.clone())?;
        tree = to_tree(&from_tree(tree).map_err(|e| match e {
            Error::Invalid { field, message } => {
                Error::invalid(format!("{where_}{}: {field}", p.name), message)
            }
            other => other,
        })?)?;
    }
    let mut config = from_tree(tree)?;
    config.node.name = name;
    config.node.namespace = namespace;
    config.validate()?;
    Ok(Resolved {
        config,
        builtin,
        remaps: args.topic_remaps(&original),
        rosout: args.rosout_logs.unwrap_or(true),
    })
}

/// The settings the workers read for each job; parameter sets replace it.
pub struct LiveConfig {
    config: RwLock<Arc<NodeConfig>>,
    recorder: OnceLock<Arc<Recorder>>,
    /// Told of every new config (the node resizes its worker pool).
    on_replace: OnceLock<ConfigListener>,
}

/// What [`LiveConfig::on_replace`] calls with each new config.
pub type ConfigListener = Box<dyn Fn(&NodeConfig) + Send + Sync>;

impl LiveConfig {
    pub fn new(config: NodeConfig) -> Arc<Self> {
        Arc::new(Self {
            config: RwLock::new(Arc::new(config)),
            recorder: OnceLock::new(),
            on_replace: OnceLock::new(),
        })
    }

    /// The current settings (a snapshot: one job plans with one config).
    pub fn get(&self) -> Arc<NodeConfig> {
        match self.config.read() {
            Ok(g) => Arc::clone(&g),
            Err(p) => Arc::clone(&p.into_inner()),
        }
    }

    fn replace(&self, config: NodeConfig) {
        let mut g = match self.config.write() {
            Ok(g) => g,
            Err(p) => p.into_inner(),
        };
        *g = Arc::new(config);
        let now = Arc::clone(&g);
        drop(g);
        if let Some(f) = self.on_replace.get() {
            f(&now);
        }
    }

    /// Calls `f` with every config a parameter set makes (once set, kept).
    pub fn on_replace(&self, f: ConfigListener) {
        let _ = self.on_replace.set(f);
    }

    /// The run's recorder, paused and resumed by `recording.enabled`.
    pub fn set_recorder(&self, recorder: Arc<Recorder>) {
        let _ = self.recorder.set(recorder);
    }
}

/// Checks a set of parameter `name` to `value` against the current config:
/// unchanged values pass, read-only settings and bad values are refused
/// with the reason; returns the new config.
fn check_set(
    live: &LiveConfig,
    name: &str,
    value: &ParameterValue,
) -> std::result::Result<Option<NodeConfig>, String> {
    let current = live.get();
    let mut tree = to_tree(&current).map_err(|e| e.to_string())?;
    let known = flatten(&tree).map_err(|e| e.to_string())?;
    let Some(old) = known.get(name) else {
        return Err(format!("{name} is not a parameter of this node"));
    };
    let new = from_parameter(value);
    if *old == new || to_parameter(old).ok().as_ref() == Some(value) {
        return Ok(None);
    }
    if !RUNTIME.contains(&name) {
        return Err(read_only_reason(name));
    }
    if matches!(value, ParameterValue::NotSet) {
        return Err(format!("parameter {name} cannot be unset"));
    }
    if name == "recording.enabled" && new == Value::Bool(true) && live.recorder.get().is_none() {
        return Err(
            "recording.enabled: the node started without recording, so no bag is open; restart it with recording.enabled: true (then this parameter pauses and resumes the recording)"
                .into(),
        );
    }
    set_leaf(&mut tree, name, new);
    from_tree(tree).map(Some).map_err(|e| e.to_string())
}

/// `NodeOptions` declaring every setting of `config` (and `builtin`), with
/// the validator and set action that keep `live` current.
pub fn node_options(
    config: &NodeConfig,
    builtin: &[(String, ParameterValue)],
    live: &Arc<LiveConfig>,
) -> Result<NodeOptions> {
    let mut options =
        NodeOptions::new().parameter_service_mapping(config.node.service_mapping.into());
    let descriptions = super::parameter_descriptors::descriptions();
    for (name, leaf) in flatten(&to_tree(config)?)? {
        let value = to_parameter(&leaf).map_err(|e| Error::invalid(&name, e))?;
        let descriptor = super::parameter_descriptors::descriptor(&name, &value, &descriptions);
        options = options
            .declare_parameter(&name, value)
            .parameter_descriptor(descriptor);
    }
    for (name, value) in builtin {
        options = options.declare_parameter(name, value.clone());
    }
    let checker = Arc::clone(live);
    let setter = Arc::clone(live);
    // The store runs both for each set; one lock keeps check and apply of
    // concurrent sets in order.
    let order = Arc::new(Mutex::new(()));
    Ok(options
        .parameter_validator(Box::new(move |name, value| {
            check_set(&checker, name, value).map(|_| ())
        }))
        .parameter_set_action(Box::new(move |name, value| {
            let _guard = order.lock().unwrap_or_else(|p| p.into_inner());
            let Some(config) = check_set(&setter, name, value)? else {
                return Ok(());
            };
            if name == "recording.enabled" {
                if let Some(r) = setter.recorder.get() {
                    r.set_paused(!config.recording.enabled);
                }
            }
            log::info!("parameter {name} set to {value:?}: in effect from the next job");
            setter.replace(config);
            Ok(())
        })))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ros_args;

    fn args(s: &str) -> RosArgs {
        let t: Vec<String> = s.split_whitespace().map(str::to_string).collect();
        ros_args::parse(&t).unwrap()
    }

    #[test]
    fn every_setting_is_one_parameter_and_maps_back() {
        let config = NodeConfig::default();
        let flat = flatten(&to_tree(&config).unwrap()).unwrap();
        for name in [
            "node.workers",
            "node.verify",
            "node.domain_id",
            "mill5.x.max_mm",
            "mill5.workpiece_origin_mm",
            "mill5.controller.execute",
            "belt6.c.max_acceleration_deg_s2",
            "recording.zstd_level",
            "post.format",
            "ipc.service",
        ] {
            assert!(flat.contains_key(name), "{name} missing");
        }
        assert_eq!(
            to_parameter(&flat["node.workers"]).unwrap(),
            ParameterValue::Integer(0)
        );
        assert_eq!(
            to_parameter(&flat["node.verify"]).unwrap(),
            ParameterValue::Boolean(true)
        );
        assert_eq!(
            to_parameter(&flat["node.domain_id"]).unwrap(),
            ParameterValue::NotSet
        );
        assert_eq!(
            to_parameter(&flat["mill5.workpiece_origin_mm"]).unwrap(),
            ParameterValue::DoubleArray(vec![2500.0, 1000.0, 300.0])
        );
        assert_eq!(
            to_parameter(&flat["node.interfaces"]).unwrap(),
            ParameterValue::StringArray(vec!["127.0.0.1".into()])
        );
        // Rebuilding the tree from the parameters gives the same config.
        let mut tree = Value::Mapping(Mapping::new());
        for (name, leaf) in &flat {
            set_leaf(
                &mut tree,
                name,
                from_parameter(&to_parameter(leaf).unwrap()),
            );
        }
        assert_eq!(from_tree(tree).unwrap(), config);
    }

    #[test]
    fn node_keys_match_like_rcl() {
        for (p, yes) in [
            ("/**", true),
            ("/*", false),
            ("/*/tp", true),
            ("/cell_b/tp", true),
            ("cell_b/tp", true),
            ("/**/tp", true),
            ("/cell_b/*", true),
            ("/cell_b/t*", true),
            ("/cell_a/tp", false),
            ("/tp", false),
            ("/**/other", false),
        ] {
            assert_eq!(node_key_matches(p, "/cell_b/tp"), yes, "{p}");
        }
        assert!(node_key_matches("/*", "/tp"));
        assert!(node_key_matches("/**", "/tp"));
    }

    fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn files_then_p_rules_then_names() {
        let dir = tempfile::tempdir().unwrap();
        let f = write(
            dir.path(),
            "p.yaml",
            "/**:\n  ros__parameters:\n    node:\n      workers: 3\n      verify: false\n    mill5.retract_mm: 12.5\n\
             /other_node:\n  ros__parameters:\n    node.workers: 7\n\
             /cell_b/tp:\n  ros__parameters:\n    node.surface_timeout_s: 4\n    use_sim_time: true\n",
        );
        let a = args(&format!(
            "-r __ns:=/cell_b -r __node:=tp --params-file {} -p node.workers:=5 -p other:node.workers:=9",
            f.display()
        ));
        let r = resolve(&NodeConfig::default(), &a).unwrap();
        let c = r.config;
        assert_eq!(c.node.workers, 5);
        assert!(!c.node.verify);
        assert_eq!(c.node.surface_timeout_s, 4.0);
        assert_eq!(c.mill5.retract_mm, 12.5);
        assert_eq!(
            (c.node.name.as_str(), c.node.namespace.as_str()),
            ("tp", "/cell_b")
        );
        assert_eq!(
            r.builtin,
            vec![(USE_SIM_TIME.to_string(), ParameterValue::Boolean(true))]
        );
    }

    #[test]
    fn bad_parameters_name_their_source() {
        let dir = tempfile::tempdir().unwrap();
        let err = |a: &str| {
            resolve(&NodeConfig::default(), &args(a))
                .unwrap_err()
                .to_string()
        };
        let e = err("-p node.wrokers:=2");
        assert!(
            e.contains("--ros-args -p node.wrokers: is not a parameter of this node"),
            "{e}"
        );
        let e = err("-p node.workers:=100000");
        assert!(
            e.contains("--ros-args -p node.workers: node.workers: 100000 is above the limit"),
            "{e}"
        );
        let e = err("-p node.verify:=maybe");
        assert!(
            e.contains(
                "-p node.verify: node.verify: invalid type: string \"maybe\", expected a boolean"
            ),
            "{e}"
        );
        let f = write(dir.path(), "flat.yaml", "node:\n  workers: 2\n");
        let e = err(&format!("--params-file {}", f.display()));
        assert!(
            e.contains("flat.yaml: node: has no ros__parameters:"),
            "{e}"
        );
        let f = write(
            dir.path(),
            "typo.yaml",
            "/**:\n  ros__parameters:\n    mill5:\n      pivot_lenght_mm: 3\n",
        );
        let e = err(&format!("--params-file {}", f.display()));
        assert!(
            e.contains("typo.yaml: mill5.pivot_lenght_mm: is not a parameter"),
            "{e}"
        );
        let f = write(
            dir.path(),
            "range.yaml",
            "/**:\n  ros__parameters:\n    recording.zstd_level: 30\n",
        );
        let e = err(&format!("--params-file {}", f.display()));
        assert!(
            e.contains("range.yaml: recording.zstd_level: 30 is above zstd's maximum 19"),
            "{e}"
        );
        let e = err("--params-file /nonexistent/p.yaml");
        assert!(e.starts_with("/nonexistent/p.yaml: "), "{e}");
    }

    #[test]
    fn the_listener_hears_each_new_config_once_it_is_in_effect() {
        use std::sync::atomic::{AtomicUsize, Ordering};
        let live = LiveConfig::new(NodeConfig::default());
        let heard = Arc::new(AtomicUsize::new(usize::MAX));
        let (h, reader) = (Arc::clone(&heard), Arc::clone(&live));
        live.on_replace(Box::new(move |c| {
            // What it is told is what the workers read from now on.
            assert_eq!(reader.get().node.workers, c.node.workers);
            h.store(c.node.workers, Ordering::SeqCst);
        }));
        let c = check_set(&live, "node.workers", &ParameterValue::Integer(3))
            .unwrap()
            .unwrap();
        live.replace(c);
        assert_eq!(heard.load(Ordering::SeqCst), 3);
    }

    #[test]
    fn run_time_sets_are_checked_and_read_only_ones_refused() {
        let live = LiveConfig::new(NodeConfig::default());
        // Unchanged values pass (the store checks every declared value).
        assert_eq!(
            check_set(
                &live,
                "mill5.pivot_length_mm",
                &ParameterValue::Double(250.0)
            ),
            Ok(None)
        );
        let e = check_set(
            &live,
            "mill5.pivot_length_mm",
            &ParameterValue::Double(300.0),
        )
        .unwrap_err();
        assert!(
            e.contains("mill5.pivot_length_mm is read-only") && e.contains("machine geometry"),
            "{e}"
        );
        let c = check_set(&live, "node.workers", &ParameterValue::Integer(4))
            .unwrap()
            .unwrap();
        assert_eq!(c.node.workers, 4);
        let c = check_set(
            &live,
            "node.job_time_limit_s",
            &ParameterValue::Double(30.0),
        )
        .unwrap()
        .unwrap();
        assert_eq!(c.node.job_time_limit_s, 30.0);
        let c = check_set(
            &live,
            "node.budget.max_points",
            &ParameterValue::Double(1e6),
        )
        .unwrap()
        .unwrap();
        assert_eq!(c.node.budget.max_points, 1e6);
        let e = check_set(&live, "node.workers", &ParameterValue::Integer(100_000)).unwrap_err();
        assert!(e.contains("node.workers: 100000 is above the limit"), "{e}");
        let e = check_set(
            &live,
            "node.surface_timeout_s",
            &ParameterValue::Double(-1.0),
        )
        .unwrap_err();
        assert_eq!(
            e,
            "invalid input: node.surface_timeout_s: must be a finite number >= 0"
        );
        let e = check_set(&live, "recording.enabled", &ParameterValue::Boolean(true)).unwrap_err();
        assert!(e.contains("started without recording"), "{e}");
        let c = check_set(&live, "node.verify", &ParameterValue::Boolean(false))
            .unwrap()
            .unwrap();
        assert!(!c.node.verify);
        let c = check_set(
            &live,
            "mill5.controller.joint_states_max_age_s",
            &ParameterValue::Double(2.5),
        )
        .unwrap()
        .unwrap();
        assert_eq!(c.mill5.controller.joint_states_max_age_s, 2.5);
    }
}
