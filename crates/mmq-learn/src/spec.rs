//! Learner selection and hyper-parameters: one documented field each, with the paper's
//! defaults where it states them, validated before anything is allocated.

use serde::{Deserialize, Serialize};

use crate::Learner;
use crate::beyond::BeyondParams;
use crate::deconv_model::DeconvModel;
use crate::deconv_q::DeconvQ;
use crate::fixed_delay::FixedDelayQ;
use crate::mmq::MultipleModelQ;
use crate::mmq_reference::MmqReference;
use crate::oracle::Oracle;
use crate::q_lambda::QLambda;
use crate::qlearning::QLearning;
use crate::sarsa_lambda::SarsaLambda;

/// Hyper-parameters shared by the tabular learners.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Learning rate α ∈ [0, 1] (paper: 0.1).
    pub alpha: f64,
    /// Discount factor γ ∈ [0, 1) (paper: 0.9).
    pub gamma: f64,
    /// Exploration rate ε ∈ [0, 1] of ε-greedy (not stated in the paper; see
    /// docs/algorithms/mmq.md for the choice).
    pub epsilon: f64,
    /// Initial value of every Q entry (optimistic initialisation; not stated).
    pub q0: f64,
}

impl Default for Params {
    fn default() -> Self {
        Self { alpha: 0.1, gamma: 0.9, epsilon: 0.01, q0: 20.0 }
    }
}

/// Which learner.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LearnerKind {
    /// Q-learning, eq. (2).
    Q,
    /// Fixed delay estimate λ̂, eq. (4).
    Fixed,
    /// Multiple-Model Q-learning, Algorithm 1 (fast, exact).
    Mmq,
    /// Algorithm 1 as a plain loop (the specification; slow).
    MmqReference,
    /// MMQ with kernel credit around the leading model.
    MmqKernel,
    /// Watkins's Q(λ) with replacing traces.
    QLambda,
    /// SARSA(λ) with replacing traces.
    SarsaLambda,
    /// Q-learning told the true credit (an upper bound, not a real agent).
    Oracle,
    /// Q-learning on deconvolved rewards with an estimated delay pmf.
    DeconvQ,
    /// Counted transitions, deconvolved rewards, value iteration.
    DeconvModel,
    /// `deconv-model` with its delay pmf over bins of simulated time.
    DeconvModelTime,
}

/// Name and one-line description of every learner, in `mmq learners` order.
pub fn catalogue() -> Vec<(LearnerKind, &'static str, &'static str)> {
    vec![
        (LearnerKind::Q, "q", "Q-learning, eq. (2): the delivered reward updates the current pair"),
        (
            LearnerKind::Fixed,
            "fixed",
            "fixed delay estimate, eq. (4): the reward at t updates the pair from λ̂ steps ago",
        ),
        (
            LearnerKind::Mmq,
            "mmq",
            "Multiple-Model Q-learning, Algorithm 1: one table per λ̂ = 0..=λ̂max, all updated every step",
        ),
        (
            LearnerKind::MmqReference,
            "mmq-reference",
            "Algorithm 1 as a plain loop, the specification of mmq (slow)",
        ),
        (
            LearnerKind::MmqKernel,
            "mmq-kernel",
            "MMQ with credit weighted by a kernel around the leading model (the paper's future work); bootstrap from all models, its own, or the leader's",
        ),
        (
            LearnerKind::QLambda,
            "q-lambda",
            "Watkins's Q(λ), replacing traces decaying by γ·trace_decay, cut at exploratory actions",
        ),
        (
            LearnerKind::SarsaLambda,
            "sarsa-lambda",
            "SARSA(λ), replacing traces decaying by γ·trace_decay (on-policy, never cut)",
        ),
        (
            LearnerKind::Oracle,
            "oracle",
            "UPPER BOUND, not a real agent: reads the channel's ground truth and credits each reward to its true (s, a, s') on arrival",
        ),
        (
            LearnerKind::DeconvQ,
            "deconv-q",
            "model-free: rewards deconvolved into R̂(s,a) with an online delay-pmf estimate (told only λ̂max), Q-learning on R̂",
        ),
        (
            LearnerKind::DeconvModel,
            "deconv-model",
            "model-based: counted transitions + deconvolved R̂(s,a) with an online delay-pmf estimate, value iteration every step, delay probes while the estimate is imprecise",
        ),
        (
            LearnerKind::DeconvModelTime,
            "deconv-model-time",
            "deconv-model with the delay pmf over bins of simulated time (time_bin_s seconds) instead of step lags: for delays in seconds and decisions of variable duration",
        ),
    ]
}

impl LearnerKind {
    /// The command-line name.
    pub fn name(self) -> &'static str {
        catalogue().into_iter().find(|c| c.0 == self).map_or("?", |c| c.1)
    }

    /// Parses a command-line name.
    pub fn parse(name: &str) -> Result<LearnerKind, LearnError> {
        catalogue().into_iter().find(|c| c.1 == name).map(|c| c.0).ok_or_else(|| LearnError::UnknownLearner {
            name: name.to_string(),
            known: catalogue().iter().map(|c| c.1).collect::<Vec<_>>().join(", "),
        })
    }
}

/// A fully specified learner.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LearnerSpec {
    /// Which learner.
    pub kind: LearnerKind,
    /// Shared hyper-parameters.
    pub params: Params,
    /// λ̂ of the fixed-delay learner, steps.
    pub lambda_hat: usize,
    /// λ̂max of MMQ, steps (N = λ̂max + 1 models; paper: 50); also the largest delay the
    /// deconvolving learners consider (`deconv-model-time`: in time bins).
    pub max_delay: usize,
    /// Parameters of the learners beyond the paper (traces, deconvolution).
    #[serde(default)]
    pub beyond: BeyondParams,
}

impl Default for LearnerSpec {
    fn default() -> Self {
        Self {
            kind: LearnerKind::Mmq,
            params: Params::default(),
            lambda_hat: 13,
            max_delay: 50,
            beyond: BeyondParams::default(),
        }
    }
}

/// Why a learner cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LearnError {
    /// A hyper-parameter outside its domain.
    #[error("`{field}` = {value} is not accepted; {accepted}")]
    InvalidParam {
        /// The parameter, as the configuration names it.
        field: &'static str,
        /// The value given.
        value: String,
        /// What is accepted.
        accepted: &'static str,
    },
    /// Tables that would not fit in memory.
    #[error(
        "the {learner} tables would need {need_gib:.1} GiB ({entries} entries) but at most {limit_gib:.1} GiB is allowed; lower `max_delay` or use a smaller world"
    )]
    TooLarge {
        /// Learner name.
        learner: &'static str,
        /// Q entries requested.
        entries: u128,
        /// GiB needed.
        need_gib: f64,
        /// GiB allowed.
        limit_gib: f64,
    },
    /// No learner by that name.
    #[error("unknown learner `{name}`; known learners: {known}")]
    UnknownLearner {
        /// The name given.
        name: String,
        /// The known names.
        known: String,
    },
}

impl LearnerSpec {
    /// Checks every parameter's domain.
    pub fn validate(&self) -> Result<(), LearnError> {
        let p = &self.params;
        let bad = |field, v: f64, accepted| {
            Err(LearnError::InvalidParam { field, value: mmq_core::stats::compact(v), accepted })
        };
        if !(0.0..=1.0).contains(&p.alpha) {
            return bad("alpha", p.alpha, "use a learning rate in [0, 1], e.g. 0.1");
        }
        if !(0.0..1.0).contains(&p.gamma) {
            return bad("gamma", p.gamma, "use a discount factor in [0, 1), e.g. 0.9");
        }
        if !(0.0..=1.0).contains(&p.epsilon) {
            return bad("epsilon", p.epsilon, "use an exploration rate in [0, 1], e.g. 0.02");
        }
        if !p.q0.is_finite() || p.q0.abs() > 1e12 {
            return bad("q0", p.q0, "use a finite initial value, e.g. 10");
        }
        crate::beyond::validate(self)
    }

    /// Bytes of the tables for `num_states` × `num_actions` (exact for the big tables).
    pub fn table_bytes(&self, num_states: usize, num_actions: usize) -> (u128, u128) {
        let sa = num_states as u128 * num_actions as u128;
        let entries = match self.kind {
            LearnerKind::Q => sa,
            LearnerKind::Fixed => sa + self.lambda_hat as u128,
            LearnerKind::Mmq | LearnerKind::MmqReference | LearnerKind::MmqKernel => {
                sa * (self.max_delay as u128 + 1)
            }
            LearnerKind::QLambda | LearnerKind::SarsaLambda | LearnerKind::Oracle => sa,
            // Q, R̂ and the lagged reward sums of every pair (worst case: all pairs
            // visited), once per reward value when decoding (worst case: MAX_VALUES of
            // them); the sparse co-occurrence counts grow with the run instead (at most
            // 16 bytes × (K + 1) per step, docs/performance.md).
            LearnerKind::DeconvQ | LearnerKind::DeconvModel | LearnerKind::DeconvModelTime => {
                let sa = if self.kind == LearnerKind::DeconvModelTime {
                    sa + num_actions as u128 // the idle state
                } else {
                    sa
                };
                let copies = if self.beyond.decode_values { crate::decode::MAX_VALUES as u128 } else { 1 };
                2 * sa
                    + copies
                        * crate::deconv::Deconvolver::stats_bytes(sa as usize, self.max_delay).div_ceil(8)
            }
        };
        (entries, entries * 8 + num_states as u128 * 12)
    }

    /// Builds the learner after validating it and checking that its tables fit within
    /// `limit_bytes`.
    pub fn build(
        &self,
        num_states: usize,
        num_actions: usize,
        limit_bytes: u128,
    ) -> Result<Box<dyn Learner>, LearnError> {
        self.validate()?;
        let deconv = matches!(
            self.kind,
            LearnerKind::DeconvQ | LearnerKind::DeconvModel | LearnerKind::DeconvModelTime
        );
        // deconv-model-time adds an idle state.
        if deconv && (num_states + 1).saturating_mul(num_actions) > crate::deconv::MAX_PAIRS {
            return Err(LearnError::InvalidParam {
                field: "world",
                value: format!("{num_states} cells × {num_actions} actions"),
                accepted: "the deconvolving learners accept at most 8,388,608 state-action pairs; use a smaller world",
            });
        }
        let (entries, bytes) = self.table_bytes(num_states, num_actions);
        if bytes > limit_bytes {
            return Err(LearnError::TooLarge {
                learner: self.kind.name(),
                entries,
                need_gib: bytes as f64 / (1u128 << 30) as f64,
                limit_gib: limit_bytes as f64 / (1u128 << 30) as f64,
            });
        }
        let p = self.params;
        Ok(match self.kind {
            LearnerKind::Q => Box::new(QLearning::new(p, num_states, num_actions)),
            LearnerKind::Fixed => Box::new(FixedDelayQ::new(p, self.lambda_hat, num_states, num_actions)),
            LearnerKind::Mmq => Box::new(MultipleModelQ::new(p, self.max_delay, num_states, num_actions)),
            LearnerKind::MmqReference => {
                Box::new(MmqReference::new(p, self.max_delay, num_states, num_actions))
            }
            LearnerKind::MmqKernel => Box::new(crate::mmq_kernel::KernelMmq::new(
                p,
                self.max_delay,
                self.beyond.kernel_width,
                self.beyond.bootstrap,
                num_states,
                num_actions,
            )),
            LearnerKind::QLambda => {
                Box::new(QLambda::new(p, self.beyond.trace_decay, num_states, num_actions))
            }
            LearnerKind::SarsaLambda => {
                Box::new(SarsaLambda::new(p, self.beyond.trace_decay, num_states, num_actions))
            }
            LearnerKind::Oracle => Box::new(Oracle::new(p, num_states, num_actions)),
            LearnerKind::DeconvQ => Box::new(DeconvQ::new(
                p,
                crate::beyond::deconv_config(self)?,
                self.beyond.replay_lag,
                num_states,
                num_actions,
            )),
            LearnerKind::DeconvModel => {
                let l = DeconvModel::new(
                    p,
                    crate::beyond::deconv_config(self)?,
                    self.beyond.optimism_visits,
                    crate::deconv_model::Probes {
                        rate: self.beyond.probe_rate,
                        precision: self.beyond.probe_precision,
                    },
                    num_states,
                    num_actions,
                );
                let z = self.beyond.optimism_confidence;
                Box::new(if z > 0.0 { l.with_confidence(z) } else { l })
            }
            LearnerKind::DeconvModelTime => Box::new(crate::deconv_model_time::DeconvModelTime::new(
                p,
                crate::beyond::deconv_config(self)?,
                self.beyond.optimism_visits,
                crate::deconv_model::Probes {
                    rate: self.beyond.probe_rate,
                    precision: self.beyond.probe_precision,
                },
                self.beyond.time_bin(),
                num_states,
                num_actions,
            )),
        })
    }
}

/// Builds a learner (see [`LearnerSpec::build`]).
pub fn build(
    spec: &LearnerSpec,
    num_states: usize,
    num_actions: usize,
    limit_bytes: u128,
) -> Result<Box<dyn Learner>, LearnError> {
    spec.build(num_states, num_actions, limit_bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_impossible_parameters_and_huge_tables() {
        let mut s = LearnerSpec::default();
        s.params.alpha = 1.5;
        assert!(s.build(81, 4, 1 << 30).unwrap_err().to_string().contains("`alpha` = 1.5"));
        s.params.alpha = 0.1;
        s.params.epsilon = f64::NAN;
        assert!(s.build(81, 4, 1 << 30).unwrap_err().to_string().contains("`epsilon`"));
        s.params.epsilon = 0.1;
        s.beyond.joint_test = f64::NAN;
        assert!(s.build(81, 4, 1 << 30).unwrap_err().to_string().contains("joint_test"));
        s.beyond.joint_test = 1.0;
        s.beyond.kernel_width = 0.0;
        assert!(s.build(81, 4, 1 << 30).unwrap_err().to_string().contains("kernel_width"));
        s.beyond.kernel_width = f64::INFINITY;
        s.beyond.pmf_smoothness = -1.0;
        assert!(s.build(81, 4, 1 << 30).unwrap_err().to_string().contains("pmf_smoothness"));
        s.beyond.pmf_smoothness = 0.0;
        s.beyond.probe_rate = 1.5;
        let e = s.build(81, 4, 1 << 30).unwrap_err().to_string();
        assert!(e.contains("probe_rate") && e.contains("[0, 1]"), "{e}");
        s.beyond.probe_rate = 0.02;
        s.beyond.probe_precision = 0.0;
        assert!(s.build(81, 4, 1 << 30).unwrap_err().to_string().contains("probe_precision"));
        s.beyond.probe_precision = 0.5;
        s.max_delay = 1_000_000_000;
        let e = s.build(81, 4, 8 << 30).unwrap_err().to_string();
        assert!(e.contains("`max_delay`") && e.contains("GiB"), "{e}");
        assert!(
            LearnerKind::parse("sarsa-x").unwrap_err().to_string().contains("known learners: q, fixed, mmq")
        );
        for (k, name, _) in catalogue() {
            assert_eq!(LearnerKind::parse(name).unwrap(), k);
        }
    }
}
