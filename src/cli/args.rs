//! The arguments of each subcommand, and each one's `run`: the call into
//! its module (docs: the `Command` variants in `mod.rs`).

use super::{
    bench_node, compare, compare_suite, demo, import, inspect, ipc_publish, node, plan, plot, post,
    record, replay, sample, simulate, verify,
};
use clap::{Args, Subcommand};
use std::path::PathBuf;
use toolpath_kernel::error::Error;

// `toolpath plan` (its help is the `Command` variant's doc).
#[derive(Args, Debug)]
pub struct PlanArgs {
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
}

// `toolpath import` (its help is the `Command` variant's doc).
#[derive(Args, Debug)]
pub struct ImportArgs {
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
}

// `toolpath inspect` (its help is the `Command` variant's doc).
#[derive(Args, Debug)]
pub struct InspectArgs {
    /// Surface file (JSON).
    surface: PathBuf,
    /// Parameter values.
    #[arg(long, num_args = 2, value_names = ["U", "V"], allow_negative_numbers = true, required = true)]
    uv: Vec<f64>,
}

// `toolpath sample` (its help is the `Command` variant's doc).
#[derive(Args, Debug)]
pub struct SampleArgs {
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
}

// `toolpath demo` (its help is the `Command` variant's doc).
#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Directory for the demo's bag (DIR/demo_run), pictures (DIR/SAMPLE.png) and node config.
    #[arg(long, default_value = "out/demo")]
    out: PathBuf,
    /// Do not record the run as a bag.
    #[arg(long)]
    no_record: bool,
}

// `toolpath verify` (its help is the `Command` variant's doc).
#[derive(Args, Debug)]
pub struct VerifyArgs {
    job: PathBuf,
    result: PathBuf,
    /// Write the residual-height map (JSON) here.
    #[arg(long)]
    map: Option<PathBuf>,
}

// `toolpath compare` (its help is the `Command` variant's doc).
#[derive(Args, Debug)]
pub struct CompareArgs {
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
}

// `toolpath simulate` (its help is the `Command` variant's doc).
#[derive(Args, Debug)]
pub struct SimulateArgs {
    job: PathBuf,
    result: PathBuf,
    /// Write the removal-depth map (JSON) here.
    #[arg(long)]
    map: Option<PathBuf>,
}

// `toolpath bench-node` (its help is the `Command` variant's doc).
#[derive(Args, Debug)]
pub struct BenchNodeArgs {
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
}

// `toolpath node` (its help is the `Command` variant's doc).
#[derive(Args, Debug)]
pub struct NodeArgs {
    /// Cell configuration (launch_configs/*.yaml).
    #[arg(long)]
    config: Option<PathBuf>,
}

// `toolpath record` (its help is the `Command` variant's doc).
#[derive(Args, Debug)]
pub struct RecordArgs {
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
}

// `toolpath bag` (its help is the `Command` variant's doc).
#[derive(Args, Debug)]
pub struct BagArgs {
    #[command(subcommand)]
    action: BagAction,
}

// `toolpath replay` (its help is the `Command` variant's doc).
#[derive(Args, Debug)]
pub struct ReplayArgs {
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
}

// `toolpath ipc-publish` (its help is the `Command` variant's doc).
#[derive(Args, Debug)]
pub struct IpcPublishArgs {
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
}

// `toolpath post` (its help is the `Command` variant's doc).
#[derive(Args, Debug)]
pub struct PostArgs {
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
}

// `toolpath plot` (its help is the `Command` variant's doc).
#[derive(Args, Debug)]
pub struct PlotArgs {
    result: PathBuf,
    /// Job file, for the surface and the residual map.
    #[arg(long)]
    job: Option<PathBuf>,
    #[arg(short, long)]
    output: PathBuf,
}

impl PlanArgs {
    pub fn run(self) -> Result<(), Error> {
        plan::run(
            &self.job,
            &self.output,
            plan::Limits {
                no_verify: self.no_verify,
                no_timing: self.no_timing,
                time_limit_s: self.time_limit,
                budget: toolpath_pipeline::Budget {
                    max_passes: self.max_passes,
                    max_points: self.max_points,
                    max_memory_mb: self.max_memory_mb,
                },
            },
        )
    }
}

impl ImportArgs {
    pub fn run(self) -> Result<(), Error> {
        import::run(&self.step, self.list, &self.faces, &self.output)
    }
}

impl InspectArgs {
    pub fn run(self) -> Result<(), Error> {
        inspect::run(&self.surface, self.uv[0], self.uv[1])
    }
}

impl SampleArgs {
    pub fn run(self) -> Result<(), Error> {
        sample::run(
            self.name.as_deref(),
            sample::RandomArgs {
                seed: self.seed,
                size: [self.size[0], self.size[1]],
                amplitude: self.amplitude,
                anisotropy: self.anisotropy,
            },
            self.list,
            self.job,
            &self.output,
        )
    }
}

impl DemoArgs {
    pub fn run(self) -> Result<(), Error> {
        demo::run(&self.out, !self.no_record)
    }
}

impl VerifyArgs {
    pub fn run(self) -> Result<(), Error> {
        verify::run(&self.job, &self.result, self.map.as_deref())
    }
}

impl CompareArgs {
    pub fn run(self) -> Result<(), Error> {
        let CompareArgs {
            job,
            suite,
            only,
            scallop,
        } = self;
        match job {
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
        }
    }
}

impl SimulateArgs {
    pub fn run(self) -> Result<(), Error> {
        simulate::run(&self.job, &self.result, self.map.as_deref())
    }
}

impl BenchNodeArgs {
    pub fn run(self) -> Result<(), Error> {
        bench_node::run(
            self.jobs,
            self.points,
            self.burst,
            self.bursts,
            self.config.as_deref(),
        )
    }
}

impl NodeArgs {
    /// `ros`: the `--ros-args` block.
    pub fn run(self, ros: Option<&[String]>) -> Result<(), Error> {
        node::run(self.config.as_deref(), ros)
    }
}

impl RecordArgs {
    pub fn run(self) -> Result<(), Error> {
        record::run(
            &self.job,
            &self.output,
            self.require_success,
            self.fake_execute,
        )
    }
}

impl BagArgs {
    pub fn run(self) -> Result<(), Error> {
        match self.action {
            BagAction::Reindex { bag } => reindex(&bag),
        }
    }
}

impl ReplayArgs {
    pub fn run(self) -> Result<(), Error> {
        replay::run(
            &self.bag,
            self.check,
            self.publish.then_some(replay::PublishArgs {
                namespace: &self.namespace,
                timeout_s: self.timeout_s,
            }),
        )
    }
}

impl IpcPublishArgs {
    pub fn run(self) -> Result<(), Error> {
        ipc_publish::run(
            &self.result,
            &self.service,
            self.prefix.as_deref(),
            self.repeat,
            self.interval_ms,
        )
    }
}

impl PostArgs {
    pub fn run(self) -> Result<(), Error> {
        post::run(
            &self.result,
            &self.job,
            self.machine.as_deref(),
            &self.format,
            &self.output,
        )
    }
}

impl PlotArgs {
    pub fn run(self) -> Result<(), Error> {
        plot::run(&self.result, self.job.as_deref(), &self.output)
    }
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
