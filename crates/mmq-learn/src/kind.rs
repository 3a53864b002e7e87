//! Which learner: [`LearnerKind`], the command-line name of each, and the catalogue of
//! learners with a one-line description each (`mmq learners`).

use serde::{Deserialize, Serialize};

use crate::error::LearnError;

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
