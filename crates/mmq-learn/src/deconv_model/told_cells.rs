//! A diagnostic, not an agent: `deconv-model` told the true cell where a robot's
//! believed cell can be wrong (`told_cells`), to measure where the delay's cost on the
//! realistic robot goes. The believed cell is what a real agent has; the true one comes
//! from the environment through the oracle's channel ([`crate::Truth`]). Told for
//! `rewards`, the reward fit credits each delivery to the true pairs (and groups them by
//! true successors); told for `transitions`, the model counts true transitions (from the
//! true cell to the true cell the primitive ended in); `both` does both. The agent still
//! acts on its believed cell. Where the environment has no belief (the grid), the true
//! cell is the believed one.

use mmq_core::State;
use serde::{Deserialize, Serialize};

use super::DeconvModel;
use crate::learner::Experience;

/// Which part of `deconv-model`'s learning is told the true cell (a diagnostic).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ToldCells {
    /// Nothing: the believed cells, as a real agent (the default).
    #[default]
    None,
    /// The reward fit's pairs and successors.
    Rewards,
    /// The transition counts.
    Transitions,
    /// Both.
    Both,
}

/// A step's cells as the reward fit and the transition counts take them: each
/// (start, end).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Cells {
    pub(crate) credit: (State, State),
    pub(crate) count: (State, State),
}

impl DeconvModel {
    /// The same model told the true cells for `told` (a diagnostic).
    pub fn telling(mut self, told: ToldCells) -> Self {
        self.told = told;
        self
    }
}

impl ToldCells {
    /// Whether the learner needs the true cells ([`crate::Learner::needs_truth`]).
    pub(crate) fn needs_truth(self) -> bool {
        self != ToldCells::None
    }

    /// The cells of step `e` for the reward fit and for the counts.
    pub(crate) fn cells(self, e: &Experience<'_>) -> Cells {
        let believed = (e.state, e.next_state);
        let truth = e.truth.and_then(|t| Some((t.true_state?, t.true_next_state?))).unwrap_or(believed);
        let (credit, count) = match self {
            ToldCells::None => (believed, believed),
            ToldCells::Rewards => (truth, believed),
            ToldCells::Transitions => (believed, truth),
            ToldCells::Both => (truth, truth),
        };
        Cells { credit, count }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learner::{Truth, exp};

    /// Believed 1 → 2, true 3 → 4: each choice takes the right pair of cells, and
    /// without the truth (the grid) every choice is the believed cells.
    #[test]
    fn each_choice_takes_its_cells() {
        let truth = Truth { true_state: Some(3), true_next_state: Some(4), ..Truth::default() };
        let e = Experience { truth: Some(&truth), ..exp(0, 1, 0, 2, 0.0) };
        let (b, t) = ((1, 2), (3, 4));
        let cases = [
            (ToldCells::None, b, b),
            (ToldCells::Rewards, t, b),
            (ToldCells::Transitions, b, t),
            (ToldCells::Both, t, t),
        ];
        for (told, credit, count) in cases {
            assert_eq!(told.cells(&e), Cells { credit, count }, "{told:?}");
            assert_eq!(told.cells(&exp(0, 1, 0, 2, 0.0)), Cells { credit: b, count: b }, "{told:?}");
        }
        assert!(!ToldCells::None.needs_truth() && ToldCells::Both.needs_truth());
    }
}
