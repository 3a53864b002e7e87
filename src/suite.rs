//! `mmq suite`: run a built-in learner or the reference on a tier of the benchmark suite
//! (`mmq_report::suite_run`: resumable, shardable), merge shard outputs, and write the
//! leaderboard of several agents' results (`mmq_report::leaderboard`).

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use clap::{Args, Subcommand};
use mmq_lab::suite::Agent;
use mmq_report::suite_run;

use crate::Failure;
use crate::progress::Bars;

/// Where a tier runs: shared by `suite run` and `suite reference`.
#[derive(Debug, Args)]
pub struct TierRun {
    /// The tier: lite (minutes) or full (the paper's budget).
    #[arg(long)]
    tier: String,
    /// The suite: a shipped version (v1) or a suite file (TOML, as worlds/suites/v1/suite.toml).
    #[arg(long, default_value = "v1")]
    suite: String,
    /// Output directory; finished seeds there are skipped (resume).
    #[arg(long, short)]
    out: PathBuf,
    /// Run only the K-th of N disjoint parts of the seeds (1 <= K <= N), e.g. 2/8.
    #[arg(long, value_name = "K/N")]
    shard: Option<String>,
    /// No progress bar and no line per finished seed.
    #[arg(long, short)]
    quiet: bool,
}

/// What `mmq suite` does (see docs/suite.md).
#[derive(Debug, Subcommand)]
pub enum SuiteAction {
    /// Run a built-in learner on every task of a tier (resumable; --shard for a cluster)
    /// and write OUT/results.json.
    Run {
        /// The learner (see `mmq learners`).
        #[arg(long)]
        learner: String,
        /// A setting of the learner, KEY=VALUE (repeatable), as for `mmq run`.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        #[command(flatten)]
        at: TierRun,
    },
    /// Run the reference, the grid MDP's optimal policy (`grid-optimal`), on every task of
    /// a tier and write OUT/results.json; `suite report` shows each agent's fraction of it.
    Reference {
        #[command(flatten)]
        at: TierRun,
    },
    /// Merge the output directories of shards of one agent and tier into --out and write
    /// its results.json.
    Merge {
        /// Suite output directories.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// The merged directory.
        #[arg(long, short)]
        out: PathBuf,
    },
    /// The leaderboard of several agents' results files (one suite and tier): leaderboard.md,
    /// CSV files and figures in --out. A results file of `suite reference` among them is the
    /// reference; without one, the shipped suites' own reference is used.
    Report {
        /// Results files (results.json), one per agent.
        #[arg(required = true)]
        files: Vec<PathBuf>,
        /// Where to write the leaderboard.
        #[arg(long, short)]
        out: PathBuf,
    },
}

/// Where the tier runs.
fn tier(at: &TierRun) -> suite_run::Tier<'_> {
    suite_run::Tier { tier: &at.tier, suite: &at.suite, out: &at.out, shard: at.shard.as_deref() }
}

/// Runs `mmq suite`.
pub fn suite(action: SuiteAction, stop: &AtomicBool) -> Result<(), Failure> {
    match action {
        SuiteAction::Run { learner, set, at } => {
            let settings = crate::run::settings(&set)?.into_iter().map(|(k, v)| (k.to_string(), v)).collect();
            Ok(suite_run::agent(&Agent { learner, settings }, tier(&at), stop, &Bars::new(at.quiet))?)
        }
        SuiteAction::Reference { at } => Ok(suite_run::reference(tier(&at), stop, &Bars::new(at.quiet))?),
        SuiteAction::Merge { dirs, out } => Ok(suite_run::merge(&dirs, &out, &Bars::new(false))?),
        SuiteAction::Report { files, out } => Ok(suite_run::leaderboard(&files, &out, &Bars::new(false))?),
    }
}
