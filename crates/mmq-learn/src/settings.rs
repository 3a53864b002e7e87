//! Which settings a learner has: [`LearnerSettings`] holds the settings of one learner,
//! tagged by its `kind`, so that a configuration lists exactly the settings the chosen
//! learner reads (an MMQ run: `max_delay`; no lasso), and a setting the learner does not
//! have is refused by name. It dispatches to each learner's settings for defaults,
//! validation, the size of the tables, the text reports show and the build.
//!
//! Each settings struct is defined beside its learner, with its defaults and its
//! validation: [`FixedSettings`] in [`crate::fixed_delay`], [`MmqSettings`] in
//! [`crate::mmq`] (also `mmq-reference`'s), [`KernelSettings`] in [`crate::mmq_kernel`],
//! [`TraceSettings`] in [`crate::q_lambda`] (also `sarsa-lambda`'s), [`DeconvSettings`]
//! in [`crate::deconv`] (shared by the deconvolving learners), [`DeconvQSettings`] in
//! [`crate::deconv_q`], [`DeconvModelSettings`] and [`ExploreSettings`] in
//! [`crate::deconv_model`], [`DeconvModelTimeSettings`] in [`crate::deconv_model_time`].
//! They are re-exported here; defined here is only [`NoSettings`], the empty settings of
//! `q` and `oracle`.

use serde::{Deserialize, Serialize};

use crate::decode::ValueDeconvolver;
pub use crate::deconv::{DeconvSettings, WeightedRounds};
pub use crate::deconv_model::{DeconvModelSettings, ExploreSettings};
pub use crate::deconv_model_time::DeconvModelTimeSettings;
pub use crate::deconv_q::DeconvQSettings;
use crate::error::LearnError;
pub use crate::fixed_delay::FixedSettings;
use crate::kind::LearnerKind;
pub use crate::mmq::MmqSettings;
pub use crate::mmq_kernel::KernelSettings;
pub use crate::q_lambda::TraceSettings;

/// Settings of a learner that has none beyond the shared parameters (`q`, `oracle`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoSettings {}

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
            S::DeconvQ(s) => s.validate(),
            S::DeconvModel(s) => s.validate(),
            S::DeconvModelTime(s) => s.validate(),
        }
    }

    /// The reward fit's features per state-action pair of a deconvolving learner: one,
    /// or `deconv-model`'s slot per outcome with `outcome_rewards`.
    pub(crate) fn reward_features_per_pair(&self) -> usize {
        match self {
            LearnerSettings::DeconvModel(s) => s.features_per_pair(),
            _ => 1,
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
            S::DeconvQ(s) => ValueDeconvolver::table_entries(&s.deconv, sa, sa),
            S::DeconvModel(s) => {
                ValueDeconvolver::table_entries(&s.deconv, sa, sa * self.reward_features_per_pair() as u128)
            }
            // The idle state adds a row.
            S::DeconvModelTime(s) => {
                let pairs = sa + num_actions as u128;
                ValueDeconvolver::table_entries(&s.deconv, pairs, pairs)
            }
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
                let l = l.telling(s.told_cells);
                let l = if s.outcome_rewards { l.with_outcome_rewards() } else { l };
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
