//! Observer hooks: what a runner tells loggers and recorders about every step.
//!
//! The runner calls [`Observer::on_step`] after the learner has seen the step. An
//! observer that does nothing costs one virtual call per step; when recording is off
//! the runner holds no observer at all. An observer that only sometimes wants the steps
//! (a live view nobody watches) hands the runner a [`StepGate`]: while it is closed the
//! runner builds no record and makes no call, and when it opens again it tells the
//! observer where the run stands ([`Observer::on_resume`]).

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

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
    /// (the robot: position and heading, [`crate::Telemetry::pose`]); `None` for the grid,
    /// whose pose is the start cell's centre.
    pub start_pose: Option<PoseSample>,
}

/// A gate an observer shares with the runner: open while at least one party wants the
/// steps (each [`StepGate::open`] is matched by a [`StepGate::close`]). The runner reads
/// it once per step: one relaxed atomic load.
#[derive(Clone, Debug, Default)]
pub struct StepGate(Arc<AtomicUsize>);

impl StepGate {
    /// A closed gate.
    pub fn new() -> Self {
        Self::default()
    }
    /// Someone wants the steps from now on.
    pub fn open(&self) {
        self.0.fetch_add(1, Ordering::SeqCst);
    }
    /// Someone no longer wants them (a close without an open does nothing).
    pub fn close(&self) {
        let _ = self.0.fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| n.checked_sub(1));
    }
    /// Whether anyone wants the steps now.
    #[inline]
    pub fn is_open(&self) -> bool {
        self.0.load(Ordering::Relaxed) > 0
    }
    /// How many want them.
    pub fn count(&self) -> usize {
        self.0.load(Ordering::SeqCst)
    }
}

/// Where a run stands just before decision step `t`: what an observer that skipped steps
/// behind a closed [`StepGate`] picks up from ([`Observer::on_resume`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Resume {
    /// The next decision step (the steps before it are done).
    pub t: u64,
    /// Simulated time now, at the start of step `t`, seconds.
    pub sim_time_s: f64,
    /// Sum of every reward emitted so far (summed in emission order).
    pub emitted_total: f64,
    /// Sum of every reward delivered so far (summed step by step).
    pub delivered_total: f64,
    /// Rewards emitted so far (the id the next emission gets).
    pub emissions: u64,
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
    /// Called after every step (while the [`Observer::step_gate`], if any, is open).
    fn on_step(&mut self, _rec: &StepRecord<'_>) {}
    /// A gate the runner reads before each step, taken once after `on_start`: while it
    /// is closed the runner skips `on_step` (and building its record; `on_tables` and
    /// `on_finish` still come); when it opens again, `on_resume` comes before the next
    /// `on_step`. `None` (the default): every step is observed.
    fn step_gate(&self) -> Option<StepGate> {
        None
    }
    /// Whether `on_step` reads emissions of [`StepRecord::ledger`] other than the step's
    /// own ([`StepRecord::emission`]) and its deliveries ([`StepRecord::delivered_ids`]).
    /// `true` (the default) has the runner keep every emission of the run; `false` only
    /// those a step's record needs ([`crate::DelayedReward::trim_ledger`]).
    fn ledger_history(&self) -> bool {
        true
    }
    /// Called when the gate opens again after steps were skipped, before step `at.t`.
    fn on_resume(&mut self, _at: &Resume) {}
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
    /// An observer that is fed by something other than the single environment's step
    /// loop (the swarm's recorder, which sees every robot) hands itself over to whoever
    /// drives it, which takes it back as its own type (`Box<dyn Any>::downcast`). The step
    /// loop's observers keep the default: `None`.
    fn into_any(self: Box<Self>) -> Option<Box<dyn std::any::Any + Send>> {
        None
    }
}
