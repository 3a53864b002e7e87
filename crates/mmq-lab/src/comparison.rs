//! The learner comparison, "learners that reach the undelayed limit": the study behind
//! `mmq paper --fig comparison`, as data. Every learner on the paper's 9×9 world and on
//! the 15×15 maze, under Poisson delays λ ∈ {0, 5, 13, 25} at ε ∈ {0.02, 0.05, 0.1},
//! and under three non-Poisson delays (uniform 0–26, a Poisson(3)/Poisson(25) mixture
//! and a WiFi-latency-like histogram) at ε ∈ {0.05, 0.1}; plus the deconvolving
//! learners told the true delay pmf (an ablation of the estimate) on 9×9. The settings
//! and their seeds are the spec `worlds/sweeps/paper-comparison.toml` ([`SPEC`]), run
//! like every study into its store ([`crate::study`]); this module orders its settings
//! for the report and summarises each. Drawing, the CSV files and the report live in
//! mmq-report.
//!
//! Fixed for every setting: α = 0.1, γ = 0.9, q0 = 10, λ̂max = 50 (the largest delay
//! the learners are told of), 150,000 steps; seeds per setting as the spec's parts give
//! them (20 for the headline settings on 9×9), at the budget of [`crate::study::Budget`].

use std::path::Path;

use mmq_core::stats::{MeanCi, mean_ci};
use mmq_core::{DelayDist, World};
use mmq_learn::LearnerKind;
use mmq_learn::deconv::{pmf_mean, pmf_median, truncated_pmf};
use serde::{Deserialize, Serialize};

use crate::error::LabError;
use crate::runner::DIAGNOSTICS_EVERY;
use crate::study::{Group, SeedRecord};
use crate::sweep::SweepSpec;

/// Names of the non-Poisson delays the shipped study runs, for the report's headings
/// (any other delay is named by its spec); the study's axes come from its plan.
pub const DELAY_NAMES: [(&str, &str); 3] = [
    ("uniform 0–26", "uniform:0:26"),
    ("mixture ½ Poisson(3) + ½ Poisson(25)", "mix:0.5*poisson:3+0.5*poisson:25"),
    (
        "WiFi-like histogram",
        "hist:0,3,9,14,12,9,6,4,3,2,1.5,1.2,1,0.8,0.7,0.6,0.6,0.7,1,1.4,1.6,1.4,1,0.7,0.5,0.4,0.3,0.3,0.2,0.2,0.2,0.1,0.1,0.1,0.1,0.1",
    ),
];
/// Steps at which the delay estimate is judged ("after 50k steps").
pub const JUDGE_AT: u64 = 50_000;

/// The study's spec (`worlds/sweeps/paper-comparison.toml`, built into the binary): the
/// settings it runs and their seeds. [`crate::study::SPECS`] lists it with the figures.
pub const SPEC: &str = include_str!("../../../worlds/sweeps/paper-comparison.toml");

/// One setting of the study.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Setting {
    /// World name (file stem).
    pub world: String,
    /// Delay spec.
    pub delay: String,
    /// Short label of the delay.
    pub delay_label: String,
    /// ε.
    pub epsilon: f64,
    /// The learner.
    pub learner: LearnerKind,
    /// Whether a deconvolving learner is told the true pmf (ablation).
    pub told: bool,
    /// A headline setting: one the spec as written runs over the most seeds of its world
    /// (20 on 9×9, 5 on the maze), the delay estimated (not told).
    #[serde(default)]
    pub headline: bool,
}

impl Setting {
    /// The learner's name as reported (`deconv-q (told pmf)` for the ablation).
    pub fn learner_label(&self) -> String {
        if self.told {
            format!("{} (told pmf)", self.learner.name())
        } else {
            self.learner.name().to_string()
        }
    }
}

/// The label of a delay in the report: `Poisson λ = 13`, or the name of a non-Poisson
/// delay of the study.
pub fn delay_label(delay: &str) -> String {
    match delay.strip_prefix("poisson:") {
        Some(l) => format!("Poisson λ = {l}"),
        None => DELAY_NAMES
            .iter()
            .find(|(_, d)| *d == delay)
            .map_or_else(|| delay.to_string(), |(l, _)| l.to_string()),
    }
}

/// Every setting of the study with its cell in `spec`, in report order: the told-pmf
/// ablation last, otherwise by world, delay, ε and learner in the order the spec first
/// names them. `written` is the spec as written (its seeds mark the headline settings);
/// its cells are `spec`'s at another budget.
pub fn plan(spec: &SweepSpec, written: &SweepSpec) -> Vec<(Setting, usize)> {
    let seeds_written = |c: usize| written.plan.cells.get(c).map_or(0, |_| written.plan.seeds_of(c).len());
    // The most seeds any cell on each world runs, as written.
    let mut most_on: std::collections::HashMap<&Path, usize> = std::collections::HashMap::new();
    for c in 0..spec.plan.cells.len() {
        let m = most_on.entry(spec.config(c).world.as_path()).or_default();
        *m = (*m).max(seeds_written(c));
    }
    let most = |c: usize| most_on[spec.config(c).world.as_path()];
    let mut v = Vec::with_capacity(spec.plan.cells.len());
    for c in 0..spec.plan.cells.len() {
        let cell = spec.config(c);
        let world = cell.world.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let setting = Setting {
            delay_label: delay_label(&cell.delay),
            delay: cell.delay.clone(),
            epsilon: cell.learner.params.epsilon,
            learner: cell.learner.kind(),
            told: cell.learner.settings.deconv().is_some_and(|d| d.told_delay.is_some()),
            world,
            headline: false,
        };
        let headline = !setting.told && seeds_written(c) == most(c);
        v.push((Setting { headline, ..setting }, c));
    }
    // Each setting's key: world, delay, ε and learner as the spec first names them.
    let keys: Vec<[String; 4]> = v
        .iter()
        .map(|(s, _)| [s.world.clone(), s.delay.clone(), s.epsilon.to_string(), s.learner.name().to_string()])
        .collect();
    let first_at = |k: usize, x: &String| keys.iter().position(|key| key[k] == *x).unwrap_or(usize::MAX);
    let ranks: Vec<(bool, [usize; 4])> = v
        .iter()
        .zip(&keys)
        .map(|((s, _), key)| (s.told, [0, 1, 2, 3].map(|k| first_at(k, &key[k]))))
        .collect();
    let mut ranked: Vec<_> = ranks.into_iter().zip(v).collect();
    ranked.sort_by_key(|(rank, _)| *rank);
    ranked.into_iter().map(|(_, setting)| setting).collect()
}

/// The seeds of the first headline setting on the first world, of its first other
/// setting, and the same on the other worlds, as the report states the budget.
pub fn seed_budget(spec: &SweepSpec, plan: &[(Setting, usize)]) -> [u64; 4] {
    let first = plan.first().map(|(s, _)| s.world.clone()).unwrap_or_default();
    let of = |nine: bool, headline: bool| {
        plan.iter()
            .find(|(s, _)| (s.world == first) == nine && s.headline == headline)
            .map_or(0, |(_, c)| spec.plan.seeds_of(*c).len() as u64)
    };
    [of(true, true), of(true, false), of(false, true), of(false, false)]
}

/// What one setting produced, over seeds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Outcome {
    /// The setting.
    pub setting: Setting,
    /// Seeds.
    pub n: usize,
    /// Relative performance (cumulative earned ÷ undelayed Q-learning's).
    pub relative: MeanCi,
    /// Earned reward per step ÷ the exact optimum.
    pub fraction: MeanCi,
    /// Earned reward per step ÷ the ε-soft ceiling (the best any policy exploring with
    /// this ε earns): how close to the limit of its exploration a learner came.
    #[serde(default)]
    pub ceiling: Option<MeanCi>,
    /// Regret against the optimum: optimum × steps − earned reward, in reward units.
    pub regret: MeanCi,
    /// Greedy evaluation, reward per step from S.
    pub greedy: MeanCi,
    /// Worst seed's greedy evaluation.
    pub greedy_min: f64,
    /// Seeds whose greedy policy is optimal from S (≥ the optimum's own 1000-step score).
    pub greedy_optimal: usize,
    /// Wall-clock seconds per seed (learning, evaluation; no baseline).
    pub seconds: MeanCi,
    /// Delay estimate (deconvolving learners): median of p̂ at every snapshot.
    pub median_curve: Vec<(u64, MeanCi)>,
    /// Mean of p̂ at every snapshot.
    pub mean_curve: Vec<(u64, MeanCi)>,
    /// p̂ at the end, mean over seeds, delays 0..=50.
    pub pmf: Vec<f64>,
    /// |median of p̂ − true median| at [`JUDGE_AT`] steps, worst seed.
    pub median_error_max: Option<f64>,
    /// Mass of p̂ at the end in the low and high lobe of the mixture (split at 12), mean.
    pub lobes: Option<(MeanCi, MeanCi)>,
    /// Delay probes per seed (`deconv-model`: `learner/probes`).
    #[serde(default)]
    pub probes: Option<MeanCi>,
}

/// The true delay pmf over 0..=50 and its median and mean.
pub fn truth(delay: &str) -> Result<(Vec<f64>, f64, f64), LabError> {
    let d = DelayDist::parse(delay)?;
    let p = truncated_pmf(&d, 50);
    let (med, mean) = (pmf_median(&p), pmf_mean(&p));
    Ok((p, med, mean))
}

/// Where the mixture's lobes are split.
pub const LOBE_SPLIT: usize = 12;

/// The greedy evaluation score of the optimal policy over `eval_steps` from S: the goal
/// reward every 1/gain·goal steps, counted whole.
pub fn optimal_greedy_score(world: &World, eval_steps: u64) -> f64 {
    let gain = mmq_core::optimum(world).gain;
    let goal = world.rewards.goal;
    let cycle = (goal / gain).round();
    goal * (eval_steps as f64 / cycle).floor() / eval_steps as f64
}

/// A seed's delay estimate after `t` steps (sampled by the runner), if it has one: its
/// median and mean.
fn delay_at(r: &SeedRecord, t: u64) -> Option<(f64, f64)> {
    r.delay_samples.iter().find(|s| s.0 == t).map(|s| (s.1, s.2))
}

/// Summarises the group of `setting` as its study's store holds it.
pub fn outcome(setting: &Setting, g: &Group, world: &World) -> Result<Outcome, LabError> {
    let optimum = mmq_core::optimum(world).gain;
    let best = optimal_greedy_score(world, g.cfg.eval_steps);
    let rs = &g.results;
    let greedy: Vec<f64> = rs.iter().map(|r| r.greedy_per_step).collect();
    let curve = |field: fn((f64, f64)) -> f64| -> Vec<(u64, MeanCi)> {
        (1..=g.cfg.steps / DIAGNOSTICS_EVERY)
            .filter_map(|i| {
                let t = i * DIAGNOSTICS_EVERY;
                let xs: Vec<f64> = rs.iter().filter_map(|r| delay_at(r, t).map(field)).collect();
                (!xs.is_empty()).then(|| (t, mean_ci(&xs)))
            })
            .collect()
    };
    // A learner whose delay pmf is estimated (not told; none for learners without one).
    let estimates = !setting.told && rs.iter().any(|r| r.delay_estimated);
    let (true_pmf, true_median, _) = truth(&setting.delay)?;
    let pmfs: Vec<Vec<f64>> = rs
        .iter()
        .filter_map(|r| {
            let p = r.delay_pmf.as_ref()?;
            p.get(..=50).map(<[f64]>::to_vec)
        })
        .collect();
    let pmf = if pmfs.is_empty() {
        Vec::new()
    } else {
        (0..=50).map(|k| pmfs.iter().map(|p| p[k]).sum::<f64>() / pmfs.len() as f64).collect()
    };
    let median_error_max = estimates
        .then(|| {
            rs.iter()
                .filter_map(|r| delay_at(r, JUDGE_AT))
                .map(|d| (d.0 - true_median).abs())
                .reduce(f64::max)
        })
        .flatten();
    let lobes = (estimates && setting.delay.starts_with("mix") && !pmfs.is_empty()).then(|| {
        let lo: Vec<f64> = pmfs.iter().map(|p| p[..LOBE_SPLIT].iter().sum()).collect();
        let hi: Vec<f64> = pmfs.iter().map(|p| p[LOBE_SPLIT..].iter().sum()).collect();
        (mean_ci(&lo), mean_ci(&hi))
    });
    let _ = true_pmf;
    let probes: Option<Vec<f64>> = rs.iter().map(|r| r.figure(mmq_learn::Figure::Probes)).collect();
    Ok(Outcome {
        setting: setting.clone(),
        n: rs.len(),
        relative: g.relative(),
        fraction: g.fraction(optimum),
        ceiling: crate::summary::ceiling_per_step(&g.cfg, world).map(|c| g.fraction_of_ceiling(c)),
        regret: g.regret(optimum),
        greedy: mean_ci(&greedy),
        greedy_min: greedy.iter().copied().fold(f64::INFINITY, f64::min),
        greedy_optimal: greedy.iter().filter(|&&x| x >= best - 1e-9).count(),
        seconds: mean_ci(&rs.iter().map(|r| r.wall_time_s).collect::<Vec<_>>()),
        median_curve: if estimates { curve(|d| d.0) } else { Vec::new() },
        mean_curve: if estimates { curve(|d| d.1) } else { Vec::new() },
        pmf,
        median_error_max,
        lobes,
        probes: probes.filter(|p| !p.is_empty()).map(|p| mean_ci(&p)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The spec runs the study the report lays out: every learner at λ ∈ LAMBDAS × ε ∈
    /// EPSILONS and at the other delays × OTHER_EPSILONS on both worlds, then the
    /// deconvolving learners told the pmf on 9×9, in that order and with the seeds the
    /// budget states.
    #[test]
    fn the_spec_runs_the_study_in_report_order() {
        use LearnerKind::*;
        let learners = [Q, Mmq, MmqKernel, QLambda, SarsaLambda, DeconvQ, DeconvModel, Oracle];
        const WORLDS: [&str; 2] = ["paper-9x9", "maze-15x15"];
        const LAMBDAS: [u32; 4] = [0, 5, 13, 25];
        const EPSILONS: [f64; 3] = [0.02, 0.05, 0.1];
        const OTHER_EPSILONS: [f64; 2] = [0.05, 0.1];
        let other_delays = DELAY_NAMES;
        let mut expected = Vec::new();
        let mut push = |world: &str, delay: &str, epsilon: f64, learner: LearnerKind, told: bool| {
            let delay_label = delay_label(delay);
            // The headline: ε 0.05 or 0.1, Poisson 13 or a non-Poisson delay, estimated.
            let headline = !told
                && OTHER_EPSILONS.contains(&epsilon)
                && (delay == "poisson:13" || other_delays.iter().any(|d| d.1 == delay));
            expected.push(Setting {
                world: world.into(),
                delay: delay.into(),
                delay_label,
                epsilon,
                learner,
                told,
                headline,
            });
        };
        for world in WORLDS {
            for l in LAMBDAS {
                for eps in EPSILONS {
                    for k in learners {
                        push(world, &format!("poisson:{l}"), eps, k, false);
                    }
                }
            }
            for (_, spec) in other_delays {
                for eps in OTHER_EPSILONS {
                    for k in learners {
                        push(world, spec, eps, k, false);
                    }
                }
            }
        }
        for spec in ["poisson:13"].into_iter().chain(other_delays.map(|d| d.1)) {
            for eps in OTHER_EPSILONS {
                for k in [DeconvQ, DeconvModel] {
                    push("paper-9x9", spec, eps, k, true);
                }
            }
        }
        use crate::study::Budget;
        let spec = Budget::default().spec(None, "paper-comparison").unwrap();
        let full = plan(&spec, &spec);
        let got: Vec<&Setting> = full.iter().map(|(s, _)| s).collect();
        assert_eq!(got, expected.iter().collect::<Vec<_>>());
        assert_eq!(seed_budget(&spec, &full), [20, 5, 5, 2]);
        let quick_spec = Budget { quick: true, ..Budget::default() }.spec(None, "paper-comparison").unwrap();
        let quick = plan(&quick_spec, &spec);
        assert_eq!(seed_budget(&quick_spec, &quick), [6, 2, 2, 1]);
        for ((s, ci), (_, qi)) in full.iter().zip(&quick) {
            let (c, q) = (spec.config(*ci), quick_spec.config(*qi));
            let (n9, headline) = (s.world == WORLDS[0], s.headline);
            let quick_seeds = [1, 2, 6][usize::from(n9) + usize::from(headline)];
            assert_eq!(quick_spec.plan.seeds_of(*qi).len(), quick_seeds, "{s:?}");
            let want = match (n9, headline) {
                (true, true) => 20,
                (true, false) | (false, true) => 5,
                (false, false) => 2,
            };
            assert_eq!(spec.plan.seeds_of(*ci).len(), want, "{s:?}");
            c.validate().unwrap();
            // The learner as the study states it: α 0.1, γ 0.9, the setting's ε, q0 10,
            // every setting at its default but the pmf the ablation is told.
            let params = mmq_learn::spec::Params { alpha: 0.1, gamma: 0.9, epsilon: s.epsilon, q0: 10.0 };
            let mut learner = mmq_learn::LearnerSpec { params, ..mmq_learn::LearnerSpec::new(s.learner) };
            if let Some(d) = learner.settings.deconv_mut() {
                d.told_delay = s.told.then(|| s.delay.clone());
            }
            assert_eq!(c.learner, learner);
            assert_eq!(
                (c.env, c.baseline, c.save_tables, c.ledger),
                (crate::EnvKind::Grid, true, false, false)
            );
            assert_eq!(
                (c.steps, c.window, c.eval_steps, c.learner.params.q0),
                (150_000, 2500, 1000, 10.0),
                "{s:?}"
            );
            assert_eq!((q.steps, q.window), (30_000, 1000));
        }
        for (_, spec) in DELAY_NAMES {
            let (p, med, _) = truth(spec).unwrap();
            assert!((p.iter().sum::<f64>() - 1.0).abs() < 1e-9 && med > 0.0);
        }
        let (_, med, mean) = truth("uniform:0:26").unwrap();
        assert!((med - 13.0).abs() < 1e-9 && (mean - 13.0).abs() < 1e-9);
    }

    #[test]
    fn optimal_greedy_score_counts_whole_goals() {
        let w = World::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../worlds/paper-9x9.toml")).unwrap();
        assert!((optimal_greedy_score(&w, 1000) - 0.58).abs() < 1e-12);
    }
}
