//! The suite's reference agent, `grid-optimal`: the world MDP's optimal policy (value
//! iteration on the grid, [`mmq_core::optimum()`]) executed on each task's environment,
//! without learning. On the grid it earns the optimum (less its exploration); on a robot
//! it earns what the grid's best plan is worth once primitives slip, take longer, or end
//! in another cell than planned, so a learner's fraction of it separates the robot's own
//! losses from the learner's.
//!
//! It runs through the sweep engine like any agent (same seeds, budgets, delays and
//! evaluation), so its results file has the same form:
//!
//! - while "learning" it acts ε-greedily around the optimal policy with the task's ε
//!   (ties among optimal actions at random): the ε-soft reference, the ceiling of an
//!   ε-greedy learner that knew the optimal policy from the first step;
//! - its greedy evaluation is the optimal policy itself (1,000 steps from S, as every
//!   agent's), the reference of `greedy_fraction_of_optimum`.
//!
//! The shipped references (`worlds/suites/<version>/reference-<tier>.json`) were made by
//! `mmq suite reference`; the leaderboard reads them when no reference file is given.

use std::path::Path;

use mmq_core::Optimum;
use mmq_learn::Learner;

use super::{Suite, SuiteResults, SuiteRun};
use crate::error::LabError;
pub use crate::grid_optimal::{GridOptimal, NAME};
use crate::sweep::SweepSpec;

/// Shipped references: (suite, tier, the results file's text).
const SHIPPED: &[(&str, &str, &str)] = &[
    ("v1", "lite", include_str!("../../../../worlds/suites/v1/reference-lite.json")),
    ("v1", "full", include_str!("../../../../worlds/suites/v1/reference-full.json")),
];

/// The reference agent of every cell of `spec` (a tier's [`Suite::external_spec`]): the
/// optimum of each cell's world is computed once, here.
pub fn learners(
    spec: &SweepSpec,
) -> impl Fn(usize, usize, usize, u64) -> Result<Box<dyn Learner>, LabError> + Sync {
    let cells: Vec<(Optimum, f64, String)> = (0..spec.plan.cells.len())
        .map(|c| {
            let cfg = spec.config(c);
            (mmq_core::optimum(spec.world(c)), cfg.learner.params.epsilon, cfg.world.display().to_string())
        })
        .collect();
    move |cell: usize, n_states: usize, n_actions: usize, _seed: u64| {
        let (optimum, epsilon, world) = &cells[cell];
        Ok(Box::new(GridOptimal::new(optimum, *epsilon, n_states, n_actions, world)?) as Box<dyn Learner>)
    }
}

impl Suite {
    /// The sweep spec and the run record of the reference on `tier`.
    pub fn reference_spec(&self, tier: &str) -> Result<(SweepSpec, SuiteRun), LabError> {
        let spec = self.external_spec(tier, NAME)?;
        let run = SuiteRun {
            suite: self.version.clone(),
            tier: tier.into(),
            agent: NAME.into(),
            tasks: self.task_names(),
            subset: false,
        };
        Ok((spec, run))
    }
}

/// The shipped reference of `suite` on `tier`, if there is one.
pub fn shipped(suite: &str, tier: &str) -> Option<SuiteResults> {
    let (_, _, text) = SHIPPED.iter().find(|s| s.0 == suite && s.1 == tier)?;
    let file = format!("worlds/suites/{suite}/reference-{tier}.json");
    super::results::parse_results(text, Path::new(&file)).ok()
}

/// Whether a results file is the reference's.
pub fn is_reference(r: &SuiteResults) -> bool {
    r.agent == NAME
}

#[cfg(test)]
mod tests {
    use super::*;
    use mmq_core::World;
    use mmq_core::seed::rng_from_seed;

    fn paper() -> (World, Optimum) {
        let w = World::load("paper-9x9").unwrap();
        let o = mmq_core::optimum(&w);
        (w, o)
    }

    /// Greedy, it takes only optimal actions, each of a tie about equally often; with
    /// ε = 1 it takes every action about equally often.
    #[test]
    fn acts_by_the_optimal_policy() {
        let (w, o) = paper();
        let mut agent = GridOptimal::new(&o, 0.0, w.num_cells(), 4, "paper-9x9").unwrap();
        let mut rng = rng_from_seed(3);
        let tie = (0..w.num_cells()).find(|&c| o.actions[c].count_ones() == 2).expect("a cell with a tie");
        let mut counts = [0usize; 4];
        for s in w.free_cells() {
            for _ in 0..50 {
                let d = agent.act(s, &mut rng);
                assert!(o.is_optimal(s, d.action) && !d.explored, "cell {s}");
                assert!(o.is_optimal(s, agent.greedy(s, &mut rng)));
            }
        }
        for _ in 0..4_000 {
            counts[agent.greedy(tie, &mut rng)] += 1;
        }
        for (a, &n) in counts.iter().enumerate() {
            if o.is_optimal(tie, a) {
                assert!((n as f64 - 2_000.0).abs() < 200.0, "{counts:?}");
            } else {
                assert_eq!(n, 0);
            }
        }
        let mut wild = GridOptimal::new(&o, 1.0, w.num_cells(), 4, "paper-9x9").unwrap();
        let mut counts = [0usize; 4];
        for _ in 0..4_000 {
            let d = wild.act(tie, &mut rng);
            assert!(d.explored);
            counts[d.action] += 1;
        }
        assert!(counts.iter().all(|&n| (n as f64 - 1_000.0).abs() < 150.0), "{counts:?}");
        let mut v = [0.0; 4];
        agent.action_values(tie, &mut v);
        assert_eq!(v.iter().sum::<f64>(), 2.0);
    }

    /// An environment whose states or actions are not the grid's is refused, naming the
    /// robot's action set.
    #[test]
    fn refuses_other_state_spaces() {
        let (w, o) = paper();
        let e = GridOptimal::new(&o, 0.0, w.num_cells() * 4, 3, "paper-9x9").unwrap_err().to_string();
        assert!(e.contains("robot.actions") && e.contains("moves"), "{e}");
    }

    /// The shipped `lite` reference is what the reference agent earns now, to the last
    /// digit, on a grid task and the realistic robot.
    #[test]
    fn the_shipped_lite_reference_is_reproduced() {
        let names = ["paper-9x9-poisson13".to_string(), "robot-realistic-9x9-poisson13".to_string()];
        let suite = Suite::builtin("v1").unwrap().only(&names).unwrap();
        let (spec, mut run) = suite.reference_spec("lite").unwrap();
        run.subset = true;
        let dir = tempfile::tempdir().unwrap();
        run.claim(dir.path()).unwrap();
        let stop = std::sync::atomic::AtomicBool::new(false);
        let ctl = crate::Control { stop: &stop, progress: &|_| {} };
        let f = learners(&spec);
        crate::sweep::run_sweep_with(&spec, dir.path(), None, ctl, &|_| {}, Some(&f)).unwrap();
        let now = super::super::results_of_dir(dir.path()).unwrap();
        let shipped = shipped("v1", "lite").unwrap();
        for t in &now.tasks {
            let s = shipped.tasks.iter().find(|x| x.task == t.task).unwrap();
            assert_eq!(t.seeds, s.seeds, "{}", t.task);
        }
    }

    /// The shipped references parse, are the reference's and cover every task of their
    /// suite and tier with the tier's seeds.
    #[test]
    fn shipped_references_cover_their_tiers() {
        let s = Suite::builtin("v1").unwrap();
        for tier in super::super::TIERS {
            let r = shipped("v1", tier).expect("a shipped reference");
            assert!(is_reference(&r) && r.complete && r.tier == tier);
            assert_eq!(r.tasks.iter().map(|t| t.task.clone()).collect::<Vec<_>>(), s.task_names());
            for t in &r.tasks {
                assert!(t.seeds.iter().all(|x| !x.failed && x.fraction_of_optimum.is_some()), "{}", t.task);
            }
        }
    }
}
