//! What one seed's run is steered by and gives back: the stop flag and progress
//! callback ([`Control`]), how a job's observer and learner are made, and the results
//! (the [`Trajectory`] of learning with its curve rows and diagnostics samples, and the
//! whole [`SeedResult`]). Shared by the runner, the step loop, the executor and the
//! sweep engine; it uses none of them.

use std::sync::atomic::{AtomicBool, Ordering};

use mmq_core::{Env, Observer};
use mmq_learn::policy::probabilistic;
use mmq_learn::{Diagnostics, Learner, Table};
use serde::{Deserialize, Serialize};

use crate::error::LabError;

/// How a run is steered from outside: a stop flag (Ctrl-C) and a progress callback.
#[derive(Clone, Copy)]
pub struct Control<'a> {
    /// Set to stop every seed at its next check (every 1024 steps).
    pub stop: &'a AtomicBool,
    /// Called with the number of decision steps just completed (in chunks).
    pub progress: &'a (dyn Fn(u64) + Sync),
}

impl std::fmt::Debug for Control<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Control").field("stop", &self.stop.load(Ordering::Relaxed)).finish()
    }
}

/// Builds a per-seed observer (an MCAP recorder, say), or none.
pub type ObserverFactory<'a> = dyn Fn(u64) -> Result<Option<Box<dyn Observer + Send>>, LabError> + Sync + 'a;

/// Builds the learner of one seed in place of the configuration's: called with the
/// numbers of states and actions of the environment and the master seed. This is how a
/// learner that is not built from a name (one of another crate, an agent in Python) runs
/// a job; its [`Learner::failure`] ends the seed as failed.
pub type LearnerFactory<'a> = dyn Fn(usize, usize, u64) -> Result<Box<dyn Learner>, LabError> + Sync + 'a;

/// Progress is reported every this many steps.
pub(crate) const CHECK_EVERY: u64 = 1024;

/// Steps between two samples of the learner's diagnostics during learning.
pub const DIAGNOSTICS_EVERY: u64 = 10_000;

/// The learner's diagnostics after `step` steps of learning (sampled right after the
/// learner observed its `step`-th step).
#[derive(Clone, Debug, PartialEq)]
pub struct DiagnosticsSample {
    /// Steps learned from.
    pub step: u64,
    /// What the learner reported then.
    pub diagnostics: Diagnostics,
}

/// One row of a learning curve: totals over the window ending at `step`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CurveRow {
    /// Steps completed at the end of the window.
    pub step: u64,
    /// Reward emitted in the window.
    pub earned: f64,
    /// Reward delivered in the window.
    pub received: f64,
    /// Reward emitted since the start.
    pub earned_cum: f64,
    /// Reward delivered since the start.
    pub received_cum: f64,
}

/// What one learning trajectory produced.
#[derive(Clone, Debug, Default)]
pub struct Trajectory {
    /// Steps completed (less than asked when interrupted).
    pub steps_done: u64,
    /// Total reward emitted.
    pub earned_total: f64,
    /// Total reward delivered.
    pub received_total: f64,
    /// Counts of step outcomes: moved, wall, goal, timeout.
    pub events: [u64; 4],
    /// The learning curve.
    pub curve: Vec<CurveRow>,
    /// Visits of every state during learning.
    pub visits: Vec<u64>,
    /// The delays of the rewards delivered (steps and seconds).
    pub delays: mmq_core::channel::DelayStats,
    /// Simulated time at the end of the last step, seconds.
    pub sim_time_s: f64,
    /// The learner's diagnostics every [`DIAGNOSTICS_EVERY`] steps (none for a learner
    /// that reports none).
    pub diagnostics: Vec<DiagnosticsSample>,
}

/// The result of one seed.
#[derive(Clone, Debug)]
pub struct SeedResult {
    /// Master seed.
    pub seed: u64,
    /// Whether all steps ran (false after Ctrl-C).
    pub complete: bool,
    /// The learner's trajectory under delay.
    pub run: Trajectory,
    /// Average reward per step of the greedy policy from `S` (no exploration, no updates).
    pub greedy_per_step: f64,
    /// The first states of the greedy evaluation, from `S`.
    pub greedy_path: Vec<usize>,
    /// Greedy actions of every state as a bit set (all maximisers), 0 for blocked cells.
    pub policy_arrows: Vec<u8>,
    /// The probabilistic policy (normalised eq. 8) of every state.
    pub policy_probs: Vec<Vec<f64>>,
    /// max_a of the acting values per state (for value maps).
    pub values: Vec<f64>,
    /// The learner's diagnostics at the end of learning (its time series is in
    /// [`Trajectory::diagnostics`] of `run`).
    pub diagnostics: Diagnostics,
    /// Environment figures (robot physics).
    pub env_stats: Vec<(String, f64)>,
    /// The learner's tables (when asked for).
    pub tables: Vec<Table>,
    /// Undelayed Q-learning on the same world, seed and horizon (when asked for).
    pub baseline: Option<Trajectory>,
    /// Baseline greedy evaluation.
    pub baseline_greedy_per_step: Option<f64>,
    /// The reference `grid-optimal` on the same environment, seed and horizon (when
    /// asked for: [`crate::config::RunConfig::reference`]).
    pub reference: Option<Trajectory>,
    /// Wall-clock seconds of this seed.
    pub wall_time_s: f64,
    /// Wall-clock seconds of the learning run alone (no evaluation, no baseline).
    pub learn_time_s: f64,
    /// Why the seed failed: its learner gave up ([`Learner::failure`]: an agent from
    /// outside mmq raised, say), or some of its output was lost (its recording could not
    /// be written); such a seed is never complete.
    pub failure: Option<String>,
}

impl SeedResult {
    /// Relative performance (eq. 3 without its stray 1/t): cumulative earned reward under
    /// delay ÷ that of the undelayed baseline. Absent without a baseline, and where the
    /// baseline's cumulative earned reward is ≤ 0: a ratio to it has no meaning then.
    pub fn relative(&self) -> Option<f64> {
        let b = self.baseline.as_ref()?;
        (b.earned_total > 0.0).then(|| self.run.earned_total / b.earned_total)
    }

    /// Cumulative earned reward ÷ the reference's: the share of what the environment
    /// allows. Absent without a reference, and where the reference earned ≤ 0.
    pub fn fraction_of_reference(&self) -> Option<f64> {
        let r = self.reference.as_ref()?;
        (r.earned_total > 0.0).then(|| self.run.earned_total / r.earned_total)
    }

    /// Earned reward per step.
    pub fn earned_per_step(&self) -> f64 {
        self.run.earned_total / self.run.steps_done.max(1) as f64
    }
}

/// Deterministic (bit set of maximisers) and probabilistic policies per state, and
/// whether every state was visited (`stop()` is asked every 1,024 states; states after a
/// stop keep no arrow and a NaN value).
pub(crate) type Policy = (Vec<u8>, Vec<Vec<f64>>, Vec<f64>, bool);
pub(crate) fn policy_of<E: Env>(env: &E, learner: &dyn Learner, stop: &dyn Fn() -> bool) -> Policy {
    let n = env.num_states();
    let na = env.num_actions();
    let mut arrows = vec![0u8; n];
    let mut probs = vec![vec![0.0; na]; n];
    let mut values = vec![f64::NAN; n];
    let mut buf = vec![0.0; na];
    for s in 0..n {
        if s % 1024 == 0 && stop() {
            return (arrows, probs, values, false);
        }
        if !env.world().is_free(env.state_cell(s)) {
            continue;
        }
        learner.action_values(s, &mut buf);
        let m = buf.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        values[s] = m;
        for (a, &q) in buf.iter().enumerate().take(8) {
            if q == m {
                arrows[s] |= 1 << a;
            }
        }
        probs[s] = probabilistic(&buf);
    }
    (arrows, probs, values, true)
}
