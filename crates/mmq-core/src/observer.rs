//! Observer hooks: what a runner tells loggers and recorders about every step.
//!
//! The runner calls [`Observer::on_step`] after the learner has seen the step. An
//! observer that does nothing costs one virtual call per step; when recording is off
//! the runner holds no observer at all.

use crate::channel::{Emission, Ledger};
use crate::env::{Action, Event, PoseSample, State, StepTrace};
use crate::world::World;

/// Everything known about one decision step.
#[derive(Debug, Clone, Copy)]
pub struct StepRecord<'a> {
    /// Decision step t.
    pub t: u64,
    /// State s_t.
    pub state: State,
    /// Action a_t.
    pub action: Action,
    /// The delay model the learner acted on (MMQ's λ̂*), if it has one.
    pub model: Option<usize>,
    /// Whether the action was exploratory (ε) rather than greedy.
    pub explored: bool,
    /// Next state s_{t+1}.
    pub next_state: State,
    /// Reward emitted by the environment at t.
    pub emitted: f64,
    /// What happened.
    pub event: Event,
    /// Delay drawn for the emitted reward, if non-zero.
    pub delay: Option<u32>,
    /// Reward delivered at t (sum of everything due).
    pub delivered: f64,
    /// Ids of the emissions delivered at t (needs the ledger).
    pub delivered_ids: &'a [u64],
    /// The channel's ground truth (ids → emissions), when kept.
    pub ledger: Option<&'a Ledger>,
    /// Simulated time at the end of the step, seconds.
    pub sim_time_s: f64,
    /// Continuous-time detail of the step (robot poses and contacts).
    pub trace: &'a StepTrace,
}

impl StepRecord<'_> {
    /// The emission made at this step, if any (needs the ledger).
    pub fn emission(&self) -> Option<&Emission> {
        let l = self.ledger?;
        let last = l.emissions().last()?;
        (last.t_emit == self.t).then_some(last)
    }
}

/// Static facts about a run, given to observers at its start.
#[derive(Debug, Clone)]
pub struct RunInfo<'a> {
    /// The world.
    pub world: &'a World,
    /// Master seed of this run.
    pub seed: u64,
    /// Learner name.
    pub learner: &'a str,
    /// Action names.
    pub action_names: &'a [String],
    /// Resolved run configuration (TOML text).
    pub config_toml: &'a str,
    /// Environment kind ("grid" or "robot").
    pub env_kind: &'a str,
    /// Extra key/value facts (versions, physics features, dt).
    pub facts: &'a [(String, String)],
    /// The agent's pose after the reset, where the environment has a continuous one
    /// (the robot: position and heading, [`crate::Env::pose`]); `None` for the grid,
    /// whose pose is the start cell's centre.
    pub start_pose: Option<PoseSample>,
}

/// Receives the steps of a run.
pub trait Observer {
    /// How often the environment should sample poses during a step (simulated seconds;
    /// `None`: no continuous trace needed).
    fn trace_period_s(&self) -> Option<f64> {
        None
    }
    /// Called once before the first step, with the initial state.
    fn on_start(&mut self, _info: &RunInfo<'_>, _initial_state: State, _sim_time_s: f64) {}
    /// Called after every step.
    fn on_step(&mut self, _rec: &StepRecord<'_>) {}
    /// Called at intervals with the learner's per-cell visit counts and greedy values.
    fn on_tables(&mut self, _t: u64, _sim_time_s: f64, _visits: &[f64], _values: &[f64]) {}
    /// Called once at the end (also when the run was interrupted: `complete` = false).
    fn on_finish(&mut self, _t: u64, _complete: bool) {}
    /// The first error that lost some of this observer's output (a write that failed,
    /// say), as one message naming the file. The runner checks it as the run goes and at
    /// the end: such a seed stops and is never reported complete.
    fn error(&self) -> Option<String> {
        None
    }
}
