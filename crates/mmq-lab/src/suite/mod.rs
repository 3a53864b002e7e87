//! The benchmark suite: versioned tasks (world, environment and profile, delay, the
//! largest delay the agent is told, ε, q0, and per tier a budget and a fixed list of
//! seeds) run for one agent on the sweep engine. A tier becomes a sweep spec with one
//! `[[part]]` per task and the learner given, so running, resuming, sharding and merging
//! are the sweep's ([`crate::sweep`]); [`results`] turns the finished jobs into one
//! results file per agent and tier, and [`stats`] holds the aggregates of the
//! leaderboard (interquartile mean, stratified bootstrap, performance profiles,
//! probability of improvement).
//!
//! Layout of an output directory: the sweep's (`spec.toml`, `sweep.json`, `cells/`,
//! `results.csv`) plus `suite.json` (which suite, tier, agent and tasks) and
//! `results.json` (the scores).

pub mod reference;
pub mod results;
pub mod stats;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use mmq_learn::LearnerKind;
use serde::{Deserialize, Serialize};

use crate::error::LabError;
use crate::settings::{has_setting, not_a_setting};
use crate::sweep::SweepSpec;

pub use results::{
    SeedScore, SuiteResults, TaskResults, collect, parse_results, read_results, results_of_dir, write_results,
};

/// The suites shipped with mmq: (version, the suite file's text).
pub const SUITES: &[(&str, &str)] = &[("v1", include_str!("../../../../worlds/suites/v1/suite.toml"))];

/// The tiers every suite has.
pub const TIERS: [&str; 2] = ["lite", "full"];

/// Largest suite file read, bytes.
const MAX_SUITE_BYTES: u64 = 1 << 20;

/// A tier's description.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TierInfo {
    /// What the tier is for.
    #[serde(default)]
    pub description: String,
}

/// One task as the suite file gives it.
#[derive(Clone, Debug, Deserialize)]
struct TaskText {
    name: String,
    #[serde(default)]
    description: String,
    #[serde(default)]
    lite: Option<toml::Table>,
    #[serde(default)]
    full: Option<toml::Table>,
    /// The task's run parameters: fields of a sweep spec.
    #[serde(flatten)]
    fields: toml::Table,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SuiteText {
    suite: String,
    #[serde(default)]
    description: String,
    tier: BTreeMap<String, TierInfo>,
    task: Vec<TaskText>,
}

/// A task: its name, what it is, the run parameters it fixes and, per tier, the budget
/// and the seeds.
#[derive(Clone, Debug)]
pub struct Task {
    /// Its name, unique in the suite.
    pub name: String,
    /// What it is.
    pub description: String,
    /// Its run parameters (sweep-spec fields: world, env, robot, delay, max_delay, ...).
    pub fields: toml::Table,
    /// Per tier: `steps`, `seeds` and any other field the tier sets.
    pub tiers: BTreeMap<String, toml::Table>,
}

/// A suite: its version, tiers and tasks.
#[derive(Clone, Debug)]
pub struct Suite {
    /// The version (`v1`).
    pub version: String,
    /// What the suite covers.
    pub description: String,
    /// Tiers by name.
    pub tiers: BTreeMap<String, TierInfo>,
    /// Tasks, in order.
    pub tasks: Vec<Task>,
    /// The suite file (named in errors; anchors relative world paths).
    pub file: PathBuf,
}

/// Fields of a task that the suite itself sets, or that are not run parameters.
const NOT_TASK_FIELDS: [&str; 7] = ["learner", "seed", "part", "settings", "beyond", "curve", "baseline"];

impl Suite {
    /// A suite shipped with mmq (`v1`).
    pub fn builtin(version: &str) -> Result<Suite, LabError> {
        let text = SUITES.iter().find(|s| s.0 == version).map(|s| s.1).ok_or_else(|| LabError::Config {
            file: format!("suite `{version}`"),
            message: format!(
                "no such suite; the shipped suites are {}",
                SUITES.iter().map(|s| s.0).collect::<Vec<_>>().join(", ")
            ),
        })?;
        Suite::parse(text, &Path::new("worlds/suites").join(version).join("suite.toml"))
    }

    /// A shipped suite by version (`v1`), or the suite file `name` when it ends in `.toml`.
    pub fn open(name: &str) -> Result<Suite, LabError> {
        if name.ends_with(".toml") { Suite::load(Path::new(name)) } else { Suite::builtin(name) }
    }

    /// Reads a suite file.
    pub fn load(path: &Path) -> Result<Suite, LabError> {
        let text =
            mmq_core::files::read_text_bounded(path, MAX_SUITE_BYTES).map_err(|e| LabError::Config {
                file: path.display().to_string(),
                message: format!("cannot read the suite file: {e}"),
            })?;
        Suite::parse(&text, path)
    }

    /// Parses a suite file's text; `file` names it in errors.
    pub fn parse(text: &str, file: &Path) -> Result<Suite, LabError> {
        let bad = |message: String| LabError::Config { file: file.display().to_string(), message };
        let s: SuiteText = toml::from_str(text).map_err(|e| bad(e.to_string().trim().replace('\n', " ")))?;
        for t in TIERS {
            if !s.tier.contains_key(t) {
                return Err(bad(format!(
                    "tier: no `[tier.{t}]`; a suite has the tiers {}",
                    TIERS.join(" and ")
                )));
            }
        }
        if let Some(t) = s.tier.keys().find(|t| !TIERS.contains(&t.as_str())) {
            return Err(bad(format!(
                "tier.{t}: unknown tier; a suite has the tiers {}",
                TIERS.join(" and ")
            )));
        }
        if s.task.is_empty() {
            return Err(bad("task: no tasks; give at least one [[task]]".into()));
        }
        let mut tasks: Vec<Task> = Vec::new();
        for (i, t) in s.task.into_iter().enumerate() {
            let at = format!("task[{i}] ({})", t.name);
            if t.name.is_empty() || !t.name.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
            {
                return Err(bad(format!("{at}.name: use letters, digits, `-` and `_` only")));
            }
            if tasks.iter().any(|x| x.name == t.name) {
                return Err(bad(format!("{at}.name: `{}` is given twice; task names are unique", t.name)));
            }
            if let Some(f) = t.fields.keys().find(|k| NOT_TASK_FIELDS.contains(&k.as_str())) {
                return Err(bad(format!(
                    "{at}.{f}: a task does not set `{f}` (the suite sets it); remove it"
                )));
            }
            let mut tiers = BTreeMap::new();
            for (tier, table) in [("lite", t.lite), ("full", t.full)] {
                let table = table.ok_or_else(|| {
                    bad(format!("{at}.{tier}: missing; give e.g. {tier} = {{ steps = 150000, seeds = 20 }}"))
                })?;
                for f in ["steps", "seeds"] {
                    if !table.contains_key(f) {
                        return Err(bad(format!(
                            "{at}.{tier}.{f}: missing; each tier of a task gives `steps` and `seeds`"
                        )));
                    }
                }
                tiers.insert(tier.to_string(), table);
            }
            tasks.push(Task { name: t.name, description: t.description, fields: t.fields, tiers });
        }
        Ok(Suite {
            version: s.suite,
            description: s.description,
            tiers: s.tier,
            tasks,
            file: file.to_path_buf(),
        })
    }

    /// The tier `tier`, checked.
    pub fn tier(&self, tier: &str) -> Result<&TierInfo, LabError> {
        self.tiers.get(tier).ok_or_else(|| LabError::Config {
            file: format!("suite {}", self.version),
            message: format!("tier `{tier}` is not a tier; use {}", TIERS.join(" or ")),
        })
    }

    /// The sweep spec of `tier` for `agent`: one `[[part]]` per task (in suite order, so
    /// cell `i` is task `i`), without the undelayed baseline. `max_delay` goes to the
    /// learners that have it; each of `settings` must be one of the learner's.
    pub fn spec(&self, tier: &str, agent: &Agent) -> Result<SweepSpec, LabError> {
        self.tier(tier)?;
        let kind = LearnerKind::parse(&agent.learner)?;
        for (k, _) in &agent.settings {
            if !has_setting(kind, k) {
                return Err(not_a_setting(kind, k));
            }
        }
        let about = format!("Suite {}, tier {tier}, agent {}.", self.version, agent.name());
        self.tier_spec(tier, kind, agent, about)
    }

    /// The sweep spec of `tier` for an agent from outside mmq named `name`, whose
    /// learner a factory builds ([`crate::sweep::run_sweep_with`]): the spec's learner is
    /// `q`, a placeholder that fixes the shared parameters (α, γ, ε, q0) the tasks give.
    pub fn external_spec(&self, tier: &str, name: &str) -> Result<SweepSpec, LabError> {
        self.tier(tier)?;
        let about = format!(
            "Suite {}, tier {tier}, agent {name} (from outside mmq: the learner field is a placeholder; the seeds' learner is the agent).",
            self.version
        );
        let placeholder = Agent { learner: LearnerKind::Q.name().into(), settings: Vec::new() };
        self.tier_spec(tier, LearnerKind::Q, &placeholder, about)
    }

    /// The suite with only the tasks named, in the suite's order; a name that is not a
    /// task is refused by name.
    pub fn only(&self, names: &[String]) -> Result<Suite, LabError> {
        if let Some(n) = names.iter().find(|n| !self.tasks.iter().any(|t| &t.name == *n)) {
            return Err(LabError::Config {
                file: format!("suite {}", self.version),
                message: format!("`{n}` is not a task; the tasks are {}", self.task_names().join(", ")),
            });
        }
        if names.is_empty() {
            return Err(LabError::Config {
                file: format!("suite {}", self.version),
                message: "no tasks chosen; name at least one task".into(),
            });
        }
        let mut s = self.clone();
        s.tasks.retain(|t| names.contains(&t.name));
        Ok(s)
    }

    fn tier_spec(
        &self,
        tier: &str,
        kind: LearnerKind,
        agent: &Agent,
        about: String,
    ) -> Result<SweepSpec, LabError> {
        let mut top = toml::Table::new();
        top.insert("name".into(), format!("suite-{}-{tier}", self.version).into());
        top.insert("description".into(), about.into());
        top.insert("learner".into(), agent.learner.clone().into());
        top.insert("baseline".into(), false.into());
        if !agent.settings.is_empty() {
            top.insert("settings".into(), toml::Value::Table(agent.settings.iter().cloned().collect()));
        }
        let parts: Vec<toml::Value> = self
            .tasks
            .iter()
            .map(|t| {
                let mut p = t.fields.clone();
                if !has_setting(kind, "max_delay") {
                    p.remove("max_delay");
                }
                if !has_setting(kind, "lambda_hat") {
                    p.remove("lambda_hat");
                }
                p.extend(t.tiers[tier].clone());
                toml::Value::Table(p)
            })
            .collect();
        top.insert("part".into(), toml::Value::Array(parts));
        let text = toml::to_string(&top).map_err(|e| LabError::Config {
            file: self.file.display().to_string(),
            message: format!("cannot write the tier as a sweep spec: {e}"),
        })?;
        let spec = SweepSpec::parse(&text, &self.file)?;
        if spec.plan.cells.len() != self.tasks.len() {
            return Err(LabError::Config {
                file: self.file.display().to_string(),
                message: format!(
                    "tier {tier}: {} tasks make {} cells; a task gives one value per field (no lists), and no two tasks are the same",
                    self.tasks.len(),
                    spec.plan.cells.len()
                ),
            });
        }
        Ok(spec)
    }

    /// The names of the tasks, in order.
    pub fn task_names(&self) -> Vec<String> {
        self.tasks.iter().map(|t| t.name.clone()).collect()
    }
}

/// A built-in learner with its settings, as an agent of the suite.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Agent {
    /// The learner's name (`mmq learners`).
    pub learner: String,
    /// Settings of the learner (`--set KEY=VALUE`), in the order given.
    pub settings: Vec<(String, toml::Value)>,
}

impl Agent {
    /// The agent's name in results: the learner, then its settings in brackets
    /// (`mmq-kernel[kernel_width=2]`).
    pub fn name(&self) -> String {
        if self.settings.is_empty() {
            return self.learner.clone();
        }
        let s: Vec<String> = self.settings.iter().map(|(k, v)| format!("{k}={}", value_text(v))).collect();
        format!("{}[{}]", self.learner, s.join(","))
    }
}

fn value_text(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        v => v.to_string(),
    }
}

/// `DIR/suite.json`: what a suite output directory holds, so that merging and writing
/// results need neither the suite file nor the command line.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SuiteRun {
    /// The suite's version.
    pub suite: String,
    /// The tier.
    pub tier: String,
    /// The agent's name.
    pub agent: String,
    /// The tasks, in the order of the sweep's cells.
    pub tasks: Vec<String>,
    /// Only some of the suite's tasks were chosen (`tasks=` of `mmq.suite.evaluate`): the
    /// results are never complete.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub subset: bool,
}

impl SuiteRun {
    /// Writes `DIR/suite.json`; a directory that already holds another suite run is
    /// refused (choose another `out`). A run of some of the tasks and one of other tasks
    /// (or all) of the same suite, tier and agent share a directory: the finished seeds
    /// of the tasks in common are kept.
    pub fn claim(&self, dir: &Path) -> Result<(), LabError> {
        if dir.join("suite.json").exists() {
            let mine = SuiteRun::read(dir)?;
            let resized = (mine.subset || self.subset)
                && (&mine.suite, &mine.tier, &mine.agent) == (&self.suite, &self.tier, &self.agent);
            if &mine != self && !resized {
                return Err(LabError::Config {
                    file: dir.join("suite.json").display().to_string(),
                    message: format!(
                        "the directory holds suite {} tier {} of agent {}; give another output directory",
                        mine.suite, mine.tier, mine.agent
                    ),
                });
            }
            if &mine == self {
                return Ok(());
            }
        }
        let text = serde_json::to_string_pretty(self).unwrap_or_default() + "\n";
        crate::output::write_atomic(&dir.join("suite.json"), text.as_bytes())
    }

    /// Merges the output directories of the shards of one suite run into `out` (they
    /// must all hold the same run) and writes its results file; the merge's outcome and
    /// the results file's path.
    pub fn merge_dirs(
        dirs: &[PathBuf],
        out: &Path,
    ) -> Result<(crate::sweep::MergeOutcome, PathBuf), LabError> {
        let first =
            dirs.first().ok_or_else(|| LabError::param("merge", "nothing", "give at least one directory"))?;
        let run = SuiteRun::read(first)?;
        for d in &dirs[1..] {
            if SuiteRun::read(d)? != run {
                return Err(LabError::Config {
                    file: d.join("suite.json").display().to_string(),
                    message: format!(
                        "holds another agent, tier or suite than {}; merge the shards of one run",
                        first.display()
                    ),
                });
            }
        }
        run.claim(out)?;
        let merged = crate::sweep::merge(dirs, out)?;
        Ok((merged, write_results(out, &results_of_dir(out)?)?))
    }

    /// Reads `DIR/suite.json`.
    pub fn read(dir: &Path) -> Result<SuiteRun, LabError> {
        let p = dir.join("suite.json");
        let bad = |message: String| LabError::Config { file: p.display().to_string(), message };
        let text = mmq_core::files::read_text_bounded(&p, MAX_SUITE_BYTES)
            .map_err(|e| bad(format!("not a suite output directory ({e}); run `mmq suite run` first")))?;
        serde_json::from_str(&text).map_err(|e| bad(e.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn agent(l: &str) -> Agent {
        Agent { learner: l.into(), settings: vec![] }
    }

    /// The shipped suite parses, and each tier is one cell per task with the task's
    /// parameters, for learners with and without `max_delay`.
    #[test]
    fn v1_tiers_are_one_cell_per_task() {
        let s = Suite::builtin("v1").unwrap();
        assert!(s.tasks.len() >= 10);
        for tier in TIERS {
            for l in ["mmq", "q"] {
                let spec = s.spec(tier, &agent(l)).unwrap();
                assert_eq!(spec.plan.cells.len(), s.tasks.len());
                for (c, t) in s.tasks.iter().enumerate() {
                    let steps = t.tiers[tier]["steps"].as_integer().unwrap() as u64;
                    assert_eq!(spec.config(c).steps, steps, "{}", t.name);
                    assert_eq!(spec.plan.param(c, "delay"), t.fields["delay"].as_str().unwrap());
                    assert!(!spec.config(c).baseline);
                }
            }
        }
    }

    /// A setting the learner lacks, an unknown tier or suite are refused by name.
    #[test]
    fn bad_names_are_refused() {
        let s = Suite::builtin("v1").unwrap();
        let e = s.tier("medium").unwrap_err().to_string();
        assert!(e.contains("`medium`") && e.contains("lite"), "{e}");
        let with = Agent { learner: "q".into(), settings: vec![("trace_decay".into(), 0.5.into())] };
        assert!(s.spec("lite", &with).unwrap_err().to_string().contains("trace_decay"));
        assert!(Suite::builtin("v9").unwrap_err().to_string().contains("v1"));
        let e = Suite::parse(
            "suite = \"x\"\n[tier.lite]\n[tier.full]\n[[task]]\nname = \"a\"\nlearner = \"q\"\n",
            Path::new("s.toml"),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("learner"), "{e}");
    }

    /// An outside agent's spec is the tier's with the placeholder learner; a subset keeps
    /// the suite's order and refuses names that are not tasks.
    #[test]
    fn external_specs_and_subsets() {
        let s = Suite::builtin("v1").unwrap();
        let spec = s.external_spec("lite", "mine").unwrap();
        assert_eq!(spec.plan.cells.len(), s.tasks.len());
        assert!(spec.text.contains("agent mine"), "{}", spec.text);
        let names = [s.tasks[3].name.clone(), s.tasks[1].name.clone()];
        let only = s.only(&names).unwrap();
        assert_eq!(only.task_names(), [s.tasks[1].name.clone(), s.tasks[3].name.clone()]);
        assert_eq!(only.external_spec("full", "mine").unwrap().plan.cells.len(), 2);
        let e = s.only(&["nope".to_string()]).unwrap_err().to_string();
        assert!(e.contains("`nope` is not a task"), "{e}");
        assert!(s.external_spec("medium", "mine").is_err());
    }

    #[test]
    fn agent_names_carry_settings() {
        let a = Agent { learner: "mmq-kernel".into(), settings: vec![("kernel_width".into(), 2.into())] };
        assert_eq!(a.name(), "mmq-kernel[kernel_width=2]");
        assert_eq!(agent("q").name(), "q");
    }
}
