//! `mmq suite`: run a built-in learner on a tier of the benchmark suite (through the
//! sweep engine: resumable, shardable), merge shard outputs, and write the leaderboard
//! of several agents' results (`mmq_report::leaderboard`).

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use clap::{Args, Subcommand};
use mmq_lab::Control;
use mmq_lab::suite::{Agent, Suite, SuiteRun, reference, results_of_dir, write_results};
use mmq_lab::sweep::{CellLearners, Shard, SweepEvent, SweepSpec, run_sweep_with};
use mmq_report::Progress as _;
use mmq_report::terminal as say;

use crate::Failure;
use crate::progress::Bars;

/// Flags of `mmq suite` (see docs/suite.md).
#[derive(Debug, Args)]
pub struct SuiteArgs {
    #[command(subcommand)]
    action: SuiteAction,
}

/// Where a tier runs: shared by `suite run` and `suite reference`.
#[derive(Debug, Args)]
struct TierRun {
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

#[derive(Debug, Subcommand)]
enum SuiteAction {
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

/// Runs `mmq suite`.
pub fn suite(a: SuiteArgs, stop: &AtomicBool) -> Result<(), Failure> {
    match a.action {
        SuiteAction::Run { learner, set, at } => {
            let settings = set.iter().map(|kv| crate::run::setting(kv)).collect::<Result<Vec<_>, _>>()?;
            let agent =
                Agent { learner, settings: settings.into_iter().map(|(k, v)| (k.to_string(), v)).collect() };
            let suite = Suite::open(&at.suite)?;
            let spec = suite.spec(&at.tier, &agent)?;
            let run = SuiteRun {
                suite: suite.version.clone(),
                tier: at.tier.clone(),
                agent: agent.name(),
                tasks: suite.task_names(),
                subset: false,
            };
            go(&spec, &run, None, &at, stop)
        }
        SuiteAction::Reference { at } => {
            let (spec, run) = Suite::open(&at.suite)?.reference_spec(&at.tier)?;
            let learners = reference::learners(&spec);
            go(&spec, &run, Some(&learners), &at, stop)
        }
        SuiteAction::Merge { dirs, out } => {
            let (merged, results) = SuiteRun::merge_dirs(&dirs, &out)?;
            let (said, missing) = say::merged(dirs.len(), &merged);
            println!("{said}");
            if let Some(m) = missing {
                eprintln!("{m}");
            }
            println!("wrote {}", results.display());
            Ok(())
        }
        SuiteAction::Report { files, out } => {
            let r = mmq_report::leaderboard::report(&files, &out)?;
            println!(
                "leaderboard of {} agent(s) on {} task(s): wrote {}",
                r.agents,
                r.tasks,
                r.markdown.display()
            );
            Ok(())
        }
    }
}

/// Runs the jobs of `spec` for the suite run `run` into `out` (learners from `learners`
/// when given, else the spec's) and writes its results file.
fn go(
    spec: &SweepSpec,
    run: &SuiteRun,
    learners: Option<&CellLearners<'_>>,
    at: &TierRun,
    stop: &AtomicBool,
) -> Result<(), Failure> {
    let (out, quiet) = (at.out.as_path(), at.quiet);
    let shard = at.shard.as_deref().map(Shard::parse).transpose()?;
    run.claim(out)?;
    let clock = Instant::now();
    let pb = Bars::new(quiet);
    let progress = |n: u64| pb.advance(n);
    let ctl = Control { stop, progress: &progress };
    let events = |e: &SweepEvent<'_>| match e {
        SweepEvent::Planned { jobs_total, jobs_here, done, baselines, steps } => {
            pb.begin(*steps, "suite");
            println!("{}", say::sweep_planned(&spec.plan, shard, *jobs_total, *jobs_here, *done, *baselines));
        }
        SweepEvent::JobDone { cell_index, seed, finished, of, wall_s, .. } => {
            let task = &run.tasks[*cell_index];
            pb.line(&format!("[{finished}/{of}] {task} seed {seed}: {wall_s:.2} s"));
        }
    };
    let outcome = run_sweep_with(spec, out, shard, ctl, &events, learners);
    pb.end();
    let outcome = outcome?;
    let results = results_of_dir(out)?;
    let path = write_results(out, &results)?;
    println!(
        "suite {} tier {}, agent {}: ran {} seed(s), skipped {} already finished, {} left ({:.1} s); wrote {}",
        run.suite,
        run.tier,
        run.agent,
        outcome.ran,
        outcome.skipped,
        outcome.left,
        clock.elapsed().as_secs_f64(),
        path.display()
    );
    Ok(())
}
