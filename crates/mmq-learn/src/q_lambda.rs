//! `q-lambda`: Watkins's Q(λ) with replacing eligibility traces (Sutton & Barto 1998,
//! §7.6; replacing traces, Singh & Sutton 1996). The trace decay is called
//! `trace_decay` (β below) so that it is not confused with the delay λ.
//!
//! ```text
//! δ_t = r_t + γ max_a' Q(s_{t+1}, a') − Q(s_t, a_t)
//! e(s_t, a_t) ← 1                                     (replacing trace)
//! Q(s, a) ← Q(s, a) + α δ_t e(s, a)          for every (s, a)
//! e(s, a) ← γ β e(s, a)                      for every (s, a)
//! e ← 0  if a_{t+1} is exploratory and not greedy in s_{t+1}   (Watkins's cut, at act)
//! ```
//!
//! Under delay, a reward delivered at t reaches the pair of k steps ago with weight
//! (γβ)^k — a fixed exponential guess at the delay, and the trace is cut at every
//! exploratory action.

use mmq_core::{Action, Rng, State};
use serde::{Deserialize, Serialize};

use crate::diagnostics::Diagnostics;
use crate::diagnostics::Figure;
use crate::error::{LearnError, bad};
use crate::learner::{Decision, Experience, Learner, max_of};
use crate::memory::Memory;
use crate::params::Params;
use crate::table::{QTable, q_table_methods};

/// Settings of `q-lambda` and `sarsa-lambda`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TraceSettings {
    /// Trace decay in [0, 1] (called λ in Sutton & Barto; named `trace_decay` here so
    /// that it is not confused with the Poisson delay λ). Default 0.9 (assumption).
    pub trace_decay: f64,
}

impl Default for TraceSettings {
    fn default() -> Self {
        Self { trace_decay: 0.9 }
    }
}

impl TraceSettings {
    pub(crate) fn validate(&self) -> Result<(), LearnError> {
        if !(0.0..=1.0).contains(&self.trace_decay) {
            return bad("trace_decay", self.trace_decay, "use a trace decay in [0, 1], e.g. 0.9");
        }
        Ok(())
    }
}

/// Traces below this are dropped (their effect is below 1e-6 of one update).
pub const TRACE_CUTOFF: f64 = 1e-6;

/// Sparse replacing eligibility traces over Q indices.
#[derive(Clone, Debug, Default)]
pub struct Traces {
    /// (index, e) of the live traces.
    live: Vec<(u32, f64)>,
}

impl Traces {
    /// e(i) ← 1.
    pub fn replace(&mut self, i: usize) {
        match self.live.iter_mut().find(|x| x.0 as usize == i) {
            Some(x) => x.1 = 1.0,
            None => self.live.push((i as u32, 1.0)),
        }
    }

    /// q(i) += step · e(i) for every live trace.
    pub fn apply(&self, q: &mut [f64], step: f64) {
        for &(i, e) in &self.live {
            q[i as usize] += step * e;
        }
    }

    /// e ← factor · e, dropping traces below [`TRACE_CUTOFF`].
    pub fn decay(&mut self, factor: f64) {
        self.live.iter_mut().for_each(|x| x.1 *= factor);
        self.live.retain(|x| x.1 >= TRACE_CUTOFF);
    }

    /// e ← 0.
    pub fn clear(&mut self) {
        self.live.clear();
    }

    /// The live traces.
    pub fn live(&self) -> &[(u32, f64)] {
        &self.live
    }
}

/// Watkins's Q(λ).
#[derive(Clone, Debug)]
pub struct QLambda {
    p: Params,
    trace_decay: f64,
    q: QTable,
    traces: Traces,
    /// Traces cut by exploratory actions.
    cuts: u64,
}

impl QLambda {
    /// A table for `num_states` × `num_actions`, every entry q0.
    pub fn new(p: Params, trace_decay: f64, num_states: usize, num_actions: usize) -> Self {
        Self {
            p,
            trace_decay,
            q: QTable::new(num_states, num_actions, p.q0),
            traces: Traces::default(),
            cuts: 0,
        }
    }

    /// Q(s, a).
    pub fn q(&self, s: State, a: Action) -> f64 {
        self.q.get(s, a)
    }

    /// The live traces.
    pub fn traces(&self) -> &Traces {
        &self.traces
    }
}

impl Learner for QLambda {
    fn name(&self) -> &'static str {
        "q-lambda"
    }

    fn act(&mut self, s: State, rng: &mut Rng) -> Decision {
        let (action, explored) = self.q.epsilon_greedy(s, self.p.epsilon, rng);
        let row = self.q.row(s);
        if explored && row[action] < max_of(row) {
            self.traces.clear();
            self.cuts += 1;
        }
        Decision { action, model: None, explored }
    }

    fn observe(&mut self, e: &Experience<'_>) {
        let (alpha, gamma) = (self.p.alpha, self.p.gamma);
        let i = self.q.index(e.state, e.action);
        let delta = e.reward + gamma * max_of(self.q.row(e.next_state)) - self.q[i];
        self.traces.replace(i);
        self.traces.apply(&mut self.q, alpha * delta);
        self.traces.decay(gamma * self.trace_decay);
    }

    q_table_methods!(q, tables);

    fn diagnostics(&self) -> Diagnostics {
        let figures = vec![(Figure::TraceDecay, self.trace_decay), (Figure::TraceCuts, self.cuts as f64)];
        Diagnostics { figures, ..Diagnostics::default() }
    }

    fn reset_history(&mut self) {
        self.traces.clear();
    }

    fn shares_tables(&self) -> bool {
        true
    }

    fn swap_memory(&mut self, other: &mut Memory) {
        other.swap_with(&mut self.traces, Traces::default);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learner::exp;
    use mmq_core::seed::rng_from_seed;

    /// α = 0.5, γ = 0.5, β = 0.5 (γβ = 0.25), q0 = 0, 3 states × 2 actions.
    #[test]
    fn watkins_by_hand() {
        let p = Params { alpha: 0.5, gamma: 0.5, epsilon: 0.0, q0: 0.0 };
        let mut l = QLambda::new(p, 0.5, 3, 2);
        // t = 0: (0,0) → 1, r = 0: δ = 0; e(0,0) = 1 → 0.25.
        l.observe(&exp(0, 0, 0, 1, 0.0));
        assert!(l.q.iter().all(|&x| x == 0.0));
        assert_eq!(l.traces().live(), &[(0, 0.25)]);
        // t = 1: (1,1) → 2, r = 4: δ = 4 + 0.5·0 − 0 = 4; e(1,1) = 1.
        //   Q(1,1) += 0.5·4·1 = 2;  Q(0,0) += 0.5·4·0.25 = 0.5. Traces → 0.0625, 0.25.
        l.observe(&exp(1, 1, 1, 2, 4.0));
        assert_eq!((l.q(1, 1), l.q(0, 0)), (2.0, 0.5));
        assert_eq!(l.traces().live(), &[(0, 0.0625), (3, 0.25)]);
        // t = 2: (2,0) → 0, r = −1: δ = −1 + 0.5·max Q(0,·)=0.5 − 0 = −0.75;
        //   Q(2,0) += 0.5·(−0.75)·1 = −0.375; Q(1,1) += 0.5·(−0.75)·0.25 = −0.09375 → 1.90625;
        //   Q(0,0) += 0.5·(−0.75)·0.0625 = −0.0234375 → 0.4765625.
        l.observe(&exp(2, 2, 0, 0, -1.0));
        assert_eq!((l.q(2, 0), l.q(1, 1), l.q(0, 0)), (-0.375, 1.90625, 0.4765625));
        // t = 3: revisit (2,0) → 0 with r = 0: replacing trace, e(2,0) = 1 (not 1.25).
        //   δ = 0 + 0.5·0.4765625 − (−0.375) = 0.61328125; Q(2,0) += 0.5·δ → −0.068359375.
        l.observe(&exp(3, 2, 0, 0, 0.0));
        assert_eq!(l.q(2, 0), -0.068359375);
    }

    /// An exploratory, non-greedy action cuts every trace; a greedy one keeps them.
    #[test]
    fn exploration_cuts_traces() {
        let p = Params { alpha: 0.5, gamma: 0.5, epsilon: 1.0, q0: 0.0 };
        let mut l = QLambda::new(p, 0.9, 2, 2);
        l.observe(&exp(0, 0, 0, 1, 2.0)); // Q(0,0) = 1, trace on (0,0)
        let mut rng = rng_from_seed(3);
        let mut cut = false;
        let mut kept = false;
        for _ in 0..64 {
            let live = !l.traces().live().is_empty();
            let d = l.act(0, &mut rng); // ε = 1: always exploratory
            if live && d.action == 1 {
                assert!(l.traces().live().is_empty(), "a non-greedy action must cut");
                cut = true;
            }
            if live && d.action == 0 {
                assert!(!l.traces().live().is_empty(), "the greedy action keeps traces");
                kept = true;
            }
            l.traces.replace(0);
        }
        assert!(cut && kept);
    }
}
