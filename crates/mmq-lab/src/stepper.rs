//! One learning trajectory and one greedy evaluation as steppable states: the step loop
//! of the runner, which [`crate::runner`] drives to the end for one seed and
//! [`crate::batch`] drives for many seeds in lockstep (every seed's step `t` before any
//! seed's step `t + 1`), so that a seed's trajectory is the same either way.
//!
//! A learning step is split in two around the learner's choice: [`Stepper::begin`] does
//! what comes before it (progress, diagnostics samples, the stop flag, the learner's
//! failure) and gives the state to act in; [`Stepper::advance`] steps the environment
//! with the action chosen, lets the learner observe and keeps the metrics.

use std::sync::atomic::Ordering;

use mmq_core::{
    DelayDist, DelayedReward, Env, Event, Observer, Rng, RunInfo, SeedTree, Start, State, StepGate,
    StepTrace, Stream, Telemetry,
};
use mmq_learn::{Decision, Diagnostics, Experience, Learner, Truth};

use crate::config::RunConfig;
use crate::error::LabError;
use crate::trajectory::{CHECK_EVERY, Control, CurveRow, DIAGNOSTICS_EVERY, DiagnosticsSample, Trajectory};

/// A learning trajectory under way: the environment behind its delay channel, the
/// exploration stream, the metrics so far and the observer's bookkeeping.
pub struct Stepper<'a, E: Env + Telemetry> {
    ch: DelayedReward<E>,
    observer: Option<&'a mut Box<dyn Observer + Send>>,
    ctl: Control<'a>,
    seed: u64,
    steps: u64,
    window: u64,
    needs_truth: bool,
    rng: Rng,
    /// The state the next step starts in.
    s: State,
    /// The next step.
    t: u64,
    /// Whether the trajectory has ended (all steps run, or stopped).
    ended: bool,
    traj: Trajectory,
    trace: StepTrace,
    truth: Truth,
    gate: Option<StepGate>,
    /// Whether the next step is observed (read at the end of the step before, so that a
    /// run without an observer pays nothing for it).
    open: bool,
    table_every: u64,
    /// Steps left until the next tables (a countdown, not a division per step).
    tables_left: u64,
    w_earned: f64,
    w_received: f64,
    /// Steps left in the current curve window (a countdown, not a division per step).
    window_left: u64,
    /// The next progress check and the next sample of the learner's diagnostics (both at
    /// the start of a step), and the earlier of the two: one comparison per step.
    next_check: u64,
    next_sample: u64,
    next_event: u64,
    pending_progress: u64,
}

impl<E: Env + Telemetry> std::fmt::Debug for Stepper<'_, E> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Stepper")
            .field("seed", &self.seed)
            .field("t", &self.t)
            .field("ended", &self.ended)
            .finish()
    }
}

impl<'a, E: Env + Telemetry> Stepper<'a, E> {
    /// Starts the trajectory of `cfg`'s steps on `env` under `dist`, with the streams of
    /// `seeds`; an observer gets the run's start (`info`: the configuration as TOML and
    /// the run's facts; `learner_name` names the learner).
    #[allow(clippy::too_many_arguments)]
    pub fn start(
        env: E,
        learner: &dyn Learner,
        dist: &DelayDist,
        cfg: &RunConfig,
        seeds: SeedTree,
        mut observer: Option<&'a mut Box<dyn Observer + Send>>,
        ctl: Control<'a>,
        info: Option<(&str, &[(String, String)])>,
        learner_name: &str,
    ) -> Result<Self, LabError> {
        let needs_truth = learner.needs_truth();
        let ledger = cfg.ledger || needs_truth || observer.is_some();
        let mut ch = DelayedReward::new(env, dist, ledger);
        // Nothing here reads the ledger after a step's record (the oracle: the step's
        // deliveries), so only an observer asking for it gets the run's whole history.
        ch.trim_ledger(!observer.as_ref().is_some_and(|o| o.ledger_history()));
        let seed = seeds.master();
        let s = ch
            .reset(seeds.seed(Stream::Env), seeds.seed(Stream::Delay), Start::World)
            .map_err(|source| LabError::Env { seed, source })?;
        let rng = seeds.rng(Stream::Explore);
        let n_states = ch.env().num_states();
        let traj = Trajectory { visits: vec![0; n_states], ..Trajectory::default() };
        if let Some(o) = observer.as_mut() {
            ch.env_mut().set_trace(o.trace_period_s());
            let names = ch.env().action_names();
            let (config_toml, facts) = info.unwrap_or(("", &[]));
            let world = ch.env().world().clone();
            let run_info = RunInfo {
                world: &world,
                seed,
                learner: learner_name,
                action_names: &names,
                config_toml,
                env_kind: cfg.env.name(),
                facts,
                start_pose: (cfg.env != crate::config::EnvKind::Grid).then(|| ch.env().pose()),
            };
            o.on_start(&run_info, s, ch.env().sim_time_s());
        }
        // An observer that sometimes wants no steps (a live view nobody watches): while its
        // gate is closed, no record is built and no call made.
        let gate = observer.as_ref().and_then(|o| o.step_gate());
        let open = gate.as_ref().is_none_or(StepGate::is_open);
        let table_every = (cfg.steps / 10).max(1);
        let (next_check, next_sample) = (CHECK_EVERY, DIAGNOSTICS_EVERY);
        Ok(Stepper {
            ch,
            observer,
            ctl,
            seed,
            steps: cfg.steps,
            window: cfg.window,
            needs_truth,
            rng,
            s,
            t: 0,
            ended: false,
            traj,
            trace: StepTrace::default(),
            truth: Truth::default(),
            gate,
            open,
            table_every,
            tables_left: table_every,
            w_earned: 0.0,
            w_received: 0.0,
            window_left: cfg.window,
            next_check,
            next_sample,
            next_event: next_check.min(next_sample),
            pending_progress: 0,
        })
    }

    /// The state of the next step, or None when the trajectory has ended: all its steps
    /// ran, the stop flag is set, the learner failed or the observer lost output. Before
    /// it, what is due at the start of a step: a sample of the learner's diagnostics, a
    /// progress report. Call [`Stepper::advance`] with the learner's decision next.
    #[inline]
    pub fn begin(&mut self, learner: &dyn Learner) -> Option<State> {
        if self.ended {
            return None;
        }
        let t = self.t;
        if t == self.steps {
            self.ended = true;
            return None;
        }
        if t == self.next_event {
            if t == self.next_sample {
                // The learner has learned from `t` steps.
                sample_diagnostics(&mut self.traj, learner, t);
                self.next_sample += DIAGNOSTICS_EVERY;
            }
            let check = t == self.next_check;
            if check {
                self.next_check += CHECK_EVERY;
            }
            self.next_event = self.next_sample.min(self.next_check);
            if check {
                // Progress in chunks.
                (self.ctl.progress)(self.pending_progress);
                self.pending_progress = 0;
                // An observer that lost output (a failed write) ends the seed: its results
                // could never be reported complete.
                if self.observer.as_ref().is_some_and(|o| o.error().is_some()) {
                    self.ended = true;
                    return None;
                }
            }
        }
        // The stop flag every step (one relaxed load: a robot primitive can take long),
        // and whether the learner gave up (an outside agent that raised).
        if self.ctl.stop.load(Ordering::Relaxed) || learner.failure().is_some() {
            self.ended = true;
            return None;
        }
        Some(self.s)
    }

    /// The exploration stream (the learner's `act` draws from it).
    #[inline]
    pub fn rng(&mut self) -> &mut Rng {
        &mut self.rng
    }

    /// Runs the step [`Stepper::begin`] opened with the learner's decision `d`: the
    /// environment's step through the delay channel, the learner's observation, the
    /// metrics and the observer's records.
    #[inline]
    pub fn advance(&mut self, d: Decision, learner: &mut dyn Learner) -> Result<(), LabError> {
        let (t, s) = (self.t, self.s);
        let seed = self.seed;
        let true_state = if self.needs_truth { self.ch.env().true_state() } else { None };
        let st = self.ch.step(d.action).map_err(|source| LabError::Env { seed, source })?;
        let truth = &mut self.truth;
        if self.needs_truth {
            truth.emitted_now = st.delay.map(|_| st.step.reward);
            truth.delivered.clear();
            truth.delivered.extend(self.ch.delivered_emissions());
            (truth.true_state, truth.true_next_state) = (true_state, self.ch.env().true_state());
        }
        learner.observe(&Experience {
            t,
            state: s,
            action: d.action,
            next_state: st.step.state,
            reward: st.delivered,
            time_s: st.time_s,
            truth: self.needs_truth.then_some(&*truth),
        });
        let traj = &mut self.traj;
        traj.visits[s] += 1;
        traj.events[event_index(st.step.event)] += 1;
        traj.earned_total += st.step.reward;
        traj.received_total += st.delivered;
        self.w_earned += st.step.reward;
        self.w_received += st.delivered;
        traj.steps_done = t + 1;
        self.pending_progress += 1;
        if let Some(o) = self.observer.as_mut() {
            if self.open {
                self.ch.env_mut().take_trace(&mut self.trace);
                o.on_step(&self.ch.record(s, d.action, d.model, d.explored, &st, &self.trace));
            }
            self.tables_left -= 1;
            if self.tables_left == 0 {
                self.tables_left = self.table_every;
                let (visits, values) = cell_tables(self.ch.env(), &*learner, &traj.visits);
                o.on_tables(t + 1, self.ch.env().sim_time_s(), &visits, &values);
            }
            if let Some(g) = &self.gate {
                let was_open = self.open;
                self.open = g.is_open();
                if self.open && !was_open {
                    // Where the run stands before the next step.
                    o.on_resume(&self.ch.resume_point());
                }
            }
        }
        self.window_left -= 1;
        if self.window_left == 0 {
            self.window_left = self.window;
            traj.curve.push(CurveRow {
                step: t + 1,
                earned: self.w_earned,
                received: self.w_received,
                earned_cum: traj.earned_total,
                received_cum: traj.received_total,
            });
            self.w_earned = 0.0;
            self.w_received = 0.0;
        }
        self.s = st.step.state;
        self.t = t + 1;
        Ok(())
    }

    /// Ends the trajectory (wherever it stands): the last diagnostics sample, the last
    /// progress, the delays, the last part of the curve; gives it back with the
    /// environment.
    pub fn finish(mut self, learner: &dyn Learner) -> (Trajectory, E) {
        let traj = &mut self.traj;
        if traj.steps_done == self.next_sample {
            sample_diagnostics(traj, learner, self.next_sample);
        }
        (self.ctl.progress)(self.pending_progress);
        traj.delays = self.ch.delay_stats();
        traj.sim_time_s = self.ch.env().sim_time_s();
        if !traj.steps_done.is_multiple_of(self.window) {
            traj.curve.push(CurveRow {
                step: traj.steps_done,
                earned: self.w_earned,
                received: self.w_received,
                earned_cum: traj.earned_total,
                received_cum: traj.received_total,
            });
        }
        (self.traj, self.ch.into_inner())
    }
}

/// A greedy evaluation under way: `steps` steps of the greedy policy from `S`, no
/// exploration and no updates (see [`crate::runner::evaluate`]).
#[derive(Debug)]
pub struct Evaluation {
    seed: u64,
    rng: Rng,
    s: State,
    left: u64,
    steps: u64,
    total: f64,
    path: Vec<usize>,
}

impl Evaluation {
    /// Resets `env` to `S` with the evaluation's stream of `seeds` for `steps` steps.
    pub fn start<E: Env + Telemetry>(
        env: &mut E,
        steps: u64,
        seeds: SeedTree,
        seed: u64,
    ) -> Result<Evaluation, LabError> {
        let mut ev = Evaluation {
            seed,
            rng: seeds.rng(Stream::Eval),
            s: 0,
            left: steps,
            steps,
            total: 0.0,
            path: Vec::new(),
        };
        if steps > 0 {
            env.set_trace(None);
            ev.s = env
                .reset(seeds.seed(Stream::Eval), Start::Respawn)
                .map_err(|source| LabError::Env { seed, source })?;
            ev.path.push(ev.s);
        }
        Ok(ev)
    }

    /// The state of the next step, or None when every step ran.
    #[inline]
    pub fn begin(&self) -> Option<State> {
        (self.left > 0).then_some(self.s)
    }

    /// The evaluation's stream (the learner's `greedy` draws from it).
    #[inline]
    pub fn rng(&mut self) -> &mut Rng {
        &mut self.rng
    }

    /// Takes the greedy action `a` in `env`.
    #[inline]
    pub fn advance<E: Env>(&mut self, env: &mut E, a: mmq_core::Action) -> Result<(), LabError> {
        let seed = self.seed;
        let st = env.step(a).map_err(|source| LabError::Env { seed, source })?;
        self.total += st.reward;
        self.s = st.state;
        if self.path.len() < 200 {
            self.path.push(self.s);
        }
        self.left -= 1;
        Ok(())
    }

    /// The average emitted reward per step (NaN for no steps) and the first states
    /// visited.
    pub fn finish(self) -> (f64, Vec<usize>) {
        if self.steps == 0 {
            return (f64::NAN, Vec::new());
        }
        (self.total / self.steps as f64, self.path)
    }
}

/// Appends the learner's diagnostics after `step` steps to the trajectory (unless it
/// reports none).
fn sample_diagnostics(traj: &mut Trajectory, learner: &dyn Learner, step: u64) {
    let diagnostics = learner.diagnostics();
    if diagnostics != Diagnostics::default() {
        traj.diagnostics.push(DiagnosticsSample { step, diagnostics });
    }
}

pub(crate) fn event_index(e: Event) -> usize {
    match e {
        Event::Moved => 0,
        Event::WallBump => 1,
        Event::Teleport => 2,
        Event::TimedOut => 3,
    }
}

/// Per-cell visit counts and greedy values for maps and logs.
fn cell_tables<E: Env>(env: &E, learner: &dyn Learner, visits: &[u64]) -> (Vec<f64>, Vec<f64>) {
    let cells = env.world().num_cells();
    let mut v = vec![0.0; cells];
    let mut val = vec![f64::NAN; cells];
    let mut buf = vec![0.0; env.num_actions()];
    for (s, &n) in visits.iter().enumerate() {
        let c = env.state_cell(s);
        v[c] += n as f64;
        if env.world().is_free(c) {
            learner.action_values(s, &mut buf);
            let m = buf.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            val[c] = if val[c].is_nan() { m } else { val[c].max(m) };
        }
    }
    (v, val)
}
