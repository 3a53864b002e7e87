//! The paper's experiments (Sections IV, V and VII), as data: every figure's settings,
//! their runs over seeds and the numbers behind each figure, with means and 95 %
//! intervals. Drawing, the CSV files and the report live in mmq-report. The same settings ship as sweep specs
//! (`worlds/sweeps/paper-*.toml`, tested equal).
//!
//! Parameters the paper leaves open, and our choices (docs/reproduction.md):
//! ε and q0 (Figs. 2–4: ε = 0.05, q0 = 10; Fig. 6: ε = 0.01, q0 = 20, with a sensitivity
//! table over three settings), the horizon (150,000 steps everywhere, as Fig. 4 states).

use std::path::{Path, PathBuf};

use mmq_core::stats::{MeanCi, mean_ci};
use mmq_core::{DelayDist, World};
use serde::{Deserialize, Serialize};

use crate::config::{EnvKind, RunConfig};
use crate::error::LabError;
use crate::exec::{Job, run_jobs_in_order};
use crate::runner::{Control, SeedResult, memory_limit, run_seed};
use crate::sweep::SweepSpec;

/// Options of `mmq paper`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PaperOptions {
    /// Seeds per setting.
    pub seeds: u64,
    /// Decision steps per seed.
    pub steps: u64,
    /// First master seed.
    pub seed: u64,
    /// Fidelity for Figs. 6–12.
    pub env: EnvKind,
    /// Directory holding the world files.
    pub worlds: PathBuf,
    /// Steps per curve point.
    pub window: u64,
    /// A folder of figure specs: a file there named as a shipped spec
    /// (`paper-fig6.toml`, ...) is run instead of the built-in copy, so that an edited
    /// copy gives the same figure and report section for the variant.
    #[serde(default)]
    pub specs: Option<PathBuf>,
}

impl PaperOptions {
    /// The paper's budget (150k steps, 20 seeds), or a quick smoke-test budget.
    pub fn new(quick: bool, env: EnvKind) -> Self {
        let (seeds, steps, window) = match (quick, env) {
            (false, EnvKind::Grid) => (20, 150_000, 2500),
            (false, EnvKind::Robot | EnvKind::Swarm) => (5, 150_000, 2500),
            (true, EnvKind::Grid) => (6, 30_000, 1000),
            (true, EnvKind::Robot | EnvKind::Swarm) => (2, 3000, 100),
        };
        Self { seeds, steps, seed: 0, env, worlds: PathBuf::from("worlds"), window, specs: None }
    }

    fn world(&self, name: &str) -> Result<World, LabError> {
        Ok(World::load(self.worlds.join(format!("{name}.toml")))?)
    }
}

/// A setting run over seeds, with its undelayed baseline attached to every seed.
#[derive(Clone, Debug)]
pub struct Group {
    /// The configuration (baseline = false; the baseline is run once per world and seed).
    pub cfg: RunConfig,
    /// Results in seed order, `baseline` filled in.
    pub results: Vec<SeedResult>,
}

impl Group {
    /// Per-seed relative performance at the end; absent (a NaN mean) unless every seed
    /// has one: where a baseline earned ≤ 0, a mean over the other seeds would mislead.
    pub fn relative(&self) -> MeanCi {
        let xs: Vec<f64> = self.results.iter().filter_map(SeedResult::relative).collect();
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

fn curve(results: &[SeedResult], f: impl Fn(&SeedResult, usize) -> Option<f64>) -> Vec<(u64, MeanCi)> {
    let Some(first) = results.first() else { return Vec::new() };
    (0..first.run.curve.len())
        .filter_map(|i| {
            let xs: Vec<f64> =
                results.iter().filter(|r| i < r.run.curve.len()).filter_map(|r| f(r, i)).collect();
            (!xs.is_empty()).then(|| (first.run.curve[i].step, mean_ci(&xs)))
        })
        .collect()
}

/// Runs many settings at once through the executor ([`crate::exec`]): every (setting,
/// seed) pair is one job in one parallel pool, each with the undelayed baseline of its
/// world, parameters, horizon and seed (computed once per distinct baseline); results
/// come back in setting and seed order. A seed the stop flag kept from starting is left
/// out of its group.
pub fn run_groups(cfgs: Vec<RunConfig>, ctl: Control<'_>) -> Result<Vec<Group>, LabError> {
    let worlds: Vec<World> = cfgs.iter().map(RunConfig::load_world).collect::<Result<_, _>>()?;
    let dists: Vec<DelayDist> = cfgs.iter().map(RunConfig::validate).collect::<Result<_, _>>()?;
    // The paper relates every setting to its baseline.
    let with_base: Vec<RunConfig> = cfgs.iter().map(|c| RunConfig { baseline: true, ..c.clone() }).collect();
    let mut jobs = Vec::new();
    let mut owner = Vec::new();
    for (g, c) in with_base.iter().enumerate() {
        for seed in c.seed_list() {
            jobs.push(Job { cfg: c, world: &worlds[g], dist: &dists[g], seed, learner: None });
            owner.push(g);
        }
    }
    let results = run_jobs_in_order(&jobs, None, ctl)?;
    let mut groups: Vec<Group> = cfgs.into_iter().map(|cfg| Group { cfg, results: Vec::new() }).collect();
    for (g, r) in owner.into_iter().zip(results) {
        if let Some(r) = r {
            groups[g].results.push(r);
        }
    }
    Ok(groups)
}

/// Total decision steps `run_groups` will take for `cfgs` (for progress bars): every
/// setting's seeds, and each distinct undelayed baseline once, as the executor runs it
/// (settings that differ only in their learner or delay share one).
pub fn total_steps(cfgs: &[RunConfig]) -> u64 {
    let mut baselines = std::collections::HashSet::new();
    let mut total = 0u64;
    for c in cfgs {
        total = total.saturating_add(c.steps.saturating_mul(c.seeds));
        for seed in c.seed_list() {
            if baselines.insert(crate::exec::BaselineKey::of(c, seed)) {
                total = total.saturating_add(c.steps);
            }
        }
    }
    total
}

/// The paper's budget, which the shipped figure specs state: steps per seed and steps
/// per curve point. `mmq paper --quick` or `--steps` scale every spec by the same factor
/// (the horizon study, whose spec runs four times as long, stays four times as long).
pub const PAPER_STEPS: u64 = 150_000;
/// Steps per curve point at [`PAPER_STEPS`].
pub const PAPER_WINDOW: u64 = 2500;

/// The paper's figures as sweep specs, shipped in the binary so that `mmq paper` runs
/// from any folder; the same files are in `worlds/sweeps/`, where `mmq sweep` runs them
/// and a copy with one line changed is the same study of a variant.
pub const SPECS: &[(&str, &str)] = &[
    ("paper-fig2", include_str!("../../../worlds/sweeps/paper-fig2.toml")),
    ("paper-fig3", include_str!("../../../worlds/sweeps/paper-fig3.toml")),
    ("paper-fig4", include_str!("../../../worlds/sweeps/paper-fig4.toml")),
    ("paper-fig6", include_str!("../../../worlds/sweeps/paper-fig6.toml")),
    ("paper-fig6-robot", include_str!("../../../worlds/sweeps/paper-fig6-robot.toml")),
    ("paper-horizon", include_str!("../../../worlds/sweeps/paper-horizon.toml")),
    ("paper-sensitivity", include_str!("../../../worlds/sweeps/paper-sensitivity.toml")),
    ("paper-comparison", include_str!("../../../worlds/sweeps/paper-comparison.toml")),
];

/// The settings of the figure spec `name` at the budget of `o`: one configuration per
/// cell, in the spec's cell order, each with `o`'s seeds; steps and curve windows are
/// the spec's scaled by `o.steps / PAPER_STEPS` and `o.window / PAPER_WINDOW`.
pub fn spec_configs(o: &PaperOptions, name: &str) -> Result<Vec<RunConfig>, LabError> {
    let spec = figure_spec(o.specs.as_deref(), name)?;
    Ok((0..spec.plan.cells.len())
        .map(|c| at_budget(spec.config(c), o.steps, o.window, o.seed, o.seeds))
        .collect())
}

/// The figure spec `name`: the file `name.toml` in `folder` when there is one (relative
/// world paths start from the folder), else the built-in copy.
pub fn figure_spec(folder: Option<&Path>, name: &str) -> Result<SweepSpec, LabError> {
    if let Some(d) = folder.filter(|d| !d.is_dir()) {
        return Err(LabError::Config {
            file: d.display().to_string(),
            message: "not a folder; give the folder that holds your copies of figure specs (e.g. an edited paper-fig6.toml)".into(),
        });
    }
    if let Some(file) = edited_spec(folder, name) {
        return SweepSpec::load(&file);
    }
    let text = SPECS.iter().find(|s| s.0 == name).map(|s| s.1).ok_or_else(|| LabError::Config {
        file: format!("{name}.toml"),
        message: format!(
            "no shipped figure spec of that name; the shipped ones: {}",
            SPECS.iter().map(|s| s.0).collect::<Vec<_>>().join(", ")
        ),
    })?;
    SweepSpec::parse(text, Path::new(&format!("{name}.toml")))
}

/// The file in `folder` that replaces the built-in figure spec `name`, if there is one.
pub fn edited_spec(folder: Option<&Path>, name: &str) -> Option<PathBuf> {
    folder.map(|d| d.join(format!("{name}.toml"))).filter(|f| f.exists())
}

/// The figure spec `name` as a message names it: the edited file in `folder`, or the
/// built-in copy.
pub fn spec_source(folder: Option<&Path>, name: &str) -> String {
    edited_spec(folder, name).map_or_else(|| format!("the built-in {name}.toml"), |f| f.display().to_string())
}

/// A spec cell's configuration at a budget: its steps and curve window scaled by
/// `steps / PAPER_STEPS` and `window / PAPER_WINDOW`, `seeds` seeds from `seed`, and no
/// baseline of its own (groups get theirs once per world and seed).
pub(crate) fn at_budget(cell: &RunConfig, steps: u64, window: u64, seed: u64, seeds: u64) -> RunConfig {
    let scale = |x: u64, by: u64, of: u64| (u128::from(x) * u128::from(by) / u128::from(of)) as u64;
    RunConfig {
        steps: scale(cell.steps, steps, PAPER_STEPS),
        window: scale(cell.window, window, PAPER_WINDOW),
        seed,
        seeds,
        baseline: false,
        ..cell.clone()
    }
}

/// Fig. 2: 3×3, plain Q-learning, relative performance vs Poisson mean λ = 0…20.
pub fn fig2_configs(o: &PaperOptions) -> Result<Vec<RunConfig>, LabError> {
    spec_configs(o, "paper-fig2")
}

/// Fig. 3: λ = 5, plain Q-learning over time on 3×3, 5×5, 9×9.
pub fn fig3_configs(o: &PaperOptions) -> Result<Vec<RunConfig>, LabError> {
    spec_configs(o, "paper-fig3")
}

/// Fig. 4: 9×9, λ = 17, fixed-delay Q with λ̂ = λ + i, i = −10…10.
pub fn fig4_configs(o: &PaperOptions) -> Result<Vec<RunConfig>, LabError> {
    spec_configs(o, "paper-fig4")
}

/// Fig. 6 (and 7–12): 9×9, λ = 13, λ̂max = 50, MMQ and Q-learning, on `o.env`.
pub fn fig6_configs(o: &PaperOptions) -> Result<Vec<RunConfig>, LabError> {
    spec_configs(o, if o.env == EnvKind::Robot { "paper-fig6-robot" } else { "paper-fig6" })
}

/// The horizon study: Fig. 6's MMQ run (grid) for several times its steps, so that
/// relative performance can be read at every horizon up to that.
pub fn horizon_configs(o: &PaperOptions) -> Result<Vec<RunConfig>, LabError> {
    spec_configs(o, "paper-horizon")
}

/// Sensitivity of Fig. 6 to the unstated ε and q0 (grid): the sensitivity spec's settings
/// and Fig. 6's, from the most exploring setting to Fig. 6's (q0 rising, ε falling),
/// each learner in its spec's order.
pub fn sensitivity_configs(o: &PaperOptions) -> Result<Vec<RunConfig>, LabError> {
    let grid = PaperOptions { env: EnvKind::Grid, ..o.clone() };
    let mut v = spec_configs(&grid, "paper-sensitivity")?;
    v.extend(spec_configs(&grid, "paper-fig6")?);
    // A stable sort: the learners of one setting keep their spec order.
    v.sort_by(|a, b| {
        let (pa, pb) = (a.learner.params, b.learner.params);
        pa.q0.total_cmp(&pb.q0).then(pb.epsilon.total_cmp(&pa.epsilon))
    });
    Ok(v)
}

/// The exact optimum of a paper world.
pub fn optimum_of(o: &PaperOptions, world: &str) -> Result<f64, LabError> {
    Ok(mmq_core::optimum(&o.world(world)?).gain)
}

/// A world of the paper by name.
pub fn world_of(o: &PaperOptions, world: &str) -> Result<World, LabError> {
    o.world(world)
}

/// One decision step as the reward-timing figure shows it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepRewards {
    /// Decision step t.
    pub t: u64,
    /// Reward the environment emitted at t.
    pub earned: f64,
    /// Reward the channel delivered at t.
    pub received: f64,
}

/// Keeps the last `keep` steps' rewards of a run.
#[derive(Debug)]
struct LastSteps {
    keep: usize,
    out: std::sync::Arc<std::sync::Mutex<std::collections::VecDeque<StepRewards>>>,
}

impl mmq_core::Observer for LastSteps {
    fn on_step(&mut self, rec: &mmq_core::StepRecord<'_>) {
        let mut q = self.out.lock().unwrap_or_else(|p| p.into_inner());
        if q.len() == self.keep {
            q.pop_front();
        }
        q.push_back(StepRewards { t: rec.t, earned: rec.emitted, received: rec.delivered });
    }
}

/// The per-step earned and received rewards of the last `keep` steps of `cfg`'s run with
/// `seed` (the same run, bit for bit, as that seed's in a group): where the delay shows.
pub fn last_steps(
    cfg: &RunConfig,
    seed: u64,
    keep: usize,
    ctl: Control<'_>,
) -> Result<Vec<StepRewards>, LabError> {
    let world = cfg.load_world()?;
    let dist = cfg.validate()?;
    let out = std::sync::Arc::new(std::sync::Mutex::new(std::collections::VecDeque::with_capacity(keep)));
    let observer = LastSteps { keep, out: out.clone() };
    let cfg = RunConfig { baseline: false, ..cfg.clone() };
    run_seed(&cfg, &world, &dist, seed, Some(Box::new(observer)), ctl, memory_limit(1))?;
    let q = out.lock().unwrap_or_else(|p| p.into_inner());
    Ok(q.iter().copied().collect())
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

    use super::*;

    /// The progress total is the steps the runs report: two settings that differ only in
    /// their delay share their seeds' baselines, which run (and count) once.
    #[test]
    fn the_progress_total_counts_shared_baselines_once() {
        let world =
            std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../worlds/paper-3x3.toml"));
        let base = RunConfig { world, steps: 2000, seeds: 2, window: 500, ..RunConfig::default() };
        let cfgs = vec![
            RunConfig { delay: "const:2".into(), ..base.clone() },
            RunConfig { delay: "poisson:3".into(), ..base },
        ];
        let done = AtomicU64::new(0);
        let progress = |n: u64| {
            done.fetch_add(n, Ordering::Relaxed);
        };
        let stop = AtomicBool::new(false);
        run_groups(cfgs.clone(), Control { stop: &stop, progress: &progress }).unwrap();
        assert_eq!(total_steps(&cfgs), 2 * 2 * 2000 + 2 * 2000);
        assert_eq!(total_steps(&cfgs), done.load(Ordering::Relaxed));
    }
}
