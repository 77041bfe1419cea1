//! The layering is visible in src/: the algorithms (geometry, tools, formats,
//! samples, planners, simulation, machines) never reach the edges (cli, ros,
//! recording, ipc, plot), and every layer uses only the layers below it.

use std::path::{Path, PathBuf};

/// Layer rank of a top-level module (lib.rs order); same rank may use each other.
fn rank(module: &str) -> Option<u32> {
    Some(match module {
        "error" | "parallel" => 0,
        "geometry" | "tools" => 1,
        "formats" | "samples" => 2,
        "planners" => 3,
        "simulation" => 4,
        "machines" => 5,
        "pipeline" | "post" => 6,
        "cli" | "ros" | "recording" | "ipc" | "plot" => 7,
        _ => return None,
    })
}

const EDGES: [&str; 5] = ["cli", "ros", "recording", "ipc", "plot"];
const ALGORITHMS: [&str; 7] = [
    "geometry",
    "tools",
    "formats",
    "samples",
    "planners",
    "simulation",
    "machines",
];

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

/// (file, module of the file, referenced module) for every crate:: reference.
fn references() -> Vec<(PathBuf, String, String)> {
    let mut out = Vec::new();
    let mut files = Vec::new();
    rust_files(&src(), &mut files);
    for f in files {
        let rel = f.strip_prefix(src()).unwrap();
        let first = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy()
            .to_string();
        let module = first.trim_end_matches(".rs").to_string();
        let text = std::fs::read_to_string(&f).unwrap();
        for r in crate_refs(&text) {
            out.push((f.clone(), module.clone(), r));
        }
    }
    out
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
    let refs = references();
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
    let bad: Vec<_> = references()
        .into_iter()
        .filter_map(|(f, m, r)| {
            let (rm, rr) = (rank(&m)?, rank(&r)?);
            (rr > rm).then(|| format!("{} (layer {m}) uses crate::{r}", f.display()))
        })
        .collect();
    assert!(bad.is_empty(), "upward dependencies:\n{}", bad.join("\n"));
}
