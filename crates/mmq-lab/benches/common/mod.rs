//! What the benches of mmq-lab share: one seed of `mmq run` through the runner's own
//! entry point ([`mmq_lab::run_seed`]), on a thread pool of a chosen size.
//!
//! A bench run is the learning trajectory alone: `baseline = false` (no undelayed
//! Q-learning), `eval_steps = 0` (no greedy evaluation), `save_tables = false`. Everything
//! else is what a seed of `mmq run` does: the runner's [`mmq_lab::stepper::Stepper`] with
//! its metrics (visits, events, learning-curve rows every `window` steps, diagnostics
//! samples), then the policy maps. The pool's size is the number of threads the runner
//! believes it runs seeds on: 1 leaves the learner no spare core, 2 lends it the second
//! (`mmq_learn::spare`), as one seed of `mmq run` gets on a 2-core machine.

#![allow(dead_code)] // each bench uses part of it

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use mmq_lab::{Control, Resolved, RunConfig, run_seed};
use mmq_learn::LearnerSpec;

/// Memory the learner's tables may take (the runner refuses a learner that needs more).
const MEM_LIMIT: u128 = 1 << 33;

/// The path of `worlds/NAME.toml` in the repository.
pub fn world_path(name: &str) -> PathBuf {
    PathBuf::from(format!("{}/../../worlds/{name}.toml", env!("CARGO_MANIFEST_DIR")))
}

/// One seed's configuration: `learner` on the world `world` under Poisson(13) delays,
/// `steps` decision steps, seed 1, no baseline, no greedy evaluation, no tables.
pub fn config(world: &str, learner: LearnerSpec, steps: u64) -> RunConfig {
    RunConfig {
        world: world_path(world),
        learner,
        delay: "poisson:13".into(),
        steps,
        seed: 1,
        seeds: 1,
        baseline: false,
        eval_steps: 0,
        save_tables: false,
        ..RunConfig::default()
    }
}

/// A configuration resolved (world loaded, delay parsed), and the pool it runs on.
#[derive(Debug)]
pub struct Seed {
    pub run: Resolved,
    pool: rayon::ThreadPool,
}

impl Seed {
    /// `cfg`, checked, on a pool of `threads` threads (1: no spare core for the learner).
    pub fn new(cfg: RunConfig, threads: usize) -> Self {
        let run = Resolved::new(cfg).expect("a valid bench configuration");
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("a thread pool");
        Seed { run, pool }
    }

    /// Runs the seed to its end through [`run_seed`]; returns the reward earned.
    pub fn run(&self) -> f64 {
        let stop = AtomicBool::new(false);
        let ctl = Control { stop: &stop, progress: &|_| {} };
        let r = self.pool.install(|| {
            run_seed(&self.run, self.run.cfg().seed, None, ctl, MEM_LIMIT).expect("the bench's run")
        });
        assert!(r.complete, "the bench's run ended early: {:?}", r.failure);
        r.run.earned_total
    }
}
