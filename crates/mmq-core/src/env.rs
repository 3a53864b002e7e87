//! The environment interface shared by the grid world and the robot: [`Env`], the MDP,
//! and [`Telemetry`], what loggers and reports read besides it.
//!
//! The task is continuing, as in the paper: `step` reports `terminated` and `truncated`
//! separately (Gymnasium's convention), and both stay false for the worlds of mmq; an
//! episode limit is a wrapper, not part of the MDP.

use serde::{Deserialize, Serialize};

use crate::world::World;

/// A discrete state (for the paper's environments: a cell index).
pub type State = usize;
/// A discrete action index.
pub type Action = usize;

/// The paper's four moves. Action index = position in [`Move::ALL`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Move {
    /// Up (row − 1).
    N,
    /// Right (column + 1).
    E,
    /// Down (row + 1).
    S,
    /// Left (column − 1).
    W,
}

impl Move {
    /// All moves in action-index order.
    pub const ALL: [Move; 4] = [Move::N, Move::E, Move::S, Move::W];

    /// The move of an action index.
    pub fn from_index(a: Action) -> Option<Move> {
        Self::ALL.get(a).copied()
    }

    /// (Δrow, Δcolumn) on the map (row 0 at the top).
    pub fn delta(self) -> (isize, isize) {
        match self {
            Move::N => (-1, 0),
            Move::E => (0, 1),
            Move::S => (1, 0),
            Move::W => (0, -1),
        }
    }

    /// Short name.
    pub fn name(self) -> &'static str {
        match self {
            Move::N => "N",
            Move::E => "E",
            Move::S => "S",
            Move::W => "W",
        }
    }

    /// An arrow for drawing policies.
    pub fn arrow(self) -> char {
        match self {
            Move::N => '↑',
            Move::E => '→',
            Move::S => '↓',
            Move::W => '←',
        }
    }
}

/// What happened during a step.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Event {
    /// A normal move (or a primitive that reached its target).
    Moved,
    /// The agent hit a wall or a blocked cell and stayed.
    WallBump,
    /// The action was taken in the goal: reward, then teleport to the respawn cell.
    Teleport,
    /// A robot primitive ran out of time before reaching its target.
    TimedOut,
}

impl Event {
    /// A stable name for logs and tables.
    pub fn name(self) -> &'static str {
        match self {
            Event::Moved => "moved",
            Event::WallBump => "wall",
            Event::Teleport => "goal",
            Event::TimedOut => "timeout",
        }
    }
}

/// The outcome of one step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    /// The next state s'.
    pub state: State,
    /// The reward the environment emitted for this step (before any delay).
    pub reward: f64,
    /// What happened.
    pub event: Event,
    /// The state is terminal (never, in the continuing task).
    pub terminated: bool,
    /// The run was cut by a limit outside the MDP.
    pub truncated: bool,
}

/// Where `reset` puts the agent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Start {
    /// The world file's rule (`random` free non-goal cell, or `respawn`).
    World,
    /// The respawn cell `S` (greedy evaluation starts here).
    Respawn,
    /// A given state.
    State(State),
}

/// An environment failure that is not a programming error.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EnvError {
    /// The action index is out of range.
    #[error("action {action} is out of range (the environment has {num_actions} actions)")]
    InvalidAction {
        /// The index given.
        action: Action,
        /// How many actions there are.
        num_actions: usize,
    },
    /// A start state that is not a free cell.
    #[error("start state {0} is not a free cell of the world")]
    InvalidStart(State),
    /// The simulation produced a non-finite or runaway state.
    #[error("physics failure at decision step {step}: {message}")]
    Physics {
        /// Decision step (since reset) at which it was detected.
        step: u64,
        /// What was wrong.
        message: String,
    },
}

/// A pose sample of a continuous-time environment (world frame, SI units).
#[derive(Clone, Copy, Debug, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseSample {
    /// Simulated time since reset, seconds.
    pub time_s: f64,
    /// Position x, metres.
    pub x: f64,
    /// Position y, metres.
    pub y: f64,
    /// Heading, radians (0 = +x, counter-clockwise).
    pub theta: f64,
}

/// A contact starting or stopping between the robot and a wall.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContactSample {
    /// Simulated time since reset, seconds.
    pub time_s: f64,
    /// True when the contact started, false when it stopped.
    pub started: bool,
    /// Which wall ("boundary-north", "block-r3c4", ...).
    pub wall: String,
}

/// Continuous-time detail of the last step, for loggers; empty for the grid.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepTrace {
    /// Poses sampled during the step at the requested period (the last one is the
    /// pose at the end of the step).
    pub poses: Vec<PoseSample>,
    /// Contacts that started or stopped during the step.
    pub contacts: Vec<ContactSample>,
    /// The robot's own pose estimate, sampled at the same times as `poses` (empty when
    /// the environment controls on the true pose).
    pub estimates: Vec<PoseSample>,
    /// Absolute localisation fixes received during the step (each with its time).
    pub fixes: Vec<PoseSample>,
}

/// An environment with discrete states and actions.
///
/// Contract (checked by `mmq_core::env::check_determinism` on every world): the same
/// seed and the same actions give the same transitions, bit for bit.
pub trait Env {
    /// Number of states; states are `0..num_states()`.
    fn num_states(&self) -> usize;
    /// Number of actions; actions are `0..num_actions()`.
    fn num_actions(&self) -> usize;
    /// A short name per action, in index order.
    fn action_names(&self) -> Vec<String>;
    /// The world this environment is built from.
    fn world(&self) -> &World;
    /// The map cell of a state (identity for the grid).
    fn state_cell(&self, state: State) -> usize {
        state
    }
    /// Starts anew: seeds the environment's own random stream and places the agent.
    fn reset(&mut self, seed: u64, start: Start) -> Result<State, EnvError>;
    /// Takes one action.
    fn step(&mut self, action: Action) -> Result<Step, EnvError>;
}

/// What an environment tells loggers and reports besides the MDP: simulated time,
/// poses, the continuous-time trace of a step and summary figures. Learners never see
/// it. The delay channel reads the clock (delays in seconds); the runner reads the rest
/// for its summaries and hands it to observers (the MCAP recorder, the live view). An
/// environment without continuous time gives a nominal clock and a pose at its cell and
/// keeps the defaults.
pub trait Telemetry {
    /// Simulated time since reset, seconds (grid: a nominal period per step).
    fn sim_time_s(&self) -> f64;
    /// Asks for pose samples every `period_s` seconds of simulated time during each
    /// step (`None` turns tracing off). Environments without continuous time ignore it.
    fn set_trace(&mut self, _period_s: Option<f64>) {}
    /// Moves the trace of the last step into `out` (cleared first).
    fn take_trace(&mut self, out: &mut StepTrace) {
        out.poses.clear();
        out.contacts.clear();
        out.estimates.clear();
        out.fixes.clear();
    }
    /// The current pose in the world frame.
    fn pose(&self) -> PoseSample;
    /// The environment's own estimate of its pose, where it controls on an estimate
    /// (the realistic robot); `None` where it knows the true pose.
    fn pose_estimate(&self) -> Option<PoseSample> {
        None
    }
    /// The state the true pose is in, where the reported state is a belief that can
    /// differ from it (the realistic robot); `None` where the state is the truth.
    fn true_state(&self) -> Option<State> {
        None
    }
    /// Summary figures of the environment (robot: physics steps, contacts, ...).
    fn stats(&self) -> Vec<(String, f64)> {
        Vec::new()
    }
}

/// Runs `steps` seeded random actions twice from the same seed and reports the first
/// step at which the transitions differ (the environment checker).
pub fn check_determinism<E: Env>(make: impl Fn() -> E, seed: u64, steps: usize) -> Result<(), String> {
    use rand::RngExt;
    let run = || -> Result<Vec<(State, u64, Event)>, String> {
        let mut env = make();
        let mut rng = crate::seed::rng_from_seed(seed ^ 0xA5A5);
        let s0 = env.reset(seed, Start::World).map_err(|e| e.to_string())?;
        let mut out = vec![(s0, 0, Event::Moved)];
        for _ in 0..steps {
            let a = rng.random_range(0..env.num_actions());
            let st = env.step(a).map_err(|e| e.to_string())?;
            out.push((st.state, st.reward.to_bits(), st.event));
        }
        Ok(out)
    };
    let (a, b) = (run()?, run()?);
    match a.iter().zip(&b).position(|(x, y)| x != y) {
        None => Ok(()),
        Some(i) => Err(format!("runs with seed {seed} differ at step {i}: {:?} vs {:?}", a[i], b[i])),
    }
}
