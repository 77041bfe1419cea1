//! The ROS 2 command-line arguments (`--ros-args ... [--]`), as rcl reads
//! them: parameters (`-p`), parameter files, remapping rules (`-r`,
//! including `__ns` and `__node`), log levels and the security enclave.
//!
//! No Rust crate parses this block (ros2-client leaves it to the
//! application), so it is read here by hand; the node's own options stay
//! with clap, which only sees the arguments outside the ROS block.

use std::ffi::OsString;
use std::path::PathBuf;
use toolpath_kernel::error::{Error, Result};

/// Start of a ROS argument block.
pub const ROS_ARGS: &str = "--ros-args";

/// Splits a command line into the program's own arguments and the tokens of
/// its `--ros-args` blocks. A block runs to a lone `--` or to the end; there
/// may be several. `None` when there is no block at all.
pub fn split(
    args: impl IntoIterator<Item = OsString>,
) -> Result<(Vec<OsString>, Option<Vec<String>>)> {
    let mut own = Vec::new();
    let mut ros: Option<Vec<String>> = None;
    let mut inside = false;
    for a in args {
        if a == ROS_ARGS {
            inside = true;
            ros.get_or_insert_with(Vec::new);
            continue;
        }
        if inside {
            if a == "--" {
                inside = false;
                continue;
            }
            let s = a.into_string().map_err(|a| {
                Error::invalid(ROS_ARGS, format!("argument {a:?} is not valid UTF-8"))
            })?;
            ros.get_or_insert_with(Vec::new).push(s);
        } else {
            own.push(a);
        }
    }
    Ok((own, ros))
}

/// rcl's log severities.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Severity {
    Debug,
    Info,
    Warn,
    Error,
    Fatal,
}

impl Severity {
    fn parse(s: &str) -> Option<Self> {
        Some(match s.to_ascii_lowercase().as_str() {
            "debug" => Self::Debug,
            "info" => Self::Info,
            "warn" | "warning" => Self::Warn,
            "error" => Self::Error,
            "fatal" => Self::Fatal,
            _ => return None,
        })
    }

    /// The `log` crate's level (it has no fatal: fatal lines are errors).
    pub fn level_filter(self) -> log::LevelFilter {
        match self {
            Self::Debug => log::LevelFilter::Debug,
            Self::Info => log::LevelFilter::Info,
            Self::Warn => log::LevelFilter::Warn,
            Self::Error | Self::Fatal => log::LevelFilter::Error,
        }
    }
}

/// `-p [node:]name:=value`; the value is YAML, as rcl reads it.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamRule {
    pub node: Option<String>,
    pub name: String,
    pub value: serde_yaml_ng::Value,
}

/// `-r [node:]from:=to`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RemapRule {
    pub node: Option<String>,
    pub from: String,
    pub to: String,
}

/// `--log-level [name:=]level`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LogLevelRule {
    /// `None` = the node's own logger.
    pub logger: Option<String>,
    pub severity: Severity,
}

/// The parsed `--ros-args` blocks, rules in command-line order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RosArgs {
    pub params: Vec<ParamRule>,
    pub params_files: Vec<PathBuf>,
    pub remaps: Vec<RemapRule>,
    pub log_levels: Vec<LogLevelRule>,
    pub enclave: Option<String>,
    /// `--enable-rosout-logs` / `--disable-rosout-logs`.
    pub rosout_logs: Option<bool>,
    /// `--enable-stdout-logs` / `--disable-stdout-logs`.
    pub stdout_logs: Option<bool>,
}

fn bad(arg: &str, why: impl Into<String>) -> Error {
    Error::invalid(format!("{ROS_ARGS} {arg}"), why)
}

/// Splits `[node:]left:=right`; `node` may not contain `/` (a node name).
fn rule<'a>(flag: &str, text: &'a str) -> Result<(Option<&'a str>, &'a str, &'a str)> {
    let Some((left, right)) = text.split_once(":=") else {
        return Err(bad(
            &format!("{flag} {text}"),
            "expected NAME:=VALUE (the separator is \":=\")",
        ));
    };
    // A node prefix is `node:` before the name; `:` does not occur in names.
    let (node, left) = match left.split_once(':') {
        Some((n, l)) => (Some(n), l),
        None => (None, left),
    };
    if let Some(n) = node {
        if n.is_empty() || n.contains('/') {
            return Err(bad(
                &format!("{flag} {text}"),
                format!("\"{n}\" is not a node name (a node prefix is NODE:NAME:=VALUE)"),
            ));
        }
    }
    if left.is_empty() {
        return Err(bad(
            &format!("{flag} {text}"),
            "the name before \":=\" is empty",
        ));
    }
    Ok((node, left, right))
}

/// Parses the tokens of the `--ros-args` blocks (see [`split`]).
pub fn parse(tokens: &[String]) -> Result<RosArgs> {
    let mut out = RosArgs::default();
    let mut it = tokens.iter();
    while let Some(flag) = it.next() {
        let flag = flag.as_str();
        // `--flag=value` is read like `--flag value` for the long options.
        let (flag, inline) = match flag.split_once('=') {
            Some((f, v)) if f.starts_with("--") && !v.starts_with('=') => (f, Some(v.to_string())),
            _ => (flag, None),
        };
        let mut value = |what: &str| -> Result<String> {
            match inline.clone().or_else(|| it.next().cloned()) {
                Some(v) => Ok(v),
                None => Err(bad(flag, format!("expects {what} after it"))),
            }
        };
        match flag {
            "-p" | "--param" => {
                let text = value("NAME:=VALUE")?;
                let (node, name, v) = rule(flag, &text)?;
                let value = parse_value(v).map_err(|e| bad(&format!("{flag} {text}"), e))?;
                out.params.push(ParamRule {
                    node: node.map(str::to_string),
                    name: name.to_string(),
                    value,
                });
            }
            "--params-file" => out.params_files.push(PathBuf::from(value("a YAML file")?)),
            "-r" | "--remap" => {
                let text = value("FROM:=TO")?;
                let (node, from, to) = rule(flag, &text)?;
                if to.is_empty() {
                    return Err(bad(&format!("{flag} {text}"), "the name after \":=\" is empty"));
                }
                out.remaps.push(RemapRule {
                    node: node.map(str::to_string),
                    from: from.to_string(),
                    to: to.to_string(),
                });
            }
            "--log-level" => {
                let text = value("a level (debug, info, warn, error, fatal) or NAME:=LEVEL")?;
                let (logger, level) = match text.split_once(":=") {
                    Some((n, l)) => (Some(n.to_string()), l),
                    None => (None, text.as_str()),
                };
                if logger.as_deref() == Some("") {
                    return Err(bad(&format!("{flag} {text}"), "the logger name before \":=\" is empty"));
                }
                let severity = Severity::parse(level).ok_or_else(|| {
                    bad(
                        &format!("{flag} {text}"),
                        format!("\"{level}\" is not a log level: debug, info, warn, error or fatal"),
                    )
                })?;
                out.log_levels.push(LogLevelRule { logger, severity });
            }
            "-e" | "--enclave" => out.enclave = Some(value("an enclave path")?),
            "--enable-rosout-logs" => out.rosout_logs = Some(true),
            "--disable-rosout-logs" => out.rosout_logs = Some(false),
            "--enable-stdout-logs" => out.stdout_logs = Some(true),
            "--disable-stdout-logs" => out.stdout_logs = Some(false),
            "--log-config-file" | "--log-file-name" => {
                return Err(bad(
                    flag,
                    "is not supported by this node (it logs to stderr and /rosout; set levels with --log-level)",
                ))
            }
            "--enable-external-lib-logs" | "--disable-external-lib-logs" => {
                return Err(bad(flag, "is not supported by this node (it has no external log library)"))
            }
            other => {
                return Err(bad(
                    other,
                    "is not a ROS argument: expected -p/--param, --params-file, -r/--remap, --log-level, -e/--enclave, --enable/--disable-rosout-logs or --enable/--disable-stdout-logs",
                ))
            }
        }
    }
    Ok(out)
}

/// A parameter value from the command line, read as YAML (`3` is an
/// integer, `3.0` a double, `true` a bool, `[1, 2]` an array, anything else
/// a string).
fn parse_value(text: &str) -> std::result::Result<serde_yaml_ng::Value, String> {
    if text.is_empty() {
        return Ok(serde_yaml_ng::Value::String(String::new()));
    }
    serde_yaml_ng::from_str(text).map_err(|e| format!("the value is not valid YAML: {e}"))
}

impl RosArgs {
    /// Whether a rule with node prefix `node` applies to the node called `name`.
    pub fn applies(node: &Option<String>, name: &str) -> bool {
        node.as_deref().is_none_or(|n| n == name)
    }

    /// The node's name and namespace after `__node` / `__ns` rules (the last
    /// applicable one wins, as in rcl). Rules with a node prefix apply only
    /// to the node of that (original) name.
    pub fn node_name(&self, name: &str, namespace: &str) -> Result<(String, String)> {
        let (mut n, mut ns) = (name.to_string(), namespace.to_string());
        for r in self.remaps.iter().filter(|r| Self::applies(&r.node, name)) {
            match r.from.as_str() {
                "__node" | "__name" => {
                    if r.to.contains('/') || r.to.contains('~') {
                        return Err(bad(
                            &format!("-r {}:={}", r.from, r.to),
                            "a node name has no '/' or '~'",
                        ));
                    }
                    n = r.to.clone()
                }
                "__ns" => {
                    if !r.to.starts_with('/') {
                        return Err(bad(
                            &format!("-r __ns:={}", r.to),
                            "the namespace must be absolute (start with '/')",
                        ));
                    }
                    ns = r.to.clone()
                }
                _ => {}
            }
        }
        Ok((n, ns))
    }

    /// The topic remapping rules for the node called `name` (original name),
    /// without `__node` / `__ns`.
    pub fn topic_remaps(&self, name: &str) -> Vec<(String, String)> {
        self.remaps
            .iter()
            .filter(|r| Self::applies(&r.node, name) && !r.from.starts_with("__"))
            .map(|r| (r.from.clone(), r.to.clone()))
            .collect()
    }
}

/// Fully qualified form of a topic name `name` for a node `node` in
/// `namespace`: absolute stays, `~/x` is under the node, relative is under
/// the namespace.
pub fn expand(name: &str, namespace: &str, node: &str) -> String {
    let ns = namespace.trim_end_matches('/');
    if let Some(rest) = name.strip_prefix('~') {
        let rest = rest.trim_start_matches('/');
        if rest.is_empty() {
            format!("{ns}/{node}")
        } else {
            format!("{ns}/{node}/{rest}")
        }
    } else if name.starts_with('/') {
        name.to_string()
    } else {
        format!("{ns}/{name}")
    }
}

/// Topic remapping: the first rule whose `from` names the same topic (both
/// expanded) gives the new name, expanded; else the name unchanged.
#[derive(Clone, Debug, Default)]
pub struct Remaps {
    rules: Vec<(String, String)>,
}

impl Remaps {
    /// Rules expanded for a node `node` in `namespace`.
    pub fn new(rules: &[(String, String)], namespace: &str, node: &str) -> Self {
        Self {
            rules: rules
                .iter()
                .map(|(f, t)| (expand(f, namespace, node), expand(t, namespace, node)))
                .collect(),
        }
    }

    /// The fully qualified topic name after remapping.
    pub fn apply(&self, fully_qualified: &str) -> String {
        self.rules
            .iter()
            .find(|(f, _)| f == fully_qualified)
            .map_or_else(|| fully_qualified.to_string(), |(_, t)| t.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_yaml_ng::Value;

    fn toks(s: &str) -> Vec<String> {
        s.split_whitespace().map(str::to_string).collect()
    }

    fn os(s: &str) -> Vec<OsString> {
        s.split_whitespace().map(OsString::from).collect()
    }

    #[test]
    fn blocks_are_split_from_the_programs_own_arguments() {
        let (own, ros) = split(os(
            "toolpath node --ros-args -p a:=1 -- --config c.yaml --ros-args -r x:=y",
        ))
        .unwrap();
        assert_eq!(own, os("toolpath node --config c.yaml"));
        assert_eq!(ros.unwrap(), toks("-p a:=1 -r x:=y"));
        let (own, ros) = split(os("toolpath node --config c.yaml")).unwrap();
        assert_eq!(own, os("toolpath node --config c.yaml"));
        assert!(ros.is_none());
        // An empty block is a block.
        assert_eq!(
            split(os("toolpath node --ros-args")).unwrap().1,
            Some(vec![])
        );
    }

    #[test]
    fn every_form_is_read() {
        let a = parse(&toks(
            "-p node.workers:=2 --param tp:node.verify:=false -p node.frame_id:=fixture \
             -p mill5.workpiece_origin_mm:=[1.0,2,3] --params-file a.yaml --params-file=b.yaml \
             -r __ns:=/cell_b -r __node:=tp --remap surface:=/cell/surfaces \
             --log-level debug --log-level rustdds:=WARN -e /cell/tp --disable-rosout-logs",
        ))
        .unwrap();
        assert_eq!(
            a.params,
            vec![
                ParamRule {
                    node: None,
                    name: "node.workers".into(),
                    value: Value::from(2)
                },
                ParamRule {
                    node: Some("tp".into()),
                    name: "node.verify".into(),
                    value: Value::from(false)
                },
                ParamRule {
                    node: None,
                    name: "node.frame_id".into(),
                    value: Value::from("fixture")
                },
                ParamRule {
                    node: None,
                    name: "mill5.workpiece_origin_mm".into(),
                    value: Value::Sequence(vec![Value::from(1.0), Value::from(2), Value::from(3)]),
                },
            ]
        );
        assert_eq!(
            a.params_files,
            vec![PathBuf::from("a.yaml"), PathBuf::from("b.yaml")]
        );
        assert_eq!(a.remaps.len(), 3);
        assert_eq!(
            a.node_name("toolpath_planner", "/").unwrap(),
            ("tp".into(), "/cell_b".into())
        );
        assert_eq!(
            a.topic_remaps("toolpath_planner"),
            vec![("surface".into(), "/cell/surfaces".into())]
        );
        assert_eq!(
            a.log_levels,
            vec![
                LogLevelRule {
                    logger: None,
                    severity: Severity::Debug
                },
                LogLevelRule {
                    logger: Some("rustdds".into()),
                    severity: Severity::Warn
                },
            ]
        );
        assert_eq!(a.enclave.as_deref(), Some("/cell/tp"));
        assert_eq!(a.rosout_logs, Some(false));
    }

    #[test]
    fn node_prefixed_rules_apply_to_that_node_only() {
        let a = parse(&toks(
            "-r other:__node:=x -r toolpath_planner:__ns:=/a -r other:job:=j2",
        ))
        .unwrap();
        assert_eq!(
            a.node_name("toolpath_planner", "/").unwrap(),
            ("toolpath_planner".into(), "/a".into())
        );
        assert!(a.topic_remaps("toolpath_planner").is_empty());
        assert_eq!(a.topic_remaps("other"), vec![("job".into(), "j2".into())]);
    }

    fn err(s: &str) -> String {
        parse(&toks(s)).unwrap_err().to_string()
    }

    #[test]
    fn bad_forms_name_the_argument() {
        assert_eq!(
            err("-p workers=2"),
            "invalid input: --ros-args -p workers=2: expected NAME:=VALUE (the separator is \":=\")"
        );
        assert_eq!(
            err("-p"),
            "invalid input: --ros-args -p: expects NAME:=VALUE after it"
        );
        assert!(
            err("-p :=3").contains("the name before \":=\" is empty"),
            "{}",
            err("-p :=3")
        );
        assert!(err("-r surface:=").contains("-r surface:=: the name after"));
        assert!(err("-p a/b:c:=1").contains("\"a/b\" is not a node name"));
        assert!(err("-p x:=[1,").contains("-p x:=[1,: the value is not valid YAML"));
        assert_eq!(
            err("--log-level loud"),
            "invalid input: --ros-args --log-level loud: \"loud\" is not a log level: debug, info, warn, error or fatal"
        );
        assert!(err("--params-file").contains("--params-file: expects a YAML file"));
        let e = err("-p a:=1 --frobnicate");
        assert!(
            e.starts_with("invalid input: --ros-args --frobnicate: is not a ROS argument"),
            "{e}"
        );
        assert!(err("--log-config-file f").contains("--log-config-file: is not supported"));
        // __ns must be absolute, __node a plain name.
        let a = parse(&toks("-r __ns:=cell")).unwrap();
        let e = a.node_name("n", "/").unwrap_err().to_string();
        assert!(
            e.contains("-r __ns:=cell: the namespace must be absolute"),
            "{e}"
        );
        let a = parse(&toks("-r __node:=a/b")).unwrap();
        assert!(a.node_name("n", "/").is_err());
    }

    #[test]
    fn values_are_yaml_like_rcl() {
        let v = |s: &str| parse_value(s).unwrap();
        assert_eq!(v("3"), Value::from(3));
        assert_eq!(v("3.5"), Value::from(3.5));
        assert_eq!(v("true"), Value::from(true));
        assert_eq!(v("fixture"), Value::from("fixture"));
        assert_eq!(v("'3'"), Value::from("3"));
        assert_eq!(v(""), Value::from(""));
    }

    #[test]
    fn names_expand_and_remap_like_rcl() {
        assert_eq!(expand("surface", "/cell_b", "tp"), "/cell_b/surface");
        assert_eq!(expand("surface", "/", "tp"), "/surface");
        assert_eq!(expand("/abs", "/cell_b", "tp"), "/abs");
        assert_eq!(expand("~/status", "/cell_b", "tp"), "/cell_b/tp/status");
        let r = Remaps::new(
            &[
                ("surface".into(), "shapes/surface".into()),
                ("/job".into(), "/cell/jobs".into()),
            ],
            "/cell_b",
            "tp",
        );
        assert_eq!(r.apply("/cell_b/surface"), "/cell_b/shapes/surface");
        // "/job" is absolute: the node's /cell_b/job is another topic.
        assert_eq!(r.apply("/cell_b/job"), "/cell_b/job");
        assert_eq!(r.apply("/job"), "/cell/jobs");
    }
}
