//! DDS stays on the configured interfaces. Two network namespaces joined by
//! a veth pair stand for the node's host and a LAN peer: with the default
//! config (loopback only) every UDP socket of the node is bound to
//! 127.0.0.1 and a peer on the other side of the veth can neither discover
//! the node nor get a job served; with `interfaces: [all]` it can (the
//! control that the peer would have reached it).
//!
//! Needs root and `ip` / `ss` (iproute2). The namespaces are removed when
//! the test ends; the node is stopped by pid.

use futures::StreamExt;
use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use toolpath_planner::messages::{self as msgs, convert, topics};
use toolpath_planner::ros::node::{qos, RosNode};

const BIN: &str = env!("CARGO_BIN_EXE_toolpath");
/// Set in the child test run inside the peer's namespace: the ROS domain.
const PEER_ENV: &str = "TOOLPATH_TEST_NETNS_PEER";

fn ip(args: &[&str]) {
    let out = Command::new("ip").args(args).output().unwrap();
    assert!(
        out.status.success(),
        "ip {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Namespaces `host` and `lan` joined by a veth pair (10.213.x.1 and
/// 10.213.x.2), loopback up in both; deleted on drop.
struct Net {
    host: String,
    lan: String,
}

impl Net {
    fn new(tag: u32) -> Net {
        let (host, lan) = (format!("tph{tag}"), format!("tpl{tag}"));
        let _ = Command::new("ip").args(["netns", "del", &host]).output();
        let _ = Command::new("ip").args(["netns", "del", &lan]).output();
        ip(&["netns", "add", &host]);
        let net = Net {
            host: host.clone(),
            lan: lan.clone(),
        };
        ip(&["netns", "add", &lan]);
        let (vh, vl) = (format!("vh{tag}"), format!("vl{tag}"));
        ip(&[
            "link", "add", &vh, "netns", &host, "type", "veth", "peer", "name", &vl, "netns", &lan,
        ]);
        let subnet = tag % 250;
        for (ns, dev, addr) in [
            (&host, &vh, format!("10.213.{subnet}.1/24")),
            (&lan, &vl, format!("10.213.{subnet}.2/24")),
        ] {
            ip(&["-n", ns, "addr", "add", &addr, "dev", dev]);
            ip(&["-n", ns, "link", "set", "lo", "up"]);
            ip(&["-n", ns, "link", "set", dev, "up"]);
            ip(&["-n", ns, "route", "add", "224.0.0.0/4", "dev", dev]);
        }
        net
    }
}

impl Drop for Net {
    fn drop(&mut self) {
        for ns in [&self.host, &self.lan] {
            let _ = Command::new("ip").args(["netns", "del", ns]).output();
        }
    }
}

/// `toolpath node` in namespace `ns` with `config`; killed by pid on drop.
struct NodeInNs(Child);

impl NodeInNs {
    fn start(ns: &str, config: &std::path::Path, domain: u16) -> NodeInNs {
        // `ip netns exec` execs the command: the child's pid is the node's.
        let mut child = Command::new("ip")
            .args(["netns", "exec", ns, BIN, "node", "--config"])
            .arg(config)
            .env("ROS_DOMAIN_ID", domain.to_string())
            .env("RUST_LOG", "off")
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        assert!(line.starts_with("ready"), "node did not start: {line:?}");
        NodeInNs(child)
    }

    /// Local addresses of the node's UDP sockets, from `ss` in `ns`.
    fn udp_addresses(&self, ns: &str) -> Vec<String> {
        let out = Command::new("ip")
            .args(["netns", "exec", ns, "ss", "-uanpH"])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let pid = format!("pid={},", self.0.id());
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter(|l| l.contains(&pid))
            .filter_map(|l| l.split_whitespace().nth(3).map(str::to_string))
            .collect()
    }
}

impl Drop for NodeInNs {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// What the peer in `ns` got: "no node" or the job's final state name.
fn peer(ns: &str, domain: u16) -> String {
    let exe = std::env::current_exe().unwrap();
    let out = Command::new("ip")
        .args(["netns", "exec", ns])
        .arg(exe)
        .args(["--exact", "peer_child", "--nocapture", "--test-threads=1"])
        .env(PEER_ENV, domain.to_string())
        .env("RUST_LOG", "off")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    stdout
        .lines()
        .find_map(|l| l.split_once("PEER: ").map(|(_, a)| a.trim().to_string()))
        .unwrap_or_else(|| panic!("peer printed no answer: {stdout}"))
}

#[test]
fn a_lan_peer_reaches_the_node_only_when_configured() {
    let uid = Command::new("id").arg("-u").output().unwrap().stdout;
    assert_eq!(uid, b"0\n", "network namespaces need root");
    let tag = std::process::id() % 10_000;
    let net = Net::new(tag);
    let dir = tempfile::tempdir().unwrap();
    let default = dir.path().join("default.yaml");
    std::fs::write(&default, "node:\n  name: netns_node\n").unwrap();
    let all = dir.path().join("all.yaml");
    std::fs::write(&all, "node:\n  name: netns_node\n  interfaces: [all]\n").unwrap();
    let domain = (40 + tag % 100) as u16;

    let node = NodeInNs::start(&net.host, &default, domain);
    let addrs = node.udp_addresses(&net.host);
    assert!(!addrs.is_empty(), "no sockets of the node found");
    assert!(
        addrs.iter().all(|a| a.starts_with("127.0.0.1:")),
        "a socket not on loopback: {addrs:?}"
    );
    assert_eq!(peer(&net.lan, domain), "no node");
    drop(node);

    let node = NodeInNs::start(&net.host, &all, domain);
    let addrs = node.udp_addresses(&net.host);
    assert!(addrs.iter().any(|a| a.starts_with("0.0.0.0:")), "{addrs:?}");
    assert_eq!(peer(&net.lan, domain), "SUCCEEDED");
}

/// The LAN peer (runs only inside [`peer`]): a participant on all
/// interfaces sends the plane sample and its job and prints what it gets.
#[test]
fn peer_child() {
    let Ok(domain) = std::env::var(PEER_ENV) else {
        return;
    };
    let domain: u16 = domain.parse().unwrap();
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    let answer = rt.block_on(async move {
        let mut ros = RosNode::new("lan_peer", "/", domain, None).unwrap();
        let surfaces = ros
            .publisher::<msgs::Surface>(topics::SURFACE, qos::shapes())
            .unwrap();
        let jobs = ros.publisher::<msgs::Job>(topics::JOB, qos::job()).unwrap();
        let statuses = ros
            .subscription::<msgs::JobStatus>(topics::JOB_STATUS, qos::status_reader())
            .unwrap();
        let found = tokio::time::timeout(
            Duration::from_secs(15),
            jobs.wait_for_subscription(&ros.node),
        )
        .await;
        if found.is_err() {
            return "no node".to_string();
        }
        let job = toolpath_planner::samples::job("plane").unwrap();
        let surface = job.shape.as_surface().unwrap();
        let header = msgs::Header::default();
        surfaces
            .publish(convert::surface_to_msg(
                "lan_plane",
                surface,
                header.clone(),
            ))
            .unwrap();
        jobs.publish(convert::job_to_msg(&job, "lan_plane", header))
            .unwrap();
        let mut stream = Box::pin(statuses.async_stream());
        let deadline = Instant::now() + Duration::from_secs(120);
        while let Ok(Some(Ok((s, _)))) = tokio::time::timeout(
            deadline.saturating_duration_since(Instant::now()),
            stream.next(),
        )
        .await
        {
            if s.job_id == job.job_id && s.is_final() {
                return msgs::JobStatus::state_name(s.state).to_string();
            }
        }
        "no final status".to_string()
    });
    println!("PEER: {answer}");
}
