//! Summaries: per-seed figures and their mean with a 95 % interval, under stable,
//! namespaced metric names (`reward/earned_per_step`, `perf/relative`, `eval/greedy_per_step`, ...).

use std::collections::BTreeMap;

use mmq_core::World;
use mmq_core::stats::{MeanCi, mean_ci};
use serde::{Deserialize, Serialize};

use crate::config::RunConfig;
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
    /// Metrics of every seed.
    pub seeds: Vec<BTreeMap<String, f64>>,
    /// Mean and 95 % interval over seeds of every metric (complete seeds only).
    pub mean: BTreeMap<String, MeanCi>,
}

/// The per-seed metrics under their stable names.
pub fn seed_metrics(r: &SeedResult, optimum: f64) -> BTreeMap<String, f64> {
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
        m.insert(format!("events/{k}"), v as f64);
    }
    if let Some(b) = &r.baseline {
        m.insert("perf/relative".into(), r.run.earned_total / b.earned_total);
        m.insert("baseline/earned_per_step".into(), b.earned_total / b.steps_done.max(1) as f64);
        m.insert(
            "baseline/fraction_of_optimum".into(),
            b.earned_total / b.steps_done.max(1) as f64 / optimum,
        );
    }
    if let Some(g) = r.baseline_greedy_per_step {
        m.insert("baseline/eval_greedy_per_step".into(), g);
    }
    for (k, v) in &r.learner_metrics {
        m.insert(k.clone(), *v);
    }
    for (k, v) in &r.env_stats {
        m.insert(format!("env/{k}"), *v);
    }
    m.insert("time/wall_s".into(), r.wall_time_s);
    m.insert("time/learn_s".into(), r.learn_time_s);
    m.insert("time/steps_per_s".into(), r.run.steps_done as f64 / r.learn_time_s.max(1e-9));
    m
}

impl Summary {
    /// Summarises `results` of `cfg` on `world`.
    pub fn new(cfg: &RunConfig, world: &World, results: &[SeedResult], complete: bool) -> Summary {
        let optimum = mmq_core::optimum(world).gain;
        let seeds: Vec<_> = results.iter().map(|r| seed_metrics(r, optimum)).collect();
        let done: Vec<_> = seeds.iter().filter(|m| m.get("complete") == Some(&1.0)).collect();
        let mut mean = BTreeMap::new();
        if let Some(first) = done.first() {
            for k in first.keys() {
                if k == "seed" || k == "complete" {
                    continue;
                }
                let xs: Vec<f64> =
                    done.iter().filter_map(|m| m.get(k).copied()).filter(|x| x.is_finite()).collect();
                if !xs.is_empty() {
                    mean.insert(k.clone(), mean_ci(&xs));
                }
            }
        }
        Summary {
            complete,
            config: cfg.clone(),
            learner: describe(&cfg.learner),
            world: world.name.clone(),
            optimum_per_step: optimum,
            seeds,
            mean,
        }
    }

    /// Mean of a metric, if present.
    pub fn get(&self, key: &str) -> Option<MeanCi> {
        self.mean.get(key).copied()
    }
}
