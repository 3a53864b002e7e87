//! Running a tier of the benchmark suite for a front end, on the sweep engine
//! ([`crate::sweep_run`]): a built-in learner ([`agent`]) or the reference
//! ([`reference()`]), resumable and shardable, then the agent's `results.json`; merging
//! the output directories of a tier's shards ([`merge`]); and the leaderboard of several
//! agents' results ([`leaderboard`]).

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use mmq_lab::suite::{Agent, Suite, SuiteRun, results_of_dir, write_results};
use mmq_lab::sweep::{CellLearners, SweepSpec};

use crate::{Progress, ReportError};

/// Where a tier runs: the fields `tier`, `suite`, `out` and `shard` of `mmq suite run`
/// and `mmq suite reference`.
#[derive(Debug, Clone, Copy)]
pub struct Tier<'a> {
    /// The tier (lite or full).
    pub tier: &'a str,
    /// A shipped suite's version (v1) or a suite file.
    pub suite: &'a str,
    /// The output directory; finished seeds there are skipped.
    pub out: &'a Path,
    /// Only the part `K/N` of the seeds.
    pub shard: Option<&'a str>,
}

/// Runs the built-in learner `agent` on every task of the tier `at` and writes its
/// results file, saying the plan, each finished seed and what ran.
pub fn agent(
    agent: &Agent,
    at: Tier<'_>,
    stop: &AtomicBool,
    progress: &dyn Progress,
) -> Result<(), ReportError> {
    let suite = Suite::open(at.suite)?;
    let spec = suite.spec(at.tier, agent)?;
    let run = SuiteRun {
        suite: suite.version.clone(),
        tier: at.tier.to_string(),
        agent: agent.name(),
        tasks: suite.task_names(),
        subset: false,
    };
    go(&spec, &run, None, at, stop, progress)
}

/// Runs the reference, the grid MDP's optimal policy, on every task of the tier `at` and
/// writes its results file.
pub fn reference(at: Tier<'_>, stop: &AtomicBool, progress: &dyn Progress) -> Result<(), ReportError> {
    let (spec, run) = Suite::open(at.suite)?.reference_spec(at.tier)?;
    let learners = mmq_lab::suite::reference::learners(&spec);
    go(&spec, &run, Some(&learners), at, stop, progress)
}

/// Runs the jobs of `spec` for the suite run `run` (learners from `learners` when given,
/// else the spec's) and writes its results file.
fn go(
    spec: &SweepSpec,
    run: &SuiteRun,
    learners: Option<&CellLearners<'_>>,
    at: Tier<'_>,
    stop: &AtomicBool,
    progress: &dyn Progress,
) -> Result<(), ReportError> {
    let shard = crate::sweep_run::shard(at.shard)?;
    run.claim(at.out)?;
    let clock = Instant::now();
    let task = |_: &str, index: usize| run.tasks[index].clone();
    let outcome = crate::sweep_run::run_jobs(spec, at.out, shard, learners, ("suite", &task), stop, progress);
    progress.end();
    let outcome = outcome?;
    let path = write_results(at.out, &results_of_dir(at.out)?)?;
    progress.say(&format!(
        "suite {} tier {}, agent {}: ran {} seed(s), skipped {} already finished, {} left ({:.1} s); wrote {}\n",
        run.suite,
        run.tier,
        run.agent,
        outcome.ran,
        outcome.skipped,
        outcome.left,
        clock.elapsed().as_secs_f64(),
        path.display()
    ));
    Ok(())
}

/// Merges the output directories of shards of one agent and tier into `out`, writes its
/// results file and says what it did.
pub fn merge(dirs: &[PathBuf], out: &Path, progress: &dyn Progress) -> Result<(), ReportError> {
    let (merged, results) = SuiteRun::merge_dirs(dirs, out)?;
    crate::sweep_run::say_merged(dirs.len(), &merged, progress);
    progress.say(&format!("wrote {}\n", results.display()));
    Ok(())
}

/// Writes the leaderboard of the results files `files` into `out`
/// ([`crate::leaderboard::report`]) and says what it wrote.
pub fn leaderboard(files: &[PathBuf], out: &Path, progress: &dyn Progress) -> Result<(), ReportError> {
    let r = crate::leaderboard::report(files, out)?;
    let (agents, tasks, md) = (r.agents, r.tasks, r.markdown.display());
    progress.say(&format!("leaderboard of {agents} agent(s) on {tasks} task(s): wrote {md}\n"));
    Ok(())
}
