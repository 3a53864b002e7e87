//! One environment behind its delay channel, as the Python `mmq.envs.MmqEnv` drives it:
//! seeded resets (the CLI's seed tree), a fast step for agents and a detailed step for
//! `info` (emission, deliveries with their delays in steps and seconds, time, event, the
//! true and believed cell), and the three policies for rewards in flight at a reset.

use mmq_core::Telemetry;
use mmq_core::{DelayedReward, DelayedStep, Emission, Env, SeedTree, Start, Stream};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::config::{AnyEnv, EnvSpec, config_err, parse_delay, parse_start};
use crate::{env_err, seed_arg};

/// What happens to rewards still in flight when an episode ends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InFlight {
    /// Lost at the reset (each episode starts with an empty channel).
    Drop,
    /// Delivered all at once with the truncated step's reward.
    Flush,
    /// Kept: delivered in the next episode at their due step (a continuing channel).
    Carry,
}

impl InFlight {
    /// Parses `drop`, `flush` or `carry`.
    pub fn parse(s: &str) -> PyResult<InFlight> {
        match s {
            "drop" => Ok(InFlight::Drop),
            "flush" => Ok(InFlight::Flush),
            "carry" => Ok(InFlight::Carry),
            _ => Err(config_err(
                "in_flight",
                format!("`{s}` is not accepted; use \"drop\", \"flush\" or \"carry\""),
            )),
        }
    }
}

/// An environment and its channel, with the bookkeeping `info` needs.
#[derive(Debug)]
pub struct Channel {
    /// The environment behind the delay channel (the ledger is kept).
    pub ch: DelayedReward<AnyEnv>,
    /// Where resets place the agent.
    pub start: Start,
    /// Rewards in flight at a reset.
    pub in_flight: InFlight,
    /// Simulated time at the end of each emission's step, by emission id.
    emit_time_s: Vec<f64>,
    /// Whether the channel has been reset once (carry keeps it afterwards).
    started: bool,
    /// Simulated time accumulated by earlier episodes (carry: time keeps running).
    time_offset_s: f64,
}

impl Channel {
    /// A channel around a fresh environment of `spec`.
    pub fn new(spec: &EnvSpec, delay: &str, start: Start, in_flight: InFlight) -> PyResult<Channel> {
        Self::with_ledger(spec, delay, start, in_flight, true)
    }

    /// As [`Channel::new`]; without the ledger (`ledger` false) the deliveries of a step
    /// are not itemised, and stepping is cheaper.
    pub fn with_ledger(
        spec: &EnvSpec,
        delay: &str,
        start: Start,
        in_flight: InFlight,
        ledger: bool,
    ) -> PyResult<Channel> {
        let dist = parse_delay(delay)?;
        let env = spec.build()?;
        if let Start::State(s) = start
            && (s >= env.num_states() || !env.world().is_free(env.state_cell(s)))
        {
            return Err(config_err("start", format!("state {s} is not a free cell of the world")));
        }
        Ok(Channel {
            ch: DelayedReward::new(env, &dist, ledger),
            start,
            in_flight,
            emit_time_s: Vec::new(),
            started: false,
            time_offset_s: 0.0,
        })
    }

    /// Starts an episode from master seed `seed` (environment and delay streams as the
    /// CLI derives them).
    pub fn reset(&mut self, seed: u64) -> Result<usize, mmq_core::EnvError> {
        let tree = SeedTree::new(seed);
        if self.in_flight == InFlight::Carry && self.started {
            self.time_offset_s = self.time_s();
            return self.ch.env_mut().reset(tree.seed(Stream::Env), self.start);
        }
        self.started = true;
        self.emit_time_s.clear();
        self.time_offset_s = 0.0;
        self.ch.reset(tree.seed(Stream::Env), tree.seed(Stream::Delay), self.start)
    }

    /// Simulated time since the channel was reset (carry: since the first reset).
    pub fn time_s(&self) -> f64 {
        self.time_offset_s + self.ch.env().sim_time_s()
    }

    /// One step through the channel (the emission's time is noted for `info`).
    #[inline]
    pub fn step(&mut self, action: usize) -> Result<DelayedStep, mmq_core::EnvError> {
        let st = self.ch.step(action)?;
        if st.delay.is_some() {
            self.note_emission();
        }
        Ok(st)
    }

    #[inline(never)]
    fn note_emission(&mut self) {
        let n = self.ch.ledger().map_or(0, |l| l.emissions().len());
        let now = self.time_s();
        self.emit_time_s.resize(n, now);
        if let Some(x) = self.emit_time_s.last_mut() {
            *x = now;
        }
    }

    /// The emissions delivered at the last step: (emission step, delay in steps, delay in
    /// seconds of simulated time, value).
    pub fn deliveries(&self) -> Vec<(u64, u32, f64, f64)> {
        let Some(ledger) = self.ch.ledger() else { return Vec::new() };
        let now = self.time_s();
        self.ch
            .delivered_ids()
            .iter()
            .filter_map(|&i| ledger.get(i))
            .map(|e| {
                let t = self.emit_time_s.get(e.id as usize).copied().unwrap_or(f64::NAN);
                (e.t_emit, e.delay, now - t, e.value)
            })
            .collect()
    }

    /// Every emission still in flight (due after the last step), as [`Self::deliveries`]
    /// would report them if delivered now.
    pub fn pending(&self) -> Vec<(u64, u32, f64, f64)> {
        let Some(ledger) = self.ch.ledger() else { return Vec::new() };
        let now = self.time_s();
        let t = self.ch.t();
        ledger
            .emissions()
            .iter()
            .filter(|e| e.due >= t)
            .map(|e| {
                let te = self.emit_time_s.get(e.id as usize).copied().unwrap_or(f64::NAN);
                (e.t_emit, e.delay, now - te, e.value)
            })
            .collect()
    }
}

/// The native side of one `mmq/Grid-v0` or `mmq/Robot-v0` environment, usable from any
/// thread (one call at a time: pyo3's borrow check refuses a second one while a call runs).
#[pyclass(module = "mmq._mmq")]
#[derive(Debug)]
pub struct EnvCore {
    inner: Channel,
}

#[pymethods]
impl EnvCore {
    /// A new environment; every argument is checked here (`ConfigError` otherwise).
    #[new]
    #[pyo3(signature = (env, world, delay, start, in_flight, preset=None, profile=None, overrides=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        env: &str,
        world: &str,
        delay: &str,
        start: &Bound<'_, PyAny>,
        in_flight: &str,
        preset: Option<&str>,
        profile: Option<&str>,
        overrides: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let spec = EnvSpec::resolve(env, world, preset, profile, overrides)?;
        let inner = Channel::new(&spec, delay, parse_start(start)?, InFlight::parse(in_flight)?)?;
        Ok(EnvCore { inner })
    }

    /// Number of states (cells, row-major).
    #[getter]
    fn n_states(&self) -> usize {
        self.inner.ch.env().num_states()
    }

    /// Number of actions.
    #[getter]
    fn n_actions(&self) -> usize {
        self.inner.ch.env().num_actions()
    }

    /// Action names in index order.
    #[getter]
    fn action_names(&self) -> Vec<String> {
        self.inner.ch.env().action_names()
    }

    /// (name, width, height, cell size in metres, goal cell, respawn cell).
    #[getter]
    fn world_facts(&self) -> (String, usize, usize, f64, usize, usize) {
        let w = self.inner.ch.env().world();
        (w.name.clone(), w.width, w.height, w.cell_size, w.goal, w.respawn)
    }

    /// The world file's text.
    #[getter]
    fn world_source(&self) -> String {
        self.inner.ch.env().world().source.clone()
    }

    /// The delay spec, normalised.
    #[getter]
    fn delay(&self) -> String {
        self.inner.ch.dist().to_string()
    }

    /// Starts an episode from master seed `seed`; returns the state.
    fn reset(&mut self, seed: &Bound<'_, PyAny>) -> PyResult<usize> {
        let seed = seed_arg(seed)?;
        self.inner.reset(seed).map_err(env_err)
    }

    /// One step, fast: (next state, delivered reward).
    fn step_fast(&mut self, action: &Bound<'_, PyAny>) -> PyResult<(usize, f64)> {
        let a = action_arg(action, self.inner.ch.env().num_actions())?;
        let st = self.inner.step(a).map_err(env_err)?;
        Ok((st.step.state, st.delivered))
    }

    /// One step with everything `info` reports: (next state, delivered, emitted, delay
    /// in steps or -1 (nothing emitted, or a delay in seconds whose steps are known only
    /// at delivery), event, decision step, simulated time in seconds, deliveries
    /// [(emission step, delay steps, delay seconds, value)], true cell or None).
    #[allow(clippy::type_complexity)]
    fn step(
        &mut self,
        action: &Bound<'_, PyAny>,
    ) -> PyResult<(usize, f64, f64, i64, &'static str, u64, f64, Vec<(u64, u32, f64, f64)>, Option<usize>)>
    {
        let a = action_arg(action, self.inner.ch.env().num_actions())?;
        let st = self.inner.step(a).map_err(env_err)?;
        let deliveries =
            if self.inner.ch.delivered_ids().is_empty() { Vec::new() } else { self.inner.deliveries() };
        Ok((
            st.step.state,
            st.delivered,
            st.step.reward,
            st.delay.filter(|&d| d != Emission::PENDING).map_or(-1, i64::from),
            st.step.event.name(),
            st.t,
            self.inner.time_s(),
            deliveries,
            self.inner.ch.env().true_state(),
        ))
    }

    /// The sum of the rewards in flight now.
    fn in_flight(&self) -> f64 {
        self.inner.ch.in_flight()
    }

    /// The rewards in flight now: [(emission step, delay steps, seconds since emission,
    /// value)].
    fn pending(&self) -> Vec<(u64, u32, f64, f64)> {
        self.inner.pending()
    }

    /// The decision step the next `step` takes (the channel's clock).
    #[getter]
    fn t(&self) -> u64 {
        self.inner.ch.t()
    }

    /// Simulated time, seconds.
    #[getter]
    fn time_s(&self) -> f64 {
        self.inner.time_s()
    }

    /// The map as text (`#` blocked, `G` goal, `S` respawn, `.` free), one line per row.
    #[getter]
    fn ascii(&self) -> String {
        self.inner.ch.env().world().ascii()
    }

    /// (emitted, delivered) totals since the channel was last emptied.
    fn totals(&self) -> (f64, f64) {
        (self.inner.ch.emitted_total(), self.inner.ch.delivered_total())
    }

    /// The true pose: (x m, y m, heading rad, simulated time s).
    fn pose(&self) -> (f64, f64, f64, f64) {
        let p = self.inner.ch.env().pose();
        (p.x, p.y, p.theta, p.time_s)
    }

    /// The robot's own pose estimate (realistic profile), or None.
    fn pose_estimate(&self) -> Option<(f64, f64, f64, f64)> {
        self.inner.ch.env().pose_estimate().map(|p| (p.x, p.y, p.theta, p.time_s))
    }

    /// Environment figures (robot physics counters).
    fn stats(&self) -> Vec<(String, f64)> {
        self.inner.ch.env().stats()
    }
}

/// An action from Python (an int or a NumPy integer) checked against the action count.
pub fn action_arg(a: &Bound<'_, PyAny>, n: usize) -> PyResult<usize> {
    match a.extract::<i64>() {
        Ok(x) if x >= 0 && (x as u64) < n as u64 => Ok(x as usize),
        Ok(x) => Err(pyo3::exceptions::PyValueError::new_err(format!(
            "action {x} is out of range; use an integer in 0..{n}"
        ))),
        Err(_) => Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "action must be an integer in 0..{n}, got {}",
            a.get_type().name().map(|n| n.to_string()).unwrap_or_default()
        ))),
    }
}
