//! `deconv-model`: model-based learning under delayed rewards. Transitions are counted
//! as they are seen (they are not delayed), rewards come from the deconvolved table R̂
//! ([`crate::deconv`], which also estimates the delay pmf), and the action values are
//! planned by value iteration on the learned model, one Gauss–Seidel sweep per step:
//!
//! ```text
//! P̂(s' | s, a) = N(s, a, s') / N(s, a)
//! Q(s, a) = q0                                              if (s, a) is not yet known
//! Q(s, a) = R̂(s, a) + γ Σ_s' P̂(s' | s, a) max_a' Q(s', a')  otherwise          (M1)
//! ```
//!
//! [`DeconvModel::new`] builds the plain learner: a pair is known once N(x) ≥ m =
//! `optimism_visits`, and it plans with (M1). The settings of `deconv-model`
//! ([`DeconvModelSettings`], in `settings.rs` beside this file) turn on, by default, (M1′)
//! and (M2) below ([`DeconvModel::planning_exploration`], [`DeconvModel::with_confidence`])
//! and rewards per outcome, R̂(s, a) = Σ_s' P̂(s' | s, a) R̂(s, a, s') (M3), fitted per
//! transition (module `outcomes`, [`DeconvModel::with_outcome_rewards`]).
//!
//! *Planning the ε-greedy values* (`plan_exploration`). The agent follows
//! the ε-greedy policy, whose random action is uniform over the actions, so the value it
//! earns from s is (1 − ε) max_a Q(s, a) + ε mean_a Q(s, a); planned with it in place of
//! max_a Q in (M1), the values prefer paths where a random action costs little (away
//! from the walls, where both "up" and "left" still lead to the goal):
//!
//! ```text
//! Q(s, a) = R̂(s, a) + γ Σ_s' P̂(s' | s, a) [ (1 − ε) max_a' Q(s', a') + ε mean_a' Q(s', a') ]   (M1′)
//! ```
//!
//! *Exploration from confidence* (z = `optimism_confidence` > 0; 0: the fixed count). A pair
//! stays optimistic (R-max style, on top of ε-greedy) until the reward fit has settled
//! its reward: the fit has found one there, or it would find one as large as the largest
//! in the world, with z standard errors to spare beyond its own significance threshold.
//! Under the delay estimate p̂ each visit u of x contributes ψ_t(x) = p̂(t − u) to the
//! fit's regressor at step t (after t − u steps), so after the steps seen so far (the
//! last at t − 1) x carries the information (the diagonal of the fit's Gram matrix,
//! without the cross terms of visits less than K steps apart)
//!
//! ```text
//! I(x) = Σ_{visits u of x} c(t − 1 − u),   c(j) = Σ_{k=0..min(j, K)} p̂(k)²
//! x is known  ⇔  N(x) ≥ 1  and  ( R̂(x) ≠ 0  or  (τ + z) σ̂ / √I(x) ≤ v_max )
//!             ⇔  N(x) ≥ 1  and  ( R̂(x) ≠ 0  or  I(x) ≥ I* = (τ + z)² σ̂² / v_max² )   (M2)
//! τ = κ √(2 ln m),   m = |X| (1 + 1/|A|)
//! ```
//!
//! σ̂/√I(x) is the standard error of R̂(x) under the reward fit's covariance σ̂² G⁻¹ (its
//! diagonal, the others held fixed), σ̂² the fit's residual variance per step
//! ([`crate::decode::ValueDeconvolver::noise_to_scale`]), v_max the largest reward value
//! found, and τ the fit's threshold in standard errors: κ = `significance` times the
//! universal threshold over the most features the fit can have (every pair and one
//! successor group per state). Without τ a pair could be called known while a reward of
//! that size would still be shrunk to zero: a wall bump known as free ties with every
//! move of a world without a known goal, and on a maze the agent spent most of its
//! steps bumping. Noise grows with the rewards collected and the information of a visit
//! with a sharp delay (Σ p̂(k)² is 0.078 for Poisson 13, 0.02 for a flat pmf on 0..=50):
//! so a pair needs few visits while rewards are rare and the delay is sharp, and more
//! once the goal's deliveries crowd the channel. σ̂, v_max and p̂ are those of the last
//! refit (before the first, σ̂² = Σ r² / t, updated every step); I(x) is updated every
//! step. Once known, a pair stays known: a rise of σ̂ as the goal is found more often
//! does not send the agent back to pairs it has already learned.
//!
//! *Delay probes.* A policy that has learned to avoid costs also stops producing the
//! rewards that date the delay best: its goal rewards come at a near-constant period, and
//! a delay k cannot be told from k + period from them. While the median of p̂ is
//! imprecise ([`crate::deconv::Deconvolver::median_se`]: a standard error above `probe_precision`
//! steps and, on the probability scale, above [`PROBE_CDF_PRECISION`]), a probe falls
//! due with probability `probe_rate` per step; a due probe is taken at the first step that
//! is not ε-exploration (`probe_steps = "greedy"`; `"exploring"`: the first step of
//! ε-exploration, in place of its random action, a cheaper probe; `"any"`: either) in a
//! state with an action known to keep the agent in place at a
//! cost (known by (M2), or tried ≥ max(m, 1) times under the fixed count, never led
//! elsewhere, R̂ < 0: a wall bump). The cost leaves at a time drawn at random and reaches
//! the agent one delay later: a sample of the delay that the period does not alias.

use mmq_core::{Action, Rng, State};
use rand::RngExt;

use crate::decode::ValueDeconvolver;
use crate::deconv::DeconvConfig;
use crate::diagnostics::Diagnostics;
use crate::diagnostics::Figure;
use crate::learner::{Decision, Experience, Learner, Table, max_of};
use crate::memory::Memory;
use crate::params::Params;
use crate::table::{QTable, q_table_methods};

mod confidence;
mod outcomes;
mod settings;
mod told_cells;
mod trajectory;

use confidence::Confidence;
use outcomes::Outcomes;
pub use outcomes::SLOTS as OUTCOME_SLOTS;
pub use settings::{DeconvModelSettings, ExploreSettings};
pub use told_cells::ToldCells;
pub(crate) use trajectory::Trajectory;

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
    probes: Probes,
    /// A probe fell due and waits for a state that has one.
    probe_due: bool,
    /// Probes taken.
    probes_taken: u64,
    /// The confidence rule (M2), when on (else the fixed count `optimism_visits`).
    confidence: Option<Confidence>,
    /// Plan the values of the ε-greedy policy followed, (M1′), instead of the greedy one.
    plan_exploration: bool,
    /// The states whose values the next sweep must recompute, and the deconvolver's
    /// refits when R̂ was last planned with ([`Dirty`]).
    dirty: Dirty,
    /// A diagnostic's true cells ([`ToldCells`]; none for an agent).
    told: ToldCells,
    /// Rewards per outcome, (M3) (module `outcomes`); None: per pair.
    outcomes: Option<Outcomes>,
}

/// Which states a sweep of (M1) must recompute: the others would get their values
/// bit for bit again, because nothing they are computed from changed since their last
/// computation. A state's values change only with R̂ (at a refit: every state), its own
/// pairs' counts and knownness (the state just left) or the value of a successor
/// (a state whose value changed marks its predecessors; those after it in state order
/// are recomputed in the same sweep, as in a full Gauss–Seidel sweep).
#[derive(Clone, Debug)]
struct Dirty {
    /// One bit per state.
    bits: Vec<u64>,
    /// The states with a pair that has led to each state.
    preds: Vec<Vec<u32>>,
    /// The deconvolver's refits at the last sweep (None: no sweep yet).
    refits: Option<u64>,
    /// Pairs tried but not yet known under (M2): checked at every sweep.
    pending: Vec<u32>,
}

impl Dirty {
    fn new(num_states: usize) -> Self {
        Self {
            bits: vec![0; num_states.div_ceil(64)],
            preds: vec![Vec::new(); num_states],
            refits: None,
            pending: Vec::new(),
        }
    }

    #[inline]
    fn mark(&mut self, s: usize) {
        self.bits[s / 64] |= 1 << (s % 64);
    }

    fn mark_all(&mut self, num_states: usize) {
        self.bits.iter_mut().for_each(|w| *w = u64::MAX);
        if !num_states.is_multiple_of(64)
            && let Some(last) = self.bits.last_mut()
        {
            *last = (1 << (num_states % 64)) - 1;
        }
    }

    /// Takes the first marked state at or after `from`, if any.
    #[inline]
    fn take_from(&mut self, from: usize) -> Option<usize> {
        let mut w = from / 64;
        let mut word = *self.bits.get(w)? & (u64::MAX << (from % 64));
        while word == 0 {
            w += 1;
            word = *self.bits.get(w)?;
        }
        let b = word.trailing_zeros() as usize;
        self.bits[w] &= !(1 << b);
        Some(w * 64 + b)
    }
}

/// Probes also stop once the probability below the median has at most this standard
/// error: the median of a pmf with two lobes can lie where there is almost no mass, and
/// then no number of probes pins it to a fraction of a step.
pub const PROBE_CDF_PRECISION: f64 = 0.02;

/// Delay probes of [`DeconvModel`] (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Probes {
    /// Probability per step that a probe falls due (0: off); a due probe is taken at the
    /// first non-exploring step in a state that has one.
    pub rate: f64,
    /// Probes stop once the median of p̂ has at most this standard error, steps.
    pub precision: f64,
    /// The steps at which a due probe may be taken.
    pub steps: ProbeSteps,
}

/// The steps at which a due delay probe may be taken (in a state that has one).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ProbeSteps {
    /// A step that is not ε-exploration: the probe replaces the greedy action.
    #[default]
    Greedy,
    /// A step of ε-exploration: the probe replaces its random action.
    Exploring,
    /// Either.
    Any,
}

impl ProbeSteps {
    fn allows(self, explored: bool) -> bool {
        match self {
            ProbeSteps::Greedy => !explored,
            ProbeSteps::Exploring => explored,
            ProbeSteps::Any => true,
        }
    }
}

impl Probes {
    /// No probes.
    pub const OFF: Probes = Probes { rate: 0.0, precision: f64::INFINITY, steps: ProbeSteps::Greedy };
}

impl DeconvModel {
    /// A model over `num_states` × `num_actions`; every value starts at q0.
    pub fn new(
        p: Params,
        cfg: DeconvConfig,
        optimism_visits: u32,
        probes: Probes,
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
            probes,
            probe_due: false,
            probes_taken: 0,
            confidence: None,
            plan_exploration: false,
            dirty: Dirty::new(num_states),
            told: ToldCells::None,
            outcomes: None,
        }
    }

    /// The same model fitting a reward per outcome (s, a, s') and planning with (M3)
    /// (module `outcomes`). Call before [`Self::with_confidence`], on a fresh model.
    pub fn with_outcome_rewards(mut self) -> Self {
        let (num_states, a_n) = (self.v.len(), self.q.num_actions());
        self.deconv = ValueDeconvolver::new(self.deconv.config().clone(), num_states * outcomes::SLOTS, a_n);
        self.outcomes = Some(Outcomes::new(num_states, a_n));
        self
    }

    /// R̂(x) of pair x as the planning takes it: the fitted reward of the pair, or under
    /// rewards per outcome (M3) over its counted successors.
    pub fn pair_reward(&self, x: usize) -> f64 {
        pair_reward(self.outcomes.as_ref(), &self.deconv, x)
    }

    /// The same model planning the values of the ε-greedy policy it follows, (M1′):
    /// V(s) = (1 − ε) max_a Q(s, a) + ε mean_a Q(s, a).
    pub fn planning_exploration(mut self) -> Self {
        self.plan_exploration = true;
        self
    }

    /// The same model with exploration from confidence (M2) at z standard errors
    /// (z > 0; the fixed count of `new` is then unused).
    pub fn with_confidence(mut self, z: f64) -> Self {
        let mut c = Confidence::new(z, self.deconv.threshold_in_se(self.tries.len()), self.tries.len());
        c.update(&self.deconv);
        self.confidence = Some(c);
        self
    }

    /// I(x) of (M2): the information on R̂(x) from the steps seen so far (None under the
    /// fixed count).
    pub fn information(&self, x: usize) -> Option<f64> {
        let c = self.confidence.as_ref()?;
        let (a0, len) = (c.a0(), c.recent.len());
        let deficit: f64 = c
            .recent
            .iter()
            .enumerate()
            .filter(|&(_, &y)| y as usize == x)
            .map(|(j, _)| a0 - c.cum[(len - 1 - j).min(c.cum.len() - 1)])
            .sum();
        Some(a0 * f64::from(self.tries[x]) - deficit)
    }

    /// I* of (M2): the information a pair needs to be known (None under the fixed count).
    pub fn information_needed(&self) -> Option<f64> {
        self.confidence.as_ref().map(|c| c.needed)
    }

    /// Whether pair `x` is known: by (M2) at a refit so far, or tried ≥ max(m, 1) times
    /// under the fixed count.
    pub fn known(&self, x: usize) -> bool {
        match &self.confidence {
            Some(c) => c.latched[x],
            None => self.tries[x] >= self.optimism_visits.max(1),
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

    /// The deconvolver, mutably (`deconv-model-time` feeds it its idle bins).
    pub(crate) fn deconvolver_mut(&mut self) -> &mut ValueDeconvolver {
        &mut self.deconv
    }

    /// The first action of `s` that is a possible delay probe: known ([`Self::known`]),
    /// only ever led back to `s`, and R̂ < 0.
    pub fn probe_action(&self, s: State) -> Option<Action> {
        let a_n = self.q.num_actions();
        (0..a_n).find(|&a| {
            let i = s * a_n + a;
            self.known(i)
                && matches!(self.next[i][..], [(s2, _)] if s2 as usize == s)
                && self.pair_reward(i) < 0.0
        })
    }

    /// One Gauss–Seidel sweep of (M1) over every state, in state order. States none of
    /// whose inputs changed since their last computation are skipped (`Dirty`): they
    /// would get the same values, so the sweep's result is that of the full sweep.
    pub fn plan(&mut self) {
        let (a_n, gamma, q0, m) = (self.q.num_actions(), self.p.gamma, self.p.q0, self.optimism_visits);
        let (soft, eps) = (self.plan_exploration, self.p.epsilon);
        let num_states = self.v.len();
        let refits = self.deconv.refits();
        if self.dirty.refits != Some(refits) {
            self.dirty.mark_all(num_states);
            self.dirty.refits = Some(refits);
        }
        if let Some(c) = self.confidence.as_mut() {
            // Before the first fit σ̂² is Σ r² / t (an upper bound), which changes every step.
            if c.refits != Some(refits) || refits == 0 {
                c.update(&self.deconv);
            }
            c.fill_deficits();
            // Knownness changes only for pairs tried and not yet known.
            let (tries, Dirty { bits, pending, .. }) = (&self.tries, &mut self.dirty);
            let (deconv, outcomes) = (&self.deconv, self.outcomes.as_ref());
            pending.retain(|&x| {
                let x = x as usize;
                if c.known(x, tries[x], pair_reward(outcomes, deconv, x)) {
                    bits[x / a_n / 64] |= 1 << (x / a_n % 64);
                    false
                } else {
                    true
                }
            });
            c.clear_deficits();
        }
        let mut from = 0;
        while let Some(s) = self.dirty.take_from(from) {
            from = s + 1;
            let mut best = f64::NEG_INFINITY;
            let mut sum = 0.0;
            for a in 0..a_n {
                let i = s * a_n + a;
                let n = self.tries[i];
                let optimistic = match self.confidence.as_ref() {
                    Some(c) => !c.latched[i],
                    None => n < m || n == 0,
                };
                let q = if optimistic {
                    q0
                } else {
                    let inv = 1.0 / n as f64;
                    let ev: f64 = self.next[i].iter().map(|&(s2, c)| c as f64 * self.v[s2 as usize]).sum();
                    // (M1), R̂ by (M3) under rewards per outcome.
                    pair_reward(self.outcomes.as_ref(), &self.deconv, i) + gamma * ev * inv
                };
                self.q[i] = q;
                best = best.max(q);
                sum += q;
            }
            if soft {
                // (M1′): the value of the ε-greedy policy, whose random action is uniform.
                best = (1.0 - eps) * best + eps * (sum / a_n as f64);
            }
            if best.to_bits() != self.v[s].to_bits() {
                self.v[s] = best;
                let Dirty { bits, preds, .. } = &mut self.dirty;
                for &p in &preds[s] {
                    bits[p as usize / 64] |= 1 << (p % 64);
                }
            }
        }
    }
}

impl Learner for DeconvModel {
    fn name(&self) -> &'static str {
        "deconv-model"
    }

    fn act(&mut self, s: State, rng: &mut Rng) -> Decision {
        let (action, explored) = self.q.epsilon_greedy(s, self.p.epsilon, rng);
        if self.probes.rate > 0.0
            && self
                .deconv
                .median_se()
                .is_some_and(|se| se.steps > self.probes.precision && se.cdf > PROBE_CDF_PRECISION)
        {
            if !self.probe_due && rng.random::<f64>() < self.probes.rate {
                self.probe_due = true;
            }
            if self.probe_due
                && self.probes.steps.allows(explored)
                && let Some(probe) = self.probe_action(s)
            {
                self.probe_due = false;
                self.probes_taken += 1;
                return Decision { action: probe, model: None, explored: true };
            }
        }
        Decision { action, model: None, explored }
    }

    fn observe(&mut self, e: &Experience<'_>) {
        // The cells a real agent has, unless a diagnostic is told the true ones.
        let cells = self.told.cells(e);
        let ((s_c, s2_c), (s, s2)) = (cells.credit, cells.count);
        let x = self.q.index(s_c, e.action);
        let feature = match self.outcomes.as_mut() {
            Some(o) => {
                // (M3) of s_c's pairs changes with its outcome counts.
                self.dirty.mark(s_c);
                o.observe(s_c, e.action, s2_c)
            }
            None => x,
        };
        self.deconv.observe_transition(feature, s2_c, e.reward);
        let i = self.q.index(s, e.action);
        self.tries[i] += 1;
        self.dirty.mark(s);
        if self.tries[i] == 1 && self.confidence.is_some() {
            self.dirty.pending.push(i as u32);
        }
        if let Some(c) = self.confidence.as_mut() {
            c.recent.push_back(x as u32);
            if c.recent.len() > c.cum.len().max(1) {
                c.recent.pop_front();
            }
        }
        let s2 = s2 as u32;
        match self.next[i].iter_mut().find(|x| x.0 == s2) {
            Some(x) => x.1 += 1,
            None => {
                self.next[i].push((s2, 1));
                let preds = &mut self.dirty.preds[s2 as usize];
                if !preds.contains(&(s as u32)) {
                    preds.push(s as u32);
                }
            }
        }
        self.plan();
    }

    fn needs_truth(&self) -> bool {
        self.told.needs_truth()
    }

    q_table_methods!(q);

    fn tables(&self) -> Vec<Table> {
        let mut t = vec![self.q.export("q")];
        let [mut r_hat, pmf] = self.deconv.tables();
        if self.outcomes.is_some() {
            // Per pair, as without outcomes: (M3).
            r_hat.shape = vec![self.v.len(), self.q.num_actions()];
            r_hat.data = (0..self.tries.len()).map(|x| self.pair_reward(x)).collect();
        }
        t.extend([r_hat, pmf]);
        t
    }

    fn diagnostics(&self) -> Diagnostics {
        let mut d = self.deconv.diagnostics();
        d.figures.push((Figure::ValueMax, max_of(&self.v)));
        d.figures.push((Figure::Probes, self.probes_taken as f64));
        let known = (0..self.tries.len()).filter(|&x| self.known(x)).count();
        d.figures.push((Figure::KnownPairs, known as f64));
        if let Some(c) = self.confidence.as_ref() {
            d.figures.push((Figure::InfoNeeded, c.needed));
            d.figures.push((Figure::InfoPerVisit, c.a0()));
        }
        d
    }

    fn reset_history(&mut self) {
        self.deconv.reset_history();
        // The deliveries still in flight are lost with the run; (M2) counts those visits
        // as complete (a slight overstatement of I(x), once per run).
        if let Some(c) = self.confidence.as_mut() {
            c.recent.clear();
        }
    }

    /// Every robot's deliveries are explained by its own past pairs (module `trajectory`).
    fn shares_tables(&self) -> bool {
        true
    }

    fn swap_memory(&mut self, other: &mut Memory) {
        self.swap_trajectory(other);
    }
}

/// [`DeconvModel::pair_reward`] over the model's parts (for closures that borrow others).
fn pair_reward(outcomes: Option<&Outcomes>, deconv: &ValueDeconvolver, x: usize) -> f64 {
    match outcomes {
        None => deconv.reward(x),
        Some(o) => o.pair_reward(deconv, x),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::deconv_q::tests::tiny_config;
    use crate::learner::exp;

    /// The trace of the deconv-q test (R̂ = (4, 2) after t = 3), planned by (M1) with one
    /// Gauss–Seidel sweep per step in state order; γ = 0.5, q0 = 0.
    #[test]
    fn value_iteration_on_counted_model_by_hand() {
        let p = Params { alpha: 0.5, gamma: 0.5, epsilon: 0.0, q0: 0.0 };
        let mut l = DeconvModel::new(p, tiny_config(), 1, Probes::OFF, 2, 1);
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

    /// (M1′) by hand: one state, two actions, both staying; action 0 tried (R̂ = 0, no
    /// reward), action 1 never (optimistic, q0 = 10); γ = ½, ε = ½. The greedy value is
    /// V = 10 and Q(0) = ½·10 = 5 at every step. The ε-greedy value, from V = q0 = 10:
    /// Q(0) = 5, V = ½·10 + ½·(5 + 10)/2 = 8.75; then Q(0) = 4.375, V = 5 + ¼·14.375 =
    /// 8.59375; fixed point V = (10 − 5ε) / (1 − εγ/2) = 60/7, Q(0) = 30/7.
    #[test]
    fn planning_the_epsilon_greedy_values_by_hand() {
        let p = Params { alpha: 0.5, gamma: 0.5, epsilon: 0.5, q0: 10.0 };
        let run = |soft: bool, steps: u64| {
            let l = DeconvModel::new(p, tiny_config(), 1, Probes::OFF, 1, 2);
            let mut l = if soft { l.planning_exploration() } else { l };
            for t in 0..steps {
                l.observe(&exp(t, 0, 0, 0, 0.0));
            }
            (l.q(0, 0), l.q(0, 1), l.v[0])
        };
        let close =
            |(q, v): (f64, f64), want: (f64, f64)| (q - want.0).abs() < 1e-12 && (v - want.1).abs() < 1e-12;
        let (q0, q1, v) = run(false, 1);
        assert_eq!((q0, q1, v), (5.0, 10.0, 10.0));
        let (q0, q1, v) = run(true, 1);
        assert!(close((q0, v), (5.0, 8.75)) && q1 == 10.0, "{q0} {v}");
        let (q0, _, v) = run(true, 2);
        assert!(close((q0, v), (4.375, 8.59375)), "{q0} {v}");
        let (q0, _, v) = run(true, 60);
        assert!(close((q0, v), (30.0 / 7.0, 60.0 / 7.0)), "{q0} {v}");
        assert_eq!(run(false, 60), (5.0, 10.0, 10.0));
    }

    /// The two-state world of the probe tests after 24 steps of its trace, ready to probe.
    fn build_probe_world(p: Params, probes: Probes) -> DeconvModel {
        let mut cfg = tiny_config();
        (cfg.told, cfg.settings.pmf_weighted) = (None, true);
        let mut l = DeconvModel::new(p, cfg, 1, probes, 2, 2);
        let trace = [(0, 0, 0, -1.0), (0, 1, 1, 0.0), (1, 0, 0, 2.0)];
        for t in 0..24 {
            let (s, a, s2, r) = trace[t % 3];
            l.observe(&exp(t as u64, s, a, s2, r));
        }
        l
    }

    /// The world below with probes taken in exploration: at ε = 1 every step explores, and
    /// the due probe replaces the random action at once (in state 0, the one with a
    /// probe); at ε = 0 no step explores and the probe waits however greedy the step, as a
    /// probe for greedy steps waits at ε = 1.
    #[test]
    fn probes_in_exploration_replace_the_random_action() {
        let inside = Probes { rate: 1.0, precision: 1e-9, steps: ProbeSteps::Exploring };
        let mut rng = mmq_core::seed::rng_from_seed(5);
        let explore = Params { alpha: 0.5, gamma: 0.5, epsilon: 1.0, q0: 0.0 };
        let mut l = build_probe_world(explore, inside);
        let d = l.act(0, &mut rng);
        assert_eq!((d.action, d.explored, l.probe_due), (0, true, false));
        assert_eq!(l.diagnostics().figure(Figure::Probes), Some(1.0));
        let greedy = Params { epsilon: 0.0, ..explore };
        let mut l = build_probe_world(greedy, inside);
        for _ in 0..5 {
            let d = l.act(0, &mut rng);
            assert_eq!((d.action, d.explored, l.probe_due), (1, false, true));
        }
        let mut l = build_probe_world(explore, Probes { steps: ProbeSteps::Greedy, ..inside });
        for _ in 0..20 {
            assert!(l.act(0, &mut rng).explored && l.probe_due);
        }
        assert_eq!(l.diagnostics().figure(Figure::Probes), Some(0.0));
    }

    /// State 0: action 0 bumps (stays, −1), action 1 moves to state 1 (0); state 1's one
    /// action returns to 0 with +2; rewards arrive at once. After a refit with the delay
    /// estimated, (0, 0) is a probe (tried, stays, R̂ < 0) and state 1 has none. With ε = 0
    /// the greedy action in 0 is 1. At rate 1 a probe falls due at once; in state 1 it
    /// waits (no probe there), and in state 0 it takes action 0 — while the median's SE is
    /// above the precision; neither a precision above it nor rate 0 probes.
    #[test]
    fn probes_take_the_known_bump_while_the_delay_is_uncertain() {
        let p = Params { alpha: 0.5, gamma: 0.5, epsilon: 0.0, q0: 0.0 };
        let build = |probes| build_probe_world(p, probes);
        let mut rng = mmq_core::seed::rng_from_seed(3);
        let mut l = build(Probes { rate: 1.0, precision: 1e-9, steps: ProbeSteps::Greedy });
        let se = l.deconvolver().median_se().expect("the delay is estimated").steps;
        assert!(l.deconvolver().reward(0) < 0.0 && se > 1e-9, "R̂ {}, SE {se}", l.deconvolver().reward(0));
        assert_eq!((l.probe_action(0), l.probe_action(1)), (Some(0), None));
        assert_eq!(l.greedy(0, &mut rng), 1);
        let waits = l.act(1, &mut rng);
        assert_eq!((waits.action, waits.explored, l.probe_due), (0, false, true));
        let probe = l.act(0, &mut rng);
        assert_eq!((probe.action, probe.explored, l.probe_due), (0, true, false));
        assert_eq!(l.diagnostics().figure(Figure::Probes), Some(1.0));
        for probes in [
            Probes { rate: 1.0, precision: se * 2.0, steps: ProbeSteps::Greedy },
            Probes { rate: 0.0, precision: 1e-9, steps: ProbeSteps::Greedy },
            Probes::OFF,
        ] {
            let mut l = build(probes);
            let d = l.act(0, &mut rng);
            assert_eq!((d.action, d.explored), (1, false), "{probes:?}");
        }
    }

    /// (M2) by hand. One state, two actions (pairs 0 and 1), told p̂ = (½, ½) (K = 1):
    /// c(0) = ¼, c(1) = ½. Pair 0 is taken four times with deliveries 0, 4, 0, 4; before
    /// the first refit σ̂² = Σ r² / t: 0 after the first step (I* = 0, one visit makes
    /// pair 0 known, and it stays known), 16 / 2 after the second (I* = z²·½). With
    /// ψ = (½, 1, 1, 1) the refit at t = 4 finds R̂(0) = Σψr / Σψ² = 8 / 3.25 with
    /// RSS = 32 − 8² / 3.25 = 160/13, so σ̂² = RSS / 4 = 40/13 and, with v_max = 4,
    /// I* = z² σ̂² / v_max² = z²·5/26. Then pair 1 is taken three times (deliveries 0; the
    /// next refit is at t = 8): after the second, I(1) = ½ + ¼ = 0.75, after the third
    /// ½ + ½ + ¼ = 1.25. Known ⇔ 1.25 ≥ z²·5/26 ⇔ z ≤ 2.5495: at z = 2.5 pair 1
    /// is known after three visits and not after two (0.75 < 1.2019), at z = 2.6 it is
    /// still optimistic (q0) after three (1.25 < 1.3).
    #[test]
    fn confidence_rule_by_hand() {
        let p = Params { alpha: 0.5, gamma: 0.5, epsilon: 0.0, q0: 100.0 };
        let mut cfg = tiny_config();
        cfg.settings.refit_every = 4;
        let run = |z: f64| {
            let mut l = DeconvModel::new(p, cfg.clone(), 1000, Probes::OFF, 1, 2).with_confidence(z);
            l.observe(&exp(0, 0, 0, 0, 0.0));
            assert_eq!(l.information_needed(), Some(0.0));
            assert!((l.information(0).unwrap() - 0.25).abs() < 1e-12);
            assert!(l.known(0) && !l.known(1) && l.q(0, 0) < 100.0 && l.q(0, 1) == 100.0);
            // Before the first fit σ̂² = Σ r² / t: 16 / 2 after the second step, v_max = 4.
            l.observe(&exp(1, 0, 0, 0, 4.0));
            assert!((l.information_needed().unwrap() - z * z * 0.5).abs() < 1e-12);
            for (t, r) in [(2, 0.0), (3, 4.0)] {
                l.observe(&exp(t, 0, 0, 0, r));
            }
            assert!((l.deconvolver().reward(0) - 8.0 / 3.25).abs() < 1e-9);
            assert!((l.information(0).unwrap() - 1.75).abs() < 1e-12);
            assert!((l.information_needed().unwrap() - z * z * 5.0 / 26.0).abs() < 1e-9);
            for t in 4..6 {
                l.observe(&exp(t, 0, 1, 0, 0.0));
            }
            assert!((l.information(1).unwrap() - 0.75).abs() < 1e-12);
            assert!(!l.known(1) && l.q(0, 1) == 100.0);
            l.observe(&exp(6, 0, 1, 0, 0.0));
            assert!((l.information(1).unwrap() - 1.25).abs() < 1e-12);
            l
        };
        let l = run(2.5);
        assert!(l.known(1) && l.q(0, 1) < 100.0, "Q {}", l.q(0, 1));
        let l = run(2.6);
        assert!(!l.known(1));
        assert_eq!(l.q(0, 1), 100.0);
    }

    /// (M2)'s two other parts. A reward the fit has found makes its pair known at once:
    /// pair 0 delivers 4 at every step (told p̂ = (½, ½)), so before the first fit
    /// σ̂² = Σ r² / t = 16 and v_max = 4, and at z = 100 I* = 100² is out of reach of its
    /// I(0) = 1.75 after four visits; but the refit at t = 4 finds
    /// R̂(0) = Σψr / Σψ² = 14 / 3.25 ≠ 0, and pair 0 is known from then on. The fit's
    /// threshold enters I*: with κ = 1, one state and two actions (m = 2 + 2/2 = 3
    /// features), I* = (√(2 ln 3) + z)² σ̂² / v_max² = (√(2 ln 3) + 2)² after the first
    /// step at z = 2.
    #[test]
    fn a_found_reward_is_known_and_the_fit_threshold_raises_the_need() {
        let p = Params { alpha: 0.5, gamma: 0.5, epsilon: 0.0, q0: 100.0 };
        let mut cfg = tiny_config();
        cfg.settings.refit_every = 4;
        let mut l = DeconvModel::new(p, cfg.clone(), 1000, Probes::OFF, 1, 2).with_confidence(100.0);
        for t in 0..3 {
            l.observe(&exp(t, 0, 0, 0, 4.0));
            assert!(!l.known(0) && l.q(0, 0) == 100.0, "t {t}");
        }
        assert!((l.information_needed().unwrap() - 1e4).abs() < 1e-6);
        l.observe(&exp(3, 0, 0, 0, 4.0));
        assert!((l.deconvolver().reward(0) - 14.0 / 3.25).abs() < 1e-9);
        assert!((l.information(0).unwrap() - 1.75).abs() < 1e-12);
        assert!(l.information(0).unwrap() < l.information_needed().unwrap());
        assert!(l.known(0) && !l.known(1) && l.q(0, 0) < 100.0);

        cfg.settings.significance = 1.0;
        let mut l = DeconvModel::new(p, cfg, 1000, Probes::OFF, 1, 2).with_confidence(2.0);
        l.observe(&exp(0, 0, 0, 0, 4.0));
        let t = (2.0 * 3.0_f64.ln()).sqrt() + 2.0;
        assert!((l.information_needed().unwrap() - t * t).abs() < 1e-12);
    }

    /// A pair never tried keeps q0 (optimism) and the greedy action goes there.
    #[test]
    fn untried_pairs_stay_optimistic() {
        let p = Params { alpha: 0.5, gamma: 0.5, epsilon: 0.0, q0: 10.0 };
        let mut l = DeconvModel::new(p, tiny_config(), 1, Probes::OFF, 2, 2);
        l.observe(&exp(0, 0, 0, 1, 0.0));
        // Q(0,0) = R̂ 0 + ½ V(1) = ½·10; Q(0,1) untried = 10.
        assert_eq!((l.q(0, 0), l.q(0, 1)), (5.0, 10.0));
        let mut rng = mmq_core::seed::rng_from_seed(1);
        assert_eq!(l.greedy(0, &mut rng), 1);
    }
}
