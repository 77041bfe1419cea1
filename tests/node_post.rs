//! The node's optional NC output (`post:` in the launch config): with it on,
//! every mill5 job leaves `<job_id>.<extension>` in the configured directory,
//! byte for byte the program `toolpath plan` + `toolpath post` give for the
//! same job; a belt job leaves none. The node runs on loopback on a domain
//! of its own and is stopped by pid.

#[path = "common/node_process.rs"]
mod node_process;

use node_process::NodeProcess;
use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_toolpath");

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

fn run(args: &[&str], domain: Option<u16>) {
    let mut cmd = Command::new(BIN);
    cmd.args(args);
    if let Some(d) = domain {
        cmd.env("ROS_DOMAIN_ID", d.to_string());
    }
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "toolpath {args:?}: {}\n{}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn the_node_writes_a_program_per_mill5_job() {
    let dir = tempfile::tempdir().unwrap();
    let nc = dir.path().join("nc");
    let config = dir.path().join("node.yaml");
    std::fs::write(
        &config,
        format!(
            "post:\n  enabled: true\n  format: heidenhain-tcpm\n  directory: \"{}\"\n",
            nc.display()
        ),
    )
    .unwrap();
    let domain = (170 + std::process::id() % 25) as u16;
    let (node, line) = NodeProcess::spawn(&config, domain);
    assert!(line.starts_with("ready"), "node did not start: {line:?}");
    for bag in ["iso_parametric_plane", "belt_iso_planar_sine_wave"] {
        let bag = repo("bags").join(bag);
        run(
            &[
                "replay",
                bag.to_str().unwrap(),
                "--publish",
                "--check",
                "--timeout-s",
                "300",
            ],
            Some(domain),
        );
    }
    drop(node);
    let mut files: Vec<String> = std::fs::read_dir(&nc)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    assert_eq!(files, ["iso_parametric_plane.h"]);
    let job = repo("bags/jobs/iso_parametric_plane.json");
    let result = dir.path().join("result.json");
    let local = dir.path().join("local.h");
    run(
        &[
            "plan",
            job.to_str().unwrap(),
            "--no-verify",
            "-o",
            result.to_str().unwrap(),
        ],
        None,
    );
    run(
        &[
            "post",
            result.to_str().unwrap(),
            "--job",
            job.to_str().unwrap(),
            "--format",
            "heidenhain-tcpm",
            "-o",
            local.to_str().unwrap(),
        ],
        None,
    );
    let from_node = std::fs::read_to_string(nc.join("iso_parametric_plane.h")).unwrap();
    assert!(from_node.starts_with("0 BEGIN PGM ISO_PARAMETRIC_PLANE MM\n"));
    assert_eq!(from_node, std::fs::read_to_string(&local).unwrap());
}
