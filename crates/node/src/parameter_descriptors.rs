//! What `ros2 param describe` says of each setting: its description (the
//! comment of its line in launch_configs/default.yaml, the documented default
//! config, so the two cannot drift apart), whether it may change while the
//! node runs, and the numeric range the config's checks accept.

use super::config::MAX_WORKERS;
use super::parameters::{read_only_reason, RUNTIME};
use ros2_client::parameters::{NumericRange, ParameterDescriptor, ParameterType, ParameterValue};
use std::collections::BTreeMap;

const DEFAULT_CONFIG: &str = include_str!("../../../launch_configs/default.yaml");

/// What the keys of an axis' flow mapping (`x: {min_mm: 0.0, ...}`) mean.
const AXIS_KEYS: &[(&str, &str)] = &[
    ("min_mm", "lower end of travel, mm"),
    ("max_mm", "upper end of travel, mm"),
    ("max_velocity_mm_s", "velocity limit, mm/s"),
    ("max_acceleration_mm_s2", "acceleration limit, mm/s^2"),
    ("min_deg", "lower end of travel, degrees"),
    ("max_deg", "upper end of travel, degrees"),
    ("max_velocity_deg_s", "velocity limit, degrees/s"),
    ("max_acceleration_deg_s2", "acceleration limit, degrees/s^2"),
];

/// Descriptions by dotted setting name, from the comments of default.yaml:
/// a line's own comment, and for the keys of an axis' flow mapping what the
/// key means.
pub fn descriptions() -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let mut path: Vec<(usize, String)> = Vec::new();
    for line in DEFAULT_CONFIG.lines() {
        let indent = line.len() - line.trim_start().len();
        let (code, comment) = match line.split_once('#') {
            Some((c, m)) => (c, m.trim()),
            None => (line, ""),
        };
        let Some((key, rest)) = code.trim().split_once(':') else {
            continue;
        };
        while path.last().is_some_and(|(i, _)| *i >= indent) {
            path.pop();
        }
        let name = path
            .iter()
            .map(|(_, k)| k.as_str())
            .chain([key.trim()])
            .collect::<Vec<_>>()
            .join(".");
        let rest = rest.trim();
        if let Some(flow) = rest.strip_prefix('{').and_then(|r| r.strip_suffix('}')) {
            for item in flow.split(',') {
                let Some((k, _)) = item.split_once(':') else {
                    continue;
                };
                let k = k.trim();
                if let Some((_, what)) = AXIS_KEYS.iter().find(|(a, _)| *a == k) {
                    let axis = key.trim().to_uppercase();
                    out.insert(format!("{name}.{k}"), format!("axis {axis}: {what}"));
                }
            }
        } else if !comment.is_empty() {
            out.insert(name.clone(), comment.to_string());
        }
        if rest.is_empty() {
            path.push((indent, key.trim().to_string()));
        }
    }
    out
}

/// The range the config's checks accept for the setting `name` of type
/// `value`, with the constraints a range cannot say.
fn range(name: &str, value: &ParameterValue) -> (NumericRange, &'static str) {
    let integer = |from_value, to_value| NumericRange::IntegerRange {
        from_value,
        to_value,
        step: 1,
    };
    let at_least_zero = NumericRange::FloatingPointRange {
        from_value: 0.0,
        to_value: f64::MAX,
        step: 0.0,
    };
    let leaf = name.rsplit('.').next().unwrap_or(name);
    match (name, value) {
        ("node.workers", ParameterValue::Integer(_)) => (integer(0, MAX_WORKERS as i64), ""),
        ("node.domain_id", ParameterValue::Integer(_)) => (integer(0, 232), ""),
        ("recording.zstd_level", ParameterValue::Integer(_)) => (integer(0, 19), ""),
        ("recording.chunk_size_kib", ParameterValue::Integer(_)) => (integer(1, i64::MAX), ""),
        ("journal.keep_finished", ParameterValue::Integer(_)) => (integer(1, i64::MAX), ""),
        (_, ParameterValue::Double(_))
            if leaf.starts_with("max_velocity")
                || leaf.starts_with("max_acceleration")
                || leaf.starts_with("max_feed_rate")
                || leaf == "pivot_length_mm"
                || leaf == "joint_states_max_age_s"
                || name.starts_with("node.budget.") =>
        {
            (at_least_zero, "> 0")
        }
        (_, ParameterValue::Double(_))
            if leaf == "retract_mm" || leaf.ends_with("_s") || leaf == "start_delay_s" =>
        {
            (at_least_zero, "")
        }
        _ => (NumericRange::NotSpecified, ""),
    }
}

/// The descriptor of the setting `name` with its declared `value`.
pub fn descriptor(
    name: &str,
    value: &ParameterValue,
    descriptions: &BTreeMap<String, String>,
) -> ParameterDescriptor {
    let read_only = !RUNTIME.contains(&name);
    let (range, constraint) = range(name, value);
    let mut constraints = Vec::new();
    if !constraint.is_empty() {
        constraints.push(constraint.to_string());
    }
    if read_only {
        constraints.push(read_only_reason(name));
    }
    ParameterDescriptor {
        name: name.to_string(),
        param_type: ParameterType::NotSet,
        description: descriptions
            .get(name)
            .cloned()
            .unwrap_or_else(|| name.to_string()),
        additional_constraints: constraints.join("; "),
        read_only,
        dynamic_typing: false,
        range,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::NodeConfig;
    use crate::parameters::{flatten, to_parameter, to_tree};

    #[test]
    fn every_setting_has_the_comment_of_its_line_as_description() {
        let d = descriptions();
        let tree = to_tree(&NodeConfig::default()).unwrap();
        let missing: Vec<String> = flatten(&tree)
            .unwrap()
            .into_keys()
            .filter(|name| !d.contains_key(name))
            .collect();
        assert!(
            missing.is_empty(),
            "no comment in default.yaml: {missing:?}"
        );
        assert_eq!(
            d["node.workers"],
            "planning threads; 0 = one per available core"
        );
        assert_eq!(
            d["mill5.a.max_velocity_deg_s"],
            "axis A: velocity limit, degrees/s"
        );
        assert_eq!(
            d["mill5.controller.execute"],
            "true = send every trajectory to the action and report its result"
        );
    }

    #[test]
    fn ranges_follow_the_config_checks_and_only_runtime_settings_are_writable() {
        let d = descriptions();
        let tree = to_tree(&NodeConfig::default()).unwrap();
        let flat: BTreeMap<String, _> = flatten(&tree).unwrap().into_iter().collect();
        let of = |name: &str| descriptor(name, &to_parameter(&flat[name]).unwrap(), &d);
        let workers = of("node.workers");
        assert!(!workers.read_only);
        assert!(matches!(
            workers.range,
            NumericRange::IntegerRange { from_value: 0, to_value, step: 1 } if to_value == MAX_WORKERS as i64
        ));
        let zstd = of("recording.zstd_level");
        assert!(zstd.read_only);
        assert!(zstd
            .additional_constraints
            .contains("read-only while the node runs"));
        let timeout = of("node.surface_timeout_s");
        assert!(!timeout.read_only && timeout.additional_constraints.is_empty());
        assert!(matches!(
            timeout.range,
            NumericRange::FloatingPointRange { from_value, .. } if from_value == 0.0
        ));
        let feed = of("mill5.max_feed_rate_mm_min");
        assert_eq!(feed.additional_constraints.split("; ").next(), Some("> 0"));
        assert!(matches!(
            of("node.frame_id").range,
            NumericRange::NotSpecified
        ));
    }
}
