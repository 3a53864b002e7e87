//! The reference agent `grid-optimal`: the world MDP's optimal policy (value iteration
//! on the grid, [`mmq_core::optimum()`]) executed on an environment without learning.
//! On the grid it earns the optimum (less its exploration); on a robot it earns what the
//! grid's best plan is worth once primitives slip, take longer, or end in another cell
//! than planned, so a learner's fraction of it separates the robot's own losses from the
//! learner's. While "learning" it acts ε-greedily around the optimal policy (ties among
//! optimal actions at random): the ε-soft reference; its greedy evaluation is the optimal
//! policy itself. The benchmark suite's reference and `mmq run --reference` run it.

use mmq_core::{Action, Move, Optimum, Rng, State};
use mmq_learn::policy::epsilon_greedy;
use mmq_learn::{Decision, Experience, Learner, Table};
use rand::RngExt;

use crate::error::LabError;

/// The reference agent's name in results files.
pub const NAME: &str = "grid-optimal";

/// The grid MDP's optimal policy as an agent (see the module's documentation).
#[derive(Clone, Debug)]
pub struct GridOptimal {
    /// Per state, the optimal actions as a bit set over [`Move::ALL`].
    optimal: Vec<u8>,
    epsilon: f64,
    n_actions: usize,
}

impl GridOptimal {
    /// The optimal policy of `optimum` for an environment of `n_states` × `n_actions`,
    /// acting ε-greedily with `epsilon`. The environment's states must be the world's
    /// cells and its actions the grid's moves (the grid, and the robot with
    /// `actions = "moves"`); `world` names it in the error otherwise.
    pub fn new(
        optimum: &Optimum,
        epsilon: f64,
        n_states: usize,
        n_actions: usize,
        world: &str,
    ) -> Result<GridOptimal, LabError> {
        if n_states != optimum.actions.len() || n_actions != Move::ALL.len() {
            return Err(LabError::Config {
                file: world.into(),
                message: format!(
                    "robot.actions: the grid-optimal reference needs the grid's states and moves ({} cells × {} actions), \
                     but the environment has {n_states} states × {n_actions} actions; use actions = \"moves\"",
                    optimum.actions.len(),
                    Move::ALL.len()
                ),
            });
        }
        Ok(GridOptimal { optimal: optimum.actions.clone(), epsilon, n_actions })
    }

    /// One of the optimal actions of `state`, uniformly at random (action 0 where there
    /// is none: a blocked cell, never visited).
    fn pick(&self, state: State, rng: &mut Rng) -> Action {
        let bits = self.optimal[state];
        let count = bits.count_ones();
        if count == 0 {
            return 0;
        }
        let mut k = rng.random_range(0..count);
        for a in 0..self.n_actions {
            if bits & (1 << a) != 0 {
                if k == 0 {
                    return a;
                }
                k -= 1;
            }
        }
        unreachable!("count set bits are below n_actions")
    }
}

impl Learner for GridOptimal {
    fn name(&self) -> &'static str {
        NAME
    }

    fn act(&mut self, state: State, rng: &mut Rng) -> Decision {
        let (action, explored) = epsilon_greedy(self.epsilon, self.n_actions, rng, |r| self.pick(state, r));
        Decision { action, model: None, explored }
    }

    /// It does not learn.
    fn observe(&mut self, _: &Experience<'_>) {}

    /// No memory and no learning: one agent serves any number of trajectories.
    fn shares_tables(&self) -> bool {
        true
    }

    fn greedy(&self, state: State, rng: &mut Rng) -> Action {
        self.pick(state, rng)
    }

    /// 1 for the optimal actions, 0 for the others (for policy maps).
    fn action_values(&self, state: State, out: &mut [f64]) {
        for (a, v) in out.iter_mut().enumerate() {
            *v = f64::from(u8::from(self.optimal[state] & (1 << a) != 0));
        }
    }

    fn tables(&self) -> Vec<Table> {
        Vec::new()
    }
}
