//! Command-line flags (stage one: raw flags; `run.rs` resolves them into a validated
//! `RunConfig`).

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

/// Learning when rewards arrive late: Multiple-Model Q-learning on the paper's grid
/// worlds and on a rapier2d robot.
#[derive(Debug, Parser)]
#[command(name = "mmq", version, about, propagate_version = true)]
pub struct Cli {
    /// Worker threads for `run`, `paper` and `sweep` (default: all cores; at most 256),
    /// given before the command: `mmq --threads 2 sweep ...`. A thread without a seed of
    /// its own helps a deconvolving learner's refits. Results do not depend on it.
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands (parsed once per process, so the size of the largest does not matter).
#[derive(Debug, Subcommand)]
#[allow(clippy::large_enum_variant)]
pub enum Command {
    /// Run one learner on one world for several seeds; writes config, summary, metrics
    /// and Q-tables into --out.
    Run(RunArgs),
    /// Check or show world files.
    #[command(subcommand)]
    World(WorldAction),
    /// List the learners, one a line, name first.
    Learners,
    /// Summarise, render or verify a recorded MCAP run.
    Replay(ReplayArgs),
    /// Reproduce the paper's figures and write a report (report.md, SVG, PNG, CSV).
    Paper(PaperArgs),
    /// Run a sweep spec (parameters × seeds), resumable and shardable, or report or merge its outputs.
    Sweep(SweepArgs),
    /// The benchmark suite: run a learner on a tier, merge shards, write a leaderboard.
    #[command(subcommand)]
    Suite(crate::suite::SuiteAction),
}

/// Which fidelities `mmq paper` runs Figs. 6–12 on.
#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum EnvChoice {
    /// The grid world (all figures).
    Grid,
    /// The robot (Figs. 6–12 only).
    Robot,
    /// Both, side by side in the report.
    Both,
}

/// Flags of `mmq paper`.
#[derive(Debug, Args)]
pub struct PaperArgs {
    /// Figures, comma-separated: 2, 3, 4, 6 (6–12 come together), sens (ε/q0 sensitivity),
    /// all, or comparison (every learner, two worlds, many delays; not part of all).
    #[arg(long, default_value = "all")]
    pub fig: String,
    /// Fidelity for Figs. 6–12: grid, robot or both.
    #[arg(long, value_enum, default_value = "grid")]
    pub env: EnvChoice,
    /// Seeds of every setting (default: the spec's, 20 grid and 5 robot; quick: 3 in 10 of them).
    #[arg(long)]
    pub seeds: Option<u64>,
    /// Steps per seed at the paper's horizon; every spec scales by steps ÷ 150,000
    /// (default: the spec's, 150,000; quick: 30,000 grid, 3,000 robot).
    #[arg(long)]
    pub steps: Option<u64>,
    /// First master seed (default: the spec's, 0).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Smoke-test budget (seconds): every figure, tiny numbers.
    #[arg(long)]
    pub quick: bool,
    /// Output directory; its runs/ keeps every finished seed, so the same command again
    /// resumes an interrupted report.
    #[arg(long, short, default_value = "report")]
    pub out: PathBuf,
    /// Run part K of N of every study's jobs (e.g. 1/4) into OUT/runs and draw nothing;
    /// then `--merge` the shards' folders.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// A report folder (a shard's --out) whose finished seeds are taken before running;
    /// repeat for several.
    #[arg(long, value_name = "DIR")]
    pub merge: Vec<PathBuf>,
    /// Folder of edited figure specs (e.g. a copy of worlds/sweeps/paper-fig6.toml) run
    /// instead of the built-in ones of the same name.
    #[arg(long)]
    pub specs: Option<PathBuf>,
    /// No progress bars.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Environment fidelity (in the order of `mmq_lab::EnvKind`).
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum EnvArg {
    /// The paper's tabular grid world.
    Grid,
    /// The rapier2d differential-drive robot.
    Robot,
    /// Several robots in one arena; rewards wait for a radio consultation (`--swarm`).
    Swarm,
}

/// Flags of `mmq run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// World: a shipped world's name (`mmq world list`) or a world file (TOML).
    #[arg(long, default_value = "paper-9x9")]
    pub world: PathBuf,
    /// Environment fidelity.
    #[arg(long, value_enum, default_value = "grid")]
    pub env: EnvArg,
    /// Learner (see `mmq learners`).
    #[arg(long, default_value = "mmq")]
    pub learner: String,
    /// Reward delay. In steps: none, const:K, poisson:L, geometric:P, uniform:LO:HI,
    /// hist:W0,W1,..., mix:P1*SPEC1+P2*SPEC2. In seconds of simulated time: const:2s,
    /// uniform:0s:20s, exponential:4s, lognormal:MEDIANs:SIGMA, hist@0.5s:W0,W1,..., wifi,
    /// mix of those. Default: poisson:13, or none for the swarm (its delays emerge).
    #[arg(long)]
    pub delay: Option<String>,
    /// Width of deconv-model-time's time bins, seconds (default 0.1); for that learner only.
    #[arg(long)]
    pub time_bin: Option<f64>,
    /// λ̂max of the MMQ learners (N = λ̂max + 1 models), or the largest delay K the
    /// deconvolving learners consider (default 50). Only for learners that have it.
    #[arg(long)]
    pub max_delay: Option<usize>,
    /// λ̂ of the fixed-delay learner (default 13). Only for `fixed`.
    #[arg(long)]
    pub lambda_hat: Option<usize>,
    /// Any other setting of the learner, as KEY=VALUE (repeatable), e.g.
    /// --set pmf_rounds=2 --set told_delay=poisson:13. The value is read as TOML
    /// (a number, true/false), else as text. A setting the learner lacks is refused by
    /// name; each learner's settings are in its page of docs/algorithms/.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Learning rate α ∈ [0, 1].
    #[arg(long, default_value_t = 0.1, allow_negative_numbers = true)]
    pub alpha: f64,
    /// Discount factor γ ∈ [0, 1).
    #[arg(long, default_value_t = 0.9, allow_negative_numbers = true)]
    pub gamma: f64,
    /// ε of ε-greedy exploration, in [0, 1].
    #[arg(long, default_value_t = 0.01, allow_negative_numbers = true)]
    pub epsilon: f64,
    /// Initial Q value (optimistic initialisation).
    #[arg(long, default_value_t = 20.0, allow_negative_numbers = true)]
    pub q0: f64,
    /// Decision steps per seed.
    #[arg(long, default_value_t = 150_000)]
    pub steps: u64,
    /// Number of seeds (run in parallel).
    #[arg(long, default_value_t = 1)]
    pub seeds: u64,
    /// First master seed (seed i is SEED + i).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Steps per row of the learning curves.
    #[arg(long, default_value_t = 1000)]
    pub window: u64,
    /// Steps of greedy evaluation from S after learning.
    #[arg(long, default_value_t = 1000)]
    pub eval_steps: u64,
    /// Also run the grid-optimal reference (the world's optimal policy, acting ε-greedily)
    /// on the same environment and seeds: what the robot allows, and the run's fraction of
    /// it (perf/fraction_of_reference). Grid and robot.
    #[arg(long)]
    pub reference: bool,
    /// Skip the undelayed Q-learning baseline (no relative performance).
    #[arg(long)]
    pub no_baseline: bool,
    /// Do not write the Q-tables.
    #[arg(long)]
    pub no_tables: bool,
    /// Record every seed's trajectory to MCAP (trajectory-seed<N>.mcap in --out).
    #[arg(long)]
    pub record: bool,
    /// Robot pose samples per second of simulated time in the recording (0: every physics
    /// step; default 10). Needs --record.
    #[arg(long, requires = "record")]
    pub record_rate: Option<f64>,
    /// Record only the first N steps (and the last --record-last N). Needs --record.
    #[arg(long, requires = "record")]
    pub record_first: Option<u64>,
    /// Record only the last N steps (and the first --record-first N). Needs --record.
    #[arg(long, requires = "record")]
    pub record_last: Option<u64>,
    /// Override a field of the world's [robot] table, e.g. --robot profile=realistic
    /// --robot preset=kobuki --robot realistic.fix_rate_hz=2 (repeatable; see docs/robot.md).
    #[arg(long = "robot", value_name = "KEY=VALUE")]
    pub robot: Vec<String>,
    /// Override a field of the world's [swarm] table, e.g. --swarm robots=8 --swarm
    /// consult=peers --swarm k=2 (repeatable; with --env swarm; see docs/swarm.md).
    #[arg(long = "swarm", value_name = "KEY=VALUE")]
    pub swarm: Vec<String>,
    /// Serve the first seed live to the Foxglove app (WebSocket) on ADDR: HOST:PORT or a
    /// port; default 127.0.0.1:8765, loopback only unless another address is named.
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = "127.0.0.1:8765")]
    pub live: Option<String>,
    /// With --live: wait for the first viewer before running, at most SECONDS (no number:
    /// until one connects or Ctrl-C).
    #[arg(long, value_name = "SECONDS", num_args = 0..=1, requires = "live")]
    pub live_wait: Option<Option<f64>>,
    /// With --live: seconds of simulated time per second while a client watches
    /// (1: real time; 0: no pacing). With no client the run is never slowed. Needs --live.
    #[arg(long, value_name = "X", default_value_t = 1.0, requires = "live")]
    pub live_speed: f64,
    /// Output directory.
    #[arg(long, short, default_value = "runs/latest")]
    pub out: PathBuf,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

/// What to do with world files.
#[derive(Debug, Subcommand)]
pub enum WorldAction {
    /// List the shipped worlds (found by name from any folder: `--world paper-9x9`).
    List,
    /// Validate world files (or shipped worlds by name); one line per file.
    Check {
        /// World files.
        #[arg(required = true)]
        files: Vec<PathBuf>,
    },
    /// Show the map, the optimal policy as arrows and the optimal average reward.
    Show {
        /// World file, or a shipped world's name.
        file: PathBuf,
        /// Print the world file itself (TOML), to copy into a file of your own and edit.
        #[arg(long)]
        toml: bool,
    },
}

/// Flags of `mmq replay`.
#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// The MCAP file (trajectory-seed<N>.mcap).
    pub file: PathBuf,
    /// Print the summary (the default when nothing else is asked).
    #[arg(long)]
    pub summary: bool,
    /// Draw the arena and the trajectory (scale bar, legend) to an SVG file and a PNG next to it.
    #[arg(long)]
    pub render: Option<PathBuf>,
    /// Re-run the simulation from the file's metadata and check it matches bit for bit.
    #[arg(long)]
    pub verify: bool,
    /// First decision step to draw.
    #[arg(long)]
    pub from: Option<u64>,
    /// Last decision step to draw.
    #[arg(long)]
    pub to: Option<u64>,
    /// Play the file to the Foxglove app (WebSocket) on ADDR (HOST:PORT or a port; default
    /// 127.0.0.1:8765) until Ctrl-C: at 1x from the first subscription; the app's timeline
    /// plays, pauses, seeks, sets the speed.
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = "127.0.0.1:8765")]
    pub serve: Option<String>,
    /// With --serve: start paused, waiting for the app's play command.
    #[arg(long, requires = "serve")]
    pub paused: bool,
}

/// Flags of `mmq sweep` (see docs/sweeps.md).
#[derive(Debug, Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct SweepArgs {
    /// Report or merge instead of running.
    #[command(subcommand)]
    pub action: Option<SweepAction>,
    /// The sweep spec (TOML).
    #[arg(required = true)]
    pub spec: Option<PathBuf>,
    /// Output directory (results.csv, sweep.json, cells/); finished jobs there are skipped (resume).
    #[arg(long, short, required = true)]
    pub out: Option<PathBuf>,
    /// Run only the K-th of N disjoint parts of the jobs (1 <= K <= N), e.g. 2/8.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// Check the spec and print the cells and jobs without running anything.
    #[arg(long)]
    pub dry_run: bool,
    /// No progress bar and no line per finished job.
    #[arg(long, short)]
    pub quiet: bool,
}

/// What `mmq sweep` does besides running.
#[derive(Debug, Subcommand)]
pub enum SweepAction {
    /// Means and 95 % intervals per cell, in DIR/report (or --out): summary.csv, report.md, a
    /// figure per numeric axis, tables per learner, learning curves and robot diagnostics
    /// when the sweep has them. Several directories (e.g. grid and robot) are reported together.
    Report {
        /// Sweep output directories (the first setting is the first directory's).
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// Where to write the report (default: DIR/report of the first DIR).
        #[arg(long, short)]
        out: Option<PathBuf>,
    },
    /// Merge the output directories of shards (or of any runs of one spec) into --out.
    Merge {
        /// Sweep output directories.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// The merged directory.
        #[arg(long, short)]
        out: PathBuf,
    },
}
