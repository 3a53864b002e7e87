//! The results file of one agent on one tier (`results.json`): per task, per seed, the
//! fraction of the optimum earned while learning, the final greedy policy's fraction of
//! the optimum, and the regret; a seed that failed carries its error instead. Written
//! from a suite output directory's finished jobs, read back checked.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::SuiteRun;
use crate::error::LabError;
use crate::sweep::{Metrics, Plan, load_failures, load_results, read_manifest};

/// Format tag of results files.
pub const FORMAT: &str = "mmq-suite-results/1";

/// Largest results file read, bytes.
const MAX_RESULTS_BYTES: u64 = 64 << 20;

/// One seed of one task: its scores, or `failed` with the error.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SeedScore {
    /// The master seed.
    pub seed: u64,
    /// The seed failed (the agent raised, returned a bad action, ran out of time).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub failed: bool,
    /// Why it failed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// Reward earned while learning over the budget ÷ the exact optimum's over as many steps.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fraction_of_optimum: Option<f64>,
    /// The final greedy policy's reward per step ÷ the optimum's (None: no greedy policy).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub greedy_fraction_of_optimum: Option<f64>,
    /// The optimum's reward over the steps run minus the reward earned.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub regret: Option<f64>,
    /// Decision steps run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub steps: Option<u64>,
    /// Reward earned per decision step while learning.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub earned_per_step: Option<f64>,
    /// The exact optimum's reward per decision step (the grid MDP's, on the robot too).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub optimum_per_step: Option<f64>,
}

impl SeedScore {
    /// A failed seed.
    pub fn failed(seed: u64, error: impl Into<String>) -> SeedScore {
        SeedScore {
            seed,
            failed: true,
            error: Some(error.into()),
            fraction_of_optimum: None,
            greedy_fraction_of_optimum: None,
            regret: None,
            steps: None,
            earned_per_step: None,
            optimum_per_step: None,
        }
    }

    /// The seed's scores from a finished job's metrics (failed if a score is not finite).
    pub fn from_metrics(seed: u64, m: &Metrics) -> SeedScore {
        let get = |k: &str| m.get(k).copied().filter(|x| x.is_finite());
        let (Some(f), Some(regret)) = (get("perf/fraction_of_optimum"), get("perf/regret")) else {
            return SeedScore::failed(seed, "the run gave no finite fraction of the optimum");
        };
        let earned = get("reward/earned_per_step");
        SeedScore {
            seed,
            failed: false,
            error: None,
            fraction_of_optimum: Some(f),
            greedy_fraction_of_optimum: get("eval/greedy_fraction_of_optimum"),
            regret: Some(regret),
            steps: get("steps").map(|s| s as u64),
            earned_per_step: earned,
            optimum_per_step: earned.filter(|_| f != 0.0).map(|e| e / f),
        }
    }
}

/// One task's seeds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TaskResults {
    /// The task's name.
    pub task: String,
    /// Its seeds, in the tier's order (finished or failed; seeds not run yet are absent).
    pub seeds: Vec<SeedScore>,
}

/// A results file: one agent on one tier of one suite.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SuiteResults {
    /// [`FORMAT`].
    pub format: String,
    /// The suite's version (`v1`).
    pub suite: String,
    /// The tier (`lite` or `full`).
    pub tier: String,
    /// The agent's name.
    pub agent: String,
    /// Version of mmq that wrote the file.
    pub mmq_version: String,
    /// Whether every seed of every task is there (finished or failed).
    pub complete: bool,
    /// Per task, in the suite's order.
    pub tasks: Vec<TaskResults>,
}

/// The results of a suite run from its plan, its jobs' metrics (None: not finished) and
/// why jobs failed (None: not failed). A run of some of the tasks is never complete.
pub fn collect(
    run: &SuiteRun,
    plan: &Plan,
    jobs: &[Option<Metrics>],
    failures: &[Option<String>],
) -> SuiteResults {
    let mut complete = !run.subset;
    let tasks = run
        .tasks
        .iter()
        .enumerate()
        .map(|(c, task)| {
            let seeds = plan
                .cell_jobs(c)
                .filter_map(|j| {
                    let (_, seed) = plan.job(j);
                    let m = jobs[j].as_ref();
                    complete &= m.is_some();
                    m.map(|m| match &failures[j] {
                        Some(e) => SeedScore::failed(seed, e.clone()),
                        None => SeedScore::from_metrics(seed, m),
                    })
                })
                .collect();
            TaskResults { task: task.clone(), seeds }
        })
        .collect();
    SuiteResults {
        format: FORMAT.into(),
        suite: run.suite.clone(),
        tier: run.tier.clone(),
        agent: run.agent.clone(),
        mmq_version: env!("CARGO_PKG_VERSION").into(),
        complete,
        tasks,
    }
}

/// The results of the suite output directory `dir` (its `suite.json`, `sweep.json` and
/// job files).
pub fn results_of_dir(dir: &Path) -> Result<SuiteResults, LabError> {
    let run = SuiteRun::read(dir)?;
    let m = read_manifest(dir)?;
    if m.plan.cells.len() != run.tasks.len() {
        return Err(LabError::Config {
            file: dir.join("suite.json").display().to_string(),
            message: format!(
                "names {} tasks but the sweep has {} cells",
                run.tasks.len(),
                m.plan.cells.len()
            ),
        });
    }
    Ok(collect(&run, &m.plan, &load_results(dir, &m.plan), &load_failures(dir, &m.plan)))
}

/// Writes `DIR/results.json` and returns its path.
pub fn write_results(dir: &Path, r: &SuiteResults) -> Result<PathBuf, LabError> {
    let p = dir.join("results.json");
    let text = serde_json::to_string_pretty(r).unwrap_or_default() + "\n";
    crate::output::write_atomic(&p, text.as_bytes())?;
    Ok(p)
}

/// Reads and checks a results file: the format, and per seed either finite scores or
/// `failed` with an error.
pub fn read_results(path: &Path) -> Result<SuiteResults, LabError> {
    let bad = |message: String| LabError::Config { file: path.display().to_string(), message };
    let text = mmq_core::files::read_text_bounded(path, MAX_RESULTS_BYTES)
        .map_err(|e| bad(format!("cannot read the results file: {e}")))?;
    parse_results(&text, path)
}

/// Parses and checks a results file's text, as [`read_results`]; `path` names it in
/// errors.
pub fn parse_results(text: &str, path: &Path) -> Result<SuiteResults, LabError> {
    let bad = |message: String| LabError::Config { file: path.display().to_string(), message };
    let r: SuiteResults = serde_json::from_str(text).map_err(|e| {
        bad(format!("not a suite results file ({e}); give a results.json of `mmq suite run`"))
    })?;
    if r.format != FORMAT {
        return Err(bad(format!("format: `{}` is not {FORMAT}", r.format)));
    }
    for t in &r.tasks {
        for s in &t.seeds {
            let at = format!("tasks[{}].seeds (seed {})", t.task, s.seed);
            if s.failed {
                if s.error.as_deref().is_none_or(str::is_empty) {
                    return Err(bad(format!("{at}: a failed seed gives its `error`")));
                }
            } else if !s.fraction_of_optimum.is_some_and(f64::is_finite)
                || !s.regret.is_some_and(f64::is_finite)
            {
                return Err(bad(format!(
                    "{at}: `fraction_of_optimum` and `regret` must be numbers (or the seed `failed` with an `error`)"
                )));
            }
        }
    }
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scores_from_metrics_and_round_trip() {
        let m: Metrics = [
            ("perf/fraction_of_optimum", 0.5),
            ("perf/regret", 100.0),
            ("eval/greedy_fraction_of_optimum", 1.0),
            ("reward/earned_per_step", 0.25),
            ("steps", 200.0),
        ]
        .into_iter()
        .map(|(k, v)| (k.into(), v))
        .collect();
        let s = SeedScore::from_metrics(3, &m);
        assert_eq!(s.fraction_of_optimum, Some(0.5));
        assert_eq!(s.optimum_per_step, Some(0.5));
        assert_eq!(s.steps, Some(200));
        let nan: Metrics = [("perf/fraction_of_optimum".into(), f64::NAN)].into_iter().collect();
        assert!(SeedScore::from_metrics(1, &nan).failed);
        let r = SuiteResults {
            format: FORMAT.into(),
            suite: "v1".into(),
            tier: "lite".into(),
            agent: "q".into(),
            mmq_version: "0".into(),
            complete: true,
            tasks: vec![TaskResults { task: "t".into(), seeds: vec![s, SeedScore::failed(4, "boom")] }],
        };
        let dir = tempfile::tempdir().unwrap();
        let p = write_results(dir.path(), &r).unwrap();
        assert_eq!(read_results(&p).unwrap(), r);
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.contains("\"failed\": true") && text.contains("\"error\": \"boom\""));
        std::fs::write(&p, text.replace("\"error\": \"boom\"", "\"error\": \"\"")).unwrap();
        assert!(read_results(&p).unwrap_err().to_string().contains("error"));
    }
}
