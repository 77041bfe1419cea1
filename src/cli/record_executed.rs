//! `toolpath record JOB -o BAG --fake-execute`: a bag of an executed run.
//! The node runs as a child process on a private ROS domain (loopback) with
//! recording into BAG; this process serves the job's machine a fake
//! FollowJointTrajectory controller (`ros::fake_controller`, 100 times
//! faster than real time), publishes the shape and the job with
//! `execute = 1`, and waits for its final status. The bag is the node's own
//! recording: inputs, outputs, and the RUNNING statuses of every executed
//! pass.

use super::demo::{demo_domain, start_node_with};
use futures::StreamExt;
use std::net::{IpAddr, Ipv4Addr};
use std::path::Path;
use std::time::Duration;
use toolpath_formats::{Job, Machine, Shape};
use toolpath_kernel::error::{Error, Result};
use toolpath_machines::Machines;
use toolpath_messages::{self as msgs, convert, topics};
use toolpath_node::fake_controller::{self, Behaviour, FakeOptions};
use toolpath_node::node::{qos, RosNode};

/// How long the job may take, planning and execution.
const JOB_TIMEOUT: Duration = Duration::from_secs(600);

/// Wall seconds per trajectory second of the fake controller.
const TIME_SCALE: f64 = 0.01;

/// The node's config: recording into `bag` (its parent and name).
fn config_text(bag: &Path) -> Result<String> {
    let name = bag
        .file_name()
        .and_then(|n| n.to_str())
        .ok_or_else(|| Error::invalid("output", "must name a bag directory"))?;
    let parent = match bag.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    std::fs::create_dir_all(&parent).map_err(|e| Error::io(parent.display().to_string(), e))?;
    let parent =
        std::fs::canonicalize(&parent).map_err(|e| Error::io(parent.display().to_string(), e))?;
    let quote = |s: &str| s.replace('\\', "\\\\").replace('"', "\\\"");
    Ok(format!(
        "# Written by `toolpath record --fake-execute`.\n\
         recording:\n  enabled: true\n  directory: \"{}\"\n  bag_name: \"{}\"\n",
        quote(&parent.display().to_string()),
        quote(name)
    ))
}

/// The fake controller of `machine` with the default machines' joints,
/// limits and home pose, at the action the node calls by default.
fn fake_options(machine: Machine) -> FakeOptions {
    let m = Machines::default();
    let axes = m.axes(machine);
    FakeOptions {
        action: axes.controller.action(machine.name()),
        joint_names: axes.joint_names,
        limits: axes.limits,
        start: axes.home,
        behaviour: Behaviour {
            time_scale: TIME_SCALE,
            ..Default::default()
        },
    }
}

/// Runs `job` through a node that records into `bag` and executes on a fake
/// controller; the job's final status and the number of goals the
/// controller received.
pub fn record(job: &Job, bag: &Path) -> Result<(msgs::JobStatus, usize)> {
    if bag.exists() {
        return Err(Error::invalid(
            "output",
            format!("{} exists: remove it or choose another", bag.display()),
        ));
    }
    let work = std::env::temp_dir().join(format!("toolpath_record_{}", std::process::id()));
    std::fs::create_dir_all(&work).map_err(|e| Error::io(work.display().to_string(), e))?;
    let config = work.join("node.yaml");
    let written = config_text(bag).and_then(|t| {
        std::fs::write(&config, t).map_err(|e| Error::io(config.display().to_string(), e))
    });
    let result = written.and_then(|()| run(job, &config));
    let _ = std::fs::remove_dir_all(&work);
    result
}

fn run(job: &Job, config: &Path) -> Result<(msgs::JobStatus, usize)> {
    let domain = demo_domain();
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| Error::planning(format!("cannot start the async runtime: {e}")))?;
    let lo = Some(vec![IpAddr::V4(Ipv4Addr::LOCALHOST)]);
    // `cell` serves the fake controller until the node has stopped.
    let (cell, fake) = runtime.block_on(async {
        let mut cell = RosNode::new("fake_controller", "/", domain, lo.clone())?;
        let fake = fake_controller::spawn(&mut cell, fake_options(job.machine))?;
        Ok::<_, Error>((cell, fake))
    })?;
    let log = std::env::var("RUST_LOG").unwrap_or_else(|_| "off".into());
    let (mut node, _) = start_node_with(domain, Some(config), &log, false)?;
    let last = runtime.block_on(send_and_wait(job, domain));
    // SIGTERM: the node writes the bag's summary and metadata.yaml.
    node.stop(Duration::from_secs(30));
    let goals = fake.goals().len();
    drop((fake, cell));
    drop(runtime);
    last.map(|s| (s, goals))
}

/// Publishes the job's shape and the job (executing), and returns its final status.
async fn send_and_wait(job: &Job, domain: u16) -> Result<msgs::JobStatus> {
    let lo = Some(vec![IpAddr::V4(Ipv4Addr::LOCALHOST)]);
    let mut ros = RosNode::new("toolpath_record", "/", domain, lo)?;
    let surface_pub = ros.publisher::<msgs::Surface>(topics::SURFACE, qos::shapes())?;
    let pocket_pub = ros.publisher::<msgs::Pocket>(topics::POCKET, qos::shapes())?;
    let job_pub = ros.publisher::<msgs::Job>(topics::JOB, qos::job())?;
    let status_sub = ros.subscription::<msgs::JobStatus>(topics::JOB_STATUS, qos::status())?;
    tokio::time::timeout(
        Duration::from_secs(30),
        job_pub.wait_for_subscription(&ros.node),
    )
    .await
    .map_err(|_| Error::planning("the node's job subscription was not discovered within 30 s"))?;
    // The node's action client discovers the fake controller meanwhile.
    tokio::time::sleep(Duration::from_secs(2)).await;
    let header = || msgs::Header {
        stamp: msgs::Time::now(),
        frame_id: "workpiece".into(),
    };
    let shape_id = format!("{}_shape", job.job_id);
    let published = match &job.shape {
        Shape::Surface(s) => surface_pub
            .publish(convert::surface_to_msg(&shape_id, s, header()))
            .is_ok(),
        Shape::Pocket(p) => pocket_pub
            .publish(convert::pocket_to_msg(&shape_id, p, header()))
            .is_ok(),
    };
    if !published {
        return Err(Error::planning("cannot publish the job's shape"));
    }
    let mut msg = convert::job_to_msg(job, &shape_id, header());
    msg.execute = msgs::Job::EXECUTE;
    job_pub
        .publish(msg)
        .map_err(|_| Error::planning("cannot publish the job"))?;
    let mut statuses = Box::pin(status_sub.async_stream());
    let deadline = tokio::time::Instant::now() + JOB_TIMEOUT;
    loop {
        let next = tokio::time::timeout_at(deadline, statuses.next())
            .await
            .map_err(|_| {
                Error::planning(format!(
                    "job {} has no final status within {} s",
                    job.job_id,
                    JOB_TIMEOUT.as_secs()
                ))
            })?;
        match next {
            Some(Ok((s, _))) if s.job_id == job.job_id && s.is_final() => return Ok(s),
            Some(_) => {}
            None => return Err(Error::planning("the status subscription ended")),
        }
    }
}
