//! Multiple-Model Q-learning (MMQ), Algorithm 1 of the paper, eqs. (5)–(7): one Q-table
//! per delay estimate λ̂ = 0..=λ̂max, all updated every step, acting on the best.
//!
//! ```text
//! (λ̂*, a*) = argmax_{λ̂, a} Q(s, a, λ̂)                                  eqs. (5)–(6)
//! for λ̂ = 0, 1, ..., λ̂max with t − λ̂ ≥ 0:
//!   Q(s_{t−λ̂}, a_{t−λ̂}, λ̂) ← (1 − α) Q(s_{t−λ̂}, a_{t−λ̂}, λ̂)
//!                            + α [ r_t + γ max_{λ̂', a} Q(s'_{t−λ̂}, a, λ̂') ]   eq. (7)
//! ```
//!
//! Speed-up, exact: the target's max over all models and actions of s' is the same for
//! every model, so it is cached per state (`best[s]`) with the number of entries that
//! attain it; an update changes one entry, and the cache is rescanned only when the
//! last entry attaining the max decreases. The result is bit-identical to the plain
//! transcription in [`crate::mmq_reference`] (tested on long random traces).

use mmq_core::{Action, Rng, State};

use crate::policy::{argmax_random_tie, epsilon_greedy};
use crate::spec::Params;
use crate::{Decision, Experience, Learner, Table, max_of};

/// Multiple-Model Q-learning with an exact cached max.
#[derive(Clone, Debug)]
pub struct MultipleModelQ {
    p: Params,
    /// N = λ̂max + 1 models.
    n: usize,
    num_actions: usize,
    /// Q[(s × N + λ̂) × |A| + a]: one contiguous block of N × |A| values per state.
    q: Vec<f64>,
    /// max_{λ̂, a} Q(s, a, λ̂), kept exact.
    best: Vec<f64>,
    /// How many entries of the block of s equal `best[s]`.
    best_count: Vec<u32>,
    /// (s, a, s') of the last N steps, by t mod N.
    history: Vec<(u32, u32, u32)>,
    /// How often each model was λ̂* of a greedy decision.
    chosen: Vec<u64>,
}

impl MultipleModelQ {
    /// N = `max_delay` + 1 models over `num_states` × `num_actions`, every entry q0.
    pub fn new(p: Params, max_delay: usize, num_states: usize, num_actions: usize) -> Self {
        let n = max_delay + 1;
        Self {
            p,
            n,
            num_actions,
            q: vec![p.q0; num_states * n * num_actions],
            best: vec![p.q0; num_states],
            best_count: vec![(n * num_actions) as u32; num_states],
            history: vec![(0, 0, 0); n],
            chosen: vec![0; n],
        }
    }

    #[inline]
    fn block(&self, s: State) -> &[f64] {
        let w = self.n * self.num_actions;
        &self.q[s * w..(s + 1) * w]
    }

    /// Q(s, a, λ̂).
    pub fn q(&self, s: State, a: Action, model: usize) -> f64 {
        self.q[(s * self.n + model) * self.num_actions + a]
    }

    /// The whole table, [s][λ̂][a].
    pub fn raw(&self) -> &[f64] {
        &self.q
    }

    /// Number of models N.
    pub fn num_models(&self) -> usize {
        self.n
    }

    /// How often each model was the acting model λ̂* of a greedy decision.
    pub fn chosen_counts(&self) -> &[u64] {
        &self.chosen
    }

    /// The model whose greedy value max_a Q(s, a, λ̂) is highest in s (lowest λ̂ on ties).
    pub fn best_model(&self, s: State) -> usize {
        let a_n = self.num_actions;
        let block = self.block(s);
        let mut best = (f64::NEG_INFINITY, 0);
        for l in 0..self.n {
            let v = max_of(&block[l * a_n..(l + 1) * a_n]);
            if v > best.0 {
                best = (v, l);
            }
        }
        best.1
    }

    #[inline]
    fn set(&mut self, s: usize, i: usize, new: f64) {
        let old = self.q[i];
        self.q[i] = new;
        let m = self.best[s];
        if new > m {
            self.best[s] = new;
            self.best_count[s] = 1;
        } else if new == m {
            if old != m {
                self.best_count[s] += 1;
            }
        } else if old == m {
            self.best_count[s] -= 1;
            if self.best_count[s] == 0 {
                self.rescan(s);
            }
        }
    }

    #[cold]
    fn rescan(&mut self, s: usize) {
        let block = self.block(s);
        let m = max_of(block);
        let c = block.iter().filter(|&&x| x == m).count() as u32;
        self.best[s] = m;
        self.best_count[s] = c;
    }
}

impl Learner for MultipleModelQ {
    fn name(&self) -> &'static str {
        "mmq"
    }

    fn act(&mut self, s: State, rng: &mut Rng) -> Decision {
        let a_n = self.num_actions;
        let w = self.n * a_n;
        let block = &self.q[s * w..(s + 1) * w];
        let mut model = 0;
        let (action, explored) = epsilon_greedy(self.p.epsilon, a_n, rng, |r| {
            let i = argmax_random_tie(block, r);
            model = i / a_n;
            i % a_n
        });
        if !explored {
            self.chosen[model] += 1;
        }
        Decision { action, model: (!explored).then_some(model), explored }
    }

    #[inline]
    fn observe(&mut self, e: &Experience<'_>) {
        let t = e.t as usize;
        let n = self.n;
        let a_n = self.num_actions;
        let (alpha, gamma, r) = (self.p.alpha, self.p.gamma, e.reward);
        self.history[t % n] = (e.state as u32, e.action as u32, e.next_state as u32);
        let upto = t.min(n - 1);
        for l in 0..=upto {
            let (s, a, s2) = self.history[(t - l) % n];
            let (s, a) = (s as usize, a as usize);
            let m = self.best[s2 as usize];
            let i = (s * n + l) * a_n + a;
            // eq. (7)
            let new = (1.0 - alpha) * self.q[i] + alpha * (r + gamma * m);
            self.set(s, i, new);
        }
    }

    fn greedy(&self, s: State, rng: &mut Rng) -> Action {
        argmax_random_tie(self.block(s), rng) % self.num_actions
    }

    fn action_values(&self, s: State, out: &mut [f64]) {
        let a_n = self.num_actions;
        let l = self.best_model(s);
        out.copy_from_slice(&self.block(s)[l * a_n..(l + 1) * a_n]);
    }

    fn tables(&self) -> Vec<Table> {
        let s = self.q.len() / (self.n * self.num_actions);
        vec![Table { name: "q".into(), shape: vec![s, self.n, self.num_actions], data: self.q.clone() }]
    }

    fn metrics(&self) -> Vec<(String, f64)> {
        let total: u64 = self.chosen.iter().sum();
        let mode = self
            .chosen
            .iter()
            .enumerate()
            .max_by_key(|&(i, &c)| (c, std::cmp::Reverse(i)))
            .map_or(0, |x| x.0);
        let mean = if total > 0 {
            self.chosen.iter().enumerate().map(|(i, &c)| i as f64 * c as f64).sum::<f64>() / total as f64
        } else {
            f64::NAN
        };
        vec![("learner/model_star_mode".into(), mode as f64), ("learner/model_star_mean".into(), mean)]
    }

    fn reset_history(&mut self) {
        self.history.iter_mut().for_each(|h| *h = (0, 0, 0));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mmq_reference::MmqReference;
    use mmq_core::seed::rng_from_seed;
    use rand::RngExt;

    fn exp(t: u64, s: State, a: Action, s2: State, r: f64) -> Experience<'static> {
        Experience { t, state: s, action: a, next_state: s2, reward: r, truth: None }
    }

    /// Algorithm 1 by hand: λ̂max = 1 (two models), 2 states, 1 action, α = 0.5,
    /// γ = 0.5, q0 = 0.
    #[test]
    fn eq7_by_hand() {
        let p = Params { alpha: 0.5, gamma: 0.5, epsilon: 0.0, q0: 0.0 };
        for fast in [true, false] {
            let mut l: Box<dyn Learner> = if fast {
                Box::new(MultipleModelQ::new(p, 1, 2, 1))
            } else {
                Box::new(MmqReference::new(p, 1, 2, 1))
            };
            let q = |l: &dyn Learner| l.tables()[0].data.clone();
            // t = 0: (s=0, a=0, s'=1), r = 4. Only λ̂ = 0 (t − 1 < 0):
            // Q(0,0,0) ← 0.5·0 + 0.5 (4 + 0.5·max Q(1,·,·)=0) = 2
            l.observe(&exp(0, 0, 0, 1, 4.0));
            assert_eq!(q(&*l), vec![2.0, 0.0, 0.0, 0.0]);
            // t = 1: (s=1, a=0, s'=0), r = 2.
            // λ̂ = 0: Q(1,0,0) ← 0 + 0.5 (2 + 0.5·max Q(0,·,·)=2) = 1.5
            // λ̂ = 1: pair of t = 0 (s=0, s'=1): Q(0,0,1) ← 0 + 0.5 (2 + 0.5·max Q(1,·,·)=1.5) = 1.375
            l.observe(&exp(1, 1, 0, 0, 2.0));
            assert_eq!(q(&*l), vec![2.0, 1.375, 1.5, 0.0]);
            // t = 2: (s=0, a=0, s'=1), r = 0.
            // λ̂ = 0: Q(0,0,0) ← 0.5·2 + 0.5 (0 + 0.5·1.5) = 1.375
            // λ̂ = 1: pair of t = 1 (s=1, s'=0), max Q(0,·,·) is now 1.375 (both models):
            //         Q(1,0,1) ← 0 + 0.5 (0 + 0.5·1.375) = 0.34375
            l.observe(&exp(2, 0, 0, 1, 0.0));
            assert_eq!(q(&*l), vec![1.375, 1.375, 1.5, 0.34375]);
        }
    }

    /// The fast learner equals the plain transcription bit for bit, tables and
    /// decisions, on long random traces with optimistic and zero initialisation.
    #[test]
    fn fast_equals_reference_bit_for_bit() {
        for (q0, max_delay, states, seed) in [(10.0, 50, 9, 1u64), (0.0, 7, 5, 2), (20.0, 13, 81, 3)] {
            let p = Params { alpha: 0.1, gamma: 0.9, epsilon: 0.1, q0 };
            let mut fast = MultipleModelQ::new(p, max_delay, states, 4);
            let mut slow = MmqReference::new(p, max_delay, states, 4);
            let mut env_rng = rng_from_seed(seed);
            let (mut r1, mut r2) = (rng_from_seed(seed + 100), rng_from_seed(seed + 100));
            let mut s = 0usize;
            for t in 0..20_000u64 {
                let d1 = fast.act(s, &mut r1);
                let d2 = slow.act(s, &mut r2);
                assert_eq!(d1, d2, "decision at t = {t}");
                let s2 = env_rng.random_range(0..states);
                let r = match env_rng.random_range(0..10) {
                    0 => 10.0,
                    1 | 2 => -1.0,
                    3 => 9.0,
                    _ => 0.0,
                };
                fast.observe(&exp(t, s, d1.action, s2, r));
                slow.observe(&exp(t, s, d1.action, s2, r));
                s = s2;
            }
            let (a, b) = (fast.raw(), slow.raw());
            assert!(a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()), "tables differ");
        }
    }

    #[test]
    fn acts_on_the_joint_argmax() {
        let p = Params { alpha: 0.5, gamma: 0.0, epsilon: 0.0, q0: 0.0 };
        let mut l = MultipleModelQ::new(p, 2, 1, 4);
        // Actions 3, 1, 2, 1, 0, 2 with rewards 0, 0, 8, −8, −8, −8 (γ = 0, α = 0.5):
        // t = 2 sets Q(0,2,0) = Q(0,1,1) = Q(0,3,2) = 4; the −8s at t = 3, 4, 5 pull
        // Q(0,1,1) (λ̂=1 at t=4) and Q(0,2,0) (λ̂=0 at t=5) down to −2, leaving
        // Q(0, a=3, λ̂=2) = 4 the single largest entry.
        for (t, (a, r)) in
            [(3, 0.0), (1, 0.0), (2, 8.0), (1, -8.0), (0, -8.0), (2, -8.0)].into_iter().enumerate()
        {
            l.observe(&exp(t as u64, 0, a, 0, r));
        }
        assert_eq!((l.q(0, 1, 1), l.q(0, 2, 0)), (-2.0, -2.0));
        let mut rng = rng_from_seed(0);
        assert_eq!(l.q(0, 3, 2), 4.0);
        let d = l.act(0, &mut rng);
        assert_eq!((d.action, d.model, d.explored), (3, Some(2), false));
        assert_eq!(l.best_model(0), 2);
    }
}
