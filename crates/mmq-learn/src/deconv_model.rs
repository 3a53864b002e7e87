//! `deconv-model`: model-based learning under delayed rewards. Transitions are counted
//! as they are seen (they are not delayed), rewards come from the deconvolved table R̂
//! ([`crate::deconv`], which also estimates the delay pmf), and the action values are
//! planned by value iteration on the learned model, one Gauss–Seidel sweep per step:
//!
//! ```text
//! P̂(s' | s, a) = N(s, a, s') / N(s, a)
//! Q(s, a) = q0                                              if N(s, a) < m
//! Q(s, a) = R̂(s, a) + γ Σ_s' P̂(s' | s, a) max_a' Q(s', a')  otherwise          (M1)
//! ```
//!
//! m = `optimism_visits`: pairs tried fewer times keep the optimistic q0 (R-max style),
//! which drives exploration on top of ε-greedy.

use mmq_core::{Action, Rng, State};

use crate::decode::ValueDeconvolver;
use crate::deconv::DeconvConfig;
use crate::spec::Params;
use crate::table::QTable;
use crate::{Decision, Experience, Learner, Table, max_of};

/// Model-based learner on counted transitions and deconvolved rewards.
#[derive(Clone, Debug)]
pub struct DeconvModel {
    p: Params,
    /// Planned Q(s, a).
    q: QTable,
    /// max_a Q(s, a).
    v: Vec<f64>,
    /// N(s, a).
    tries: Vec<u32>,
    /// (s', N(s, a, s')) per pair.
    next: Vec<Vec<(u32, u32)>>,
    deconv: ValueDeconvolver,
    optimism_visits: u32,
}

impl DeconvModel {
    /// A model over `num_states` × `num_actions`; every value starts at q0.
    pub fn new(
        p: Params,
        cfg: DeconvConfig,
        optimism_visits: u32,
        num_states: usize,
        num_actions: usize,
    ) -> Self {
        let pairs = num_states * num_actions;
        Self {
            p,
            q: QTable::new(num_states, num_actions, p.q0),
            v: vec![p.q0; num_states],
            tries: vec![0; pairs],
            next: vec![Vec::new(); pairs],
            deconv: ValueDeconvolver::new(cfg, num_states, num_actions),
            optimism_visits,
        }
    }

    /// Q(s, a).
    pub fn q(&self, s: State, a: Action) -> f64 {
        self.q.get(s, a)
    }

    /// The deconvolver (R̂ and p̂).
    pub fn deconvolver(&self) -> &ValueDeconvolver {
        &self.deconv
    }

    /// One Gauss–Seidel sweep of (M1) over every state, in state order.
    pub fn plan(&mut self) {
        let (a_n, gamma, q0, m) = (self.q.num_actions(), self.p.gamma, self.p.q0, self.optimism_visits);
        for s in 0..self.v.len() {
            let mut best = f64::NEG_INFINITY;
            for a in 0..a_n {
                let i = s * a_n + a;
                let n = self.tries[i];
                let q = if n < m || n == 0 {
                    q0
                } else {
                    let inv = 1.0 / n as f64;
                    let ev: f64 = self.next[i].iter().map(|&(s2, c)| c as f64 * self.v[s2 as usize]).sum();
                    // (M1)
                    self.deconv.reward(i) + gamma * ev * inv
                };
                self.q[i] = q;
                best = best.max(q);
            }
            self.v[s] = best;
        }
    }
}

impl Learner for DeconvModel {
    fn name(&self) -> &'static str {
        "deconv-model"
    }

    fn act(&mut self, s: State, rng: &mut Rng) -> Decision {
        let (action, explored) = self.q.epsilon_greedy(s, self.p.epsilon, rng);
        Decision { action, model: None, explored }
    }

    fn observe(&mut self, e: &Experience<'_>) {
        let i = self.q.index(e.state, e.action);
        self.deconv.observe_transition(i, e.next_state, e.reward);
        self.tries[i] += 1;
        let s2 = e.next_state as u32;
        match self.next[i].iter_mut().find(|x| x.0 == s2) {
            Some(x) => x.1 += 1,
            None => self.next[i].push((s2, 1)),
        }
        self.plan();
    }

    fn greedy(&self, s: State, rng: &mut Rng) -> Action {
        self.q.greedy(s, rng)
    }

    fn action_values(&self, s: State, out: &mut [f64]) {
        out.copy_from_slice(self.q.row(s));
    }

    fn tables(&self) -> Vec<Table> {
        let mut t = vec![self.q.export("q")];
        t.extend(self.deconv.tables());
        t
    }

    fn metrics(&self) -> Vec<(String, f64)> {
        let mut m = self.deconv.metrics();
        m.push(("learner/value_max".into(), max_of(&self.v)));
        m
    }

    fn reset_history(&mut self) {
        self.deconv.reset_history();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::deconv_q::tests::tiny_config;
    use crate::exp;

    /// The trace of the deconv-q test (R̂ = (4, 2) after t = 3), planned by (M1) with one
    /// Gauss–Seidel sweep per step in state order; γ = 0.5, q0 = 0.
    #[test]
    fn value_iteration_on_counted_model_by_hand() {
        let p = Params { alpha: 0.5, gamma: 0.5, epsilon: 0.0, q0: 0.0 };
        let mut l = DeconvModel::new(p, tiny_config(), 1, 2, 1);
        let trace = [(0, 1, 2.0), (1, 0, 3.0), (0, 1, 3.0)];
        for (t, &(s, s2, r)) in trace.iter().enumerate() {
            l.observe(&exp(t as u64, s, 0, s2, r));
        }
        assert_eq!((l.q(0, 0), l.q(1, 0)), (0.0, 0.0));
        // t = 3 refits (R̂ = (4, 2)), then sweeps: Q(0) = 4 + ½ V(1) = 4 + ½·0 = 4,
        // then Q(1) = 2 + ½ V(0) = 2 + 2 = 4.
        l.observe(&exp(3, 1, 0, 0, 3.0));
        assert!((l.q(0, 0) - 4.0).abs() < 1e-9 && (l.q(1, 0) - 4.0).abs() < 1e-9);
        // t = 4: Q(0) = 4 + ½·4 = 6, Q(1) = 2 + ½·6 = 5 (fixed point 20/3, 16/3).
        l.observe(&exp(4, 0, 0, 1, 3.0));
        assert!((l.q(0, 0) - 6.0).abs() < 1e-9 && (l.q(1, 0) - 5.0).abs() < 1e-9);
        for t in 5..60 {
            let s = t % 2;
            l.observe(&exp(t as u64, s, 0, 1 - s, 3.0));
        }
        assert!((l.q(0, 0) - 20.0 / 3.0).abs() < 1e-6 && (l.q(1, 0) - 16.0 / 3.0).abs() < 1e-6);
    }

    /// A pair never tried keeps q0 (optimism) and the greedy action goes there.
    #[test]
    fn untried_pairs_stay_optimistic() {
        let p = Params { alpha: 0.5, gamma: 0.5, epsilon: 0.0, q0: 10.0 };
        let mut l = DeconvModel::new(p, tiny_config(), 1, 2, 2);
        l.observe(&exp(0, 0, 0, 1, 0.0));
        // Q(0,0) = R̂ 0 + ½ V(1) = ½·10; Q(0,1) untried = 10.
        assert_eq!((l.q(0, 0), l.q(0, 1)), (5.0, 10.0));
        let mut rng = mmq_core::seed::rng_from_seed(1);
        assert_eq!(l.greedy(0, &mut rng), 1);
    }
}
