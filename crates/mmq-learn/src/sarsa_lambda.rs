//! `sarsa-lambda`: SARSA(λ) with replacing eligibility traces (Sutton & Barto 1998,
//! §7.5). The trace decay is called `trace_decay` (β below), not to be confused with
//! the delay λ.
//!
//! ```text
//! δ_t = r_t + γ Q(s_{t+1}, a_{t+1}) − Q(s_t, a_t)
//! e(s_t, a_t) ← 1
//! Q(s, a) ← Q(s, a) + α δ_t e(s, a),   e(s, a) ← γ β e(s, a)     for every (s, a)
//! ```
//!
//! δ_t needs a_{t+1}, which is chosen after step t is observed, so the update of step t
//! is made when step t + 1 is observed (its action is a_{t+1}); the last step of a run
//! is never learned. On-policy: exploratory actions do not cut the traces.

use mmq_core::{Action, State};

use crate::diagnostics::Diagnostics;
use crate::diagnostics::Figure;
use crate::learner::{Experience, Learner};
use crate::memory::Memory;
use crate::params::Params;
use crate::q_lambda::Traces;
use crate::table::{QTable, q_table_methods};

/// SARSA(λ).
#[derive(Clone, Debug)]
pub struct SarsaLambda {
    p: Params,
    trace_decay: f64,
    q: QTable,
    traces: Traces,
    /// Step t waiting for a_{t+1}: (s_t, a_t, r_t, s_{t+1}).
    pending: Option<(u32, u32, f64, u32)>,
}

impl SarsaLambda {
    /// A table for `num_states` × `num_actions`, every entry q0.
    pub fn new(p: Params, trace_decay: f64, num_states: usize, num_actions: usize) -> Self {
        Self {
            p,
            trace_decay,
            q: QTable::new(num_states, num_actions, p.q0),
            traces: Traces::default(),
            pending: None,
        }
    }

    /// Q(s, a).
    pub fn q(&self, s: State, a: Action) -> f64 {
        self.q.get(s, a)
    }
}

impl Learner for SarsaLambda {
    fn name(&self) -> &'static str {
        "sarsa-lambda"
    }

    fn observe(&mut self, e: &Experience<'_>) {
        let (alpha, gamma) = (self.p.alpha, self.p.gamma);
        if let Some((s, a, r, s2)) = self.pending.take() {
            if s2 as usize == e.state {
                let i = self.q.index(s as usize, a as usize);
                let next = self.q.get(e.state, e.action);
                let delta = r + gamma * next - self.q[i];
                self.traces.replace(i);
                self.traces.apply(&mut self.q, alpha * delta);
                self.traces.decay(gamma * self.trace_decay);
            } else {
                self.traces.clear();
            }
        }
        self.pending = Some((e.state as u32, e.action as u32, e.reward, e.next_state as u32));
    }

    q_table_methods!(q, tables, act(p));

    fn diagnostics(&self) -> Diagnostics {
        Diagnostics { figures: vec![(Figure::TraceDecay, self.trace_decay)], ..Diagnostics::default() }
    }

    fn reset_history(&mut self) {
        self.pending = None;
        self.traces.clear();
    }

    fn shares_tables(&self) -> bool {
        true
    }

    fn swap_memory(&mut self, other: &mut Memory) {
        let mut mine = (std::mem::take(&mut self.traces), self.pending.take());
        other.swap_with(&mut mine, || (Traces::default(), None));
        (self.traces, self.pending) = mine;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learner::exp;

    /// α = 0.5, γ = 0.5, β = 0.5 (γβ = 0.25), q0 = 0, 3 states × 2 actions.
    #[test]
    fn sarsa_lambda_by_hand() {
        let p = Params { alpha: 0.5, gamma: 0.5, epsilon: 0.0, q0: 0.0 };
        let mut l = SarsaLambda::new(p, 0.5, 3, 2);
        // t = 0: (0,0) → 1, r = 2: waits for a_1.
        l.observe(&exp(0, 0, 0, 1, 2.0));
        assert!(l.q.iter().all(|&x| x == 0.0));
        // t = 1: a_1 = 1. Step 0: δ = 2 + 0.5·Q(1,1)=0 − 0 = 2; Q(0,0) += 0.5·2 = 1.
        //   Trace (0,0) → 0.25. Step 1 ((1,1) → 2, r = 0) waits.
        l.observe(&exp(1, 1, 1, 2, 0.0));
        assert_eq!(l.q(0, 0), 1.0);
        // t = 2: a_2 = 0 in state 2. Step 1: δ = 0 + 0.5·Q(2,0)=0 − Q(1,1)=0 = 0: nothing.
        //   Traces (0,0) 0.0625, (1,1) 0.25. Step 2 ((2,0) → 0, r = 4) waits.
        l.observe(&exp(2, 2, 0, 0, 4.0));
        assert_eq!((l.q(0, 0), l.q(1, 1)), (1.0, 0.0));
        // t = 3: a_3 = 0 in state 0 (the next action's own value, not the max):
        //   Step 2: δ = 4 + 0.5·Q(0,0)=1 − Q(2,0)=0 = 4.5; step α δ = 2.25:
        //   Q(2,0) += 2.25·1 = 2.25; Q(1,1) += 2.25·0.25 = 0.5625;
        //   Q(0,0) += 2.25·0.0625 = 0.140625 → 1.140625.
        l.observe(&exp(3, 0, 0, 1, 0.0));
        assert_eq!((l.q(2, 0), l.q(1, 1), l.q(0, 0)), (2.25, 0.5625, 1.140625));
    }

    /// A step whose successor is not the next observed state (a new run) is dropped.
    #[test]
    fn broken_chain_is_not_learned() {
        let p = Params { alpha: 0.5, gamma: 0.5, epsilon: 0.0, q0: 0.0 };
        let mut l = SarsaLambda::new(p, 0.5, 3, 2);
        l.observe(&exp(0, 0, 0, 1, 2.0));
        l.observe(&exp(1, 2, 1, 2, 0.0)); // s_1 = 2 ≠ s'_0 = 1
        assert!(l.q.iter().all(|&x| x == 0.0));
    }
}
