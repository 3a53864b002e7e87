//! `deconv-q`: model-free Q-learning on a deconvolved reward table. The delivered reward
//! never enters a Q update directly; it only trains R̂(s, a) ([`crate::deconv`], which
//! also estimates the delay pmf), and every transition is learned at once with
//!
//! ```text
//! Q(s_t, a_t) ← Q(s_t, a_t) + α [ R̂(s_t, a_t) + γ max_a' Q(s_{t+1}, a') − Q(s_t, a_t) ]   (2')
//! ```
//!
//! — eq. (2) with the reward replaced by its current estimate. Since R̂(s_t, a_t) has not
//! yet heard of this visit's own reward, the transition of `replay_lag` steps ago is
//! learned again by the same rule (a one-transition replay; 0 turns it off).

use mmq_core::{Action, State};
use serde::{Deserialize, Serialize};

use crate::decode::ValueDeconvolver;
use crate::deconv::{DeconvConfig, DeconvSettings};
use crate::diagnostics::Diagnostics;
use crate::error::{LearnError, bad};
use crate::learner::{Experience, Learner, Table, max_of};
use crate::memory::Memory;
use crate::params::Params;
use crate::table::{QTable, q_table_methods};

/// Settings of `deconv-q`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DeconvQSettings {
    /// The deconvolution.
    #[serde(flatten)]
    pub deconv: DeconvSettings,
    /// Each transition is learned again this many steps later, when R̂ has heard of its
    /// reward (0: learned once, at once; at most 2^20). Default 50, as K.
    pub replay_lag: usize,
}

impl Default for DeconvQSettings {
    fn default() -> Self {
        Self { deconv: DeconvSettings::default(), replay_lag: 50 }
    }
}

impl DeconvQSettings {
    /// Checks every setting's domain (the first failing field is reported).
    pub(crate) fn validate(&self) -> Result<(), LearnError> {
        self.deconv.validate()?;
        if self.replay_lag > 1 << 20 {
            return bad("replay_lag", self.replay_lag, "use a lag of at most 2^20 steps");
        }
        Ok(())
    }
}

/// Q-learning on R̂.
#[derive(Clone, Debug)]
pub struct DeconvQ {
    p: Params,
    q: QTable,
    deconv: ValueDeconvolver,
    /// Steps after which a transition is learned a second time (0: never).
    replay_lag: usize,
    /// (s, a, s') of the last `replay_lag` + 1 steps, by t mod length.
    history: Vec<(u32, u32, u32)>,
    /// Steps since the last history reset.
    seen: u64,
}

impl DeconvQ {
    /// Q-learning over `num_states` × `num_actions` with the deconvolver configured by
    /// `cfg`; `replay_lag` = 0 learns each transition once.
    pub fn new(
        p: Params,
        cfg: DeconvConfig,
        replay_lag: usize,
        num_states: usize,
        num_actions: usize,
    ) -> Self {
        Self {
            p,
            q: QTable::new(num_states, num_actions, p.q0),
            deconv: ValueDeconvolver::new(cfg, num_states, num_actions),
            replay_lag,
            history: vec![(0, 0, 0); replay_lag + 1],
            seen: 0,
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

    #[inline]
    fn learn(&mut self, s: usize, a: usize, s2: usize) {
        let (alpha, gamma) = (self.p.alpha, self.p.gamma);
        let m = max_of(self.q.row(s2));
        let i = self.q.index(s, a);
        let r = self.deconv.reward(i);
        // eq. (2')
        self.q[i] += alpha * (r + gamma * m - self.q[i]);
    }
}

impl Learner for DeconvQ {
    fn name(&self) -> &'static str {
        "deconv-q"
    }

    fn observe(&mut self, e: &Experience<'_>) {
        self.deconv.observe_transition(self.q.index(e.state, e.action), e.next_state, e.reward);
        self.learn(e.state, e.action, e.next_state);
        if self.replay_lag > 0 {
            let n = self.history.len();
            let slot = self.seen as usize % n;
            self.history[slot] = (e.state as u32, e.action as u32, e.next_state as u32);
            if self.seen >= self.replay_lag as u64 {
                let (s, a, s2) = self.history[(self.seen as usize - self.replay_lag) % n];
                self.learn(s as usize, a as usize, s2 as usize);
            }
        }
        self.seen += 1;
    }

    q_table_methods!(q, act(p));

    fn tables(&self) -> Vec<Table> {
        let mut t = vec![self.q.export("q")];
        t.extend(self.deconv.tables());
        t
    }

    fn diagnostics(&self) -> Diagnostics {
        self.deconv.diagnostics()
    }

    fn reset_history(&mut self) {
        self.seen = 0;
        self.deconv.reset_history();
    }

    /// Each robot keeps its stream in the deconvolver and its own replay history.
    fn shares_tables(&self) -> bool {
        true
    }

    fn swap_memory(&mut self, other: &mut Memory) {
        let n = self.history.len();
        let mut mine = (Some(self.deconv.stream()), std::mem::take(&mut self.history), self.seen);
        other.swap_with(&mut mine, || (None, vec![(0, 0, 0); n], 0));
        self.deconv.enter(mine.0);
        (self.history, self.seen) = (mine.1, mine.2);
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::learner::exp;

    /// K = 1 and the told pmf p = (½, ½), no penalties, a refit after 4 steps; two
    /// states with one action alternating 0 → 1 → 0 → ...
    pub(crate) fn tiny_config() -> DeconvConfig {
        let settings = DeconvSettings { refit_every: 4, ..DeconvSettings::unpenalised(1) };
        DeconvConfig { settings, told: Some(vec![0.5, 0.5]) }
    }

    /// Deliveries 2, 3, 3, 3 are exactly r_t = ½ R(x_t) + ½ R(x_{t−1}) with R = (4, 2)
    /// (r_0 = ½ R(0) = 2, then ½·4 + ½·2 = 3), so the refit after t = 3 finds R̂ = (4, 2).
    /// α = 0.5, γ = 0.5, q0 = 0.
    #[test]
    fn q_learning_on_deconvolved_rewards_by_hand() {
        let p = Params { alpha: 0.5, gamma: 0.5, epsilon: 0.0, q0: 0.0 };
        let trace = [(0, 1, 2.0), (1, 0, 3.0), (0, 1, 3.0), (1, 0, 3.0), (0, 1, 3.0)];
        for lag in [0, 2] {
            let mut l = DeconvQ::new(p, tiny_config(), lag, 2, 1);
            for (t, &(s, s2, r)) in trace.iter().enumerate().take(3) {
                l.observe(&exp(t as u64, s, 0, s2, r));
            }
            // R̂ = 0 before the first refit: every update keeps Q = 0.
            assert_eq!((l.q(0, 0), l.q(1, 0)), (0.0, 0.0));
            // t = 3 refits first: R̂ = (4, 2). Then (1 → 0): Q(1) ← 0 + ½ (2 + ½·0 − 0) = 1.
            // With lag 2 the transition of t = 1, (1 → 0), is learned again:
            //   Q(1) ← 1 + ½ (2 + ½·0 − 1) = 1.5.
            l.observe(&exp(3, 1, 0, 0, 3.0));
            let r = l.deconvolver().rewards();
            assert!((r[0] - 4.0).abs() < 1e-9 && (r[1] - 2.0).abs() < 1e-9, "R̂ = {r:?}");
            assert!((l.q(1, 0) - if lag == 0 { 1.0 } else { 1.5 }).abs() < 1e-9);
            // t = 4, (0 → 1): Q(0) ← 0 + ½ (4 + ½·Q(1) − 0): 2.25 (lag 0) or 2.375 (lag 2);
            // with lag 2 the transition of t = 2, (0 → 1), follows:
            //   Q(0) ← 2.375 + ½ (4 + ½·1.5 − 2.375) = 3.5625.
            l.observe(&exp(4, 0, 0, 1, 3.0));
            assert!((l.q(0, 0) - if lag == 0 { 2.25 } else { 3.5625 }).abs() < 1e-9, "{}", l.q(0, 0));
        }
    }
}
