//! Each learner's own settings: one struct per family of learners, each with its
//! defaults, its validation, the size of its tables and the text reports show.
//! [`LearnerSettings`] holds the settings of one learner, tagged by its `kind`, so that a
//! configuration lists exactly the settings the chosen learner reads (an MMQ run:
//! `max_delay`; no lasso), and a setting the learner does not have is refused by name.

use mmq_core::DelayDist;
use serde::{Deserialize, Serialize};

use crate::deconv::{DeconvConfig, truncated_pmf};
use crate::error::{LearnError, bad};
use crate::kind::LearnerKind;
use crate::mmq_kernel::Bootstrap;

/// Settings of a learner that has none beyond the shared parameters (`q`, `oracle`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoSettings {}

/// Settings of `fixed`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FixedSettings {
    /// λ̂ of eq. (4), steps: the reward at t updates the pair from λ̂ steps ago. Default 13,
    /// the mean of the paper's Poisson delay (assumption: the paper states no value).
    pub lambda_hat: usize,
}

impl Default for FixedSettings {
    fn default() -> Self {
        Self { lambda_hat: 13 }
    }
}

/// Settings of `mmq` and `mmq-reference`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MmqSettings {
    /// λ̂max of Algorithm 1, steps: N = λ̂max + 1 models (paper: 50).
    pub max_delay: usize,
}

impl Default for MmqSettings {
    fn default() -> Self {
        Self { max_delay: 50 }
    }
}

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
    fn validate(&self) -> Result<(), LearnError> {
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

/// Settings of `q-lambda` and `sarsa-lambda`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TraceSettings {
    /// Trace decay in [0, 1] (called λ in Sutton & Barto; named `trace_decay` here so
    /// that it is not confused with the Poisson delay λ). Default 0.9 (assumption).
    pub trace_decay: f64,
}

impl Default for TraceSettings {
    fn default() -> Self {
        Self { trace_decay: 0.9 }
    }
}

impl TraceSettings {
    fn validate(&self) -> Result<(), LearnError> {
        if !(0.0..=1.0).contains(&self.trace_decay) {
            return bad("trace_decay", self.trace_decay, "use a trace decay in [0, 1], e.g. 0.9");
        }
        Ok(())
    }
}

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
    fn validate(&self) -> Result<(), LearnError> {
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

    /// Table entries of a deconvolving learner over `pairs` state-action pairs: Q, R̂ and
    /// the lagged reward sums of every pair (worst case: all pairs visited), once per
    /// reward value when decoding (worst case: MAX_VALUES of them); the sparse
    /// co-occurrence counts grow with the run instead (at most 24 bytes × (K + 1) per
    /// step, docs/performance.md).
    fn table_entries(&self, pairs: u128) -> u128 {
        let copies = if self.decode_values { crate::decode::MAX_VALUES as u128 } else { 1 };
        2 * pairs
            + copies * crate::deconv::Deconvolver::stats_bytes(pairs as usize, self.max_delay).div_ceil(8)
    }
}

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

/// Exploration of the model-based deconvolving learners ([`crate::deconv_model`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ExploreSettings {
    /// A pair tried fewer times than this keeps its optimistic value q0 (R-max style
    /// exploration); 0 plans with every pair's estimate at once. Default 10. Used by
    /// `deconv-model-time`, and by `deconv-model` when `optimism_confidence` is 0.
    pub optimism_visits: u32,
    /// Probability per step, in [0, 1], that a *delay probe* falls due while the median
    /// of the delay estimate has a standard error above `probe_precision`; a due probe is
    /// taken at the first non-exploring step in a state where some action is known to
    /// keep the agent where it is at a cost (a wall bump). Its reward leaves at a random
    /// time and so samples the delay without the period of the goal's rewards (0: off).
    pub probe_rate: f64,
    /// Probes stop once the median of the delay estimate has a standard error of at most
    /// this many steps (`deconv-model-time`: bins) ([`crate::deconv::Deconvolver::median_se`]; > 0).
    pub probe_precision: f64,
    /// The steps at which a due probe is taken: `"greedy"` (a step that is not
    /// ε-exploration; the default of `deconv-model-time`), `"exploring"` (a step of
    /// ε-exploration, in place of its random action) or `"any"` (`deconv-model`'s
    /// default).
    pub probe_steps: crate::deconv_model::ProbeSteps,
}

impl Default for ExploreSettings {
    fn default() -> Self {
        Self {
            optimism_visits: 10,
            probe_rate: 0.02,
            probe_precision: 0.5,
            probe_steps: crate::deconv_model::ProbeSteps::Greedy,
        }
    }
}

impl ExploreSettings {
    fn validate(&self) -> Result<(), LearnError> {
        if !(0.0..=1.0).contains(&self.probe_rate) {
            return bad("probe_rate", self.probe_rate, "use a probability in [0, 1], e.g. 0.02 (0: off)");
        }
        if !(self.probe_precision.is_finite() && self.probe_precision > 0.0) {
            return bad(
                "probe_precision",
                self.probe_precision,
                "use a standard error > 0 in steps, e.g. 0.5",
            );
        }
        Ok(())
    }

    fn probes(&self) -> crate::deconv_model::Probes {
        crate::deconv_model::Probes {
            rate: self.probe_rate,
            precision: self.probe_precision,
            steps: self.probe_steps,
        }
    }
}

/// Settings of `deconv-model`.
///
/// Its defaults ([`Default`]) put the reward first: exploration from confidence (z = 2),
/// delay probes on any step, refits every 100 steps early, four rounds of the
/// alternation per refit, refits on surprise (z = 3), sparser refits once the delay has
/// settled (s = 0.5 steps) and planning the ε-greedy policy's values
/// (docs/algorithms/deconv-model.md, "Reward first"). A setting that a
/// configuration file does not give reads as off ([`Self::when_absent`]): a recording
/// made before a setting existed then replays as it ran.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default = "DeconvModelSettings::when_absent", deny_unknown_fields)]
pub struct DeconvModelSettings {
    /// The deconvolution.
    #[serde(flatten)]
    pub deconv: DeconvSettings,
    /// Exploration.
    #[serde(flatten)]
    pub explore: ExploreSettings,
    /// z ≥ 0, exploration from confidence: a pair keeps its optimistic value q0 (R-max
    /// style) until the reward fit has found a reward there, or would find one as large as
    /// the largest found with z standard errors to spare beyond its significance threshold
    /// ([`crate::deconv_model`], (M2)). Default 2; 0: the fixed count `optimism_visits`
    /// (docs/algorithms/deconv-model.md, "Exploration from confidence", says what each
    /// costs).
    pub optimism_confidence: f64,
    /// Plan the values of the ε-greedy policy the agent follows,
    /// V(s) = (1 − ε) max_a Q + ε mean_a Q ([`crate::deconv_model`], (M1′)), so that it
    /// prefers paths where a random action costs little (the default); false:
    /// V(s) = max_a Q.
    pub plan_exploration: bool,
}

impl Default for DeconvModelSettings {
    fn default() -> Self {
        let off = Self::when_absent();
        Self {
            deconv: DeconvSettings {
                refit_every: 100,
                pmf_rounds: 4,
                refit_on_surprise: 3.0,
                sparse_refits_below_se: 0.5,
                ..off.deconv
            },
            explore: ExploreSettings { probe_steps: crate::deconv_model::ProbeSteps::Any, ..off.explore },
            optimism_confidence: 2.0,
            plan_exploration: true,
        }
    }
}

impl DeconvModelSettings {
    /// Every reward-first setting off: the fixed count `optimism_visits`, probes on greedy
    /// steps, refits every 250 steps early, one round, no refits on surprise, planning
    /// V(s) = max_a Q. The value of a setting a configuration file does not give, and the
    /// construction the "visit-count" rows of the docs measure.
    pub fn when_absent() -> Self {
        Self {
            deconv: DeconvSettings::default(),
            explore: ExploreSettings::default(),
            optimism_confidence: 0.0,
            plan_exploration: false,
        }
    }
}

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
    /// bins ([`crate::deconv_model_time`]).
    pub time_bin_s: f64,
}

impl Default for DeconvModelTimeSettings {
    fn default() -> Self {
        Self {
            deconv: DeconvSettings::default(),
            explore: ExploreSettings::default(),
            time_bin_s: crate::deconv_model_time::DEFAULT_TIME_BIN_S,
        }
    }
}

/// One learner's settings, tagged by its `kind` (the learner's command-line name).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum LearnerSettings {
    /// `q`.
    Q(NoSettings),
    /// `fixed`.
    Fixed(FixedSettings),
    /// `mmq`.
    Mmq(MmqSettings),
    /// `mmq-reference`.
    MmqReference(MmqSettings),
    /// `mmq-kernel`.
    MmqKernel(KernelSettings),
    /// `q-lambda`.
    QLambda(TraceSettings),
    /// `sarsa-lambda`.
    SarsaLambda(TraceSettings),
    /// `oracle`.
    Oracle(NoSettings),
    /// `deconv-q`.
    DeconvQ(DeconvQSettings),
    /// `deconv-model`.
    DeconvModel(DeconvModelSettings),
    /// `deconv-model-time`.
    DeconvModelTime(DeconvModelTimeSettings),
}

impl LearnerSettings {
    /// The default settings of `kind`.
    pub fn of(kind: LearnerKind) -> Self {
        use LearnerSettings as S;
        match kind {
            LearnerKind::Q => S::Q(NoSettings {}),
            LearnerKind::Fixed => S::Fixed(FixedSettings::default()),
            LearnerKind::Mmq => S::Mmq(MmqSettings::default()),
            LearnerKind::MmqReference => S::MmqReference(MmqSettings::default()),
            LearnerKind::MmqKernel => S::MmqKernel(KernelSettings::default()),
            LearnerKind::QLambda => S::QLambda(TraceSettings::default()),
            LearnerKind::SarsaLambda => S::SarsaLambda(TraceSettings::default()),
            LearnerKind::Oracle => S::Oracle(NoSettings {}),
            LearnerKind::DeconvQ => S::DeconvQ(DeconvQSettings::default()),
            LearnerKind::DeconvModel => S::DeconvModel(DeconvModelSettings::default()),
            LearnerKind::DeconvModelTime => S::DeconvModelTime(DeconvModelTimeSettings::default()),
        }
    }

    /// Which learner.
    pub fn kind(&self) -> LearnerKind {
        use LearnerSettings as S;
        match self {
            S::Q(_) => LearnerKind::Q,
            S::Fixed(_) => LearnerKind::Fixed,
            S::Mmq(_) => LearnerKind::Mmq,
            S::MmqReference(_) => LearnerKind::MmqReference,
            S::MmqKernel(_) => LearnerKind::MmqKernel,
            S::QLambda(_) => LearnerKind::QLambda,
            S::SarsaLambda(_) => LearnerKind::SarsaLambda,
            S::Oracle(_) => LearnerKind::Oracle,
            S::DeconvQ(_) => LearnerKind::DeconvQ,
            S::DeconvModel(_) => LearnerKind::DeconvModel,
            S::DeconvModelTime(_) => LearnerKind::DeconvModelTime,
        }
    }

    /// The deconvolution settings, for the deconvolving learners.
    pub fn deconv(&self) -> Option<&DeconvSettings> {
        match self {
            LearnerSettings::DeconvQ(s) => Some(&s.deconv),
            LearnerSettings::DeconvModel(s) => Some(&s.deconv),
            LearnerSettings::DeconvModelTime(s) => Some(&s.deconv),
            _ => None,
        }
    }

    /// The deconvolution settings, mutable, for the deconvolving learners.
    pub fn deconv_mut(&mut self) -> Option<&mut DeconvSettings> {
        match self {
            LearnerSettings::DeconvQ(s) => Some(&mut s.deconv),
            LearnerSettings::DeconvModel(s) => Some(&mut s.deconv),
            LearnerSettings::DeconvModelTime(s) => Some(&mut s.deconv),
            _ => None,
        }
    }

    /// λ̂max (MMQ family) or K (deconvolving learners), if the learner has one.
    pub fn max_delay(&self) -> Option<usize> {
        match self {
            LearnerSettings::Mmq(s) | LearnerSettings::MmqReference(s) => Some(s.max_delay),
            LearnerSettings::MmqKernel(s) => Some(s.max_delay),
            other => other.deconv().map(|d| d.max_delay),
        }
    }

    /// Checks every setting's domain (the first failing field is reported).
    pub fn validate(&self) -> Result<(), LearnError> {
        use LearnerSettings as S;
        match self {
            S::Q(_) | S::Oracle(_) | S::Fixed(_) | S::Mmq(_) | S::MmqReference(_) => Ok(()),
            S::MmqKernel(s) => s.validate(),
            S::QLambda(s) | S::SarsaLambda(s) => s.validate(),
            S::DeconvQ(s) => {
                s.deconv.validate()?;
                if s.replay_lag > 1 << 20 {
                    return bad("replay_lag", s.replay_lag, "use a lag of at most 2^20 steps");
                }
                Ok(())
            }
            S::DeconvModel(s) => {
                s.deconv.validate()?;
                s.explore.validate()?;
                if !(s.optimism_confidence.is_finite() && s.optimism_confidence >= 0.0) {
                    return bad(
                        "optimism_confidence",
                        s.optimism_confidence,
                        "use a number of standard errors ≥ 0, e.g. 2 (0: the fixed count optimism_visits)",
                    );
                }
                Ok(())
            }
            S::DeconvModelTime(s) => {
                s.deconv.validate()?;
                s.explore.validate()?;
                let b = s.time_bin_s;
                if !(b.is_finite() && b > 0.0 && b <= 3600.0) {
                    return bad("time_bin_s", b, "use a bin width in seconds in (0, 3600], e.g. 0.1");
                }
                Ok(())
            }
        }
    }

    /// Table entries for `num_states` × `num_actions` (exact for the big tables).
    pub fn table_entries(&self, num_states: usize, num_actions: usize) -> u128 {
        use LearnerSettings as S;
        let sa = num_states as u128 * num_actions as u128;
        match self {
            S::Q(_) | S::Oracle(_) | S::QLambda(_) | S::SarsaLambda(_) => sa,
            S::Fixed(s) => sa + s.lambda_hat as u128,
            S::Mmq(s) | S::MmqReference(s) => sa * (s.max_delay as u128 + 1),
            S::MmqKernel(s) => sa * (s.max_delay as u128 + 1),
            S::DeconvQ(s) => s.deconv.table_entries(sa),
            S::DeconvModel(s) => s.deconv.table_entries(sa),
            // The idle state adds a row.
            S::DeconvModelTime(s) => s.deconv.table_entries(sa + num_actions as u128),
        }
    }

    /// The settings reports show after the shared parameters (`, λ̂ = 13`), or nothing.
    pub fn describe(&self) -> String {
        match self {
            LearnerSettings::Fixed(s) => format!(", λ̂ = {}", s.lambda_hat),
            LearnerSettings::Mmq(s) | LearnerSettings::MmqReference(s) => format!(", λ̂max = {}", s.max_delay),
            _ => String::new(),
        }
    }

    /// Builds the learner (after [`Self::validate`]).
    pub(crate) fn build(
        &self,
        p: crate::params::Params,
        num_states: usize,
        num_actions: usize,
    ) -> Result<Box<dyn crate::learner::Learner>, LearnError> {
        use crate::{deconv_model, deconv_model_time, deconv_q, fixed_delay, mmq, mmq_kernel, mmq_reference};
        use LearnerSettings as S;
        let (n, m) = (num_states, num_actions);
        Ok(match self {
            S::Q(_) => Box::new(crate::qlearning::QLearning::new(p, n, m)),
            S::Fixed(s) => Box::new(fixed_delay::FixedDelayQ::new(p, s.lambda_hat, n, m)),
            S::Mmq(s) => Box::new(mmq::MultipleModelQ::new(p, s.max_delay, n, m)),
            S::MmqReference(s) => Box::new(mmq_reference::MmqReference::new(p, s.max_delay, n, m)),
            S::MmqKernel(s) => {
                Box::new(mmq_kernel::KernelMmq::new(p, s.max_delay, s.kernel_width, s.bootstrap, n, m))
            }
            S::QLambda(s) => Box::new(crate::q_lambda::QLambda::new(p, s.trace_decay, n, m)),
            S::SarsaLambda(s) => Box::new(crate::sarsa_lambda::SarsaLambda::new(p, s.trace_decay, n, m)),
            S::Oracle(_) => Box::new(crate::oracle::Oracle::new(p, n, m)),
            S::DeconvQ(s) => Box::new(deconv_q::DeconvQ::new(p, s.deconv.config()?, s.replay_lag, n, m)),
            S::DeconvModel(s) => {
                let l = deconv_model::DeconvModel::new(
                    p,
                    s.deconv.config()?,
                    s.explore.optimism_visits,
                    s.explore.probes(),
                    n,
                    m,
                );
                let l = if s.plan_exploration { l.planning_exploration() } else { l };
                let z = s.optimism_confidence;
                Box::new(if z > 0.0 { l.with_confidence(z) } else { l })
            }
            S::DeconvModelTime(s) => Box::new(deconv_model_time::DeconvModelTime::new(
                p,
                s.deconv.config()?,
                s.explore.optimism_visits,
                s.explore.probes(),
                s.time_bin_s,
                n,
                m,
            )),
        })
    }
}
