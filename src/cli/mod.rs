//! The `toolpath` command line. One module per subcommand; this file only
//! parses arguments and maps errors to exit codes (2 for bad input).

pub mod bench_node;
mod compare;
mod compare_milling;
mod compare_mpec;
mod compare_pocket;
mod compare_suite;
mod demo;
mod import;
mod inspect;
mod ipc_publish;
mod node;
mod plan;
mod plot;
mod post;
mod progress;
mod record;
mod record_executed;
mod replay;
mod sample;
mod simulate;
mod table;
mod verify;

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use toolpath_kernel::error::Error;

#[derive(Parser, Debug)]
#[command(
    name = "toolpath",
    version,
    about = "Plans CNC toolpaths and tool-pose trajectories on freeform surfaces"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Plan a job file and write the result as JSON.
    Plan {
        /// Job file (JSON).
        job: PathBuf,
        /// Result file ("-" for stdout).
        #[arg(short, long, default_value = "-")]
        output: PathBuf,
        /// Skip the simulator check (max_scallop_mm is then null).
        #[arg(long)]
        no_verify: bool,
        /// Write compute_ms as 0 so repeated runs give identical bytes.
        #[arg(long)]
        no_timing: bool,
        /// Stop planning after this many seconds (exit code 5); the job's
        /// own time_limit_s also applies, the shorter stops it.
        #[arg(long, value_name = "S")]
        time_limit: Option<f64>,
        /// Refuse, before planning, a job estimated to need more passes.
        #[arg(long, value_name = "N", default_value_t = toolpath_pipeline::Budget::DEFAULT.max_passes)]
        max_passes: f64,
        /// Refuse, before planning, a job estimated to need more toolpath points.
        #[arg(long, value_name = "N", default_value_t = toolpath_pipeline::Budget::DEFAULT.max_points)]
        max_points: f64,
        /// Refuse, before planning, a job estimated to need more memory (MB).
        #[arg(long, value_name = "MB", default_value_t = toolpath_pipeline::Budget::DEFAULT.max_memory_mb)]
        max_memory_mb: f64,
    },
    /// List the faces of a STEP file, or write chosen faces as trimmed surfaces (JSON).
    Import {
        /// STEP file (AP203/AP214/AP242, Part 21).
        step: PathBuf,
        /// List the faces: STEP entity id, surface type, area (mm²), bounding box (mm).
        #[arg(long)]
        list: bool,
        /// Entity id of a face to write (repeat for several: a JSON array).
        #[arg(long = "face", value_name = "ID")]
        faces: Vec<u64>,
        /// Output file ("-" for stdout).
        #[arg(short, long, default_value = "-")]
        output: PathBuf,
    },
    /// Print the differential geometry of a surface at (u, v) as JSON.
    Inspect {
        /// Surface file (JSON).
        surface: PathBuf,
        /// Parameter values.
        #[arg(long, num_args = 2, value_names = ["U", "V"], allow_negative_numbers = true, required = true)]
        uv: Vec<f64>,
    },
    /// Write a built-in sample surface or pocket (or its job) as JSON, a STEP sample as its STEP file; `random --seed N` a seeded random bicubic surface.
    Sample {
        /// Sample name (see --list), or `random`.
        name: Option<String>,
        /// random: the seed (same seed and options, same bytes).
        #[arg(long)]
        seed: Option<u64>,
        /// random: extent along x and y, mm.
        #[arg(long, num_args = 2, value_names = ["X", "Y"], default_values_t = [200.0, 150.0])]
        size: Vec<f64>,
        /// random: half-range of the random control heights, mm.
        #[arg(long, default_value_t = 3.0)]
        amplitude: f64,
        /// random: depth of the trough along x, in amplitudes (0: none).
        #[arg(long, default_value_t = 0.0)]
        anisotropy: f64,
        /// List the samples.
        #[arg(long)]
        list: bool,
        /// Write the sample's ready job (surface embedded) instead of the shape.
        #[arg(long)]
        job: bool,
        /// Output file ("-" for stdout).
        #[arg(short, long, default_value = "-")]
        output: PathBuf,
    },
    /// Start the node on loopback, send it every sample shape and job over DDS, print the results table, record the run and draw each sample.
    Demo {
        /// Directory for the demo's bag (DIR/demo_run), pictures (DIR/SAMPLE.png) and node config.
        #[arg(long, default_value = "out/demo")]
        out: PathBuf,
        /// Do not record the run as a bag.
        #[arg(long)]
        no_record: bool,
    },
    /// Run the scallop simulator on a milling result and report residual height, gouge and uncovered area.
    Verify {
        job: PathBuf,
        result: PathBuf,
        /// Write the residual-height map (JSON) here.
        #[arg(long)]
        map: Option<PathBuf>,
    },
    /// Plan one surface and tool with the comparable strategies and print them side by side;
    /// --suite: the flat-end strategies on the fixed suite of random and built-in surfaces.
    Compare {
        /// Job file (not with --suite).
        #[arg(required_unless_present = "suite", conflicts_with = "suite")]
        job: Option<PathBuf>,
        /// Plan and verify the suite (docs/results.md) instead of one job.
        #[arg(long)]
        suite: bool,
        /// With --suite: only the surfaces whose name contains this.
        #[arg(long, requires = "suite")]
        only: Option<String>,
        /// With --suite: plan every surface for this scallop height, mm,
        /// instead of its job's (0.05); the regularity of the offsetting
        /// shows across heights (docs/results.md).
        #[arg(long, requires = "suite")]
        scallop: Option<f64>,
    },
    /// Run the belt-grinding material-removal simulation on a result.
    Simulate {
        job: PathBuf,
        result: PathBuf,
        /// Write the removal-depth map (JSON) here.
        #[arg(long)]
        map: Option<PathBuf>,
    },
    /// Benchmark the node on loopback: overhead beyond planning (p50/p90/p99) and a job burst.
    BenchNode {
        /// Jobs timed one at a time (after 3 warm-up jobs; 0: burst only).
        #[arg(long, default_value_t = 200)]
        jobs: usize,
        /// Points per timed toolpath (about).
        #[arg(long, default_value_t = 10_000)]
        points: usize,
        /// Jobs sent back to back in the burst (0: no burst).
        #[arg(long, default_value_t = 200)]
        burst: usize,
        /// How many bursts (the figure is their median time).
        #[arg(long, default_value_t = 5)]
        bursts: usize,
        /// The node's config (default: planning only, no recording or
        /// journal), e.g. to measure what recording and the journal cost.
        #[arg(long)]
        config: Option<PathBuf>,
    },
    /// Run the ROS 2 node. ROS arguments follow `--ros-args` (-p NAME:=VALUE,
    /// --params-file FILE, -r FROM:=TO incl. __ns and __node, --log-level):
    /// see docs/node.md.
    Node {
        /// Cell configuration (launch_configs/*.yaml).
        #[arg(long)]
        config: Option<PathBuf>,
    },
    /// Plan a job and record the run as a rosbag2 (MCAP) bag.
    Record {
        job: PathBuf,
        /// Bag directory to create.
        #[arg(short, long)]
        output: PathBuf,
        /// Exit non-zero unless the job succeeds (the bag is written either way).
        #[arg(long)]
        require_success: bool,
        /// Run the job through a node that executes it on a fake
        /// FollowJointTrajectory controller (loopback, a private domain) and
        /// keep the node's recording of the run.
        #[arg(long)]
        fake_execute: bool,
    },
    /// Bag maintenance.
    Bag {
        #[command(subcommand)]
        action: BagAction,
    },
    /// Re-plan the jobs of a bag; with --check compare with the recorded outputs.
    Replay {
        /// Bag directory or its .mcap file.
        bag: PathBuf,
        #[arg(long)]
        check: bool,
        /// Republish the inputs to a running node (ROS_DOMAIN_ID, loopback) instead of planning locally.
        #[arg(long)]
        publish: bool,
        /// With --publish: the node's namespace.
        #[arg(long, default_value = "/")]
        namespace: String,
        /// With --publish: how long to wait for the node's answers, s.
        #[arg(long, default_value_t = 900.0)]
        timeout_s: f64,
    },
    /// Publish a result file over iceoryx2 (the zero-copy toolpath service; layout in docs/formats.md).
    IpcPublish {
        result: PathBuf,
        #[arg(long, default_value = toolpath_ipc::SERVICE_NAME)]
        service: String,
        /// iceoryx2 file-name prefix (default: iceoryx2's own).
        #[arg(long)]
        prefix: Option<String>,
        /// Send the result this many times...
        #[arg(long, default_value_t = 1)]
        repeat: u32,
        /// ... this many milliseconds apart.
        #[arg(long, default_value_t = 100)]
        interval_ms: u64,
    },
    /// Write a milling result as an NC program (APT, or G-code for a 5-axis controller).
    Post {
        /// Result file (JSON) of a milling job.
        result: PathBuf,
        /// The job file the result was planned from (tool, feed rate, part).
        #[arg(long)]
        job: PathBuf,
        /// Machine definition (YAML, e.g. launch_configs/machines/mill5.yaml) or a cell config (its mill5); default: the built-in mill5.
        #[arg(long)]
        machine: Option<PathBuf>,
        /// apt, linuxcnc-tcp, fanuc-tcp, sinumerik-traori, heidenhain-tcpm, linuxcnc-joint or fanuc-joint.
        #[arg(long)]
        format: String,
        /// Program file ("-" for stdout).
        #[arg(short, long, default_value = "-")]
        output: PathBuf,
    },
    /// Draw a result as PNG or SVG.
    Plot {
        result: PathBuf,
        /// Job file, for the surface and the residual map.
        #[arg(long)]
        job: Option<PathBuf>,
        #[arg(short, long)]
        output: PathBuf,
    },
}

#[derive(Subcommand, Debug)]
pub enum BagAction {
    /// Rewrite a bag whose writer was killed with its summary and
    /// metadata.yaml (like `ros2 bag reindex`), so that the standard readers
    /// open it.
    Reindex {
        /// Bag directory.
        bag: PathBuf,
    },
}

/// Exit code of an internal error (a panic): EX_SOFTWARE of sysexits.h.
pub const INTERNAL_ERROR_EXIT: i32 = 70;

/// [`run`] with panics turned into one line on stderr and exit code
/// [`INTERNAL_ERROR_EXIT`] instead of a backtrace; with `RUST_BACKTRACE`
/// set, the standard report is kept for debugging. In the node a panic in
/// a job is caught at the job boundary and only this line is logged.
pub fn run_guarded() -> i32 {
    if std::env::var_os("RUST_BACKTRACE").is_none() {
        std::panic::set_hook(Box::new(|info| {
            let what = info
                .payload()
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| info.payload().downcast_ref::<String>().cloned())
                .unwrap_or_default();
            let at = info
                .location()
                .map(|l| format!(" at {}:{}", l.file(), l.line()))
                .unwrap_or_default();
            eprintln!("error: internal error (please report): {what}{at}");
        }));
    }
    std::panic::catch_unwind(run).unwrap_or(INTERNAL_ERROR_EXIT)
}

/// Runs the CLI and returns the process exit code.
pub fn run() -> i32 {
    // The `--ros-args` block is ROS's, not clap's (see `ros::ros_args`).
    let (own, ros) = match toolpath_node::ros_args::split(std::env::args_os()) {
        Ok(split) => split,
        Err(e) => {
            eprintln!("error: {e}");
            return e.exit_code();
        }
    };
    let cli = Cli::parse_from(own);
    if ros.is_some() && !matches!(cli.command, Command::Node { .. }) {
        eprintln!(
            "error: {} is only accepted by `toolpath node`",
            toolpath_node::ros_args::ROS_ARGS
        );
        return 2;
    }
    match dispatch(cli.command, ros.as_deref()) {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {e}");
            e.exit_code()
        }
    }
}

/// Runs one command; `ros` is the `--ros-args` block (`toolpath node` only).
fn dispatch(command: Command, ros: Option<&[String]>) -> Result<(), Error> {
    match command {
        Command::Plan {
            job,
            output,
            no_verify,
            no_timing,
            time_limit,
            max_passes,
            max_points,
            max_memory_mb,
        } => plan::run(
            &job,
            &output,
            plan::Limits {
                no_verify,
                no_timing,
                time_limit_s: time_limit,
                budget: toolpath_pipeline::Budget {
                    max_passes,
                    max_points,
                    max_memory_mb,
                },
            },
        ),
        Command::Import {
            step,
            list,
            faces,
            output,
        } => import::run(&step, list, &faces, &output),
        Command::Inspect { surface, uv } => inspect::run(&surface, uv[0], uv[1]),
        Command::Sample {
            name,
            seed,
            size,
            amplitude,
            anisotropy,
            list,
            job,
            output,
        } => sample::run(
            name.as_deref(),
            sample::RandomArgs {
                seed,
                size: [size[0], size[1]],
                amplitude,
                anisotropy,
            },
            list,
            job,
            &output,
        ),
        Command::Demo { out, no_record } => demo::run(&out, !no_record),
        Command::Verify { job, result, map } => verify::run(&job, &result, map.as_deref()),
        Command::Compare {
            job,
            suite,
            only,
            scallop,
        } => match job {
            // clap counts the --suite flag's default as present, so its
            // `requires` lets these through with a job file.
            Some(_) if !suite && (only.is_some() || scallop.is_some()) => Err(Error::invalid(
                if only.is_some() {
                    "--only"
                } else {
                    "--scallop"
                },
                "goes with --suite, not with a job file",
            )),
            Some(job) if !suite => compare::run(&job),
            _ => compare_suite::run(only.as_deref(), scallop),
        },
        Command::Simulate { job, result, map } => simulate::run(&job, &result, map.as_deref()),
        Command::Node { config } => node::run(config.as_deref(), ros),
        Command::BenchNode {
            jobs,
            points,
            burst,
            bursts,
            config,
        } => bench_node::run(jobs, points, burst, bursts, config.as_deref()),
        Command::Record {
            job,
            output,
            require_success,
            fake_execute,
        } => record::run(&job, &output, require_success, fake_execute),
        Command::Bag {
            action: BagAction::Reindex { bag },
        } => reindex(&bag),
        Command::Replay {
            bag,
            check,
            publish,
            namespace,
            timeout_s,
        } => replay::run(
            &bag,
            check,
            publish.then_some(replay::PublishArgs {
                namespace: &namespace,
                timeout_s,
            }),
        ),
        Command::IpcPublish {
            result,
            service,
            prefix,
            repeat,
            interval_ms,
        } => ipc_publish::run(&result, &service, prefix.as_deref(), repeat, interval_ms),
        Command::Plot {
            result,
            job,
            output,
        } => plot::run(&result, job.as_deref(), &output),
        Command::Post {
            result,
            job,
            machine,
            format,
            output,
        } => post::run(&result, &job, machine.as_deref(), &format, &output),
    }
}

fn reindex(bag: &std::path::Path) -> Result<(), Error> {
    let (summary, truncated) = toolpath_recording::reindex::reindex(bag)?;
    if let Some(why) = truncated {
        eprintln!("{why}");
    }
    println!(
        "reindexed {}: {} messages in {} chunks",
        summary.directory.display(),
        summary.messages,
        summary.chunks
    );
    Ok(())
}
