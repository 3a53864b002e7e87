//! A study's cells read back from its store: each cell's configuration and the records
//! of its finished seeds, with the figures the report draws from them (means and 95 %
//! intervals over seeds).

use std::path::Path;

use mmq_core::stats::{MeanCi, mean_ci};

use crate::config::RunConfig;
use crate::sweep::{SeedRecord, SweepSpec, load_records};

/// A cell of a study over its seeds, every seed with its undelayed baseline.
#[derive(Clone, Debug)]
pub struct Group {
    /// The cell's configuration: its seeds (`seed`, `seeds`) those the plan runs.
    pub cfg: RunConfig,
    /// The cell's index in its spec ([`SweepSpec::run`] is its resolved run).
    pub cell: usize,
    /// The records of its finished seeds, in seed order.
    pub results: Vec<SeedRecord>,
}

/// Every cell of `spec` with the records its store `dir` holds, in the plan's order (a
/// cell none of whose seeds finished has no results).
pub fn groups(spec: &SweepSpec, dir: &Path) -> Vec<Group> {
    let plan = &spec.plan;
    let mut records = load_records(dir, plan);
    configs(spec)
        .into_iter()
        .enumerate()
        .map(|(c, cfg)| Group {
            cfg,
            cell: c,
            results: plan.cell_jobs(c).filter_map(|j| records[j].take()).collect(),
        })
        .collect()
}

/// Each cell's configuration of `spec`, with the seeds its plan runs (`seed`, `seeds`).
pub fn configs(spec: &SweepSpec) -> Vec<RunConfig> {
    (0..spec.plan.cells.len())
        .map(|c| {
            let seeds = spec.plan.seeds_of(c);
            RunConfig {
                seed: seeds.first().copied().unwrap_or(0),
                seeds: seeds.len() as u64,
                ..spec.config(c).clone()
            }
        })
        .collect()
}

impl Group {
    /// Per-seed relative performance at the end; absent (a NaN mean) unless every seed
    /// has one: where a baseline earned ≤ 0, a mean over the other seeds would mislead.
    pub fn relative(&self) -> MeanCi {
        let xs: Vec<f64> = self.results.iter().filter_map(SeedRecord::relative).collect();
        if xs.len() < self.results.len() {
            return mean_ci(&[]);
        }
        mean_ci(&xs)
    }
    /// Fraction of the ε-soft ceiling during learning.
    pub fn fraction_of_ceiling(&self, ceiling: f64) -> MeanCi {
        self.fraction(ceiling)
    }
    /// Regret against the exact optimum: optimum × steps − earned reward, per seed.
    pub fn regret(&self, optimum: f64) -> MeanCi {
        mean_ci(
            &self
                .results
                .iter()
                .map(|r| optimum * r.run.steps_done as f64 - r.run.earned_total)
                .collect::<Vec<_>>(),
        )
    }
    /// Fraction of the exact optimum during learning.
    pub fn fraction(&self, optimum: f64) -> MeanCi {
        mean_ci(&self.results.iter().map(|r| r.earned_per_step() / optimum).collect::<Vec<_>>())
    }
    /// Greedy evaluation reward per step.
    pub fn greedy(&self) -> MeanCi {
        mean_ci(&self.results.iter().map(|r| r.greedy_per_step).collect::<Vec<_>>())
    }
    /// Relative performance over time: at each curve point, the mean over seeds of
    /// cumulative earned ÷ cumulative baseline earned (points where a baseline's
    /// cumulative reward is not yet positive are skipped for that seed).
    pub fn relative_curve(&self) -> Vec<(u64, MeanCi)> {
        curve(&self.results, |r, i| {
            let b = r.baseline.as_ref()?.curve.get(i)?.earned_cum;
            (b > 0.0).then(|| r.run.curve[i].earned_cum / b)
        })
    }
    /// Earned reward per step within each window, mean over seeds.
    pub fn earned_curve(&self) -> Vec<(u64, MeanCi)> {
        let w = self.cfg.window as f64;
        curve(&self.results, |r, i| Some(r.run.curve[i].earned / w))
    }
    /// Received reward per step within each window, mean over seeds.
    pub fn received_curve(&self) -> Vec<(u64, MeanCi)> {
        let w = self.cfg.window as f64;
        curve(&self.results, |r, i| Some(r.run.curve[i].received / w))
    }
}

fn curve(results: &[SeedRecord], f: impl Fn(&SeedRecord, usize) -> Option<f64>) -> Vec<(u64, MeanCi)> {
    let Some(first) = results.first() else { return Vec::new() };
    (0..first.run.curve.len())
        .filter_map(|i| {
            let xs: Vec<f64> =
                results.iter().filter(|r| i < r.run.curve.len()).filter_map(|r| f(r, i)).collect();
            (!xs.is_empty()).then(|| (first.run.curve[i].step, mean_ci(&xs)))
        })
        .collect()
}
