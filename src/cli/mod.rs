//! The `toolpath` command line. One module per subcommand; this file only
//! parses arguments and maps errors to exit codes (2 for bad input).

mod args;
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

pub use args::*;
use clap::{Parser, Subcommand};
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
    Plan(PlanArgs),
    /// List the faces of a STEP file, or write chosen faces as trimmed surfaces (JSON).
    Import(ImportArgs),
    /// Print the differential geometry of a surface at (u, v) as JSON.
    Inspect(InspectArgs),
    /// Write a built-in sample surface or pocket (or its job) as JSON, a STEP sample as its STEP file; `random --seed N` a seeded random bicubic surface.
    Sample(SampleArgs),
    /// Start the node on loopback, send it every sample shape and job over DDS, print the results table, record the run and draw each sample.
    Demo(DemoArgs),
    /// Run the scallop simulator on a milling result and report residual height, gouge and uncovered area.
    Verify(VerifyArgs),
    /// Plan one surface and tool with the comparable strategies and print them side by side;
    /// --suite: the flat-end strategies on the fixed suite of random and built-in surfaces.
    Compare(CompareArgs),
    /// Run the belt-grinding material-removal simulation on a result.
    Simulate(SimulateArgs),
    /// Benchmark the node on loopback: overhead beyond planning (p50/p90/p99) and a job burst.
    BenchNode(BenchNodeArgs),
    /// Run the ROS 2 node. ROS arguments follow `--ros-args` (-p NAME:=VALUE,
    /// --params-file FILE, -r FROM:=TO incl. __ns and __node, --log-level):
    /// see docs/node.md.
    Node(NodeArgs),
    /// Plan a job and record the run as a rosbag2 (MCAP) bag.
    Record(RecordArgs),
    /// Bag maintenance.
    Bag(BagArgs),
    /// Re-plan the jobs of a bag; with --check compare with the recorded outputs.
    Replay(ReplayArgs),
    /// Publish a result file over iceoryx2 (the zero-copy toolpath service; layout in docs/formats.md).
    IpcPublish(IpcPublishArgs),
    /// Write a milling result as an NC program (APT, or G-code for a 5-axis controller).
    Post(PostArgs),
    /// Draw a result as PNG or SVG.
    Plot(PlotArgs),
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
    if ros.is_some() && !matches!(cli.command, Command::Node(_)) {
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
        Command::Plan(a) => a.run(),
        Command::Import(a) => a.run(),
        Command::Inspect(a) => a.run(),
        Command::Sample(a) => a.run(),
        Command::Demo(a) => a.run(),
        Command::Verify(a) => a.run(),
        Command::Compare(a) => a.run(),
        Command::Simulate(a) => a.run(),
        Command::Node(a) => a.run(ros),
        Command::BenchNode(a) => a.run(),
        Command::Record(a) => a.run(),
        Command::Bag(a) => a.run(),
        Command::Replay(a) => a.run(),
        Command::IpcPublish(a) => a.run(),
        Command::Plot(a) => a.run(),
        Command::Post(a) => a.run(),
    }
}
