//! The deconvolution's settings ([`DeconvSettings`]), shared by the deconvolving learners
//! (`deconv-q`, `deconv-model`, `deconv-model-time`, each of which flattens them into its
//! own settings): their defaults, written once here, their validation, and the
//! [`DeconvConfig`] a [`super::Deconvolver`] is built from.

use mmq_core::DelayDist;
use serde::{Deserialize, Serialize};

use super::DeconvConfig;
use crate::error::{LearnError, bad};
use crate::pmf::truncated_pmf;

/// The fits of the delay pmf in a refit that run the reweighted passes
/// ([`DeconvSettings::pmf_weighted_rounds`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WeightedRounds {
    /// Every fit: both starts and every further round.
    #[default]
    Every,
    /// The fits a refit can end with: the last round, or both starts when there is one
    /// round; the earlier fits are plain least squares.
    Last,
}

/// Deconvolution settings, shared by `deconv-q`, `deconv-model` and `deconv-model-time`
/// ([`crate::deconv`]; the measurements behind the defaults: docs/algorithms/deconvolution.md).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct DeconvSettings {
    /// K, the largest delay considered: steps (`deconv-model-time`: time bins); at most
    /// 65536. Default 50, as MMQ's λ̂max.
    pub max_delay: usize,
    /// Strength of the zero-mean prior on every reward estimate R̂(s, a), in visits'
    /// worth of information (≥ 0): R̂ is shrunk by n / (n + prior) after n visits.
    pub reward_prior: f64,
    /// L1 (lasso) penalty on R̂(s, a), in reward units (≥ 0): estimates whose evidence is
    /// weaker than this are set to exactly zero, and the others are biased towards zero
    /// by this much.
    pub lasso: f64,
    /// κ ≥ 0: a reward estimate is kept only when it lies more than κ·√(2 ln m) standard
    /// errors from zero, m the number of reward features (κ = 1: the universal threshold
    /// of Donoho & Johnstone, which keeps false positives rare among hundreds of pairs).
    pub significance: f64,
    /// Fit a reward per state (shared by its actions) besides the reward per pair: the
    /// sparsest explanation then credits a goal state rather than the pairs that enter it.
    /// Off by default: on the 15×15 maze the state features explained the wall bumps of
    /// corridor cells as a penalty on every action there, and `deconv-model` never
    /// learned to stop bumping.
    pub state_rewards: bool,
    /// Reward features per transition: the actions of a state that have only ever led to
    /// one and the same next state share a reward feature besides their own (a pair
    /// seen leading to two next states leaves its group). On by default: in the paper's
    /// worlds it groups the goal's actions (all teleport to S) and the wall bumps of a
    /// cell (all stay put), so the goal's reward is credited to the goal rather than to
    /// the move into it one step earlier, which had made the delay estimate one step
    /// late. `state_rewards` takes precedence.
    pub successor_groups: bool,
    /// κ_J ≥ 0: after the lasso, a pair keeps its reward only if it is also significant
    /// jointly with the other rewarded pairs (more than κ_J times the lasso's threshold
    /// in joint standard errors); the least significant is dropped and the rest refitted.
    /// 0 turns the test off. Pair features only (ignored with `state_rewards`). On by
    /// default (1): without it, a corridor step and its way back on the 15×15 maze
    /// could carry +11 and −11, a loop `deconv-model` chased.
    pub joint_test: f64,
    /// Refine the delay pmf by reweighted least squares on the stored history (each step
    /// weighted by the inverse variance of its delivery); false: plain least squares.
    pub pmf_weighted: bool,
    /// Which fits of the delay pmf in a refit run the reweighted passes (with
    /// `pmf_weighted`): `every` (the default), or `last`, only the fits a refit can end
    /// with (its last round; both starts when `pmf_rounds` is 1), the earlier ones by plain
    /// least squares. `last` is the cheaper: on paper-9x9 with `deconv-model`'s defaults
    /// it takes a third to a half less CPU time and earns as much on average, but a flat
    /// delay's median is less accurate early (docs/performance.md, "Trading estimates for
    /// speed").
    pub pmf_weighted_rounds: WeightedRounds,
    /// Decode each delivery into the discrete reward values it is a sum of (9 = +10 − 1)
    /// and deconvolve each value on its own with a shared delay pmf: the wall bumps' −1s
    /// then form a series of their own, whose irregular timing identifies a delay wider
    /// than the goal's period. On by default: on 9×9 it brought `deconv-model`'s worst
    /// uniform-delay median error at 50k from 5.0 to 1.7 steps at equal reward, and
    /// `deconv-q`'s reward from 100 % to 103 %.
    pub decode_values: bool,
    /// κ_p ≥ 0, in the reweighted fit: a delay keeps its estimated probability only with
    /// more than κ_p standard errors of evidence (0: plain least squares, whose
    /// non-negativity turns noise into spurious mass at every delay). Default 1, measured
    /// best for a flat delay.
    pub pmf_significance: f64,
    /// ν ≥ 0: pull of the delay-pmf fit towards the uniform pmf, worth ν visits of the
    /// largest reward; it fades as rewards come in, so that early fits stay broad.
    /// Default 5 (a strong pull put mass at long delays where the data hardly tell delays
    /// apart, and the median came out high).
    pub pmf_prior: f64,
    /// ρ ≥ 0: roughness penalty of the delay-pmf fit, ½ ρ max_x R̂(x)² Σ_k (p(k+1) − p(k))²,
    /// in visits of the largest reward (0: off). A smooth pmf resists the aliasing of
    /// delays k and k + P by a regular goal period P.
    pub pmf_smoothness: f64,
    /// Steps between two refits of R̂ and the delay pmf early on (≥ 1); later refits
    /// come every max(refit_every, t/refit_growth) steps. Default 250 (`deconv-model`:
    /// 100).
    pub refit_every: u64,
    /// g ≥ 1: once t/g exceeds `refit_every`, the refit after one at step t comes at
    /// t + t/g, so that the number of refits grows with the logarithm of the run's length
    /// (a smaller g refits less often: cheaper, the estimates staler). Default 8: g = 4
    /// refits 27 times in 150,000 steps instead of 45 and takes about 30 % less CPU time,
    /// but earned less on paper-9x9 and the maze (docs/performance.md).
    pub refit_growth: u64,
    /// Rounds of the alternation per refit, in [1, 20]: p̂ given R̂, then R̂ given p̂. Both
    /// starts (the previous p̂ and the uniform pmf) get one round; the better one then
    /// gets `pmf_rounds` − 1 more. Default 1. One round leaves p̂ partway between its
    /// start and the fit, and the uniform start wins most refits, so the delay median runs
    /// high for tens of thousands of steps; 4 rounds (`deconv-model`'s default) halved its
    /// error on paper-9x9 under the reward-first settings (docs/algorithms/deconv-model.md).
    pub pmf_rounds: u32,
    /// τ ≥ 0: a refit's rounds stop early once the delay pmf has settled, that is after
    /// the first round that moved no p̂(k) by more than τ from where the round started
    /// (the kept start's first round starts from the previous p̂, or from the uniform pmf).
    /// 0 (the default): every one of the `pmf_rounds` rounds runs. τ = 1e-4 skips late
    /// rounds, which move p̂ by 1e-5 or less, and earned what τ = 0 earns on paper-9x9
    /// and the maze with 10 % and 5 % less work (docs/performance.md, "Rounds until
    /// the pmf settles, and fewer cold starts").
    pub pmf_tolerance: f64,
    /// n ≥ 0: after the cold start (the alternation from the uniform pmf, which a refit
    /// compares with the one from the previous p̂) has lost n refits in a row, the next
    /// 2^(losses − n) refits (at most 64) skip it; a win starts the count again. 0 (the
    /// default): every refit tries it. The cold start gets an alternation locked onto a
    /// wrong delay out again, at the cost of a fit of p̂ and two of R̂ per refit; with
    /// n = 2 and τ = 1e-4 paper-9x9 takes a quarter less work, but its worst seed under
    /// Poisson 13 earned less (docs/performance.md, "Rounds until the pmf settles, and
    /// fewer cold starts").
    pub cold_start_backoff: u32,
    /// s ≥ 0, in steps: once a refit finds the standard error of the delay median below
    /// s (the delay estimate has settled), the next refit comes after t/g_s steps
    /// (g_s: `settled_refit_growth`) instead of t/g (g: `refit_growth`); refits return to
    /// t/g whenever the error is s or more. 0 (the default; `deconv-model`: 0.5): off. On
    /// paper-9x9, s = 0.5 with g_s = 3 takes about 40 % off the CPU time of a
    /// 150,000-step run and earns as much under the four delays and on the maze
    /// (docs/performance.md, "Sparser refits once the delay has settled").
    pub sparse_refits_below_se: f64,
    /// g_s ≥ 1: the later refits come every t/g_s steps instead of t/g while the delay has
    /// settled (`sparse_refits_below_se`; unused when that is 0). Default 3 (paper-9x9 at
    /// over 300 k steps per second with a spare core). g_s = 4 earned as much and took a
    /// fifth more time; g_s = 2 runs at over 400 k steps per second but left the uniform
    /// delay's median 1.5 steps off at 50k in the worst seed and one maze seed at 44 % of
    /// the ε-soft ceiling (docs/performance.md, "Sparser refits once the delay has
    /// settled").
    pub settled_refit_growth: u64,
    /// z ≥ 0: refit at once when the deliveries since the last refit fall short of what
    /// R̂ and p̂ predict by more than z standard errors (a reward the fit put where there
    /// is none, which the agent then seeks; a cost put on the moves around a bump, which
    /// then looks free) (`surprise.rs`, (S)). 0 (the default; `deconv-model`: 3): refits
    /// only on the schedule of `refit_every` and `refit_growth`.
    pub refit_on_surprise: f64,
    /// Tells the learner the true delay distribution (a delay spec in steps such as
    /// `poisson:13`) instead of letting it estimate it: an ablation that measures what
    /// the estimate costs. Absent (the default): estimate it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub told_delay: Option<String>,
}

impl Default for DeconvSettings {
    fn default() -> Self {
        Self {
            max_delay: 50,
            reward_prior: 1.0,
            lasso: 0.1,
            significance: 1.0,
            state_rewards: false,
            successor_groups: true,
            joint_test: 1.0,
            pmf_weighted: true,
            pmf_weighted_rounds: WeightedRounds::Every,
            decode_values: true,
            pmf_significance: 1.0,
            pmf_prior: 5.0,
            pmf_smoothness: 0.0,
            refit_every: 250,
            refit_growth: 8,
            pmf_rounds: 1,
            pmf_tolerance: 0.0,
            cold_start_backoff: 0,
            sparse_refits_below_se: 0.0,
            settled_refit_growth: 3,
            refit_on_surprise: 0.0,
            told_delay: None,
        }
    }
}

impl DeconvSettings {
    /// K = `max_delay` with every penalty, prior and refinement off (no reward prior,
    /// lasso or significance thresholds, no successor groups, plain least squares for p,
    /// no decoding) and no refit on the schedule before step 1,000,000: the plain fit of
    /// (D2) that tests check by hand. The rest as [`Default`].
    #[cfg(test)]
    pub(crate) fn unpenalised(max_delay: usize) -> Self {
        Self {
            max_delay,
            reward_prior: 0.0,
            lasso: 0.0,
            significance: 0.0,
            successor_groups: false,
            joint_test: 0.0,
            pmf_weighted: false,
            decode_values: false,
            pmf_significance: 0.0,
            pmf_prior: 0.0,
            refit_every: 1_000_000,
            ..Self::default()
        }
    }

    pub(crate) fn validate(&self) -> Result<(), LearnError> {
        // Finite and ≥ 0, checked in this order (the first failing field is reported).
        let non_negative: [(&'static str, f64, &'static str); 10] = [
            ("reward_prior", self.reward_prior, "use a prior strength ≥ 0, e.g. 1"),
            ("lasso", self.lasso, "use an L1 penalty ≥ 0 in reward units, e.g. 0.1"),
            ("significance", self.significance, "use a multiple of the universal threshold ≥ 0, e.g. 1"),
            ("joint_test", self.joint_test, "use a multiple of the lasso's threshold ≥ 0, e.g. 1 (0: off)"),
            ("pmf_significance", self.pmf_significance, "use a number of standard errors ≥ 0, e.g. 1"),
            ("pmf_prior", self.pmf_prior, "use a prior weight ≥ 0 in visits, e.g. 5"),
            ("pmf_smoothness", self.pmf_smoothness, "use a penalty ≥ 0 in visits, e.g. 10 (0: off)"),
            ("pmf_tolerance", self.pmf_tolerance, "use a probability ≥ 0, e.g. 1e-4 (0: every round runs)"),
            (
                "sparse_refits_below_se",
                self.sparse_refits_below_se,
                "use a standard error ≥ 0 in steps, e.g. 0.5 (0: off)",
            ),
            (
                "refit_on_surprise",
                self.refit_on_surprise,
                "use a number of standard errors ≥ 0, e.g. 3 (0: off)",
            ),
        ];
        for (field, value, accepted) in non_negative {
            if !(value.is_finite() && value >= 0.0) {
                return bad(field, value, accepted);
            }
        }
        if self.refit_every == 0 {
            return bad("refit_every", 0, "use at least 1 step between refits, e.g. 250");
        }
        if self.refit_growth == 0 {
            return bad(
                "refit_growth",
                0,
                "use a divisor ≥ 1 of the step count, e.g. 8 (refits every t/8 steps)",
            );
        }
        if self.settled_refit_growth == 0 {
            return bad(
                "settled_refit_growth",
                0,
                "use a divisor ≥ 1 of the step count, e.g. 3 (refits every t/3 steps once the delay has settled)",
            );
        }
        if !(1..=20).contains(&self.pmf_rounds) {
            return bad(
                "pmf_rounds",
                self.pmf_rounds,
                "use 1 to 20 rounds of the alternation per refit, e.g. 1",
            );
        }
        if self.max_delay > 1 << 16 {
            return bad("max_delay", self.max_delay, "the deconvolving learners accept at most 65536");
        }
        if let Some(d) = &self.told_delay {
            match DelayDist::parse(d) {
                Err(_) => {
                    return bad("told_delay", d, "use a delay spec such as poisson:13 (see `delay`)");
                }
                Ok(dist) if dist.unit() == mmq_core::DelayUnit::Seconds => {
                    return bad(
                        "told_delay",
                        d,
                        "a told delay is a pmf over step lags: give it in steps, e.g. poisson:13 (a delay in seconds is learned by deconv-model-time)",
                    );
                }
                Ok(_) => {}
            }
        }
        Ok(())
    }

    /// The deconvolver configuration (after `validate`).
    pub fn config(&self) -> Result<DeconvConfig, LearnError> {
        let told = match &self.told_delay {
            Some(d) => Some(truncated_pmf(
                &DelayDist::parse(d).map_err(|_| LearnError::InvalidParam {
                    field: "told_delay",
                    value: d.clone(),
                    accepted: "use a delay spec such as poisson:13 (see `delay`)",
                })?,
                self.max_delay,
            )),
            None => None,
        };
        Ok(DeconvConfig { settings: self.clone(), told })
    }
}
