//! Hyper-parameters of the learners beyond the paper (issue 8): eligibility traces, the
//! oracle, and the learners that deconvolve delayed rewards ([`crate::deconv`]). One
//! documented field each, with serde defaults so configurations written before these
//! learners existed still parse.

use mmq_core::DelayDist;
use serde::{Deserialize, Serialize};

use crate::deconv::{DeconvConfig, truncated_pmf};
use crate::spec::{LearnError, LearnerSpec};

/// Parameters of `q-lambda`, `sarsa-lambda`, `deconv-q` and `deconv-model`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BeyondParams {
    /// Trace decay of Q(λ) and SARSA(λ), in [0, 1] (called λ in Sutton & Barto; named
    /// `trace_decay` here so that it is not confused with the Poisson delay λ).
    pub trace_decay: f64,
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
    /// learned to stop bumping (docs/algorithms/beyond.md).
    pub state_rewards: bool,
    /// Reward features per transition: the actions of a state that have only ever led to
    /// one and the same next state share a reward feature besides their own (a pair
    /// seen leading to two next states leaves its group). On by default: in the paper's
    /// worlds it groups the goal's actions (all teleport to S) and the wall bumps of a
    /// cell (all stay put), so the goal's reward is credited to the goal rather than to
    /// the move into it one step earlier, which had made the delay estimate one step
    /// late (docs/algorithms/beyond.md). `state_rewards` takes precedence.
    pub successor_groups: bool,
    /// κ_J ≥ 0: after the lasso, a pair keeps its reward only if it is also significant
    /// jointly with the other rewarded pairs (more than κ_J times the lasso's threshold
    /// in joint standard errors); the least significant is dropped and the rest refitted.
    /// 0 turns the test off. Pair features only (ignored with `state_rewards`). On by
    /// default (1): without it, a corridor step and its way back on the 15×15 maze
    /// could carry +11 and −11, a loop `deconv-model` chased (docs/algorithms/beyond.md).
    pub joint_test: f64,
    /// Refine the delay pmf by reweighted least squares on the stored history (each step
    /// weighted by the inverse variance of its delivery); false: plain least squares.
    pub pmf_weighted: bool,
    /// Decode each delivery into the discrete reward values it is a sum of (9 = +10 − 1)
    /// and deconvolve each value on its own with a shared delay pmf: the wall bumps' −1s
    /// then form a series of their own, whose irregular timing identifies a delay wider
    /// than the goal's period (docs/algorithms/beyond.md, "Delay estimate"). On by default:
    /// on 9×9 it brought `deconv-model`'s worst uniform-delay median error at 50k from 5.0
    /// to 1.7 steps at equal reward, and `deconv-q`'s reward from 100 % to 103 %.
    pub decode_values: bool,
    /// κ_p ≥ 0, in the reweighted fit: a delay keeps its estimated probability only with
    /// more than κ_p standard errors of evidence (0: plain least squares, whose
    /// non-negativity turns noise into spurious mass at every delay). Default 1 (2, then
    /// 3, before the successor groups removed the one-step shift that a larger κ_p had
    /// partly compensated; 1 measured best for a flat delay: docs/algorithms/beyond.md).
    pub pmf_significance: f64,
    /// ν ≥ 0: pull of the delay-pmf fit towards the uniform pmf, worth ν visits of the
    /// largest reward; it fades as rewards come in, so that early fits stay broad.
    /// Default 5 (was 50: where the data hardly tell delays apart, the pull towards the
    /// uniform pmf on 0..=K put mass at long delays and the median came out high).
    pub pmf_prior: f64,
    /// ρ ≥ 0: roughness penalty of the delay-pmf fit, ½ ρ max_x R̂(x)² Σ_k (p(k+1) − p(k))²,
    /// in visits of the largest reward (0: off). A smooth pmf resists the aliasing of
    /// delays k and k + P by a regular goal period P.
    pub pmf_smoothness: f64,
    /// Steps between two refits of R̂ and the delay pmf early on (≥ 1); later refits
    /// come every max(refit_every, t/8) steps.
    pub refit_every: u64,
    /// `deconv-model`: z ≥ 0, exploration from confidence: a pair keeps its optimistic
    /// value q0 (R-max style) until the reward fit's standard error of its reward is at
    /// most 1/z of the largest reward value found, so that a reward that large there would
    /// lie z standard errors from zero ([`crate::deconv_model`], (M2)); 2 is about a 95 %
    /// interval. Default 0 (off): the fixed count `optimism_visits`. z = 2 gained 1.2 / 1.4
    /// points on 9×9 at Poisson 13 (ε 0.05 / 0.1) but cost the maze 30 / 15 points of the
    /// optimum earned while learning and lost a seed on the mixture delay
    /// (docs/algorithms/deconv-model.md, "Exploration from confidence").
    pub optimism_confidence: f64,
    /// `deconv-model-time`, and `deconv-model` unless `optimism_confidence` > 0: a pair
    /// tried fewer times than this keeps its optimistic value q0 (R-max style
    /// exploration); 0 plans with every pair's estimate at once.
    pub optimism_visits: u32,
    /// `deconv-model`: probability per step, in [0, 1], that a *delay probe* falls due
    /// while the median of the delay estimate has a standard error above
    /// `probe_precision`; a due probe is taken at the first non-exploring step in a state
    /// where some action is known to keep the agent where it is at a cost (known as in
    /// `optimism_confidence`, or tried ≥ max(`optimism_visits`, 1) times under the fixed
    /// count; never led elsewhere, R̂ < 0: a wall bump). Its reward
    /// leaves at a random time and so samples the delay without the period of the goal's
    /// rewards (0: off; [`crate::deconv_model`]).
    pub probe_rate: f64,
    /// `deconv-model`: probes stop once the median of the delay estimate has a standard
    /// error of at most this many steps ([`crate::deconv::Deconvolver::median_se`]; > 0).
    pub probe_precision: f64,
    /// `deconv-q`: each transition is learned again this many steps later, when R̂ has
    /// heard of its reward (0: learned once, at once).
    pub replay_lag: usize,
    /// `mmq-kernel`: width h of the Gaussian kernel around the leading model, in steps of
    /// λ̂ (> 0; `inf` gives every model full credit, as MMQ). Default 10, the best of
    /// {1, 3, 5, 10, 20, 50, ∞} on 9×9 at Poisson 13 (docs/algorithms/mmq-kernel.md).
    pub kernel_width: f64,
    /// `mmq-kernel`: where the target's max looks: `all` models (the paper), the updated
    /// model's `own` row, or the `leader`'s.
    pub bootstrap: crate::mmq_kernel::Bootstrap,
    /// Tells the deconvolving learners the true delay distribution (a `--delay` spec such
    /// as `poisson:13`) instead of letting them estimate it: an ablation that measures
    /// what the estimate costs. `None` (the default) = estimate it.
    pub told_delay: Option<String>,
    /// `deconv-model-time`: width b of its time bins, seconds (> 0; absent: 0.1 s, the
    /// grid's default step period). At most the shortest decision's duration, or
    /// decisions get moved to later bins ([`crate::deconv_model_time`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub time_bin_s: Option<f64>,
}

impl BeyondParams {
    /// The time bin of `deconv-model-time`, seconds.
    pub fn time_bin(&self) -> f64 {
        self.time_bin_s.unwrap_or(crate::deconv_model_time::DEFAULT_TIME_BIN_S)
    }
}

impl Default for BeyondParams {
    fn default() -> Self {
        Self {
            trace_decay: 0.9,
            reward_prior: 1.0,
            lasso: 0.1,
            significance: 1.0,
            state_rewards: false,
            successor_groups: true,
            joint_test: 1.0,
            pmf_weighted: true,
            decode_values: true,
            pmf_significance: 1.0,
            pmf_prior: 5.0,
            pmf_smoothness: 0.0,
            refit_every: 250,
            optimism_confidence: 0.0,
            optimism_visits: 10,
            probe_rate: 0.02,
            probe_precision: 0.5,
            replay_lag: 50,
            kernel_width: 10.0,
            bootstrap: crate::mmq_kernel::Bootstrap::All,
            told_delay: None,
            time_bin_s: None,
        }
    }
}

/// Checks the domains of the parameters of `spec.beyond`.
pub fn validate(spec: &LearnerSpec) -> Result<(), LearnError> {
    let b = &spec.beyond;
    let bad = |field, value: String, accepted| Err(LearnError::InvalidParam { field, value, accepted });
    if !(0.0..=1.0).contains(&b.trace_decay) {
        return bad("trace_decay", b.trace_decay.to_string(), "use a trace decay in [0, 1], e.g. 0.9");
    }
    // Finite and ≥ 0, checked in this order (the first failing field is reported).
    let non_negative: [(&'static str, f64, &'static str); 8] = [
        ("reward_prior", b.reward_prior, "use a prior strength ≥ 0, e.g. 1"),
        ("lasso", b.lasso, "use an L1 penalty ≥ 0 in reward units, e.g. 0.1"),
        ("significance", b.significance, "use a multiple of the universal threshold ≥ 0, e.g. 1"),
        ("joint_test", b.joint_test, "use a multiple of the lasso's threshold ≥ 0, e.g. 1 (0: off)"),
        ("pmf_significance", b.pmf_significance, "use a number of standard errors ≥ 0, e.g. 1"),
        ("pmf_prior", b.pmf_prior, "use a prior weight ≥ 0 in visits, e.g. 5"),
        ("pmf_smoothness", b.pmf_smoothness, "use a penalty ≥ 0 in visits, e.g. 10 (0: off)"),
        (
            "optimism_confidence",
            b.optimism_confidence,
            "use a number of standard errors ≥ 0, e.g. 2 (0: the fixed count optimism_visits)",
        ),
    ];
    for (field, value, accepted) in non_negative {
        if !(value.is_finite() && value >= 0.0) {
            return bad(field, value.to_string(), accepted);
        }
    }
    if b.kernel_width.is_nan() || b.kernel_width <= 0.0 {
        return bad(
            "kernel_width",
            b.kernel_width.to_string(),
            "use a kernel width > 0 in steps of the delay estimate, e.g. 10 (inf: no kernel)",
        );
    }
    if !(0.0..=1.0).contains(&b.probe_rate) {
        return bad(
            "probe_rate",
            b.probe_rate.to_string(),
            "use a probability in [0, 1], e.g. 0.02 (0: off)",
        );
    }
    if !(b.probe_precision.is_finite() && b.probe_precision > 0.0) {
        return bad(
            "probe_precision",
            b.probe_precision.to_string(),
            "use a standard error > 0 in steps, e.g. 0.5",
        );
    }
    if b.refit_every == 0 {
        return bad("refit_every", "0".into(), "use at least 1 step between refits, e.g. 250");
    }
    if let Some(b) = b.time_bin_s
        && !(b.is_finite() && b > 0.0 && b <= 3600.0)
    {
        return bad("time_bin_s", b.to_string(), "use a bin width in seconds in (0, 3600], e.g. 0.1");
    }
    let deconv = matches!(
        spec.kind,
        crate::LearnerKind::DeconvQ | crate::LearnerKind::DeconvModel | crate::LearnerKind::DeconvModelTime
    );
    if deconv && spec.max_delay > 1 << 16 {
        return bad(
            "max_delay",
            spec.max_delay.to_string(),
            "the deconvolving learners accept at most 65536",
        );
    }
    if b.replay_lag > 1 << 20 {
        return bad("replay_lag", b.replay_lag.to_string(), "use a lag of at most 2^20 steps");
    }
    if let Some(d) = &b.told_delay
        && DelayDist::parse(d).is_err()
    {
        return bad("told_delay", d.clone(), "use a delay spec such as poisson:13 (see `delay`)");
    }
    if let Some(d) = &b.told_delay
        && DelayDist::parse(d).is_ok_and(|d| d.unit() == mmq_core::DelayUnit::Seconds)
    {
        return bad(
            "told_delay",
            d.clone(),
            "a told delay is a pmf over step lags: give it in steps, e.g. poisson:13 (a delay in seconds is learned by deconv-model-time)",
        );
    }
    Ok(())
}

/// The deconvolver configuration of a (validated) spec.
pub fn deconv_config(spec: &LearnerSpec) -> Result<DeconvConfig, LearnError> {
    let b = &spec.beyond;
    let told = match &b.told_delay {
        Some(d) => Some(truncated_pmf(
            &DelayDist::parse(d).map_err(|_| LearnError::InvalidParam {
                field: "told_delay",
                value: d.clone(),
                accepted: "use a delay spec such as poisson:13 (see `delay`)",
            })?,
            spec.max_delay,
        )),
        None => None,
    };
    Ok(DeconvConfig {
        max_delay: spec.max_delay,
        reward_prior: b.reward_prior,
        lasso: b.lasso,
        significance: b.significance,
        state_rewards: b.state_rewards,
        successor_groups: b.successor_groups,
        joint_test: b.joint_test,
        pmf_weighted: b.pmf_weighted,
        pmf_significance: b.pmf_significance,
        pmf_prior: b.pmf_prior,
        pmf_smoothness: b.pmf_smoothness,
        refit_every: b.refit_every,
        told,
        decode_values: b.decode_values,
    })
}
