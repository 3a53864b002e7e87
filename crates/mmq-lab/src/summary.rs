//! Summaries: per-seed figures and their mean with a 95 % interval, under stable,
//! namespaced metric names (`reward/earned_per_step`, `perf/relative`, `eval/greedy_per_step`, ...).

use std::collections::BTreeMap;

use mmq_core::World;
use mmq_core::stats::{MeanCi, mean_ci};
use mmq_learn::{DelayEstimate, Diagnostics};
use serde::{Deserialize, Serialize};

use crate::config::RunConfig;
use crate::metric::MetricId;
use crate::runner::{SeedResult, describe};

/// The machine-readable summary of a run (`summary.json`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Summary {
    /// False when the run was interrupted: then only finished seeds are summarised and
    /// unfinished ones are marked.
    pub complete: bool,
    /// The resolved configuration.
    pub config: RunConfig,
    /// Learner description with its parameters.
    pub learner: String,
    /// World name.
    pub world: String,
    /// Exact optimal average reward per step of the world.
    pub optimum_per_step: f64,
    /// The ε-soft ceiling: the best average reward per step of any policy that explores
    /// with the run's ε as the learners do (absent where the actions are not the four
    /// moves, e.g. the robot's `heading` action set).
    #[serde(default)]
    pub ceiling_per_step: Option<f64>,
    /// Metrics of every seed.
    pub seeds: Vec<SeedEntry>,
    /// Mean and 95 % interval over seeds of every metric (complete seeds only).
    pub mean: BTreeMap<String, MeanCi>,
    /// Why a metric is absent from `mean` (e.g. relative performance when the undelayed
    /// baseline earned nothing).
    #[serde(default)]
    pub notes: Vec<String>,
}

/// One seed's metrics in `summary.json`: the seed as an integer, whether it finished,
/// and every metric under its stable name.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SeedEntry {
    /// The master seed.
    pub seed: u64,
    /// Whether every step of this seed ran and every output of it was written.
    pub complete: bool,
    /// Why an output of this seed was lost (a recording that could not be written).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// The metrics (absent keys: not measured, or without meaning for this seed).
    #[serde(flatten)]
    pub metrics: BTreeMap<String, f64>,
}

/// Why relative performance is absent for one seed.
pub const RELATIVE_ABSENT: &str = "relative performance is absent where the undelayed baseline's cumulative earned reward is ≤ 0 (a ratio to it has no meaning); see perf/regret and perf/fraction_of_ceiling";

/// The ε-soft ceiling of a run's setting, when its actions are the world's four moves.
pub fn ceiling_per_step(cfg: &RunConfig, world: &World) -> Option<f64> {
    ceiling_per_step_until(cfg, world, &|| false).flatten()
}

/// [`ceiling_per_step`] that gives up when `stop()` says so: `None` when stopped,
/// `Some(None)` when the setting has no ceiling (actions other than the four moves).
pub fn ceiling_per_step_until(
    cfg: &RunConfig,
    world: &World,
    stop: &dyn Fn() -> bool,
) -> Option<Option<f64>> {
    let moves = match cfg.env {
        crate::config::EnvKind::Grid => true,
        crate::config::EnvKind::Robot | crate::config::EnvKind::Swarm => {
            mmq_robot::RobotConfig::from_world(world).is_ok_and(|c| c.actions == mmq_robot::ActionSet::Moves)
        }
    };
    if !moves {
        return Some(None);
    }
    mmq_core::epsilon_soft_ceiling_until(world, cfg.learner.params.epsilon, stop).map(|c| Some(c.gain))
}

/// Said in a summary whose ceiling was not computed because the run was stopped.
pub const CEILING_CUT: &str = "the ε-soft ceiling was not computed: the run was stopped while its summary was written (perf/fraction_of_ceiling is absent)";

/// A learner's diagnostics under their metric names: its figures as named, the delay
/// estimate as `delay/mean_est`, `delay/median_est`, `delay/estimated` (1 or 0),
/// `delay/median_se` and `delay/median_cdf_se` (when known), `delay/pmf/KKK` (lag K, three
/// digits), `delay/mean_est_s` and `delay/median_est_s` (time bins), and the decoded
/// reward values as `reward/value/V`.
pub fn diagnostics_entries(d: &Diagnostics) -> Vec<(MetricId, f64)> {
    let mut m = Vec::new();
    if let Some(p) = &d.delay {
        m.push(("delay/mean_est".into(), p.mean));
        m.push(("delay/median_est".into(), p.median));
        m.push(("delay/estimated".into(), f64::from(u8::from(p.estimated))));
        push_median_se(&mut m, p, None);
        for (k, x) in p.pmf.iter().enumerate() {
            m.push((format!("delay/pmf/{k:03}").into(), *x));
        }
        if let (Some(mean), Some(median)) = (p.mean_s(), p.median_s()) {
            m.push(("delay/mean_est_s".into(), mean));
            m.push(("delay/median_est_s".into(), median));
        }
    }
    m.extend(d.figures.iter().map(|(k, v)| (k.name().into(), *v)));
    for (v, &value) in d.reward_values.iter().enumerate() {
        m.push((format!("reward/value/{v}").into(), value));
    }
    m
}

/// The standard errors of the median of `p`, when known, named with the suffix `at`.
fn push_median_se(m: &mut Vec<(MetricId, f64)>, p: &DelayEstimate, at: Option<u64>) {
    if let Some(se) = p.median_se {
        let id = |name: &str| at.map_or_else(|| MetricId::named(name), |t| MetricId::at(name, t));
        m.push((id("delay/median_se"), se.steps));
        m.push((id("delay/median_cdf_se"), se.cdf));
    }
}

/// A seed's learner metrics: its final diagnostics ([`diagnostics_entries`]) and, from
/// the samples taken during learning, the delay estimate at step T as
/// `delay/mean_est@T`, `delay/median_est@T`, `delay/median_se@T`, `delay/median_cdf_se@T`.
pub fn learner_entries(r: &SeedResult) -> Vec<(MetricId, f64)> {
    let mut m = diagnostics_entries(&r.diagnostics);
    for s in &r.run.diagnostics {
        if let Some(p) = &s.diagnostics.delay {
            m.push((MetricId::at("delay/mean_est", s.step), p.mean));
            m.push((MetricId::at("delay/median_est", s.step), p.median));
            push_median_se(&mut m, p, Some(s.step));
        }
    }
    m
}

/// The per-seed metrics under their stable names: `optimum` is the world's optimal
/// reward per step, `ceiling` its ε-soft ceiling (if known).
pub fn seed_metrics(r: &SeedResult, optimum: f64, ceiling: Option<f64>) -> BTreeMap<MetricId, f64> {
    let mut m = BTreeMap::new();
    let steps = r.run.steps_done.max(1) as f64;
    m.insert("seed".into(), r.seed as f64);
    m.insert("complete".into(), f64::from(u8::from(r.complete)));
    m.insert("steps".into(), r.run.steps_done as f64);
    m.insert("reward/earned_total".into(), r.run.earned_total);
    m.insert("reward/received_total".into(), r.run.received_total);
    m.insert("reward/earned_per_step".into(), r.run.earned_total / steps);
    m.insert("reward/received_per_step".into(), r.run.received_total / steps);
    m.insert("perf/fraction_of_optimum".into(), r.run.earned_total / steps / optimum);
    m.insert("perf/regret".into(), optimum * r.run.steps_done as f64 - r.run.earned_total);
    if let Some(c) = ceiling {
        m.insert("perf/fraction_of_ceiling".into(), r.run.earned_total / steps / c);
    }
    m.insert("eval/greedy_per_step".into(), r.greedy_per_step);
    m.insert("eval/greedy_fraction_of_optimum".into(), r.greedy_per_step / optimum);
    // The delays of the rewards delivered, in steps and in seconds of simulated time.
    if r.run.delays.delivered > 0 {
        m.insert("delay/delivered".into(), r.run.delays.delivered as f64);
        m.insert("delay/delivered_mean_steps".into(), r.run.delays.mean_steps());
        m.insert("delay/delivered_mean_s".into(), r.run.delays.mean_s());
    }
    m.insert("time/sim_s".into(), r.run.sim_time_s);
    for (k, v) in ["moved", "wall", "goal", "timeout"].iter().zip(r.run.events) {
        m.insert(format!("events/{k}").into(), v as f64);
    }
    if let Some(rel) = r.relative() {
        m.insert("perf/relative".into(), rel);
    }
    if let Some(b) = &r.baseline {
        m.insert("baseline/earned_per_step".into(), b.earned_total / b.steps_done.max(1) as f64);
        m.insert(
            "baseline/fraction_of_optimum".into(),
            b.earned_total / b.steps_done.max(1) as f64 / optimum,
        );
    }
    if let Some(x) = &r.reference {
        let per_step = x.earned_total / x.steps_done.max(1) as f64;
        m.insert("reference/earned_per_step".into(), per_step);
        m.insert("reference/fraction_of_optimum".into(), per_step / optimum);
    }
    if let Some(f) = r.fraction_of_reference() {
        m.insert("perf/fraction_of_reference".into(), f);
    }
    if let Some(g) = r.baseline_greedy_per_step {
        m.insert("baseline/eval_greedy_per_step".into(), g);
    }
    for (k, v) in learner_entries(r) {
        m.insert(k, v);
    }
    for (k, v) in &r.env_stats {
        m.insert(format!("env/{k}").into(), *v);
    }
    m.insert("time/wall_s".into(), r.wall_time_s);
    m.insert("time/learn_s".into(), r.learn_time_s);
    m.insert("time/steps_per_s".into(), r.run.steps_done as f64 / r.learn_time_s.max(1e-9));
    m
}

/// Mean and 95 % interval of every metric `keep` accepts over finished seeds' metrics
/// (non-finite values left out). Relative performance is summarised only when every seed
/// has it (a mean over the seeds that happen to have one would mislead); otherwise the
/// returned notes say why it is absent.
pub fn aggregate<K: Ord + Clone + std::borrow::Borrow<str>>(
    seeds: &[&BTreeMap<K, f64>],
    keep: impl Fn(&str) -> bool,
) -> (BTreeMap<K, MeanCi>, Vec<String>) {
    const RELATIVE: &str = "perf/relative";
    let count = |key: &str| seeds.iter().filter(|m| m.contains_key(key)).count();
    let mut notes = Vec::new();
    let relative_whole = count(RELATIVE) == seeds.len();
    if count("baseline/earned_per_step") > 0 && !relative_whole {
        notes.push(format!(
            "{RELATIVE} is absent: {} of {} seeds have none ({RELATIVE_ABSENT})",
            seeds.len() - count(RELATIVE),
            seeds.len()
        ));
    }
    let keys: std::collections::BTreeSet<&K> = seeds.iter().flat_map(|m| m.keys()).collect();
    let mut mean = BTreeMap::new();
    for k in keys.into_iter().filter(|k| keep((*k).borrow()) && ((*k).borrow() != RELATIVE || relative_whole))
    {
        let xs: Vec<f64> =
            seeds.iter().filter_map(|m| m.get((*k).borrow()).copied()).filter(|x| x.is_finite()).collect();
        if !xs.is_empty() {
            mean.insert(k.clone(), mean_ci(&xs));
        }
    }
    (mean, notes)
}

impl Summary {
    /// Summarises `results` of `cfg` on `world`.
    pub fn new(cfg: &RunConfig, world: &World, results: &[SeedResult], complete: bool) -> Summary {
        Summary::new_until(cfg, world, results, complete, &|| false)
    }

    /// [`Summary::new`] that skips the ε-soft ceiling (seconds on the largest worlds) once
    /// `stop()` says so; such a summary is incomplete and says why in its notes.
    pub fn new_until(
        cfg: &RunConfig,
        world: &World,
        results: &[SeedResult],
        complete: bool,
        stop: &dyn Fn() -> bool,
    ) -> Summary {
        let optimum = mmq_core::optimum(world).gain;
        let cut = ceiling_per_step_until(cfg, world, stop);
        let ceiling = cut.flatten();
        let seeds: Vec<SeedEntry> = results
            .iter()
            .map(|r| {
                let mut metrics = seed_metrics(r, optimum, ceiling);
                metrics.remove("seed");
                metrics.remove("complete");
                // summary.json names each metric by its text.
                let metrics = metrics.into_iter().map(|(k, v)| (k.to_string(), v)).collect();
                SeedEntry { seed: r.seed, complete: r.complete, error: r.failure.clone(), metrics }
            })
            .collect();
        let done: Vec<&BTreeMap<String, f64>> =
            seeds.iter().filter(|e| e.complete).map(|e| &e.metrics).collect();
        let (mean, mut notes) = aggregate(&done, |_| true);
        if cut.is_none() {
            notes.push(CEILING_CUT.to_string());
        }
        Summary {
            complete: complete && cut.is_some(),
            config: cfg.clone(),
            learner: describe(&cfg.learner),
            world: world.name.clone(),
            optimum_per_step: optimum,
            ceiling_per_step: ceiling,
            seeds,
            mean,
            notes,
        }
    }

    /// Mean of a metric, if present.
    pub fn get(&self, key: &str) -> Option<MeanCi> {
        self.mean.get(key).copied()
    }
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use super::*;

    /// A stop while the summary is made leaves out the ceiling, marks the summary
    /// incomplete and says why; without one the same summary has its ceiling.
    #[test]
    fn a_stop_during_the_summary_leaves_out_the_ceiling_and_says_so() {
        let world = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../worlds/paper-9x9.toml"));
        let cfg = RunConfig { world, ..RunConfig::default() };
        let w = cfg.load_world().unwrap();
        let whole = Summary::new_until(&cfg, &w, &[], true, &|| false);
        assert!(whole.complete);
        assert_eq!(whole.ceiling_per_step, ceiling_per_step(&cfg, &w));
        assert!(whole.ceiling_per_step.is_some_and(|c| c > 0.58 && c < 10.0 / 17.0));
        assert!(!whole.notes.iter().any(|n| n == CEILING_CUT));
        let cut = Summary::new_until(&cfg, &w, &[], true, &|| true);
        assert!(!cut.complete);
        assert_eq!(cut.ceiling_per_step, None);
        assert!(cut.notes.iter().any(|n| n == CEILING_CUT), "{:?}", cut.notes);
        assert_eq!(cut.optimum_per_step, whole.optimum_per_step);
    }
}
