//! `toolpath node` as a child process for the node tests: started on a
//! domain of its own with a launch config, killed by pid when dropped.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};

/// A fresh ROS domain in 1..=230 for one node test: random per run and
/// process, so concurrent runs in other checkouts stay apart; `salt` keeps
/// the nodes of one test binary apart (the random base is drawn once per
/// process, so two salts never share a domain). (Not every test binary uses it.)
#[allow(dead_code)]
pub fn fresh_domain(salt: u32) -> u16 {
    static BASE: std::sync::OnceLock<u32> = std::sync::OnceLock::new();
    let base = *BASE.get_or_init(|| {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.subsec_nanos());
        nanos ^ std::process::id().wrapping_mul(7919)
    });
    (1 + base.wrapping_add(salt) % 230) as u16
}

pub struct NodeProcess {
    pub child: Child,
}

impl NodeProcess {
    /// `toolpath node --config CONFIG` on `domain`, and its first stdout
    /// line (the ready line).
    #[allow(dead_code)]
    pub fn spawn(config: &Path, domain: u16) -> (NodeProcess, String) {
        let mut command = Command::new(env!("CARGO_BIN_EXE_toolpath"));
        command
            .args(["node", "--config", config.to_str().unwrap()])
            .env("ROS_DOMAIN_ID", domain.to_string())
            .env("RUST_LOG", "off");
        Self::start(command)
    }

    /// Starts `command` (a `toolpath node` command line) with stdout piped
    /// and stderr dropped; the process and its first stdout line.
    #[allow(dead_code)]
    pub fn start(mut command: Command) -> (NodeProcess, String) {
        let mut child = command
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        (NodeProcess { child }, line)
    }
}

impl Drop for NodeProcess {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
