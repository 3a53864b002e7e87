//! `deconv-model-time`: [`crate::deconv_model`] with its delay pmf over *time bins* of
//! simulated time instead of step lags, for rewards whose delay is in seconds while
//! decisions take a variable time (a robot's primitives).
//!
//! Time is cut into bins of width b seconds (`time_bin_s`); bin v covers (v·b, (v+1)·b].
//! A step that ends at time T (`Experience::time_s`) falls in bin v(T) = ⌈T/b⌉ − 1 (T0),
//! and its pair x_t is placed there. The deconvolver of `deconv-model` then runs on the
//! sequence of bins instead of steps: a bin in which no decision ended carries the *idle
//! pair* x∅ (an extra state, never acted in, whose one pair leads back to itself). With
//! the lag j counted in bins, the model fitted is
//!
//! ```text
//! r̃(v) = Σ_j q̂(j) R̂(x(v − j)) + noise,   R̂(x∅) estimated like any pair (≈ 0)    (T1)
//! ```
//!
//! A reward reaches the learner only when a decision ends, having arrived somewhere in
//! the bins since the previous decision's end. Placed at the decision's bin, deliveries
//! would fall only where real pairs sit, and (T1) would explain them by a lag-0 mass on
//! every real pair. So the delivery r_t is placed in one bin drawn uniformly from the
//! window (v(t−1), v(t)] (T2; the draw is a hash of t, so no random stream is used):
//! r̃(v) = r_t in that bin, 0 in the window's other bins. In expectation r̃ is the arrival
//! series averaged over each window, and q̂ estimates the delay's pmf smoothed by the
//! window — its mean is close to the delay's, not delay + wait. Planning (M1), optimism
//! and probes are those of `deconv-model`; the probes' precision and `max_delay` K count
//! bins, and so do the refit schedule's steps.
//!
//! When every decision lasts exactly b seconds (the grid with `time_bin_s` = its
//! `step_period_s`), bins are steps, no bin is idle, and the learner's values are those of
//! `deconv-model` bit for bit (tested). Two decisions ending in one bin cannot both sit
//! there: the later one moves to the next free bin (`learner/time_bins_shifted` counts
//! them); choose b at most the shortest decision.

use mmq_core::{Action, Rng, State};
use serde::{Deserialize, Serialize};

use crate::deconv::{DeconvConfig, DeconvSettings};
use crate::deconv_model::{DeconvModel, ExploreSettings, Probes, Trajectory};
use crate::diagnostics::Diagnostics;
use crate::diagnostics::Figure;
use crate::error::{LearnError, bad};
use crate::learner::{Decision, Experience, Learner, Table};
use crate::memory::Memory;
use crate::params::Params;

/// Settings of `deconv-model-time`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DeconvModelTimeSettings {
    /// The deconvolution; `max_delay` counts time bins.
    #[serde(flatten)]
    pub deconv: DeconvSettings,
    /// Exploration.
    #[serde(flatten)]
    pub explore: ExploreSettings,
    /// Width b of the time bins, seconds, in (0, 3600]. Default 0.1 s, the grid's step
    /// period. At most the shortest decision's duration, or decisions get moved to later
    /// bins (see the module comment).
    pub time_bin_s: f64,
}

impl Default for DeconvModelTimeSettings {
    fn default() -> Self {
        Self {
            deconv: DeconvSettings::default(),
            explore: ExploreSettings::default(),
            time_bin_s: DEFAULT_TIME_BIN_S,
        }
    }
}

impl DeconvModelTimeSettings {
    /// Checks every setting's domain (the first failing field is reported).
    pub(crate) fn validate(&self) -> Result<(), LearnError> {
        self.deconv.validate()?;
        self.explore.validate()?;
        let b = self.time_bin_s;
        if !(b.is_finite() && b > 0.0 && b <= 3600.0) {
            return bad("time_bin_s", b, "use a bin width in seconds in (0, 3600], e.g. 0.1");
        }
        Ok(())
    }
}

/// Default bin width of `deconv-model-time`, seconds (the grid's default step period).
pub const DEFAULT_TIME_BIN_S: f64 = 0.1;

/// Relative slack when placing a time in its bin: a step that ends at 0.3 s is in the
/// third 0.1 s bin even though 0.3 / 0.1 = 2.9999999999999996.
const BIN_SLACK: f64 = 1e-9;

/// `deconv-model` on time bins (module docs).
#[derive(Clone, Debug)]
pub struct DeconvModelTime {
    inner: DeconvModel,
    bin_s: f64,
    num_states: usize,
    num_actions: usize,
    /// The bin of the last decision (None: none yet in this run).
    last_bin: Option<u64>,
    /// Decisions moved to a later bin, and idle bins fed.
    shifted: u64,
    idle_bins: u64,
}

impl DeconvModelTime {
    /// A model over `num_states` × `num_actions` with bins of `bin_s` seconds (> 0).
    pub fn new(
        p: Params,
        cfg: DeconvConfig,
        optimism_visits: u32,
        probes: Probes,
        bin_s: f64,
        num_states: usize,
        num_actions: usize,
    ) -> Self {
        Self {
            inner: DeconvModel::new(p, cfg, optimism_visits, probes, num_states + 1, num_actions),
            bin_s,
            num_states,
            num_actions,
            last_bin: None,
            shifted: 0,
            idle_bins: 0,
        }
    }

    /// The bin width, seconds.
    pub fn bin_s(&self) -> f64 {
        self.bin_s
    }

    /// The model on bins (with its idle state `num_states`).
    pub fn inner(&self) -> &DeconvModel {
        &self.inner
    }

    /// The bin of a step that ends at `time_s`: ⌈T/b⌉ − 1, at least 0.
    pub fn bin_of(&self, time_s: f64) -> u64 {
        let x = time_s / self.bin_s;
        ((x - BIN_SLACK * x.abs().max(1.0)).ceil() - 1.0).max(0.0) as u64
    }

    /// The idle pair x∅ (the idle state's action 0).
    fn idle_pair(&self) -> usize {
        self.num_states * self.num_actions
    }
}

impl Learner for DeconvModelTime {
    fn name(&self) -> &'static str {
        "deconv-model-time"
    }

    fn act(&mut self, s: State, rng: &mut Rng) -> Decision {
        self.inner.act(s, rng)
    }

    fn observe(&mut self, e: &Experience<'_>) {
        let mut v = self.bin_of(e.time_s);
        let first_free = self.last_bin.map_or(0, |l| l + 1);
        if v < first_free {
            v = first_free;
            self.shifted += 1;
        }
        // The delivery sits in one bin of the window (last decision, v], drawn uniformly
        // (T2); bins in which no decision ended carry the idle pair.
        let n = v - first_free + 1;
        let at = if n == 1 { 0 } else { splitmix64(e.t) % n };
        let idle = self.idle_pair();
        for i in 0..n - 1 {
            let r = if i == at { e.reward } else { 0.0 };
            self.inner.deconvolver_mut().observe_transition(idle, self.num_states, r);
            self.idle_bins += 1;
        }
        self.last_bin = Some(v);
        let reward = if at == n - 1 { e.reward } else { 0.0 };
        self.inner.observe(&Experience { reward, ..*e });
    }

    fn greedy(&self, s: State, rng: &mut Rng) -> Action {
        self.inner.greedy(s, rng)
    }

    fn action_values(&self, s: State, out: &mut [f64]) {
        self.inner.action_values(s, out);
    }

    /// Q and R̂ without the idle state's row; p̂ over bins.
    fn tables(&self) -> Vec<Table> {
        let mut t = self.inner.tables();
        for table in &mut t {
            if table.shape.len() == 2 && table.shape[0] == self.num_states + 1 {
                table.shape[0] = self.num_states;
                table.data.truncate(self.num_states * table.shape[1]);
            }
        }
        t
    }

    /// The delay estimate's lags count bins of `time_bin_s` seconds.
    fn diagnostics(&self) -> Diagnostics {
        let mut d = self.inner.diagnostics();
        if let Some(delay) = d.delay.as_mut() {
            delay.time_bin_s = Some(self.bin_s);
        }
        d.figures.push((Figure::TimeBinS, self.bin_s));
        d.figures.push((Figure::TimeBinsIdle, self.idle_bins as f64));
        d.figures.push((Figure::TimeBinsShifted, self.shifted as f64));
        d
    }

    fn reset_history(&mut self) {
        self.inner.reset_history();
        self.last_bin = None;
    }

    /// Each robot keeps its own bins: its stream in the model and its last decision's bin.
    fn shares_tables(&self) -> bool {
        true
    }

    fn swap_memory(&mut self, other: &mut Memory) {
        let mut mine = (self.inner.take_trajectory(), self.last_bin);
        other.swap_with(&mut mine, || (Trajectory::default(), None));
        self.inner.put_trajectory(mine.0);
        self.last_bin = mine.1;
    }
}

/// SplitMix64 of `x` (Steele, Lea and Flood 2014): the learner's placement draws depend
/// on the step index alone, so they need no random stream.
fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::deconv_q::tests::tiny_config;
    use mmq_core::seed::rng_from_seed;
    use rand::RngExt;

    fn params() -> Params {
        Params { alpha: 0.5, gamma: 0.5, epsilon: 0.1, q0: 1.0 }
    }

    fn experience(t: u64, s: State, a: Action, s2: State, r: f64, time_s: f64) -> Experience<'static> {
        Experience { t, state: s, action: a, next_state: s2, reward: r, time_s, truth: None }
    }

    /// Bins: ⌈T/b⌉ − 1, robust to the rounding of a product clock.
    #[test]
    fn steps_fall_in_the_bin_that_ends_at_or_after_them() {
        let l = DeconvModelTime::new(params(), tiny_config(), 1, Probes::OFF, 0.1, 2, 2);
        for (t, want) in [(0.1, 0), (0.2, 1), (3.0 * 0.1, 2), (0.25, 2), (0.35, 3), (0.05, 0), (0.0, 0)] {
            assert_eq!(l.bin_of(t), want, "T = {t}");
        }
        for t in 1..10_000u64 {
            assert_eq!(l.bin_of(t as f64 * 0.1), t - 1, "step {t}");
        }
    }

    /// Decisions of exactly one bin: no idle bin, no shift, and every value equals
    /// `deconv-model`'s bit for bit over a random 3-state chain with delayed rewards.
    #[test]
    fn one_decision_per_bin_is_deconv_model_bit_for_bit() {
        let mut cfg = tiny_config();
        cfg.settings.refit_every = 20;
        let mut step = DeconvModel::new(params(), cfg.clone(), 2, Probes::OFF, 3, 2);
        let mut time = DeconvModelTime::new(params(), cfg, 2, Probes::OFF, 0.1, 3, 2);
        let (mut ra, mut rb) = (rng_from_seed(3), rng_from_seed(3));
        let mut env = rng_from_seed(9);
        let (mut s, mut pending) = (0usize, vec![0.0; 3000]);
        for t in 0..2000u64 {
            let (a, b) = (step.act(s, &mut ra), time.act(s, &mut rb));
            assert_eq!(a, b, "t = {t}");
            let (s2, r) = match (s, a.action) {
                (2, _) => (0, 10.0),
                (s, 0) => (s + 1, 0.0),
                (s, _) => (s, -1.0),
            };
            if r != 0.0 {
                pending[t as usize + env.random_range(0..3)] += r;
            }
            let e = experience(t, s, a.action, s2, pending[t as usize], (t + 1) as f64 * 0.1);
            step.observe(&e);
            time.observe(&e);
            for x in 0..3 {
                for y in 0..2 {
                    assert_eq!(step.q(x, y).to_bits(), time.inner().q(x, y).to_bits(), "t = {t}");
                }
            }
            s = s2;
        }
        let m = time.diagnostics();
        let get = |k| m.figure(k);
        assert_eq!((get(Figure::TimeBinsIdle), get(Figure::TimeBinsShifted)), (Some(0.0), Some(0.0)));
        assert_eq!(time.tables()[0].shape, vec![3, 2]);
    }

    /// A delay of 1 s while decisions take 0.3 or 0.7 s at random: the lag in steps
    /// varies (1 to 3) and the reward waits up to 0.7 s for a decision's end. The time
    /// model finds R̂ of the rewarded pair (5, less the lasso's bias), 0 elsewhere and for
    /// the idle pair, and a delay pmf whose mean is the 1 s delay (10 bins) within 1.5
    /// bins: the placement (T2) undoes the wait on average.
    #[test]
    fn recovers_a_delay_in_seconds_under_variable_step_durations() {
        let mut cfg = crate::deconv::tests::cfg(24, None);
        let s = &mut cfg.settings;
        (s.lasso, s.significance, s.reward_prior, s.refit_every) = (0.1, 1.0, 1.0, 1000);
        (s.pmf_weighted, s.pmf_significance, s.pmf_prior) = (true, 1.0, 5.0);
        let mut l = DeconvModelTime::new(params(), cfg, 1, Probes::OFF, 0.1, 2, 2);
        let mut rng = rng_from_seed(11);
        let (mut now, mut due): (f64, Vec<(f64, f64)>) = (0.0, Vec::new());
        let mut s = 0;
        for t in 0..20_000u64 {
            let a = usize::from(rng.random_bool(0.5));
            now += if rng.random_bool(0.5) { 0.3 } else { 0.7 };
            // Pair (1, 1) pays 5 (state 1, action 1); every action flips the state.
            if s == 1 && a == 1 {
                due.push((now + 1.0, 5.0));
            }
            let r: f64 = due.iter().filter(|d| d.0 <= now + 1e-9).map(|d| d.1).sum();
            due.retain(|d| d.0 > now + 1e-9);
            l.observe(&experience(t, s, a, 1 - s, r, now));
            s = 1 - s;
        }
        let d = l.inner().deconvolver();
        assert!((d.reward(3) - 5.0).abs() < 0.5, "R̂(1, 1) = {}", d.reward(3));
        for x in [0, 1, 2, 4] {
            assert!(d.reward(x).abs() < 0.5, "R̂({x}) = {}", d.reward(x));
        }
        let mean = crate::deconv::pmf_mean(d.pmf());
        assert!((8.5..=11.5).contains(&mean), "p̂ mean {mean} bins: {:?}", d.pmf());
        let m = l.diagnostics();
        let mean_s = m.delay.as_ref().and_then(|d| d.mean_s()).unwrap();
        assert!((mean_s - 1.0).abs() < 0.15, "{mean_s}");
        assert!(m.figure(Figure::TimeBinsIdle).unwrap() > 0.0);
    }
}
