//! mmq-grid: the paper's tabular grid world (Section IV) on any [`World`].
//!
//! States are cell indices, actions the four moves N, E, S, W. Any action in `G` yields
//! the goal reward and moves the agent to `S`; moving into the boundary or a blocked
//! cell yields the wall reward and stays; every other move yields the step reward. The
//! dynamics are the world's own ([`World::transition`]), precomputed into a table.
//!
//! Architecture invariant: this crate knows no learner, no physics and no log format.

use mmq_core::{
    Action, Env, EnvError, Event, Move, PoseSample, Start, StartRule, State, Step, Telemetry, World,
};
use rand::RngExt;

/// Nominal duration of one grid step when the world does not set `step_period_s`,
/// seconds (the time base of grid logs; the world's `step_period_s` overrides it).
pub const STEP_PERIOD_S: f64 = mmq_core::world::DEFAULT_STEP_PERIOD_S;

/// The paper's grid world.
#[derive(Clone, Debug)]
pub struct GridEnv {
    world: World,
    /// (next cell, reward, event) for every (cell, action), row-major by cell.
    table: Vec<(u32, f64, Event)>,
    /// Free non-goal cells, the support of the random start rule.
    starts: Vec<usize>,
    state: State,
    t: u64,
}

impl GridEnv {
    /// The grid world of `world`.
    pub fn new(world: &World) -> Self {
        let mut table = Vec::with_capacity(world.num_cells() * 4);
        for c in 0..world.num_cells() {
            for m in Move::ALL {
                let (n, r, e) = world.transition(c, m);
                table.push((n as u32, r, e));
            }
        }
        let starts = world.free_cells().filter(|&c| c != world.goal).collect();
        Self { world: world.clone(), table, starts, state: world.respawn, t: 0 }
    }

    /// The current state.
    pub fn state(&self) -> State {
        self.state
    }
}

impl Env for GridEnv {
    fn num_states(&self) -> usize {
        self.world.num_cells()
    }

    fn num_actions(&self) -> usize {
        4
    }

    fn action_names(&self) -> Vec<String> {
        Move::ALL.iter().map(|m| m.name().to_string()).collect()
    }

    fn world(&self) -> &World {
        &self.world
    }

    fn reset(&mut self, seed: u64, start: Start) -> Result<State, EnvError> {
        let mut rng = mmq_core::seed::rng_from_seed(seed);
        self.t = 0;
        self.state = match start {
            Start::World => match self.world.start {
                StartRule::Random => self.starts[rng.random_range(0..self.starts.len())],
                StartRule::Respawn => self.world.respawn,
            },
            Start::Respawn => self.world.respawn,
            Start::State(s) if self.world.is_free(s) => s,
            Start::State(s) => return Err(EnvError::InvalidStart(s)),
        };
        Ok(self.state)
    }

    #[inline]
    fn step(&mut self, action: Action) -> Result<Step, EnvError> {
        if action >= 4 {
            return Err(EnvError::InvalidAction { action, num_actions: 4 });
        }
        let (next, reward, event) = self.table[self.state * 4 + action];
        self.state = next as usize;
        self.t += 1;
        Ok(Step { state: self.state, reward, event, terminated: false, truncated: false })
    }
}

impl Telemetry for GridEnv {
    /// t × the world's `step_period_s`.
    fn sim_time_s(&self) -> f64 {
        self.t as f64 * self.world.step_period_s
    }

    fn pose(&self) -> PoseSample {
        let (x, y) = self.world.cell_center(self.state);
        PoseSample { time_s: self.sim_time_s(), x, y, theta: 0.0 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mmq_core::env::check_determinism;

    fn worlds() -> Vec<World> {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../worlds");
        let mut v: Vec<_> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|x| x == "toml"))
            .collect();
        v.sort();
        // The shipped worlds: a loop over none of them would check nothing.
        assert!(v.len() >= 8, "expected the 8 shipped worlds in {dir}, found {}", v.len());
        v.iter().map(|p| World::load(p).unwrap()).collect()
    }

    /// The environment checker: same seed ⇒ same transitions, on every shipped world.
    #[test]
    fn every_world_is_deterministic() {
        for w in worlds() {
            check_determinism(|| GridEnv::new(&w), 11, 2000).unwrap();
        }
    }

    #[test]
    fn paper_moves_by_hand() {
        let w = World::parse("map = \"\"\"\nG..\n...\n..S\n\"\"\"", "t").unwrap();
        let mut env = GridEnv::new(&w);
        assert_eq!(env.reset(0, Start::Respawn).unwrap(), 8);
        let n = env.step(0).unwrap(); // N from (2,2) to (1,2)
        assert_eq!((n.state, n.reward, n.event), (5, 0.0, Event::Moved));
        let e = env.step(1).unwrap(); // E into the boundary
        assert_eq!((e.state, e.reward, e.event), (5, -1.0, Event::WallBump));
        env.step(0).unwrap();
        env.step(3).unwrap();
        let w1 = env.step(3).unwrap();
        assert_eq!(w1.state, 0);
        let g = env.step(2).unwrap(); // any action in G
        assert_eq!((g.state, g.reward, g.event), (8, 10.0, Event::Teleport));
        assert!(env.step(4).is_err());
    }

    #[test]
    fn random_start_covers_free_non_goal_cells() {
        let w = World::parse("map = \"\"\"\nG.#\n..S\n\"\"\"", "t").unwrap();
        let mut env = GridEnv::new(&w);
        let mut seen = std::collections::BTreeSet::new();
        for seed in 0..200 {
            seen.insert(env.reset(seed, Start::World).unwrap());
        }
        assert_eq!(seen.into_iter().collect::<Vec<_>>(), vec![1, 3, 4, 5]);
    }
}
