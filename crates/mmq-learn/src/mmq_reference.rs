//! Multiple-Model Q-learning, Algorithm 1 of the paper, transcribed as plainly as
//! possible. This is the specification the fast [`crate::mmq::MultipleModelQ`] must
//! match bit for bit (tests and benches compare them); it is not used for runs.
//!
//! ```text
//! for each step t:
//!   (λ̂*, a*) = argmax_{λ̂, a} Q(s, a, λ̂)          eqs. (5)–(6), joint, ties at random, ε-greedy
//!   execute a*, observe r_t and s'
//!   for λ̂ from 0 to λ̂max with t − λ̂ ≥ 0:
//!     Q(s_{t−λ̂}, a_{t−λ̂}, λ̂) ← (1 − α) Q(s_{t−λ̂}, a_{t−λ̂}, λ̂)
//!                              + α [ r_t + γ max_{λ̂', a} Q(s'_{t−λ̂}, a, λ̂') ]   eq. (7)
//! ```
//!
//! Updates are in place and in increasing λ̂, so a later model's target sees the
//! earlier models' updates of the same step (the plain loop's semantics).

use mmq_core::{Action, Rng, State};

use crate::learner::{Decision, Experience, Learner, Table, max_of};
use crate::memory::Memory;
use crate::params::Params;
use crate::policy::{argmax_random_tie, epsilon_greedy};

/// The plain transcription of Algorithm 1.
#[derive(Clone, Debug)]
pub struct MmqReference {
    p: Params,
    /// N = λ̂max + 1 models.
    n: usize,
    num_actions: usize,
    /// Q[(s × N + λ̂) × |A| + a].
    q: Vec<f64>,
    /// (s, a, s') of the last N steps, by t mod N.
    history: Vec<(usize, usize, usize)>,
}

impl MmqReference {
    /// N = `max_delay` + 1 models over `num_states` × `num_actions`, every entry q0.
    pub fn new(p: Params, max_delay: usize, num_states: usize, num_actions: usize) -> Self {
        let n = max_delay + 1;
        Self { p, n, num_actions, q: vec![p.q0; num_states * n * num_actions], history: vec![(0, 0, 0); n] }
    }

    fn block(&self, s: State) -> &[f64] {
        let w = self.n * self.num_actions;
        &self.q[s * w..(s + 1) * w]
    }

    /// Q(s, a, λ̂).
    pub fn q(&self, s: State, a: Action, model: usize) -> f64 {
        self.q[(s * self.n + model) * self.num_actions + a]
    }

    /// The whole table, `[s][λ̂][a]`.
    pub fn raw(&self) -> &[f64] {
        &self.q
    }
}

impl Learner for MmqReference {
    fn name(&self) -> &'static str {
        "mmq-reference"
    }

    fn act(&mut self, s: State, rng: &mut Rng) -> Decision {
        act_on_block(self.block(s), self.num_actions, self.p.epsilon, rng)
    }

    fn observe(&mut self, e: &Experience<'_>) {
        let t = e.t as usize;
        self.history[t % self.n] = (e.state, e.action, e.next_state);
        for l in 0..self.n {
            if t < l {
                break;
            }
            let (s, a, s2) = self.history[(t - l) % self.n];
            let m = max_of(self.block(s2));
            let i = (s * self.n + l) * self.num_actions + a;
            // eq. (7)
            self.q[i] = (1.0 - self.p.alpha) * self.q[i] + self.p.alpha * (e.reward + self.p.gamma * m);
        }
    }

    fn greedy(&self, s: State, rng: &mut Rng) -> Action {
        argmax_random_tie(self.block(s), rng) % self.num_actions
    }

    fn action_values(&self, s: State, out: &mut [f64]) {
        best_model_values(self.block(s), self.num_actions, out);
    }

    fn tables(&self) -> Vec<Table> {
        vec![q_table(&self.q, self.n, self.num_actions)]
    }

    fn shares_tables(&self) -> bool {
        true
    }

    fn swap_memory(&mut self, other: &mut Memory) {
        let n = self.n;
        other.swap_with(&mut self.history, || vec![(0, 0, 0); n]);
    }
}

/// Eqs. (5)–(6) on a state's block Q(s, ·, ·) in `[λ̂][a]` order: ε-greedy on the joint
/// argmax over models and actions, ties at random; the model acted on when greedy.
pub(crate) fn act_on_block(block: &[f64], a_n: usize, epsilon: f64, rng: &mut Rng) -> Decision {
    let mut model = None;
    let (action, explored) = epsilon_greedy(epsilon, a_n, rng, |r| {
        let i = argmax_random_tie(block, r);
        model = Some(i / a_n);
        i % a_n
    });
    Decision { action, model: if explored { None } else { model }, explored }
}

/// The action values of the best model of a state's block (the model whose best action
/// is highest; ties to the smaller λ̂).
pub(crate) fn best_model_values(block: &[f64], a_n: usize, out: &mut [f64]) {
    let n = block.len() / a_n;
    let best = (0..n)
        .max_by(|&x, &y| {
            max_of(&block[x * a_n..(x + 1) * a_n])
                .total_cmp(&max_of(&block[y * a_n..(y + 1) * a_n]))
                .then(y.cmp(&x))
        })
        .unwrap_or(0);
    out.copy_from_slice(&block[best * a_n..(best + 1) * a_n]);
}

/// The [s][λ̂][a] table `q` for export.
pub(crate) fn q_table(q: &[f64], n: usize, a_n: usize) -> Table {
    Table { name: "q".into(), shape: vec![q.len() / (n * a_n), n, a_n], data: q.to_vec() }
}
