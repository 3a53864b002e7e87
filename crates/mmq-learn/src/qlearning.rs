//! Q-learning (Watkins), the paper's eq. (2):
//!
//! Q_{k+1}(s, a) ← Q_k(s, a) + α [ r + γ max_a' Q_k(s', a') − Q_k(s, a) ]
//!
//! r is whatever reward arrives at t — under a delay channel, rewards caused by earlier
//! actions. This is the paper's "single-model Q-learning (λ̂ = 0)".

use mmq_core::{Action, State};

use crate::learner::{Experience, Learner};
use crate::params::Params;
use crate::policy::greedy_value;
use crate::table::{QTable, q_table_methods};

/// Tabular Q-learning.
#[derive(Clone, Debug)]
pub struct QLearning {
    p: Params,
    q: QTable,
}

impl QLearning {
    /// A table for `num_states` × `num_actions`, every entry `p.q0`.
    pub fn new(p: Params, num_states: usize, num_actions: usize) -> Self {
        Self { p, q: QTable::new(num_states, num_actions, p.q0) }
    }

    /// Q(s, ·).
    #[inline]
    pub fn row(&self, s: State) -> &[f64] {
        self.q.row(s)
    }

    /// Q(s, a).
    pub fn q(&self, s: State, a: Action) -> f64 {
        self.q.get(s, a)
    }
}

impl Learner for QLearning {
    fn name(&self) -> &'static str {
        "q"
    }

    #[inline]
    fn observe(&mut self, e: &Experience<'_>) {
        let (alpha, gamma) = (self.p.alpha, self.p.gamma);
        let m = greedy_value(self.q.row(e.next_state));
        let i = self.q.index(e.state, e.action);
        let q = &mut self.q[i];
        // eq. (2)
        *q += alpha * (e.reward + gamma * m - *q);
    }

    q_table_methods!(q, tables, act(p));

    fn shares_tables(&self) -> bool {
        // No memory: every update reads only its own step.
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learner::exp;

    /// Two hand-computed updates of eq. (2) with α = 0.1, γ = 0.9, q0 = 0.
    #[test]
    fn eq2_by_hand() {
        let p = Params { alpha: 0.1, gamma: 0.9, epsilon: 0.0, q0: 0.0 };
        let mut l = QLearning::new(p, 3, 2);
        // Q(0,1) ← 0 + 0.1 (10 + 0.9·0 − 0) = 1
        l.observe(&exp(0, 0, 1, 1, 10.0));
        assert_eq!(l.q(0, 1), 1.0);
        // Q(2,0) ← 0 + 0.1 (−1 + 0.9·max(Q(0,·)) − 0) = 0.1 (−1 + 0.9) = −0.01
        l.observe(&exp(1, 2, 0, 0, -1.0));
        assert!((l.q(2, 0) - (-0.01)).abs() < 1e-15);
        // Q(0,1) ← 1 + 0.1 (0 + 0.9·max(Q(2,·)) − 1) with max(Q(2,·)) = 0: 1 − 0.1 = 0.9
        l.observe(&exp(2, 0, 1, 2, 0.0));
        assert!((l.q(0, 1) - 0.9).abs() < 1e-15);
    }

    #[test]
    fn greedy_follows_the_table_and_q0_initialises() {
        let p = Params { alpha: 0.5, gamma: 0.9, epsilon: 0.0, q0: 10.0 };
        let mut l = QLearning::new(p, 2, 4);
        assert_eq!(l.row(1), &[10.0; 4]);
        l.observe(&exp(0, 1, 2, 0, 0.0)); // Q(1,2) ← 10 + 0.5 (0 + 9 − 10) = 9.5
        assert_eq!(l.q(1, 2), 9.5);
        let mut rng = mmq_core::seed::rng_from_seed(0);
        for _ in 0..50 {
            assert_ne!(l.greedy(1, &mut rng), 2);
        }
    }
}
