//! Kernel-credit MMQ (`mmq-kernel`): the paper's own next step — "a kernel
//! that gives less credit to delay estimates far from λ̂*" — together with the two
//! bootstraps the issue names (each model's own, or the leading model's). Algorithm 1
//! with two changes:
//!
//! ```text
//! for each step t:
//!   (λ̂*, a*) = argmax_{λ̂, a} Q(s, a, λ̂)                         eqs. (5)–(6), as MMQ
//!   L = the model chosen most often by greedy decisions so far (the leader; ties: the
//!       smaller λ̂; before the first greedy decision every weight is 1)
//!   for λ̂ from 0 to λ̂max with t − λ̂ ≥ 0:
//!     w(λ̂) = exp(−(λ̂ − L)² / (2 h²))                              (h = kernel_width)
//!     M = max_{λ̂', a} Q(s'_{t−λ̂}, a, λ̂')    bootstrap = all (the paper's eq. (7))
//!       | max_a Q(s'_{t−λ̂}, a, λ̂)            bootstrap = own
//!       | max_a Q(s'_{t−λ̂}, a, L)            bootstrap = leader
//!     Q(s_{t−λ̂}, a_{t−λ̂}, λ̂) ← Q + α w(λ̂) [ r_t + γ M − Q ]
//! ```
//!
//! With h = ∞ and bootstrap = all it is exactly Algorithm 1 (the test
//! `infinite_width_and_all_is_mmq` holds it to [`crate::mmq_reference`] bit for bit).
//! The leader is the running mode of λ̂* rather than each decision's λ̂*: early on the
//! models tie and λ̂* jumps between them, and a kernel that followed it would spread
//! credit as evenly as no kernel at all. A plain loop like the reference (no caches):
//! O(N² |A|) per step with bootstrap = all.

use mmq_core::{Action, Rng, State};
use serde::{Deserialize, Serialize};

use crate::diagnostics::Diagnostics;
use crate::diagnostics::Figure;
use crate::error::{LearnError, bad};
use crate::learner::{Decision, Experience, Learner, Table, max_of};
use crate::memory::Memory;
use crate::mmq_reference::{act_on_block, best_model_values, q_table};
use crate::params::Params;
use crate::policy::argmax_random_tie;

/// Settings of `mmq-kernel`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct KernelSettings {
    /// λ̂max, steps: N = λ̂max + 1 models (as `mmq`; default 50).
    pub max_delay: usize,
    /// Width h of the Gaussian kernel around the leading model, in steps of λ̂ (> 0;
    /// `inf` gives every model full credit, as MMQ). Default 10, the best of
    /// {1, 3, 5, 10, 20, 50, ∞} on 9×9 at Poisson 13 (docs/algorithms/mmq-kernel.md).
    pub kernel_width: f64,
    /// Where the target's max looks: `all` models (the paper), the updated model's `own`
    /// row, or the `leader`'s.
    pub bootstrap: Bootstrap,
}

impl Default for KernelSettings {
    fn default() -> Self {
        Self { max_delay: 50, kernel_width: 10.0, bootstrap: Bootstrap::All }
    }
}

impl KernelSettings {
    pub(crate) fn validate(&self) -> Result<(), LearnError> {
        if self.kernel_width.is_nan() || self.kernel_width <= 0.0 {
            return bad(
                "kernel_width",
                self.kernel_width,
                "use a kernel width > 0 in steps of the delay estimate, e.g. 10 (inf: no kernel)",
            );
        }
        Ok(())
    }
}

/// Where the target's max looks (the `bootstrap` setting).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Bootstrap {
    /// Over every model and action of s' (the paper's eq. (7)).
    #[default]
    All,
    /// Over the actions of s' in the updated model only.
    Own,
    /// Over the actions of s' in the leading model.
    Leader,
}

/// Kernel-credit MMQ.
#[derive(Clone, Debug)]
pub struct KernelMmq {
    p: Params,
    /// N = λ̂max + 1 models.
    n: usize,
    num_actions: usize,
    /// h, steps (∞ allowed).
    width: f64,
    bootstrap: Bootstrap,
    /// Q[(s × N + λ̂) × |A| + a], as the reference.
    q: Vec<f64>,
    /// (s, a, s') of the last N steps, by t mod N.
    history: Vec<(usize, usize, usize)>,
    /// How often each model was λ̂* of a greedy decision.
    chosen: Vec<u64>,
}

impl KernelMmq {
    /// N = `max_delay` + 1 models over `num_states` × `num_actions`, every entry q0.
    pub fn new(
        p: Params,
        max_delay: usize,
        width: f64,
        bootstrap: Bootstrap,
        num_states: usize,
        num_actions: usize,
    ) -> Self {
        let n = max_delay + 1;
        Self {
            p,
            n,
            num_actions,
            width,
            bootstrap,
            q: vec![p.q0; num_states * n * num_actions],
            history: vec![(0, 0, 0); n],
            chosen: vec![0; n],
        }
    }

    fn block(&self, s: State) -> &[f64] {
        let w = self.n * self.num_actions;
        &self.q[s * w..(s + 1) * w]
    }

    fn row(&self, s: State, model: usize) -> &[f64] {
        let i = (s * self.n + model) * self.num_actions;
        &self.q[i..i + self.num_actions]
    }

    /// Q(s, a, λ̂).
    pub fn q(&self, s: State, a: Action, model: usize) -> f64 {
        self.q[(s * self.n + model) * self.num_actions + a]
    }

    /// The leader L (None before the first greedy decision).
    pub fn leader(&self) -> Option<usize> {
        let (best, &count) = self.chosen.iter().enumerate().rev().max_by_key(|&(_, c)| *c)?;
        (count > 0).then_some(best)
    }

    /// w(λ̂) for the leader `leader`.
    pub fn weight(&self, model: usize, leader: Option<usize>) -> f64 {
        match leader {
            Some(l) if self.width.is_finite() => {
                let d = model as f64 - l as f64;
                (-d * d / (2.0 * self.width * self.width)).exp()
            }
            _ => 1.0,
        }
    }
}

impl Learner for KernelMmq {
    fn name(&self) -> &'static str {
        "mmq-kernel"
    }

    fn act(&mut self, s: State, rng: &mut Rng) -> Decision {
        let d = act_on_block(self.block(s), self.num_actions, self.p.epsilon, rng);
        if let Some(m) = d.model {
            self.chosen[m] += 1;
        }
        d
    }

    fn observe(&mut self, e: &Experience<'_>) {
        let t = e.t as usize;
        self.history[t % self.n] = (e.state, e.action, e.next_state);
        let leader = self.leader();
        for l in 0..self.n {
            if t < l {
                break;
            }
            let w = self.weight(l, leader);
            let (s, a, s2) = self.history[(t - l) % self.n];
            let m = match self.bootstrap {
                Bootstrap::All => max_of(self.block(s2)),
                Bootstrap::Own => max_of(self.row(s2, l)),
                Bootstrap::Leader => max_of(self.row(s2, leader.unwrap_or(l))),
            };
            let i = (s * self.n + l) * self.num_actions + a;
            if w == 1.0 {
                // eq. (7) with the reference's operations, so that h = ∞ is MMQ bit for bit.
                self.q[i] = (1.0 - self.p.alpha) * self.q[i] + self.p.alpha * (e.reward + self.p.gamma * m);
            } else {
                self.q[i] += self.p.alpha * w * (e.reward + self.p.gamma * m - self.q[i]);
            }
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

    fn diagnostics(&self) -> Diagnostics {
        let total: u64 = self.chosen.iter().sum();
        let mean = if total > 0 {
            self.chosen.iter().enumerate().map(|(k, &c)| k as f64 * c as f64).sum::<f64>() / total as f64
        } else {
            f64::NAN
        };
        let figures = vec![
            (Figure::MmqLeader, self.leader().map_or(f64::NAN, |l| l as f64)),
            (Figure::MmqMeanChosenModel, mean),
        ];
        Diagnostics { figures, ..Diagnostics::default() }
    }

    fn reset_history(&mut self) {
        self.history.iter_mut().for_each(|h| *h = (0, 0, 0));
    }

    fn shares_tables(&self) -> bool {
        true
    }

    fn swap_memory(&mut self, other: &mut Memory) {
        let n = self.n;
        other.swap_with(&mut self.history, || vec![(0, 0, 0); n]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learner::exp;
    use crate::mmq_reference::MmqReference;
    use mmq_core::seed::rng_from_seed;
    use rand::RngExt;

    fn params() -> Params {
        Params { alpha: 0.5, gamma: 0.9, epsilon: 0.0, q0: 0.0 }
    }

    /// Two models (λ̂max = 1), two states, one action; leader λ̂ = 1, h = 1: w(0) =
    /// e^{−1/2} = 0.60653, w(1) = 1. Step 0: (0, 0) → 1, r = 0: model 0 updates Q(0, 0, 0)
    /// towards 0 + 0.9·0 — stays 0. Step 1: (1, 0) → 0, r = 10:
    /// - model 0 updates Q(1, 0, 0) += 0.5·0.60653·(10 + 0.9·M − 0) with M over s' = 0;
    /// - model 1 updates Q(0, 0, 1) += 0.5·1·(10 + 0.9·M' − 0) with M' over s' = 1 (the
    ///   step-0 transition), after model 0's update of the same step.
    ///
    /// bootstrap = all: M = max Q(0, ·, ·) = 0 → Q(1,0,0) = 3.03265; M' = max Q(1, ·, ·) =
    /// 3.03265 → Q(0,0,1) = 0.5·(10 + 2.72939) = 6.36469.
    /// bootstrap = own: M' = Q(1, 0, 1) = 0 → Q(0,0,1) = 5.
    /// bootstrap = leader (1): model 0's M = Q(0, 0, 1) = 0 (same), model 1's M' = Q(1, 0, 1) = 0 → 5.
    #[test]
    fn kernel_and_bootstraps_by_hand() {
        let w0 = (-0.5f64).exp();
        for (b, want01) in [
            (Bootstrap::All, 0.5 * (10.0 + 0.9 * 0.5 * w0 * 10.0)),
            (Bootstrap::Own, 5.0),
            (Bootstrap::Leader, 5.0),
        ] {
            let mut l = KernelMmq::new(params(), 1, 1.0, b, 2, 1);
            l.chosen = vec![2, 5];
            assert_eq!(l.leader(), Some(1));
            l.observe(&exp(0, 0, 0, 1, 0.0));
            assert_eq!(l.q(0, 0, 0), 0.0);
            l.observe(&exp(1, 1, 0, 0, 10.0));
            assert!((l.q(1, 0, 0) - 0.5 * w0 * 10.0).abs() < 1e-12, "{b:?}: {}", l.q(1, 0, 0));
            assert!((l.q(0, 0, 1) - want01).abs() < 1e-12, "{b:?}: {} vs {want01}", l.q(0, 0, 1));
        }
        // The leader's bootstrap reads the leader's row even for model 0: make it non-zero.
        let mut l = KernelMmq::new(params(), 1, 1.0, Bootstrap::Leader, 2, 1);
        l.chosen = vec![0, 1];
        l.q[1] = 4.0; // Q(0, 0, 1)
        l.observe(&exp(0, 1, 0, 0, 0.0)); // model 0: (1, 0) → 0, M = Q(0, 0, 1) = 4
        assert!((l.q(1, 0, 0) - 0.5 * w0 * 0.9 * 4.0).abs() < 1e-12);
        // The leader: the most chosen model, ties to the smaller λ̂; none before any choice.
        l.chosen = vec![3, 3];
        assert_eq!(l.leader(), Some(0));
        l.chosen = vec![0, 0];
        assert_eq!(l.leader(), None);
        assert_eq!(l.weight(0, None), 1.0);
    }

    /// h = ∞ with the paper's bootstrap is Algorithm 1: every entry and every decision
    /// equal to the reference's, bit for bit, on a random trace.
    #[test]
    fn infinite_width_and_all_is_mmq() {
        let p = Params { alpha: 0.1, gamma: 0.9, epsilon: 0.1, q0: 5.0 };
        let (states, actions, k) = (6, 3, 4);
        let mut a = KernelMmq::new(p, k, f64::INFINITY, Bootstrap::All, states, actions);
        let mut b = MmqReference::new(p, k, states, actions);
        let (mut ra, mut rb) = (rng_from_seed(3), rng_from_seed(3));
        let mut env = rng_from_seed(4);
        let mut s = 0;
        for t in 0..3000 {
            let (da, db) = (a.act(s, &mut ra), b.act(s, &mut rb));
            assert_eq!(da, db, "step {t}");
            let s2 = env.random_range(0..states);
            let r = if env.random_bool(0.2) { env.random_range(-1.0..10.0) } else { 0.0 };
            a.observe(&exp(t, s, da.action, s2, r));
            b.observe(&exp(t, s, db.action, s2, r));
            s = s2;
        }
        for (x, y) in a.q.iter().zip(b.raw()) {
            assert_eq!(x.to_bits(), y.to_bits());
        }
    }
}
