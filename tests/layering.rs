//! The layering is visible in src/: the algorithms (geometry, tools, formats,
//! samples, planners, simulation, machines, post) never reach the edges (cli,
//! ros, recording, ipc, plot), every layer uses only the layers below it, and
//! the edges are ranked among themselves so that no two of them can import
//! each other (the node records, so `ros` may use `recording`, never the
//! reverse).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Layer rank of a top-level module (lib.rs order). Modules of one rank may
/// use each other, except the edges: an edge uses only lower ranks.
fn rank(module: &str) -> Option<u32> {
    Some(match module {
        "error" | "parallel" => 0,
        "geometry" | "tools" => 1,
        "formats" | "samples" => 2,
        "planners" => 3,
        "simulation" => 4,
        "machines" => 5,
        // NC post-processors: from machines' joint trajectories to NC code.
        "pipeline" | "post" => 6,
        // The node's messages, shared by the node and the bags.
        "messages" => 7,
        "ipc" | "plot" | "recording" => 8,
        "ros" => 9,
        "cli" => 10,
        _ => return None,
    })
}

const EDGES: [&str; 5] = ["cli", "ros", "recording", "ipc", "plot"];
const ALGORITHMS: [&str; 8] = [
    "geometry",
    "tools",
    "formats",
    "samples",
    "planners",
    "simulation",
    "machines",
    "post",
];

/// Whether module `from` may refer to module `to` (both ranked).
fn may_use(from: &str, to: &str) -> bool {
    match (rank(from), rank(to)) {
        (Some(f), Some(t)) => t < f || (t == f && (from == to || !EDGES.contains(&from))),
        _ => true,
    }
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<_> = entries.flatten().map(|e| e.path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// Top-level crate modules a source text refers to as `crate::NAME` (also
/// inside `use crate::{a, b::c}` groups), comments stripped.
fn crate_refs(text: &str) -> Vec<String> {
    let mut code = String::new();
    for line in text.lines() {
        let line = match line.find("//") {
            Some(k) => &line[..k],
            None => line,
        };
        code.push_str(line);
        code.push('\n');
    }
    let mut refs = Vec::new();
    let mut rest = code.as_str();
    while let Some(k) = rest.find("crate::") {
        let after = &rest[k + "crate::".len()..];
        if let Some(group) = after.strip_prefix('{') {
            // Top-level names of a group: split at commas outside nested braces.
            let mut depth = 0;
            let mut item = String::new();
            for c in group.chars() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        refs.push(item.trim().split("::").next().unwrap_or("").to_string());
                        item.clear();
                        continue;
                    }
                    _ => {}
                }
                if depth == 0 {
                    item.push(c);
                }
            }
            refs.push(item.trim().split("::").next().unwrap_or("").to_string());
        } else {
            let name: String = after
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            refs.push(name);
        }
        rest = after;
    }
    refs.retain(|r| !r.is_empty());
    refs
}

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// The top-level module a source file under src/ belongs to (`ros` for
/// `ros/node.rs`, `pipeline` for `pipeline.rs`).
fn module_of(rel: &Path) -> String {
    let first = rel
        .components()
        .next()
        .unwrap()
        .as_os_str()
        .to_string_lossy()
        .to_string();
    first.trim_end_matches(".rs").to_string()
}

/// (file, module of the file, referenced module) for every crate:: reference
/// in `sources` (paths relative to src/, with their text).
fn references_in(sources: &[(PathBuf, String)]) -> Vec<(PathBuf, String, String)> {
    let mut out = Vec::new();
    for (rel, text) in sources {
        let module = module_of(rel);
        for r in crate_refs(text) {
            out.push((rel.clone(), module.clone(), r));
        }
    }
    out
}

/// Every .rs file under src/ (relative path, text).
fn sources() -> Vec<(PathBuf, String)> {
    let mut files = Vec::new();
    rust_files(&src(), &mut files);
    files
        .into_iter()
        .map(|f| {
            let text = std::fs::read_to_string(&f).unwrap();
            (f.strip_prefix(src()).unwrap().to_path_buf(), text)
        })
        .collect()
}

/// "file (layer m) uses crate::r" for every reference against the ranks.
fn upward_uses(refs: &[(PathBuf, String, String)]) -> Vec<String> {
    refs.iter()
        .filter(|(_, m, r)| !may_use(m, r))
        .map(|(f, m, r)| format!("{} (layer {m}) uses crate::{r}", f.display()))
        .collect()
}

#[test]
fn the_scanner_finds_grouped_and_plain_references() {
    let text = "use crate::geometry::NurbsSurface;\n// crate::ros is only mentioned\nuse crate::{formats::{Job, Shape}, ros, tools::Tool};\nlet x = crate::plot::draw();";
    assert_eq!(
        crate_refs(text),
        vec!["geometry", "formats", "ros", "tools", "plot"]
    );
}

#[test]
fn algorithms_never_reach_the_edges() {
    let refs = references_in(&sources());
    assert!(refs.iter().any(|(_, m, _)| m == "geometry"), "scanned src/");
    let bad: Vec<_> = refs
        .iter()
        .filter(|(_, m, r)| ALGORITHMS.contains(&m.as_str()) && EDGES.contains(&r.as_str()))
        .map(|(f, _, r)| format!("{} uses crate::{r}", f.display()))
        .collect();
    assert!(bad.is_empty(), "layering violations:\n{}", bad.join("\n"));
}

#[test]
fn every_layer_uses_only_layers_below_it() {
    let bad = upward_uses(&references_in(&sources()));
    assert!(bad.is_empty(), "upward dependencies:\n{}", bad.join("\n"));
}

#[test]
fn every_top_level_module_has_a_rank() {
    let unranked: BTreeSet<String> = sources()
        .iter()
        .map(|(rel, _)| module_of(rel))
        .filter(|m| m != "lib" && m != "main" && rank(m).is_none())
        .collect();
    assert!(
        unranked.is_empty(),
        "give these modules a rank in tests/layering.rs: {unranked:?}"
    );
}

/// The rank check on made-up sources: an edge importing a higher edge, or an
/// edge of its own rank, is reported; the allowed directions are not.
#[test]
fn the_rank_check_reports_an_edge_importing_a_higher_edge() {
    let source = |path: &str, text: &str| (PathBuf::from(path), text.to_string());
    let bad = upward_uses(&references_in(&[
        source(
            "recording/runs.rs",
            "use crate::messages::topics;\nuse crate::ros::node::{qos, RosNode};\n",
        ),
        source("recording/mod.rs", "pub fn f() { crate::plot::draw(); }\n"),
        source(
            "messages/convert.rs",
            "use crate::{formats::Job, recording::runs};\n",
        ),
        source("ipc/mod.rs", "use crate::cli;\n"),
        source("post/mod.rs", "use crate::messages::Toolpath;\n"),
    ]));
    assert_eq!(
        bad,
        vec![
            "recording/runs.rs (layer recording) uses crate::ros",
            "recording/mod.rs (layer recording) uses crate::plot",
            "messages/convert.rs (layer messages) uses crate::recording",
            "ipc/mod.rs (layer ipc) uses crate::cli",
            "post/mod.rs (layer post) uses crate::messages",
        ]
    );
    let fine = upward_uses(&references_in(&[
        source(
            "ros/recorder.rs",
            "use crate::recording::{runs, BagWriter};\nuse crate::ipc::SERVICE_NAME;\n",
        ),
        source("ros/node.rs", "use crate::ros::config::NodeConfig;\n"),
        source(
            "recording/runs.rs",
            "use crate::{messages, pipeline, recording::Bag};\n",
        ),
        source(
            "messages/outputs.rs",
            "use crate::{formats::Job, machines, pipeline};\n",
        ),
        source(
            "post/mod.rs",
            "use crate::{formats::Job, machines::JointTrajectory};\n",
        ),
        source(
            "cli/replay.rs",
            "use crate::{plot, recording::runs, ros::republish};\n",
        ),
        source("geometry/nurbs.rs", "use crate::tools::Tool;\n"),
    ]));
    assert!(fine.is_empty(), "{fine:?}");
}
