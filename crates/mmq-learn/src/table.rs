//! The one action-value table Q(s, a) of the tabular learners (`q`, `fixed`, `q-lambda`,
//! `sarsa-lambda`, `oracle`, `deconv-q`, `deconv-model`): a flat row-major vector
//! Q[s × |A| + a], the ε-greedy and greedy choices over a row, and its export. The table
//! dereferences to that flat slice, so an update reads as `q[i] += ...`. MMQ keeps its own
//! layout (one table per delay estimate, `mmq.rs`).

use std::ops::{Deref, DerefMut};

/// The [`Learner`](crate::learner::Learner) methods every learner acting on one [`QTable`] shares,
/// written once: inside `impl Learner for L`, `q_table_methods!(q);` gives `greedy` and
/// `action_values` over the table in field `q`; `q_table_methods!(q, tables);` adds
/// `tables` (the table, exported as "q"); `q_table_methods!(q, tables, act(p));` adds
/// `act`, ε-greedy with the ε of the parameters in field `p` and no model to report, and
/// `act(p, model = lambda_hat)` reports the field `lambda_hat` as the model
/// (`q_table_methods!(q, act(p))`: `act` without `tables`). A learner's
/// own file then holds its update rule.
macro_rules! q_table_methods {
    ($q:ident) => {
        fn greedy(&self, s: mmq_core::State, rng: &mut mmq_core::Rng) -> mmq_core::Action {
            self.$q.greedy(s, rng)
        }

        fn action_values(&self, s: mmq_core::State, out: &mut [f64]) {
            out.copy_from_slice(self.$q.row(s));
        }
    };
    ($q:ident, tables) => {
        q_table_methods!($q);

        fn tables(&self) -> Vec<crate::learner::Table> {
            vec![self.$q.export("q")]
        }
    };
    ($q:ident, act($p:ident)) => {
        q_table_methods!($q);

        fn act(&mut self, s: mmq_core::State, rng: &mut mmq_core::Rng) -> crate::learner::Decision {
            let (action, explored) = self.$q.epsilon_greedy(s, self.$p.epsilon, rng);
            crate::learner::Decision { action, model: None, explored }
        }
    };
    ($q:ident, tables, act($p:ident)) => {
        q_table_methods!($q, tables);

        fn act(&mut self, s: mmq_core::State, rng: &mut mmq_core::Rng) -> crate::learner::Decision {
            let (action, explored) = self.$q.epsilon_greedy(s, self.$p.epsilon, rng);
            crate::learner::Decision { action, model: None, explored }
        }
    };
    ($q:ident, tables, act($p:ident, model = $m:ident)) => {
        q_table_methods!($q, tables);

        fn act(&mut self, s: mmq_core::State, rng: &mut mmq_core::Rng) -> crate::learner::Decision {
            let (action, explored) = self.$q.epsilon_greedy(s, self.$p.epsilon, rng);
            crate::learner::Decision { action, model: Some(self.$m), explored }
        }
    };
}
pub(crate) use q_table_methods;

use mmq_core::{Action, Rng, State};

use crate::learner::Table;
use crate::policy::{argmax_random_tie, epsilon_greedy};

/// Q(s, a) for `num_states` × `num_actions`, row-major.
#[derive(Clone, Debug)]
pub struct QTable {
    num_actions: usize,
    q: Vec<f64>,
}

impl QTable {
    /// Every entry `q0`.
    pub fn new(num_states: usize, num_actions: usize, q0: f64) -> Self {
        Self { num_actions, q: vec![q0; num_states * num_actions] }
    }

    /// |A|.
    #[inline]
    pub fn num_actions(&self) -> usize {
        self.num_actions
    }

    /// The flat index of (s, a).
    #[inline]
    pub fn index(&self, s: State, a: Action) -> usize {
        s * self.num_actions + a
    }

    /// Q(s, ·).
    #[inline]
    pub fn row(&self, s: State) -> &[f64] {
        &self.q[s * self.num_actions..(s + 1) * self.num_actions]
    }

    /// Q(s, a).
    #[inline]
    pub fn get(&self, s: State, a: Action) -> f64 {
        self.q[s * self.num_actions + a]
    }

    /// ε-greedy over Q(s, ·), ties at random: (action, explored). Draws as
    /// [`epsilon_greedy`] does.
    #[inline]
    pub fn epsilon_greedy(&self, s: State, epsilon: f64, rng: &mut Rng) -> (Action, bool) {
        let row = self.row(s);
        epsilon_greedy(epsilon, self.num_actions, rng, |r| argmax_random_tie(row, r))
    }

    /// argmax_a Q(s, a), ties at random.
    #[inline]
    pub fn greedy(&self, s: State, rng: &mut Rng) -> Action {
        argmax_random_tie(self.row(s), rng)
    }

    /// The table for export as `name` (shape [states, actions]).
    pub fn export(&self, name: &str) -> Table {
        Table {
            name: name.into(),
            shape: vec![self.q.len() / self.num_actions, self.num_actions],
            data: self.q.clone(),
        }
    }
}

impl Deref for QTable {
    type Target = [f64];
    #[inline]
    fn deref(&self) -> &[f64] {
        &self.q
    }
}

impl DerefMut for QTable {
    #[inline]
    fn deref_mut(&mut self) -> &mut [f64] {
        &mut self.q
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn row_major_layout_and_export() {
        let mut t = QTable::new(3, 2, 1.5);
        assert_eq!(t.index(2, 1), 5);
        let i = t.index(1, 0);
        t[i] = 4.0;
        assert_eq!((t.get(1, 0), t.row(1)), (4.0, &[4.0, 1.5][..]));
        let mut rng = mmq_core::seed::rng_from_seed(3);
        assert_eq!(t.greedy(1, &mut rng), 0);
        assert_eq!(t.epsilon_greedy(1, 0.0, &mut rng), (0, false));
        let e = t.export("q");
        assert_eq!((e.name.as_str(), e.shape.as_slice(), e.data[2]), ("q", &[3, 2][..], 4.0));
    }
}
