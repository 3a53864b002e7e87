//! Reward-value decoding: the deliveries of a world whose rewards take a few discrete
//! values are sums of those values, and each value can be deconvolved on its own.
//!
//! A delivery of 9 in the paper's worlds is one +10 and one −1 that arrived together.
//! Least squares on the summed deliveries ([`crate::deconv`]) reads the −1 as noise on
//! the +10s; split apart, the −1s form a series of their own with almost no noise. That
//! matters for the delay estimate: the goal's rewards come at a near-constant period, so
//! a delay k and k + period explain them alike, while the wall bumps that exploration
//! causes come at irregular times and tell the delays apart
//! (docs/algorithms/deconvolution.md, "Delay estimate").
//!
//! The values are found from the deliveries themselves: a non-zero delivered value seen
//! often enough ([`MIN_SEEN`] times and 1 % of the non-zero deliveries), most frequent
//! first, is a new value unless it is a sum of at most [`MAX_PARTS`] values already
//! found (9 = 10 − 1, 20 = 10 + 10); at most [`MAX_VALUES`]. A delivery r then decodes
//! into the counts n_v ≥ 0 with Σ_v n_v v = r and the fewest parts; one that does not
//! decode goes whole to the value of largest magnitude. Each value v gets its own
//! [`Deconvolver`] fed n_v·v every step, and all of them share one delay pmf
//! (`Deconvolver::refit_all`): R̂ = Σ_v R̂_v. Until two values are found (and always
//! with decoding off) a single deconvolver sees the summed deliveries, exactly as
//! without this module. When the set of values changes, the per-value deconvolvers are
//! rebuilt from the stored history.
//!
//! Assumes rewards are deterministic per transition with few distinct values (the
//! paper's worlds, the maze, the robot); with continuous rewards no value is seen
//! twice and the summed fit is kept. The per-value deconvolvers see the same pairs, so one
//! set of co-occurrence counts (the first's) serves them all; each keeps its own lagged
//! reward sums.

use std::collections::HashMap;

use crate::deconv::{DeconvConfig, DeconvSettings, Deconvolver, next_refit_after};
use crate::diagnostics::Diagnostics;
use crate::diagnostics::Figure;
use crate::learner::Table;
use crate::surprise::{self, Surprise};

/// At most this many reward values.
pub const MAX_VALUES: usize = 4;
/// A delivery decodes into at most this many rewards.
pub const MAX_PARTS: u32 = 12;
/// A delivered value must be seen at least this many times to be a reward value.
pub const MIN_SEEN: u32 = 5;
/// Delivered values are compared in units of 1e-9.
const QUANTUM: f64 = 1e-9;

/// The key of a delivered value.
fn key(v: f64) -> i64 {
    (v / QUANTUM).round() as i64
}

/// The counts n_v ≥ 0, Σ n_v ≤ [`MAX_PARTS`], with Σ n_v `values[v]` = r (to 1e-9 in
/// relative terms) and the fewest parts (the first found of equally few); None when no
/// counts add up to r.
pub fn decode(values: &[f64], r: f64) -> Option<Vec<u32>> {
    fn search(
        values: &[f64],
        r: f64,
        tol: f64,
        left: u32,
        at: usize,
        cur: &mut Vec<u32>,
        best: &mut Option<(u32, Vec<u32>)>,
    ) {
        let used: u32 = cur.iter().sum();
        if best.as_ref().is_some_and(|(n, _)| *n <= used) {
            return;
        }
        if at == values.len() {
            let sum: f64 = cur.iter().zip(values).map(|(&n, &v)| f64::from(n) * v).sum();
            if (sum - r).abs() <= tol {
                *best = Some((used, cur.clone()));
            }
            return;
        }
        for n in 0..=left {
            cur.push(n);
            search(values, r, tol, left - n, at + 1, cur, best);
            cur.pop();
        }
    }
    let scale = values.iter().fold(r.abs(), |m, v| m.max(v.abs())).max(1.0);
    let mut best = None;
    search(values, r, 1e-9 * scale, MAX_PARTS, 0, &mut Vec::with_capacity(values.len()), &mut best);
    best.map(|(_, n)| n)
}

/// The reward values in `seen` (delivered value key → the value as first seen and the
/// times seen; `nonzero` deliveries in all), sorted ascending: see the module documentation.
pub fn find_values(seen: &HashMap<i64, (f64, u32)>, nonzero: u64) -> Vec<f64> {
    let min = u64::from(MIN_SEEN).max(nonzero / 100);
    let mut cand: Vec<(u32, i64, f64)> =
        seen.iter().filter(|&(_, &(_, n))| u64::from(n) >= min).map(|(&k, &(v, n))| (n, k, v)).collect();
    cand.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut values: Vec<f64> = Vec::new();
    for (_, _, v) in cand {
        if values.len() == MAX_VALUES {
            break;
        }
        if values.is_empty() || decode(&values, v).is_none() {
            values.push(v);
        }
    }
    values.sort_by(f64::total_cmp);
    values
}

/// One step of history: pair, next state, delivery, and the trajectory that took it.
#[derive(Clone, Copy, Debug)]
struct Step {
    x: u32,
    next: u32,
    stream: u32,
    r: f64,
}

/// Deconvolution with the deliveries decoded into reward values (or summed, with
/// `decode_values` off): the reward model of `deconv-q` and `deconv-model`.
#[derive(Clone, Debug)]
pub struct ValueDeconvolver {
    cfg: DeconvConfig,
    num_states: usize,
    num_actions: usize,
    /// The reward values, ascending (empty: one deconvolver of the summed deliveries).
    values: Vec<f64>,
    /// One deconvolver per value (or the one of the summed deliveries).
    parts: Vec<Deconvolver>,
    /// R̂ = Σ_v R̂_v by pair id (with values).
    r: Vec<f64>,
    /// Every step (with decoding on), and the steps at which a new run of a trajectory
    /// started (with that trajectory).
    hist: Vec<Step>,
    runs: Vec<(usize, u32)>,
    /// The trajectories so far ([`Self::new_stream`]; the one being fed is the parts').
    streams: usize,
    /// Each non-zero delivered value (as first seen) and the times it was seen, by key;
    /// and the non-zero deliveries.
    seen: HashMap<i64, (f64, u32)>,
    nonzero: u64,
    /// Each delivered value's shares by value (cache of [`Self::shares`]).
    cache: HashMap<i64, Vec<f64>>,
    next_refit: u64,
    /// Rebuilds of the per-value deconvolvers.
    rebuilds: u64,
    /// The largest |delivered reward| so far.
    max_delivery: f64,
    /// The test that calls a refit when the deliveries fall short (`refit_on_surprise`
    /// > 0), and the refits it called.
    surprise: Option<Surprise>,
    surprise_refits: u64,
}

impl ValueDeconvolver {
    /// Table entries of a deconvolving learner with `settings` over `pairs` state-action
    /// pairs whose reward fit has `features` features (the pairs, or their outcomes): Q,
    /// R̂ and the lagged reward sums of every feature (worst case: all seen), once per
    /// reward value when decoding (worst case: MAX_VALUES of them); the sparse
    /// co-occurrence counts grow with the run instead (at most 24 bytes × (K + 1) per
    /// step, docs/performance.md).
    pub(crate) fn table_entries(settings: &DeconvSettings, pairs: u128, features: u128) -> u128 {
        let copies = if settings.decode_values { MAX_VALUES as u128 } else { 1 };
        pairs
            + features
            + copies * Deconvolver::stats_bytes(features as usize, settings.max_delay).div_ceil(8)
    }

    /// A reward model over `num_states` × `num_actions` pairs.
    pub fn new(cfg: DeconvConfig, num_states: usize, num_actions: usize) -> Self {
        let st = &cfg.settings;
        let surprise = (st.refit_on_surprise > 0.0)
            .then(|| Surprise::new(st.refit_on_surprise, st.max_delay, st.refit_every));
        Self {
            parts: vec![Deconvolver::new(cfg.clone(), num_states, num_actions)],
            cfg,
            num_states,
            num_actions,
            values: Vec::new(),
            r: vec![0.0; num_states * num_actions],
            hist: Vec::new(),
            runs: Vec::new(),
            streams: 1,
            seen: HashMap::new(),
            nonzero: 0,
            cache: HashMap::new(),
            next_refit: 0,
            rebuilds: 0,
            max_delivery: 0.0,
            surprise,
            surprise_refits: 0,
        }
    }

    /// R̂(x).
    #[inline]
    pub fn reward(&self, x: usize) -> f64 {
        if self.values.is_empty() { self.parts[0].reward(x) } else { self.r[x] }
    }

    /// The whole reward table R̂ by pair id.
    pub fn rewards(&self) -> &[f64] {
        if self.values.is_empty() { self.parts[0].rewards() } else { &self.r }
    }

    /// The (shared) delay pmf p̂.
    pub fn pmf(&self) -> &[f64] {
        self.parts[0].pmf()
    }

    /// Standard errors of the shared pmf's median ([`Deconvolver::median_se`]).
    pub fn median_se(&self) -> Option<crate::deconv::MedianSe> {
        self.parts[0].median_se()
    }

    /// (σ̂ / v)²: the noise of the deliveries relative to the largest reward, which sets
    /// how much information a pair's reward needs before a reward that large would stand
    /// out ([`crate::deconv_model`], (M2)). σ̂² is the residual variance per step of the
    /// reward fit, summed over the per-value fits (their noises are independent parts of
    /// each delivery); v is the largest reward value found, or before two values are
    /// found the largest delivery seen. 0 before any non-zero delivery.
    pub fn noise_to_scale(&self) -> f64 {
        let v = if self.values.is_empty() {
            self.max_delivery
        } else {
            self.values.iter().fold(0.0_f64, |m, v| m.max(v.abs()))
        };
        if v <= 0.0 {
            return 0.0;
        }
        self.noise_variance() / (v * v)
    }

    /// σ̂²: the reward fit's residual variance per step, summed over the per-value fits.
    fn noise_variance(&self) -> f64 {
        self.parts.iter().map(Deconvolver::noise_variance).sum()
    }

    /// The reward fit's significance threshold in standard errors over `pairs`
    /// state-action pairs (the most pair features a fit can have).
    pub fn threshold_in_se(&self, pairs: usize) -> f64 {
        crate::deconv::threshold_in_se(self.cfg.settings.significance, pairs, self.num_actions)
    }

    /// The configuration it was built with.
    pub(crate) fn config(&self) -> &DeconvConfig {
        &self.cfg
    }

    /// Refits of the reward fit so far.
    pub fn refits(&self) -> u64 {
        self.parts[0].refits()
    }

    /// The reward values found (empty until two are).
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// The deconvolvers: one per value, or the one of the summed deliveries.
    pub fn parts(&self) -> &[Deconvolver] {
        &self.parts
    }

    /// One step: pair `x` was taken, led to `next_state`, and `reward` was delivered.
    /// Refits when due; returns true when it did.
    pub fn observe_transition(&mut self, x: usize, next_state: usize, reward: f64) -> bool {
        let refitted = self.observe_step(x, next_state, reward);
        if self.surprise.is_none() {
            return refitted;
        }
        if refitted {
            if let Some(m) = self.surprise.as_mut() {
                m.restart();
            }
            return true;
        }
        // No refit: R̂ and p̂ are those the delivery was due under.
        let predicted = surprise::predicted(self.pmf(), self.parts[0].recent_pairs(), |y| self.reward(y));
        let sigma2 = self.noise_variance();
        let Some(m) = self.surprise.as_mut() else {
            return false;
        };
        if !m.residual(reward - predicted, sigma2) {
            return false;
        }
        m.restart();
        self.surprise_refits += 1;
        // With the single deconvolver of the summed deliveries (before two values are
        // found) this comes on top of that deconvolver's own schedule.
        self.refit();
        true
    }

    /// [`Self::observe_transition`] without the test (S).
    fn observe_step(&mut self, x: usize, next_state: usize, reward: f64) -> bool {
        self.max_delivery = self.max_delivery.max(reward.abs());
        if !self.cfg.settings.decode_values {
            return self.parts[0].observe_transition(x, next_state, reward);
        }
        self.hist.push(Step {
            x: x as u32,
            next: next_state as u32,
            stream: self.stream() as u32,
            r: reward,
        });
        if reward != 0.0 {
            self.seen.entry(key(reward)).or_insert((reward, 0)).1 += 1;
            self.nonzero += 1;
        }
        if self.values.is_empty() {
            let refitted = self.parts[0].observe_transition(x, next_state, reward);
            if refitted {
                self.update_values();
            }
            return refitted;
        }
        let shares = self.shares(reward);
        for (d, &share) in self.parts.iter_mut().zip(&shares) {
            d.record_successor(x, next_state);
            d.record(x, share);
        }
        let t = self.parts[0].steps();
        let mut refitted = false;
        if t >= self.next_refit {
            self.refit();
            refitted = true;
        }
        refitted
    }

    /// The shared refit of the per-value deconvolvers, then a check of the values.
    fn refit(&mut self) {
        Deconvolver::refit_all(&mut self.parts);
        let t = self.parts[0].steps();
        self.next_refit = next_refit_after(&self.cfg.settings, t, self.parts[0].delay_settled());
        self.sum_rewards();
        self.update_values();
    }

    /// R̂ = Σ_v R̂_v.
    fn sum_rewards(&mut self) {
        self.r.iter_mut().for_each(|x| *x = 0.0);
        for d in &self.parts {
            self.r.iter_mut().zip(d.rewards()).for_each(|(x, y)| *x += y);
        }
    }

    /// A delivery's part for each value: n_v·v by [`decode`], or all of it to the value of
    /// largest magnitude when it does not decode.
    fn shares(&mut self, reward: f64) -> Vec<f64> {
        let values = &self.values;
        self.cache
            .entry(key(reward))
            .or_insert_with(|| match decode(values, reward) {
                Some(n) => n.iter().zip(values).map(|(&n, &v)| f64::from(n) * v).collect(),
                None => {
                    let big = (0..values.len())
                        .max_by(|&a, &b| values[a].abs().total_cmp(&values[b].abs()))
                        .unwrap_or(0);
                    (0..values.len()).map(|v| if v == big { reward } else { 0.0 }).collect()
                }
            })
            .clone()
    }

    /// Finds the values again; when two or more are found and they changed, rebuilds one
    /// deconvolver per value from the history (continuing the delay estimate) and refits.
    fn update_values(&mut self) {
        let values = find_values(&self.seen, self.nonzero);
        if values.len() < 2 || values == self.values {
            return;
        }
        self.values = values;
        self.cache.clear();
        self.rebuilds += 1;
        let mut parts: Vec<Deconvolver> = self
            .values
            .iter()
            .enumerate()
            .map(|(k, &v)| {
                // They all see the same pairs: the first keeps the co-occurrence counts
                // for all of them.
                let mut d =
                    Deconvolver::with_counts(self.cfg.clone(), self.num_states, self.num_actions, k == 0);
                d.set_sign(v);
                d
            })
            .collect();
        let runs = self.runs.clone();
        let mut run = runs.iter().peekable();
        for j in 0..self.hist.len() {
            while let Some(&(_, stream)) = run.next_if(|&&(start, _)| start == j) {
                for d in parts.iter_mut() {
                    d.set_stream(stream as usize);
                    d.reset_history();
                }
            }
            let s = self.hist[j];
            for d in parts.iter_mut() {
                d.set_stream(s.stream as usize);
            }
            let shares = self.shares(s.r);
            for (d, &share) in parts.iter_mut().zip(&shares) {
                d.record_successor(s.x as usize, s.next as usize);
                d.record(s.x as usize, share);
            }
        }
        let stream = self.stream();
        for d in &mut parts {
            d.inherit(&self.parts[0]);
            d.set_stream(stream);
        }
        self.parts = parts;
        self.refit();
    }

    /// R̂ (`r_hat`, shape [states, actions]) and p̂ (`delay_pmf`), for export.
    pub fn tables(&self) -> [Table; 2] {
        let [mut r, p] = self.parts[0].tables();
        r.data = self.rewards().to_vec();
        [r, p]
    }

    /// Diagnostics: the delay estimate ([`Deconvolver::diagnostics`], shared) and the
    /// reward values found.
    pub fn diagnostics(&self) -> Diagnostics {
        let mut d = self.parts[0].diagnostics();
        if self.cfg.settings.decode_values {
            d.figures.push((Figure::RewardValuesFound, self.values.len() as f64));
            d.figures.push((Figure::RewardValueRebuilds, self.rebuilds as f64));
            d.reward_values.clone_from(&self.values);
        }
        if self.surprise.is_some() {
            d.figures.push((Figure::DelaySurpriseRefits, self.surprise_refits as f64));
        }
        d
    }

    /// Forgets the last K steps of the trajectory being fed (a new run starts);
    /// statistics, R̂ and p̂ are kept.
    pub fn reset_history(&mut self) {
        self.parts.iter_mut().for_each(Deconvolver::reset_history);
        if let Some(m) = self.surprise.as_mut() {
            m.restart();
        }
        if self.cfg.settings.decode_values {
            self.runs.push((self.hist.len(), self.stream() as u32));
        }
    }

    /// The trajectory being fed (0 until [`Self::set_stream`]).
    pub fn stream(&self) -> usize {
        self.parts[0].stream()
    }

    /// A new trajectory's number, for [`Self::set_stream`].
    pub fn new_stream(&mut self) -> usize {
        self.streams += 1;
        if let Some(m) = self.surprise.as_mut() {
            m.set_trajectories(self.streams as u64);
        }
        self.streams - 1
    }

    /// Feeds trajectory `i` (0, or a number from [`Self::new_stream`]) from now on: its
    /// steps are lagged only against its own (parameter sharing: the robots of a swarm
    /// fit one R̂ and one p̂, each delivery explained by its own robot's past pairs). The
    /// test (S) is one over every trajectory's residuals (each is zero-mean under the
    /// model, whichever robot it came from), made once every trajectory has had, on
    /// average, the steps one trajectory's test waits for.
    pub fn set_stream(&mut self, i: usize) {
        debug_assert!(i < self.streams, "stream {i} of {}", self.streams);
        self.parts.iter_mut().for_each(|d| d.set_stream(i));
    }

    /// Feeds `stream`, or a new trajectory's stream when `None` (one that has not started):
    /// what a learner's memory swap does.
    pub fn enter(&mut self, stream: Option<usize>) {
        let i = stream.unwrap_or_else(|| self.new_stream());
        self.set_stream(i);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::deconv::pmf_mean;
    use crate::deconv::tests::cfg;
    use mmq_core::seed::rng_from_seed;
    use rand::RngExt;

    /// Three states, 0 → 1 → 2 (the goal) by action 0; action 1 bumps (stays, −1) in 0
    /// and 1; any action in 2 pays +10 and returns to 0. Action 1 with probability 0.3,
    /// delays uniform on {1, 2, 3}; `steps` steps into `observe`.
    fn chain(steps: usize, bumps: bool, mut observe: impl FnMut(usize, usize, f64)) {
        let mut rng = rng_from_seed(5);
        let (mut s, mut pending) = (0, vec![0.0; steps + 4]);
        for t in 0..steps {
            let a = usize::from(rng.random_bool(0.3));
            let (s2, r) = match (s, a) {
                (2, _) => (0, 10.0),
                (s, 0) => (s + 1, 0.0),
                (s, _) => (s, if bumps { -1.0 } else { 0.0 }),
            };
            if r != 0.0 {
                pending[t + rng.random_range(1..=3)] += r;
            }
            observe(s * 2 + a, s2, pending[t]);
            s = s2;
        }
    }

    fn config() -> DeconvConfig {
        let mut c = cfg(6, None);
        let s = &mut c.settings;
        (s.lasso, s.significance, s.reward_prior, s.refit_every) = (0.1, 1.0, 1.0, 1000);
        (s.successor_groups, s.pmf_weighted, s.pmf_significance, s.pmf_prior) = (true, true, 1.0, 5.0);
        c.settings.decode_values = true;
        c
    }

    /// A reward that stops. One state, two actions taken in turn, the delay told to be 1
    /// step; action 0 pays +4 until step 400, then nothing. Scheduled refits (every 50
    /// steps, growth 1) come at 50, 100, 200, 400 and 800. Without the test (S), R̂(0) stays
    /// 4 after step 400; with it, σ̂² = 0 at the refit at 400 (the fit is exact), so the
    /// shortfall calls a refit as soon as `refit_every` = 50 steps have passed: at 450,
    /// 500, 550 and 600. At 600, R̂(0) is least squares over all 300 visits, 200 of them
    /// paid: 800/300.
    #[test]
    fn a_reward_that_stops_is_refitted_on_surprise_by_hand() {
        let run = |z: f64| {
            let mut c = cfg(1, Some(vec![0.0, 1.0]));
            (c.settings.refit_every, c.settings.refit_growth, c.settings.refit_on_surprise) = (50, 1, z);
            let mut d = ValueDeconvolver::new(c, 1, 2);
            let mut pending = 0.0;
            let mut refit_at = Vec::new();
            for t in 0..600 {
                let x = t % 2;
                if d.observe_transition(x, 0, pending) {
                    refit_at.push(t + 1);
                }
                pending = if x == 0 && t < 400 { 4.0 } else { 0.0 };
            }
            let surprised = d.diagnostics().figure(Figure::DelaySurpriseRefits);
            (d.reward(0), refit_at, surprised)
        };
        let (r, at, surprised) = run(0.0);
        assert_eq!(at, [50, 100, 200, 400]);
        assert!((r - 4.0).abs() < 1e-9, "R̂(0) = {r}");
        assert_eq!(surprised, None);
        let (r, at, surprised) = run(3.0);
        assert_eq!(at, [50, 100, 200, 400, 450, 500, 550, 600]);
        assert!((r - 800.0 / 300.0).abs() < 1e-9, "R̂(0) = {r}");
        assert_eq!(surprised, Some(4.0));
    }

    /// Two chains on disjoint states (0..3 and 3..6) as two trajectories taking turns; the
    /// second starts half-way and bumps for −2.5, a third value, so the values change late
    /// and the per-value deconvolvers are rebuilt from the whole history, each step
    /// replayed in its own trajectory. R̂ has each chain's rewards on its own pairs.
    #[test]
    fn a_rebuild_replays_each_trajectory_as_its_own() {
        let steps = 60_000;
        let mut d = ValueDeconvolver::new(config(), 6, 2);
        let b = d.new_stream();
        let mut rng = rng_from_seed(9);
        // Per chain: its state, its deliveries by its own step, its steps, its bump.
        let mut chains = [(0, vec![0.0; steps + 4], 0, -1.0), (0, vec![0.0; steps + 4], 0, -2.5)];
        for t in 0..steps {
            let i = usize::from(t >= steps / 2 && rng.random_bool(0.5));
            d.set_stream([0, b][i]);
            let (s, pending, u, bump) = &mut chains[i];
            let a = usize::from(rng.random_bool(0.3));
            let (s2, r) = match (*s, a) {
                (2, _) => (0, 10.0),
                (s, 0) => (s + 1, 0.0),
                (s, _) => (s, *bump),
            };
            if r != 0.0 {
                pending[*u + rng.random_range(1..=3)] += r;
            }
            d.observe_transition((3 * i + *s) * 2 + a, 3 * i + s2, pending[*u]);
            (*s, *u) = (s2, *u + 1);
        }
        d.refit();
        assert_eq!(d.values(), [-2.5, -1.0, 10.0]);
        let mut want = [0.0; 12];
        (want[1], want[3], want[4], want[5]) = (-1.0, -1.0, 10.0, 10.0);
        (want[7], want[9], want[10], want[11]) = (-2.5, -2.5, 10.0, 10.0);
        for (x, (&got, w)) in d.rewards().iter().zip(want).enumerate() {
            assert!((got - w).abs() < 0.5, "R̂({x}) = {got}, want {w}: {:?}", d.rewards());
        }
    }

    /// With one reward value there is nothing to decode: every step, R̂ and p̂ are those of
    /// the plain deconvolver of the summed deliveries, bit for bit.
    #[test]
    fn one_value_is_the_summed_fit() {
        let mut plain = Deconvolver::new(config(), 3, 2);
        let mut decoded = ValueDeconvolver::new(config(), 3, 2);
        chain(20_000, false, |x, s2, r| {
            assert_eq!(plain.observe_transition(x, s2, r), decoded.observe_transition(x, s2, r));
            assert_eq!(plain.rewards(), decoded.rewards());
        });
        assert!(decoded.values().is_empty());
        assert_eq!(plain.pmf(), decoded.pmf());
        assert!((plain.reward(4) - 10.0).abs() < 0.5, "R̂(G) = {}", plain.reward(4));
    }

    /// Wall bumps (−1) and the goal (+10): the deliveries decode into the two values, each
    /// gets its own reward table (the −1 table carries the bumps and not the goal, and
    /// the other way round), R̂ is their sum, and one pmf is shared and right.
    #[test]
    fn two_values_are_deconvolved_apart_with_one_pmf() {
        let mut d = ValueDeconvolver::new(config(), 3, 2);
        chain(40_000, true, |x, s2, r| {
            d.observe_transition(x, s2, r);
        });
        assert_eq!(d.values(), &[-1.0, 10.0]);
        let [neg, pos] = d.parts() else { panic!("{} parts", d.parts().len()) };
        for x in 0..6 {
            assert_eq!(d.reward(x), neg.reward(x) + pos.reward(x), "R̂ = Σ_v R̂_v at pair {x}");
        }
        // The lasso biases an estimate towards zero by λ₁ = 0.1 and by its significance
        // threshold: −0.86 for a bump.
        for bump in [1, 3] {
            assert!((neg.reward(bump) + 1.0).abs() < 0.2, "R̂_−1(bump {bump}) = {}", neg.reward(bump));
            assert_eq!(pos.reward(bump), 0.0, "the +10 table has no bump");
        }
        for goal in [4, 5] {
            assert!((pos.reward(goal) - 10.0).abs() < 0.5, "R̂_10(G) = {}", pos.reward(goal));
            assert_eq!(neg.reward(goal), 0.0, "the −1 table has no goal");
        }
        assert!(neg.rewards().iter().all(|&r| r <= 0.0) && pos.rewards().iter().all(|&r| r >= 0.0));
        assert_eq!(neg.pmf(), pos.pmf());
        assert!((pmf_mean(d.pmf()) - 2.0).abs() < 0.1, "p̂ = {:?}", d.pmf());
        let m = d.diagnostics();
        assert_eq!(m.figure(Figure::RewardValuesFound), Some(2.0));
        assert_eq!(m.reward_values.len(), 2);
    }

    /// The two values' fits are the same when one is fitted on a second thread
    /// (and the cold starts run on a third) as on one thread, bit for bit.
    #[test]
    fn two_values_fit_the_same_on_any_thread() {
        let run = |beside: bool| {
            crate::spare::FORCE.with(|f| f.set(Some(beside)));
            let mut d = ValueDeconvolver::new(config(), 3, 2);
            chain(20_000, true, |x, s2, r| {
                d.observe_transition(x, s2, r);
            });
            crate::spare::FORCE.with(|f| f.set(None));
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            let parts: Vec<_> =
                d.parts().iter().map(|p| (bits(p.rewards()), p.refits(), p.rounds())).collect();
            (bits(d.pmf()), parts, d.diagnostics().figures)
        };
        let alone = run(false);
        assert_eq!(alone.1.len(), 2, "two values found");
        for _ in 0..3 {
            assert_eq!(run(true), alone);
        }
    }

    #[test]
    fn deliveries_decode_into_the_fewest_values() {
        let v = [-1.0, 10.0];
        assert_eq!(decode(&v, 9.0), Some(vec![1, 1]));
        assert_eq!(decode(&v, 0.0), Some(vec![0, 0]));
        assert_eq!(decode(&v, 19.0), Some(vec![1, 2]));
        assert_eq!(decode(&v, -2.0), Some(vec![2, 0]));
        assert_eq!(decode(&v, 20.0), Some(vec![0, 2]));
        // 10·a − b = 3 needs 7 bumps and a goal: 8 parts, within MAX_PARTS.
        assert_eq!(decode(&v, 3.0), Some(vec![7, 1]));
        assert_eq!(decode(&v, 0.5), None);
        assert_eq!(decode(&v, -13.0), None, "13 parts are more than MAX_PARTS");
        assert_eq!(decode(&[], 0.0), Some(vec![]));
        assert_eq!(decode(&[], 1.0), None);
    }

    #[test]
    fn values_are_the_frequent_deliveries_that_are_not_sums() {
        let mut seen = HashMap::new();
        for (v, n) in [(10.0, 50), (-1.0, 40), (9.0, 8), (20.0, 6), (-2.0, 5), (0.25, 4), (7.5, 6)] {
            seen.insert(key(v), (v, n));
        }
        // 0.25 is seen too rarely; 9, 20, −2 are sums of 10 and −1; 7.5 is not.
        assert_eq!(find_values(&seen, 119), vec![-1.0, 7.5, 10.0]);
        // 1 % of 1000 non-zero deliveries is 10: 7.5 (6 times) no longer counts.
        assert_eq!(find_values(&seen, 1000), vec![-1.0, 10.0]);
        assert!(find_values(&HashMap::new(), 0).is_empty());
    }
}
