//! `oracle`: Q-learning told the channel's ground truth — an **upper bound, not a real
//! agent**. It reads [`Truth`](crate::learner::Truth) (which emission fed which delivery), so
//! every delivered reward is credited to the exact transition that earned it, on
//! arrival:
//!
//! ```text
//! zero-reward transition (s, a, s') at t:     Q(s, a) ← Q(s, a) + α [ 0 + γ max Q(s', ·) − Q(s, a) ]   at t
//! emission v of (s, a, s') at t, due at t+d:  Q(s, a) ← Q(s, a) + α [ v + γ max Q(s', ·) − Q(s, a) ]   at t + d
//! ```
//!
//! A transition whose reward is in flight is not learned until the reward arrives. The
//! only thing the delay still costs the oracle is that lateness.

use std::collections::HashMap;

use mmq_core::{Action, State};

use crate::diagnostics::Diagnostics;
use crate::diagnostics::Figure;
use crate::learner::{Experience, Learner, max_of};
use crate::memory::Memory;
use crate::params::Params;
use crate::table::{QTable, q_table_methods};

/// Q-learning with true credit assignment (needs [`Truth`](crate::learner::Truth)).
#[derive(Clone, Debug)]
pub struct Oracle {
    p: Params,
    q: QTable,
    /// Transitions whose reward is in flight, by emission step: (s, a, s').
    pending: HashMap<u64, (u32, u32, u32)>,
    /// Rewards credited on arrival.
    credited: u64,
}

impl Oracle {
    /// A table for `num_states` × `num_actions`, every entry q0.
    pub fn new(p: Params, num_states: usize, num_actions: usize) -> Self {
        Self { p, q: QTable::new(num_states, num_actions, p.q0), pending: HashMap::new(), credited: 0 }
    }

    /// Q(s, a).
    pub fn q(&self, s: State, a: Action) -> f64 {
        self.q.get(s, a)
    }

    /// Transitions whose reward has not arrived yet.
    pub fn in_flight(&self) -> usize {
        self.pending.len()
    }

    #[inline]
    fn learn(&mut self, s: usize, a: usize, r: f64, s2: usize) {
        let (alpha, gamma) = (self.p.alpha, self.p.gamma);
        let m = max_of(self.q.row(s2));
        let i = self.q.index(s, a);
        let q = &mut self.q[i];
        *q += alpha * (r + gamma * m - *q);
    }
}

impl Learner for Oracle {
    fn name(&self) -> &'static str {
        "oracle"
    }

    fn observe(&mut self, e: &Experience<'_>) {
        let Some(truth) = e.truth else {
            // Without the ground truth the oracle is plain Q-learning (eq. 2); the
            // runner always gives it the truth since `needs_truth` is true.
            self.learn(e.state, e.action, e.reward, e.next_state);
            return;
        };
        if truth.emitted_now.is_some() {
            self.pending.insert(e.t, (e.state as u32, e.action as u32, e.next_state as u32));
        } else {
            self.learn(e.state, e.action, 0.0, e.next_state);
        }
        for &(t_emit, value) in &truth.delivered {
            if let Some((s, a, s2)) = self.pending.remove(&t_emit) {
                self.learn(s as usize, a as usize, value, s2 as usize);
                self.credited += 1;
            }
        }
    }

    q_table_methods!(q, tables, act(p));

    fn needs_truth(&self) -> bool {
        true
    }

    fn diagnostics(&self) -> Diagnostics {
        let figures =
            vec![(Figure::Credited, self.credited as f64), (Figure::InFlight, self.pending.len() as f64)];
        Diagnostics { figures, ..Diagnostics::default() }
    }

    fn reset_history(&mut self) {
        self.pending.clear();
    }

    fn shares_tables(&self) -> bool {
        true
    }

    fn swap_memory(&mut self, other: &mut Memory) {
        other.swap_with(&mut self.pending, HashMap::new);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learner::Truth;

    fn exp<'a>(t: u64, s: State, a: Action, s2: State, r: f64, truth: &'a Truth) -> Experience<'a> {
        Experience {
            t,
            state: s,
            action: a,
            next_state: s2,
            reward: r,
            time_s: (t + 1) as f64,
            truth: Some(truth),
        }
    }

    /// A hand-made ground truth: the +10 of t = 0 arrives at t = 2 together with the −1
    /// of t = 1 (overlapping, out of order); t = 3 earns nothing. α = 0.5, γ = 0.5, q0 = 0.
    #[test]
    fn credits_true_pairs_on_arrival() {
        let p = Params { alpha: 0.5, gamma: 0.5, epsilon: 0.0, q0: 0.0 };
        let mut l = Oracle::new(p, 4, 2);
        // t = 0: (0, 1) → 1 emits +10, nothing delivered: no update yet.
        let t0 = Truth { emitted_now: Some(10.0), delivered: vec![], ..Truth::default() };
        l.observe(&exp(0, 0, 1, 1, 0.0, &t0));
        assert!(l.q.iter().all(|&x| x == 0.0));
        assert_eq!(l.in_flight(), 1);
        // t = 1: (1, 0) → 2 emits −1; nothing delivered.
        let t1 = Truth { emitted_now: Some(-1.0), delivered: vec![], ..Truth::default() };
        l.observe(&exp(1, 1, 0, 2, 0.0, &t1));
        // t = 2: (2, 1) → 3 emits nothing: learned at once with r = 0:
        //   Q(2,1) ← 0 + 0.5 (0 + 0.5·max Q(3,·)=0 − 0) = 0.
        // Delivered 9 = (t=1, −1) + (t=0, +10), listed in that order:
        //   Q(1,0) ← 0 + 0.5 (−1 + 0.5·max Q(2,·)=0 − 0) = −0.5
        //   Q(0,1) ← 0 + 0.5 (10 + 0.5·max Q(1,·)=0 − 0) = 5      (max Q(1,·) = max(−0.5, 0) = 0)
        let t2 = Truth { emitted_now: None, delivered: vec![(1, -1.0), (0, 10.0)], ..Truth::default() };
        l.observe(&exp(2, 2, 1, 3, 9.0, &t2));
        assert_eq!((l.q(1, 0), l.q(0, 1), l.q(2, 1)), (-0.5, 5.0, 0.0));
        assert_eq!(l.in_flight(), 0);
        // t = 3: (3, 0) → 0 earns nothing: Q(3,0) ← 0.5 (0 + 0.5·max Q(0,·)=5) = 1.25.
        l.observe(&exp(3, 3, 0, 0, 0.0, &Truth::default()));
        assert_eq!(l.q(3, 0), 1.25);
        // t = 4: a zero-delay emission: (0, 1) → 1 emits +10 and receives it at once:
        //   Q(0,1) ← 5 + 0.5 (10 + 0.5·max Q(1,·)=0 − 5) = 7.5.
        let t4 = Truth { emitted_now: Some(10.0), delivered: vec![(4, 10.0)], ..Truth::default() };
        l.observe(&exp(4, 0, 1, 1, 10.0, &t4));
        assert_eq!(l.q(0, 1), 7.5);
        assert_eq!(l.diagnostics().figure(Figure::Credited), Some(3.0));
    }

    #[test]
    fn needs_the_truth() {
        let l = Oracle::new(Params::default(), 2, 2);
        assert!(l.needs_truth());
    }
}
