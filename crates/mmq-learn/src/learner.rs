//! The core types every learner shares: the [`Learner`] trait, what it decides
//! ([`Decision`]), what it learns from ([`Experience`], and the oracle's [`Truth`]), the
//! tables it exports ([`Table`]), and `max_of`.

use mmq_core::{Action, Rng, State};

use crate::diagnostics::Diagnostics;
use crate::memory::Memory;

/// What the learner decided in a state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Decision {
    /// The action to take.
    pub action: Action,
    /// The delay model acted on (MMQ's λ̂*), if the learner has models and acted greedily.
    pub model: Option<usize>,
    /// True when the action was drawn by ε-exploration.
    pub explored: bool,
}

/// Ground truth the channel and the environment know; only diagnostics read it (the
/// oracle learner, and `deconv-model` told the true cells).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Truth {
    /// The reward emitted at this step, if it was non-zero (it is in flight now).
    pub emitted_now: Option<f64>,
    /// Emissions delivered at this step: (emission step, value).
    pub delivered: Vec<(u64, f64)>,
    /// The true cell at the step's start and at its end, where the state is a belief
    /// that can be wrong (the robot's; None elsewhere).
    pub true_state: Option<State>,
    pub true_next_state: Option<State>,
}

/// One step as the learner sees it.
#[derive(Clone, Copy, Debug)]
pub struct Experience<'a> {
    /// Decision step t (0, 1, 2, ...; consecutive).
    pub t: u64,
    /// s_t.
    pub state: State,
    /// a_t.
    pub action: Action,
    /// s_{t+1} (s').
    pub next_state: State,
    /// r_t: the reward delivered at t (a sum of delayed emissions, maybe 0).
    pub reward: f64,
    /// Simulated time at the end of step t, seconds since the run started (the robot's
    /// physical clock; the grid's t × its nominal step period). Learners that count
    /// steps ignore it.
    pub time_s: f64,
    /// Ground truth, given only to learners whose [`Learner::needs_truth`] is true.
    pub truth: Option<&'a Truth>,
}

/// A named table of numbers for export (shape in C order).
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    /// File stem, e.g. `q` for `q.npy`.
    pub name: String,
    /// Dimensions, e.g. [states, models, actions].
    pub shape: Vec<usize>,
    /// Data in C order.
    pub data: Vec<f64>,
}

/// A learning agent for the continuing task.
pub trait Learner: Send + std::fmt::Debug {
    /// Short name (as on the command line).
    fn name(&self) -> &'static str;
    /// Chooses the action in `state` (ε-greedy, ties at random).
    fn act(&mut self, state: State, rng: &mut Rng) -> Decision;
    /// Learns from one step.
    fn observe(&mut self, exp: &Experience<'_>);
    /// The greedy action (no exploration; ties at random).
    fn greedy(&self, state: State, rng: &mut Rng) -> Action;
    /// The action values the policy acts on in `state` (MMQ: those of its best model).
    fn action_values(&self, state: State, out: &mut [f64]);
    /// The Q-tables, for export.
    fn tables(&self) -> Vec<Table>;
    /// Whether the learner must be given [`Truth`] (only the oracle).
    fn needs_truth(&self) -> bool {
        false
    }
    /// What the learner reports about itself now: named figures and its delay estimate
    /// (callers sample it on a schedule for a time series).
    fn diagnostics(&self) -> Diagnostics {
        Diagnostics::default()
    }
    /// Starts a new run: clears memories of past steps (tables are kept).
    fn reset_history(&mut self) {}
    /// Whether several trajectories can learn into this learner's tables, each with its
    /// own memory of past steps ([`Self::swap_memory`]; parameter sharing). False for a
    /// learner whose statistics are built from one trajectory's consecutive steps.
    fn shares_tables(&self) -> bool {
        false
    }
    /// Exchanges the learner's memory of the current trajectory (what
    /// [`Self::reset_history`] clears) with `other`, another trajectory's (empty: one
    /// that has not started). Tables and estimates stay. Does nothing when
    /// [`Self::shares_tables`] is false.
    fn swap_memory(&mut self, other: &mut Memory) {
        let _ = other;
    }
    /// Why the learner cannot go on, if it cannot: an agent from outside mmq (a Python
    /// object, say) that raised or answered with an action out of range. The runner checks
    /// it before every step and ends the seed as failed with this text. mmq's own learners
    /// never fail.
    fn failure(&self) -> Option<String> {
        None
    }
}

/// Maximum of a slice (NaN-free values).
#[inline]
pub(crate) fn max_of(xs: &[f64]) -> f64 {
    xs.iter().copied().fold(f64::NEG_INFINITY, f64::max)
}

/// Test helper: the experience of step `t`, (s, a) → s2 with delivered reward `r`, no truth.
#[cfg(test)]
pub(crate) fn exp(t: u64, s: State, a: Action, s2: State, r: f64) -> Experience<'static> {
    Experience { t, state: s, action: a, next_state: s2, reward: r, time_s: (t + 1) as f64, truth: None }
}
