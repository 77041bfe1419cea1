//! The workspace's layers (docs/architecture.md, "Layers"). Cargo forbids
//! cycles between crates; this test checks what Cargo cannot: that every crate
//! depends only on crates ranked below it (an upward dependency that makes no
//! cycle compiles), that the edges stay apart, and that the kernel and the
//! planning crates build without transport (no DDS, tokio, iceoryx2, OpenSSL
//! or plotting in their dependency trees). It reads `cargo metadata`.

use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::process::Command;
use std::sync::OnceLock;

/// A workspace crate's rank: a crate may depend (normally, not as a
/// dev-dependency) only on crates of a lower rank. The edges share a rank
/// but `ipc`, `plot` and `recording` use none of each other, and the node is
/// above the recording; the CLI package is above everything.
fn rank(name: &str) -> Option<u32> {
    Some(match name {
        "toolpath_kernel" | "toolpath_motion" | "toolpath_collision" | "toolpath_kinematics" => 0,
        "toolpath_formats" => 1,
        "toolpath_samples" => 2,
        "toolpath_planners" | "toolpath_simulation" | "toolpath_machines" => 3,
        "toolpath_post" => 4,
        "toolpath_pipeline" => 5,
        "toolpath_messages" => 6,
        "toolpath_ipc" | "toolpath_plot" | "toolpath_recording" => 7,
        "toolpath_node" => 8,
        "toolpath_planner" => 9,
        _ => return None,
    })
}

/// Crates that must not appear anywhere in the dependency tree of the
/// geometry and planning layers.
const TRANSPORT: [&str; 8] = [
    "rustdds",
    "ros2-client",
    "tokio",
    "iceoryx2",
    "openssl",
    "plotters",
    "mcap",
    "clap",
];

/// The layers that must build without `TRANSPORT`.
const ALGORITHMS: [&str; 11] = [
    "toolpath_kernel",
    "toolpath_kinematics",
    "toolpath_motion",
    "toolpath_collision",
    "toolpath_formats",
    "toolpath_samples",
    "toolpath_planners",
    "toolpath_simulation",
    "toolpath_machines",
    "toolpath_post",
    "toolpath_pipeline",
];

struct Metadata {
    /// Workspace crate -> its normal dependencies (names), workspace or not.
    direct: BTreeMap<String, BTreeSet<String>>,
    /// Every package (by id) -> its normal dependencies (ids), resolved.
    resolved: BTreeMap<String, Vec<String>>,
    /// Package id -> name.
    names: BTreeMap<String, String>,
    /// Workspace crate name -> package id.
    members: BTreeMap<String, String>,
}

/// The host's target triple, from `rustc -vV`.
fn host() -> String {
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let out = Command::new(rustc)
        .arg("-vV")
        .output()
        .expect("run rustc -vV");
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    text.lines()
        .find_map(|l| l.strip_prefix("host: "))
        .expect("rustc -vV names the host")
        .to_string()
}

/// `cargo metadata` once per test binary (the tests share it), resolved for
/// the host only, so that no other platform's crates are needed.
fn metadata() -> &'static Metadata {
    static MD: OnceLock<Metadata> = OnceLock::new();
    MD.get_or_init(read_metadata)
}

fn read_metadata() -> Metadata {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args([
            "metadata",
            "--format-version",
            "1",
            "--offline",
            "--filter-platform",
        ])
        .arg(host())
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run cargo metadata");
    assert!(
        out.status.success(),
        "cargo metadata failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: Value = serde_json::from_slice(&out.stdout).expect("cargo metadata is JSON");
    let ids: BTreeSet<&str> = v["workspace_members"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m.as_str().unwrap())
        .collect();
    let mut md = Metadata {
        direct: BTreeMap::new(),
        resolved: BTreeMap::new(),
        names: BTreeMap::new(),
        members: BTreeMap::new(),
    };
    for p in v["packages"].as_array().unwrap() {
        let id = p["id"].as_str().unwrap();
        let name = p["name"].as_str().unwrap().to_string();
        md.names.insert(id.to_string(), name.clone());
        if ids.contains(id) {
            md.members.insert(name.clone(), id.to_string());
            let deps = p["dependencies"]
                .as_array()
                .unwrap()
                .iter()
                .filter(|d| d["kind"].is_null())
                .map(|d| d["name"].as_str().unwrap().to_string())
                .collect();
            md.direct.insert(name, deps);
        }
    }
    for n in v["resolve"]["nodes"].as_array().unwrap() {
        let deps = n["deps"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|d| {
                d["dep_kinds"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .any(|k| k["kind"].is_null())
            })
            .map(|d| d["pkg"].as_str().unwrap().to_string())
            .collect();
        md.resolved
            .insert(n["id"].as_str().unwrap().to_string(), deps);
    }
    md
}

/// "a depends on b (rank ra <= rb)" for every workspace dependency against
/// the ranks, and edges that use each other.
fn upward(direct: &BTreeMap<String, BTreeSet<String>>) -> Vec<String> {
    let mut bad = Vec::new();
    for (a, deps) in direct {
        let Some(ra) = rank(a) else { continue };
        for b in deps {
            let Some(rb) = rank(b) else { continue };
            if rb >= ra {
                bad.push(format!("{a} (rank {ra}) depends on {b} (rank {rb})"));
            }
        }
    }
    bad
}

/// Every package in the normal dependency tree of `root`, by name.
fn tree(md: &Metadata, root: &str) -> BTreeSet<String> {
    let mut seen = BTreeSet::new();
    let mut stack = vec![md.members[root].clone()];
    let mut names = BTreeSet::new();
    while let Some(id) = stack.pop() {
        if !seen.insert(id.clone()) {
            continue;
        }
        names.insert(md.names[&id].clone());
        stack.extend(md.resolved.get(&id).into_iter().flatten().cloned());
    }
    names
}

#[test]
fn every_workspace_crate_has_a_rank() {
    let md = metadata();
    let unranked: Vec<&String> = md.members.keys().filter(|m| rank(m).is_none()).collect();
    assert!(
        unranked.is_empty(),
        "give these crates a rank in tests/layering.rs: {unranked:?}"
    );
    assert!(md.members.len() >= 14, "{:?}", md.members.keys());
}

#[test]
fn every_crate_depends_only_on_lower_layers() {
    let md = metadata();
    let bad = upward(&md.direct);
    assert!(bad.is_empty(), "upward dependencies:\n{}", bad.join("\n"));
}

#[test]
fn the_algorithms_build_without_transport() {
    let md = metadata();
    for c in ALGORITHMS {
        let t = tree(md, c);
        let found: Vec<&str> = TRANSPORT
            .iter()
            .copied()
            .filter(|x| t.contains(*x))
            .collect();
        assert!(found.is_empty(), "{c} pulls in {found:?}");
    }
    // The check sees a transport crate where there is one.
    assert!(tree(md, "toolpath_node").contains("rustdds"));
}

#[test]
fn the_rank_check_reports_upward_and_sideways_dependencies() {
    let direct: BTreeMap<String, BTreeSet<String>> = [
        (
            "toolpath_recording",
            &["toolpath_node", "toolpath_messages"][..],
        ),
        ("toolpath_plot", &["toolpath_ipc"][..]),
        ("toolpath_planners", &["toolpath_machines", "nalgebra"][..]),
        ("toolpath_kernel", &["toolpath_formats"][..]),
        (
            "toolpath_node",
            &["toolpath_recording", "toolpath_kernel"][..],
        ),
    ]
    .into_iter()
    .map(|(a, b)| (a.to_string(), b.iter().map(|s| s.to_string()).collect()))
    .collect();
    assert_eq!(
        upward(&direct),
        vec![
            "toolpath_kernel (rank 0) depends on toolpath_formats (rank 1)",
            "toolpath_planners (rank 3) depends on toolpath_machines (rank 3)",
            "toolpath_plot (rank 7) depends on toolpath_ipc (rank 7)",
            "toolpath_recording (rank 7) depends on toolpath_node (rank 8)",
        ]
    );
}
