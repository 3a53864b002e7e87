//! The hyper-parameters every tabular learner shares: learning rate α, discount γ,
//! exploration rate ε and the initial value q0 ([`Params`]). A leaf: it uses nothing else
//! of the crate, so that every learner can read it.

use serde::{Deserialize, Serialize};

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
