//! The settings of `deconv-model` ([`DeconvModelSettings`]: the deconvolution, the
//! exploration, and the learner's own (M1′) and (M2) switches) and the exploration it
//! shares with `deconv-model-time` ([`ExploreSettings`]: optimism and delay probes).

use serde::{Deserialize, Serialize};

use super::{ProbeSteps, Probes, ToldCells};
use crate::deconv::DeconvSettings;
use crate::error::{LearnError, bad};

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
    pub probe_steps: ProbeSteps,
}

impl Default for ExploreSettings {
    fn default() -> Self {
        Self { optimism_visits: 10, probe_rate: 0.02, probe_precision: 0.5, probe_steps: ProbeSteps::Greedy }
    }
}

impl ExploreSettings {
    pub(crate) fn validate(&self) -> Result<(), LearnError> {
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

    pub(crate) fn probes(&self) -> Probes {
        Probes { rate: self.probe_rate, precision: self.probe_precision, steps: self.probe_steps }
    }
}

/// Settings of `deconv-model`.
///
/// Its defaults ([`Default`]) put the reward first: exploration from confidence (z = 2),
/// delay probes on any step, refits every 100 steps early, four rounds of the
/// alternation per refit, refits on surprise (z = 3), sparser refits once the delay has
/// settled (s = 0.5 steps), planning the ε-greedy policy's values
/// (docs/algorithms/deconv-model.md, "Reward first") and rewards per outcome. A setting that a
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
    /// A diagnostic, not an agent: which part of the learning is told the robot's true
    /// cell where the believed one can be wrong, `"none"` (the default), `"rewards"`,
    /// `"transitions"` or `"both"` ([`super::ToldCells`]).
    pub told_cells: ToldCells,
    /// Fit a reward per outcome (s, a, s') and plan with each pair's average over its
    /// counted outcomes ([`crate::deconv_model`], (M3)), so that a reward earned from a
    /// cell the agent did not believe it was in is credited to a rare outcome rather than
    /// to the whole pair. On by default; on a world whose moves are deterministic (the
    /// grid, the ideal robot) it learns exactly what rewards per pair learn.
    pub outcome_rewards: bool,
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
            explore: ExploreSettings { probe_steps: ProbeSteps::Any, ..off.explore },
            optimism_confidence: 2.0,
            plan_exploration: true,
            told_cells: ToldCells::None,
            outcome_rewards: true,
        }
    }
}

impl DeconvModelSettings {
    /// Checks every setting's domain (the first failing field is reported).
    pub(crate) fn validate(&self) -> Result<(), LearnError> {
        self.deconv.validate()?;
        self.explore.validate()?;
        if !(self.optimism_confidence.is_finite() && self.optimism_confidence >= 0.0) {
            return bad(
                "optimism_confidence",
                self.optimism_confidence,
                "use a number of standard errors ≥ 0, e.g. 2 (0: the fixed count optimism_visits)",
            );
        }
        Ok(())
    }

    /// The reward features per state-action pair: one, or a slot per outcome.
    pub(crate) fn features_per_pair(&self) -> usize {
        if self.outcome_rewards { super::OUTCOME_SLOTS } else { 1 }
    }

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
            told_cells: ToldCells::None,
            outcome_rewards: false,
        }
    }
}
