//! The node with DDS Security (SROS2 conventions, `--features security`):
//! keystores made at test time by tests/sros2/make_keystore.sh (plain
//! openssl) in temporary directories. With ROS_SECURITY_STRATEGY=Enforce and
//! `--ros-args --enclave /toolpath_planner`, a client with its own enclave
//! of the same keystore is served; an unsecured participant and one whose
//! enclave comes from another keystore (its own CAs, the same enclave name)
//! get no job served, no status and no toolpath, not even the
//! transient-local history. A permissions document changed by one byte, or
//! an enclave the keystore does not have, stops the node before it is
//! ready with an error naming the file or the enclave. Loopback only, a
//! random domain, nodes killed by pid.

#[path = "common/node_client.rs"]
mod node_client;
#[path = "common/node_process.rs"]
mod node_process;

use futures::StreamExt;
use node_client::{next_status_of, NodeClient};
use node_process::NodeProcess;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use toolpath_planner::formats::Shape;
use toolpath_planner::messages::{self as msgs, convert, topics};
use toolpath_planner::ros::node::qos;
use toolpath_planner::samples;

const NODE_ENCLAVE: &str = "/toolpath_planner";
const CLIENT_ENCLAVE: &str = "/cell/client";

/// Runs tests/sros2/make_keystore.sh with `args`, for `domain`.
fn make_keystore(domain: u16, args: &[&str]) {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/sros2/make_keystore.sh");
    let out = Command::new("bash")
        .arg(script)
        .args(args)
        .env("ROS_DOMAIN_ID", domain.to_string())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "make_keystore.sh {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A keystore in `dir` with the node's and the client's enclaves.
fn keystore(dir: &Path, domain: u16) -> PathBuf {
    let ks = dir.join("keystore");
    let s = ks.to_str().unwrap();
    make_keystore(domain, &["create_keystore", s]);
    make_keystore(domain, &["create_enclave", s, NODE_ENCLAVE]);
    make_keystore(domain, &["create_enclave", s, CLIENT_ENCLAVE]);
    ks
}

fn enclave_dir(keystore: &Path, enclave: &str) -> PathBuf {
    keystore
        .join("enclaves")
        .join(enclave.trim_start_matches('/'))
}

/// `toolpath node` with the SROS2 variables for `keystore` under
/// `strategy` and `--ros-args --enclave ENCLAVE`.
fn node_command(
    config: &Path,
    domain: u16,
    keystore: &Path,
    strategy: &str,
    enclave: &str,
) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_toolpath"));
    c.args(["node", "--config", config.to_str().unwrap()])
        .args(["--ros-args", "--enclave", enclave])
        .env("ROS_DOMAIN_ID", domain.to_string())
        .env("ROS_SECURITY_ENABLE", "true")
        .env("ROS_SECURITY_STRATEGY", strategy)
        .env("ROS_SECURITY_KEYSTORE", keystore)
        .env("RUST_LOG", "off")
        .env_remove("ROS_SECURITY_ENCLAVE_OVERRIDE");
    c
}

fn config(dir: &Path) -> PathBuf {
    let config = dir.join("node.yaml");
    std::fs::write(&config, "node:\n  verify: false\n").unwrap();
    config
}

/// Runs a node that must not start: its exit code and stderr, within 30 s.
fn failed_start(mut c: Command) -> (i32, String) {
    let mut child = c
        .env("RUST_LOG", "error")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(30);
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("the node did not stop within 30 s");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let (mut out, mut err) = (String::new(), String::new());
    child
        .stdout
        .take()
        .unwrap()
        .read_to_string(&mut out)
        .unwrap();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    assert!(!out.contains("ready"), "the node got ready: {out}");
    (status.code().unwrap_or(-1), err)
}

#[test]
fn an_authorised_client_is_served_and_others_get_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = node_process::fresh_domain(0);
    let ks = keystore(dir.path(), d);
    // An attacker's keystore: valid DDS Security files, the same enclave
    // name, but its own identity and permissions CAs.
    let foreign = dir.path().join("foreign");
    std::fs::create_dir(&foreign).unwrap();
    let foreign_ks = keystore(&foreign, d);

    let config = config(dir.path());
    let (_node, ready) = NodeProcess::start(node_command(&config, d, &ks, "Enforce", NODE_ENCLAVE));
    assert!(
        ready.starts_with("ready") && ready.contains("DDS Security enclave"),
        "node said {ready:?}"
    );

    let job = samples::job("plane").unwrap();
    let Shape::Surface(surface) = &job.shape else {
        panic!("plane is a surface job")
    };
    let surface_msg = convert::surface_to_msg("plane_shape", surface, msgs::Header::default());
    let job_msg = |id: &str| {
        let mut m = convert::job_to_msg(&job, "plane_shape", msgs::Header::default());
        m.job_id = id.into();
        m
    };

    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let started = Instant::now();
        let mut client =
            NodeClient::connect_secured("cell_client", d, Some(&enclave_dir(&ks, CLIENT_ENCLAVE)))
                .await;
        let discovered = started.elapsed();
        let toolpaths = client
            .ros
            .subscription::<msgs::Toolpath>(topics::TOOLPATH, qos::results())
            .unwrap();
        let mut toolpaths = Box::pin(toolpaths.async_stream());
        client.surfaces.publish(surface_msg.clone()).unwrap();
        client.jobs.publish(job_msg("authorised")).unwrap();
        let mut statuses = Box::pin(client.status.async_stream());
        let deadline = Instant::now() + Duration::from_secs(60);
        let st = loop {
            let st = next_status_of(&mut statuses, "authorised", deadline).await;
            if st.is_final() {
                break st;
            }
        };
        assert_eq!(st.state, msgs::JobStatus::SUCCEEDED, "{}", st.message);
        let (tp, _) = tokio::time::timeout(Duration::from_secs(10), toolpaths.next())
            .await
            .expect("the authorised client got no toolpath")
            .unwrap()
            .unwrap();
        assert_eq!(tp.job_id, "authorised");
        assert!(!tp.passes.is_empty());

        // The outsiders publish the surface and a job each and read the
        // outputs (transient-local: a matched reader would get the history
        // of the authorised job at once).
        let mut outsiders = Vec::new();
        for (name, dir) in [
            ("unsecured_client", None),
            (
                "foreign_client",
                Some(enclave_dir(&foreign_ks, CLIENT_ENCLAVE)),
            ),
        ] {
            let mut c = NodeClient::unconnected(name, d, dir.as_deref());
            let toolpaths = c
                .ros
                .subscription::<msgs::Toolpath>(topics::TOOLPATH, qos::results())
                .unwrap();
            c.surfaces.publish(surface_msg.clone()).unwrap();
            c.jobs.publish(job_msg(name)).unwrap();
            outsiders.push((name, c, toolpaths));
        }
        // Several times the authorised client's discovery and handshake.
        let wait = (discovered * 3).max(Duration::from_secs(5));
        tokio::time::sleep(wait).await;
        for (name, c, toolpaths) in &outsiders {
            assert!(
                c.status.take().unwrap().is_none(),
                "{name} read a job status"
            );
            assert!(
                toolpaths.take().unwrap().is_none(),
                "{name} read a toolpath"
            );
        }

        // The node still serves the authorised client, and never saw the
        // outsiders' jobs: no status of theirs came before this job's end.
        client.jobs.publish(job_msg("after")).unwrap();
        let deadline = Instant::now() + Duration::from_secs(60);
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let (st, _) = tokio::time::timeout(left, statuses.next())
                .await
                .expect("no final status of after")
                .unwrap()
                .unwrap();
            assert!(
                st.job_id == "after" || st.job_id == "authorised",
                "the node served {}: {}",
                st.job_id,
                st.message
            );
            if st.job_id == "after" && st.is_final() {
                assert_eq!(st.state, msgs::JobStatus::SUCCEEDED, "{}", st.message);
                break;
            }
        }
        for (name, c, toolpaths) in &outsiders {
            assert!(
                c.status.take().unwrap().is_none(),
                "{name} read a job status"
            );
            assert!(
                toolpaths.take().unwrap().is_none(),
                "{name} read a toolpath"
            );
        }
    });
}

#[test]
fn a_permissions_file_changed_by_one_byte_stops_the_node() {
    let dir = tempfile::tempdir().unwrap();
    let d = node_process::fresh_domain(1);
    let ks = keystore(dir.path(), d);
    let node_dir = enclave_dir(&ks, NODE_ENCLAVE);
    let permissions = node_dir.join("permissions.p7s");
    let mut bytes = std::fs::read(&permissions).unwrap();
    // The signed text grants everything to CN=/toolpath_planner; one byte
    // more in the domain range would be a grant nobody signed.
    let at = bytes
        .windows(5)
        .position(|w| w == b"</id>")
        .expect("a domain id in the permissions")
        - 1;
    bytes[at] = if bytes[at] == b'9' { b'8' } else { b'9' };
    std::fs::write(&permissions, &bytes).unwrap();

    let config = config(dir.path());
    let (code, err) = failed_start(node_command(&config, d, &ks, "Enforce", NODE_ENCLAVE));
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains(&format!("{}", permissions.display()))
            && err.contains("the signature does not verify against permissions_ca.cert.pem"),
        "{err}"
    );
    // Under the permissive strategy too: a file that is there but does not
    // verify is tampering, not a missing keystore.
    let (code, err) = failed_start(node_command(&config, d, &ks, "Permissive", NODE_ENCLAVE));
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("permissions.p7s"), "{err}");

    // RustDDS refuses the file as well, without the node's own check.
    let files = rustdds::DomainParticipantSecurityConfigFiles::with_ros_default_names(
        &node_dir,
        String::new(),
    );
    let refused = rustdds::DomainParticipantBuilder::new(d)
        .with_only_networks([std::net::Ipv4Addr::LOCALHOST])
        .builtin_security(files)
        .build();
    assert!(refused.is_err(), "RustDDS accepted the changed permissions");
}

#[test]
fn an_enclave_the_keystore_lacks_stops_the_node() {
    let dir = tempfile::tempdir().unwrap();
    let d = node_process::fresh_domain(2);
    let ks = keystore(dir.path(), d);
    let config = config(dir.path());
    let (code, err) = failed_start(node_command(&config, d, &ks, "Enforce", "/no_such_node"));
    assert_eq!(code, 2, "{err}");
    let missing = enclave_dir(&ks, "/no_such_node");
    assert!(
        err.contains("--enclave /no_such_node")
            && err.contains(&format!("{} is not a directory", missing.display())),
        "{err}"
    );
    // A relative enclave path is not one.
    let (code, err) = failed_start(node_command(&config, d, &ks, "Enforce", "toolpath_planner"));
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("must be absolute"), "{err}");
    // Not enforced: the node starts, unsecured.
    let (node, ready) =
        NodeProcess::start(node_command(&config, d, &ks, "Permissive", "/no_such_node"));
    drop(node);
    assert!(
        ready.starts_with("ready") && !ready.contains("DDS Security"),
        "node said {ready:?}"
    );
}
