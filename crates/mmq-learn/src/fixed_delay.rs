//! Q-learning with a fixed delay estimate λ̂, the paper's eq. (4):
//!
//! Q_{k+1}(s_{t−λ̂}, a_{t−λ̂}) ← Q_k(s_{t−λ̂}, a_{t−λ̂}) + α [ r_t + γ max_a Q_k(s'_{t−λ̂}, a) ]
//!                              − α [ Q_k(s_{t−λ̂}, a_{t−λ̂}) ]
//!
//! The reward received at t is credited to the pair from λ̂ steps ago (the mode of a
//! Poisson delay is near its mean). Steps t < λ̂ make no update.

use mmq_core::{Action, State};
use serde::{Deserialize, Serialize};

use crate::diagnostics::Diagnostics;
use crate::diagnostics::Figure;
use crate::learner::{Experience, Learner};
use crate::memory::Memory;
use crate::params::Params;
use crate::policy::greedy_value;
use crate::table::{QTable, q_table_methods};

/// Settings of `fixed`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FixedSettings {
    /// λ̂ of eq. (4), steps: the reward at t updates the pair from λ̂ steps ago. Default 13,
    /// the mean of the paper's Poisson delay (assumption: the paper states no value).
    pub lambda_hat: usize,
}

impl Default for FixedSettings {
    fn default() -> Self {
        Self { lambda_hat: 13 }
    }
}

/// Fixed-delay-estimate Q-learning.
#[derive(Clone, Debug)]
pub struct FixedDelayQ {
    p: Params,
    lambda_hat: usize,
    q: QTable,
    /// Last λ̂ + 1 transitions (s, a, s'), indexed by t mod (λ̂ + 1).
    history: Vec<(u32, u32, u32)>,
}

impl FixedDelayQ {
    /// A table for `num_states` × `num_actions` assuming delay `lambda_hat`.
    pub fn new(p: Params, lambda_hat: usize, num_states: usize, num_actions: usize) -> Self {
        Self {
            p,
            lambda_hat,
            q: QTable::new(num_states, num_actions, p.q0),
            history: vec![(0, 0, 0); lambda_hat + 1],
        }
    }

    /// Q(s, a).
    pub fn q(&self, s: State, a: Action) -> f64 {
        self.q.get(s, a)
    }
}

impl Learner for FixedDelayQ {
    fn name(&self) -> &'static str {
        "fixed"
    }

    fn observe(&mut self, e: &Experience<'_>) {
        let n = self.history.len();
        self.history[(e.t as usize) % n] = (e.state as u32, e.action as u32, e.next_state as u32);
        if (e.t as usize) < self.lambda_hat {
            return;
        }
        let (s, a, s2) = self.history[(e.t as usize - self.lambda_hat) % n];
        let (alpha, gamma) = (self.p.alpha, self.p.gamma);
        let m = greedy_value(self.q.row(s2 as usize));
        let i = self.q.index(s as usize, a as usize);
        let q = &mut self.q[i];
        // eq. (4), in the paper's order of terms
        *q = *q + alpha * (e.reward + gamma * m) - alpha * *q;
    }

    q_table_methods!(q, tables, act(p, model = lambda_hat));

    fn shares_tables(&self) -> bool {
        true
    }

    fn swap_memory(&mut self, other: &mut Memory) {
        let n = self.history.len();
        other.swap_with(&mut self.history, || vec![(0, 0, 0); n]);
    }

    fn diagnostics(&self) -> Diagnostics {
        Diagnostics { figures: vec![(Figure::LambdaHat, self.lambda_hat as f64)], ..Diagnostics::default() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learner::exp;

    /// λ̂ = 2: the reward received at t = 2 updates the pair of t = 0, with the max taken
    /// at that pair's own next state.
    #[test]
    fn eq4_by_hand() {
        let p = Params { alpha: 0.5, gamma: 0.9, epsilon: 0.0, q0: 0.0 };
        let mut l = FixedDelayQ::new(p, 2, 4, 2);
        l.observe(&exp(0, 0, 1, 1, 0.0)); // no update: t < λ̂
        l.observe(&exp(1, 1, 0, 2, 0.0)); // no update
        assert!(l.q.iter().all(|&x| x == 0.0));
        l.observe(&exp(2, 2, 1, 3, 10.0)); // Q(0,1) ← 0 + 0.5 (10 + 0.9·0) − 0.5·0 = 5
        assert_eq!(l.q(0, 1), 5.0);
        assert_eq!(l.q(2, 1), 0.0);
        // t = 3 credits t = 1: (s=1, a=0, s'=2). Q(1,0) ← 0 + 0.5 (−1 + 0.9·0) = −0.5
        l.observe(&exp(3, 3, 0, 0, -1.0));
        assert_eq!(l.q(1, 0), -0.5);
        // t = 4 credits t = 2: (2, 1, 3): Q(2,1) ← 0 + 0.5 (0 + 0.9·max Q(3,·)=0) = 0
        // t = 5 credits t = 3: (3, 0, 0): Q(3,0) ← 0 + 0.5 (2 + 0.9·5) = 3.25
        l.observe(&exp(4, 0, 1, 1, 0.0));
        l.observe(&exp(5, 1, 1, 1, 2.0));
        assert_eq!(l.q(3, 0), 3.25);
    }

    /// λ̂ = 0 is exactly Q-learning up to floating-point association of eq. (4) vs (2).
    #[test]
    fn zero_delay_estimate_is_q_learning() {
        let p = Params { alpha: 0.1, gamma: 0.9, epsilon: 0.0, q0: 0.0 };
        let mut f = FixedDelayQ::new(p, 0, 3, 2);
        let mut q = crate::qlearning::QLearning::new(p, 3, 2);
        let trace = [(0, 1, 1, 0.0), (1, 0, 2, -1.0), (2, 1, 0, 10.0), (0, 0, 1, 0.0), (1, 1, 2, 10.0)];
        for (t, &(s, a, s2, r)) in trace.iter().enumerate() {
            f.observe(&exp(t as u64, s, a, s2, r));
            q.observe(&exp(t as u64, s, a, s2, r));
        }
        for s in 0..3 {
            for a in 0..2 {
                assert!((f.q(s, a) - q.q(s, a)).abs() < 1e-12);
            }
        }
    }
}
