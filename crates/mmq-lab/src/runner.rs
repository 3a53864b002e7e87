//! The runner: one seed of learning (environment → delay channel → learner), its
//! metrics, the greedy evaluation and the undelayed baseline; and many seeds in
//! parallel, in seed order, so results never depend on the thread count.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use mmq_core::{
    DelayDist, DelayedReward, Env, Event, Move, Observer, Optimum, RunInfo, SeedTree, Start, StepGate,
    StepTrace, Stream, Telemetry, World,
};
use mmq_grid::GridEnv;
use mmq_learn::policy::probabilistic;
use mmq_learn::{Diagnostics, Experience, Learner, LearnerSpec, Table, Truth};
use mmq_robot::{RobotConfig, RobotEnv};
use serde::{Deserialize, Serialize};

use crate::config::{EnvKind, RunConfig};
use crate::error::LabError;
use crate::exec::{Job, run_jobs_in_order};

/// How a run is steered from outside: a stop flag (Ctrl-C) and a progress callback.
#[derive(Clone, Copy)]
pub struct Control<'a> {
    /// Set to stop every seed at its next check (every 1024 steps).
    pub stop: &'a AtomicBool,
    /// Called with the number of decision steps just completed (in chunks).
    pub progress: &'a (dyn Fn(u64) + Sync),
}

impl std::fmt::Debug for Control<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Control").field("stop", &self.stop.load(Ordering::Relaxed)).finish()
    }
}

/// Builds a per-seed observer (an MCAP recorder, say), or none.
pub type ObserverFactory<'a> = dyn Fn(u64) -> Result<Option<Box<dyn Observer + Send>>, LabError> + Sync + 'a;

/// Builds the learner of one seed in place of the configuration's: called with the
/// numbers of states and actions of the environment and the master seed. This is how a
/// learner that is not built from a name (one of another crate, an agent in Python) runs
/// a job; its [`Learner::failure`] ends the seed as failed.
pub type LearnerFactory<'a> = dyn Fn(usize, usize, u64) -> Result<Box<dyn Learner>, LabError> + Sync + 'a;

/// Progress is reported every this many steps.
const CHECK_EVERY: u64 = 1024;

/// Steps between two samples of the learner's diagnostics during learning.
pub const DIAGNOSTICS_EVERY: u64 = 10_000;

/// The learner's diagnostics after `step` steps of learning (sampled right after the
/// learner observed its `step`-th step).
#[derive(Clone, Debug, PartialEq)]
pub struct DiagnosticsSample {
    /// Steps learned from.
    pub step: u64,
    /// What the learner reported then.
    pub diagnostics: Diagnostics,
}

/// One row of a learning curve: totals over the window ending at `step`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CurveRow {
    /// Steps completed at the end of the window.
    pub step: u64,
    /// Reward emitted in the window.
    pub earned: f64,
    /// Reward delivered in the window.
    pub received: f64,
    /// Reward emitted since the start.
    pub earned_cum: f64,
    /// Reward delivered since the start.
    pub received_cum: f64,
}

/// What one learning trajectory produced.
#[derive(Clone, Debug, Default)]
pub struct Trajectory {
    /// Steps completed (less than asked when interrupted).
    pub steps_done: u64,
    /// Total reward emitted.
    pub earned_total: f64,
    /// Total reward delivered.
    pub received_total: f64,
    /// Counts of step outcomes: moved, wall, goal, timeout.
    pub events: [u64; 4],
    /// The learning curve.
    pub curve: Vec<CurveRow>,
    /// Visits of every state during learning.
    pub visits: Vec<u64>,
    /// The delays of the rewards delivered (steps and seconds).
    pub delays: mmq_core::channel::DelayStats,
    /// Simulated time at the end of the last step, seconds.
    pub sim_time_s: f64,
    /// The learner's diagnostics every [`DIAGNOSTICS_EVERY`] steps (none for a learner
    /// that reports none).
    pub diagnostics: Vec<DiagnosticsSample>,
}

/// The result of one seed.
#[derive(Clone, Debug)]
pub struct SeedResult {
    /// Master seed.
    pub seed: u64,
    /// Whether all steps ran (false after Ctrl-C).
    pub complete: bool,
    /// The learner's trajectory under delay.
    pub run: Trajectory,
    /// Average reward per step of the greedy policy from `S` (no exploration, no updates).
    pub greedy_per_step: f64,
    /// The first states of the greedy evaluation, from `S`.
    pub greedy_path: Vec<usize>,
    /// Greedy actions of every state as a bit set (all maximisers), 0 for blocked cells.
    pub policy_arrows: Vec<u8>,
    /// The probabilistic policy (normalised eq. 8) of every state.
    pub policy_probs: Vec<Vec<f64>>,
    /// max_a of the acting values per state (for value maps).
    pub values: Vec<f64>,
    /// The learner's diagnostics at the end of learning (its time series is in
    /// [`Trajectory::diagnostics`] of `run`).
    pub diagnostics: Diagnostics,
    /// Environment figures (robot physics).
    pub env_stats: Vec<(String, f64)>,
    /// The learner's tables (when asked for).
    pub tables: Vec<Table>,
    /// Undelayed Q-learning on the same world, seed and horizon (when asked for).
    pub baseline: Option<Trajectory>,
    /// Baseline greedy evaluation.
    pub baseline_greedy_per_step: Option<f64>,
    /// Wall-clock seconds of this seed.
    pub wall_time_s: f64,
    /// Wall-clock seconds of the learning run alone (no evaluation, no baseline).
    pub learn_time_s: f64,
    /// Why the seed failed: its learner gave up ([`Learner::failure`]: an agent from
    /// outside mmq raised, say), or some of its output was lost (its recording could not
    /// be written); such a seed is never complete.
    pub failure: Option<String>,
}

impl SeedResult {
    /// Relative performance (eq. 3 without its stray 1/t): cumulative earned reward under
    /// delay ÷ that of the undelayed baseline. Absent without a baseline, and where the
    /// baseline's cumulative earned reward is ≤ 0: a ratio to it has no meaning then.
    pub fn relative(&self) -> Option<f64> {
        let b = self.baseline.as_ref()?;
        (b.earned_total > 0.0).then(|| self.run.earned_total / b.earned_total)
    }

    /// Earned reward per step.
    pub fn earned_per_step(&self) -> f64 {
        self.run.earned_total / self.run.steps_done.max(1) as f64
    }
}

/// Per-run facts handed to observers and recorded in summaries: versions, the
/// environment, and for the robot the physics build (rapier version, determinism
/// features, dt, preset).
pub fn run_facts(cfg: &RunConfig, world: &World) -> Vec<(String, String)> {
    let mut f = vec![
        ("mmq_version".to_string(), env!("CARGO_PKG_VERSION").to_string()),
        ("env".to_string(), cfg.env.name().to_string()),
    ];
    match cfg.env {
        EnvKind::Grid => f.push(("grid_step_period_s".to_string(), world.step_period_s.to_string())),
        EnvKind::Robot => match robot_env(world) {
            Ok(env) => {
                f.extend(env.features());
                f.push(("robot.radius_m".into(), env.config().radius_m.to_string()));
            }
            Err(e) => f.push(("robot_error".into(), e.to_string())),
        },
    }
    f
}

/// The robot environment of `world` (its `[robot]` table resolved and validated).
pub fn robot_env(world: &World) -> Result<RobotEnv, LabError> {
    RobotEnv::new(world, robot_config(world)?).map_err(|e| env_build(world, e))
}

/// Loads the world file at `path` and checks it as a run would: a `[robot]` table too,
/// against the world's cell size (a robot run would refuse it at its start).
pub fn check_world(path: &std::path::Path) -> Result<World, LabError> {
    let world = World::load(path)?;
    if world.robot.is_some() {
        robot_env(&world)?;
    }
    Ok(world)
}

/// The robot's configuration from `world`'s `[robot]` table; errors name the world file.
fn robot_config(world: &World) -> Result<RobotConfig, LabError> {
    RobotConfig::from_world(world).map_err(|e| env_build(world, e))
}

/// An environment that cannot be built from `world`, naming its file.
fn env_build(world: &World, e: impl std::fmt::Display) -> LabError {
    let file = world.path.as_ref().map_or_else(|| world.name.clone(), |p| p.display().to_string());
    LabError::EnvBuild(format!("{file}: {e}"))
}

/// The learner's table shape, (states, actions), in `cfg`'s environment on `world`,
/// without building the environment.
pub fn table_shape(cfg: &RunConfig, world: &World) -> Result<(usize, usize), LabError> {
    match cfg.env {
        EnvKind::Grid => Ok((world.num_cells(), Move::ALL.len())),
        EnvKind::Robot => Ok(robot_config(world)?.actions.table_shape(world.num_cells())),
    }
}

/// Refuses, before anything is allocated, a learner whose tables for one seed (the
/// learner's and its baseline's) need more than `limit` bytes; returns what they need.
pub fn check_tables_fit(cfg: &RunConfig, world: &World, limit: u128) -> Result<u128, LabError> {
    let (n_s, n_a) = table_shape(cfg, world)?;
    let (entries, bytes) = cfg.learner.table_bytes(n_s, n_a);
    if bytes > limit {
        return Err(mmq_learn::LearnError::TooLarge {
            learner: cfg.learner.kind().name(),
            entries,
            need_gib: bytes as f64 / (1u128 << 30) as f64,
            limit_gib: limit as f64 / (1u128 << 30) as f64,
        }
        .into());
    }
    Ok(bytes)
}

/// Runs one seed: learning under delay, greedy evaluation, then the baseline (when the
/// configuration asks for one).
pub fn run_seed(
    cfg: &RunConfig,
    world: &World,
    dist: &DelayDist,
    seed: u64,
    observer: Option<Box<dyn Observer + Send>>,
    ctl: Control<'_>,
    mem_limit: u128,
) -> Result<SeedResult, LabError> {
    run_seed_as(cfg, world, dist, seed, observer, ctl, mem_limit, cfg.baseline, None)
}

/// [`run_seed`] that runs the baseline only if `own_baseline` (the executor shares
/// baselines between jobs and attaches them itself), with the learner of `learner` when
/// given; the configuration is recorded as given either way.
pub(crate) fn run_seed_as(
    cfg: &RunConfig,
    world: &World,
    dist: &DelayDist,
    seed: u64,
    observer: Option<Box<dyn Observer + Send>>,
    ctl: Control<'_>,
    mem_limit: u128,
    own_baseline: bool,
    learner: Option<&LearnerFactory<'_>>,
) -> Result<SeedResult, LabError> {
    match cfg.env {
        EnvKind::Grid => {
            run_seed_on(cfg, world, dist, seed, observer, ctl, mem_limit, own_baseline, learner, || {
                Ok(GridEnv::new(world))
            })
        }
        EnvKind::Robot => {
            run_seed_on(cfg, world, dist, seed, observer, ctl, mem_limit, own_baseline, learner, || {
                robot_env(world)
            })
        }
    }
}

/// `run_seed_as` on environments made by `make`; the learner is `learner`'s when given,
/// else the configuration's.
pub fn run_seed_on<E: Env + Telemetry>(
    cfg: &RunConfig,
    world: &World,
    dist: &DelayDist,
    seed: u64,
    mut observer: Option<Box<dyn Observer + Send>>,
    ctl: Control<'_>,
    mem_limit: u128,
    own_baseline: bool,
    learner: Option<&LearnerFactory<'_>>,
    make: impl Fn() -> Result<E, LabError>,
) -> Result<SeedResult, LabError> {
    let clock = Instant::now();
    // This seed holds one of the worker threads; its learner may borrow another for work
    // that changes no result while one is free (`mmq_learn::spare`).
    mmq_learn::spare::set_threads(rayon::current_num_threads());
    let _job = mmq_learn::spare::Job::start();
    let env = make()?;
    let mut learner = match learner {
        Some(f) => f(env.num_states(), env.num_actions(), seed)?,
        None => cfg.learner.build(env.num_states(), env.num_actions(), mem_limit)?,
    };
    let seeds = SeedTree::new(seed);
    let config_toml = cfg.to_toml();
    let facts = run_facts(cfg, world);
    let learn_clock = Instant::now();
    let (run, env) = learn(
        env,
        &mut *learner,
        dist,
        cfg,
        seeds,
        observer.as_mut(),
        ctl,
        Some((&config_toml, &facts)),
        cfg.learner.kind().name(),
    )?;
    let learn_s = learn_clock.elapsed().as_secs_f64();
    let complete = run.steps_done == cfg.steps;
    let mut env = env;
    // Physics figures of the learning run (before evaluation resets the environment).
    let env_stats = env.stats();
    // A stopped run is not evaluated: the evaluation's steps would delay the stop (a
    // robot's thousand primitives take seconds), and a partial policy's score means little.
    let eval_steps = if complete { cfg.eval_steps } else { 0 };
    let (greedy_per_step, greedy_path) = evaluate(&mut env, &*learner, eval_steps, seeds, seed)?;
    // The policy maps visit every state (a second on the largest worlds): a stop cuts them
    // short, and the seed is then incomplete.
    let stopped = || ctl.stop.load(Ordering::Relaxed);
    let (policy_arrows, policy_probs, values, whole) = policy_of(&env, &*learner, &stopped);
    let complete = complete && whole;
    let mut failure = learner.failure();
    if let Some(o) = observer.as_mut() {
        o.on_finish(run.steps_done, complete);
        failure = failure.or_else(|| o.error());
    }
    let complete = complete && failure.is_none();
    let (mut baseline, mut baseline_greedy) = (None, None);
    if own_baseline && complete {
        let spec = cfg.baseline_learner();
        let env = make()?;
        let mut base = spec.build(env.num_states(), env.num_actions(), mem_limit)?;
        let (traj, mut env) = learn(env, &mut *base, &DelayDist::None, cfg, seeds, None, ctl, None, "q")?;
        if traj.steps_done == cfg.steps {
            baseline_greedy = Some(evaluate(&mut env, &*base, cfg.eval_steps, seeds, seed)?.0);
            baseline = Some(traj);
        }
    }
    let complete = complete && (!own_baseline || baseline.is_some());
    Ok(SeedResult {
        seed,
        complete,
        run,
        greedy_per_step,
        greedy_path,
        policy_arrows,
        policy_probs,
        values,
        diagnostics: learner.diagnostics(),
        env_stats,
        tables: if cfg.save_tables { learner.tables() } else { Vec::new() },
        baseline,
        baseline_greedy_per_step: baseline_greedy,
        wall_time_s: clock.elapsed().as_secs_f64(),
        learn_time_s: learn_s,
        failure,
    })
}

/// The learning loop of one trajectory.
#[allow(clippy::too_many_arguments)]
fn learn<E: Env + Telemetry>(
    env: E,
    learner: &mut dyn Learner,
    dist: &DelayDist,
    cfg: &RunConfig,
    seeds: SeedTree,
    mut observer: Option<&mut Box<dyn Observer + Send>>,
    ctl: Control<'_>,
    info: Option<(&str, &[(String, String)])>,
    learner_name: &str,
) -> Result<(Trajectory, E), LabError> {
    let needs_truth = learner.needs_truth();
    let ledger = cfg.ledger || needs_truth || observer.is_some();
    let mut ch = DelayedReward::new(env, dist, ledger);
    // Nothing here reads the ledger after a step's record (the oracle: the step's
    // deliveries), so only an observer asking for it gets the run's whole history.
    ch.trim_ledger(!observer.as_ref().is_some_and(|o| o.ledger_history()));
    let seed = seeds.master();
    let env_err = |source| LabError::Env { seed, source };
    let mut s =
        ch.reset(seeds.seed(Stream::Env), seeds.seed(Stream::Delay), Start::World).map_err(env_err)?;
    let mut rng = seeds.rng(Stream::Explore);
    let n_states = ch.env().num_states();
    let mut traj = Trajectory { visits: vec![0; n_states], ..Trajectory::default() };
    let mut trace = StepTrace::default();
    let mut truth = Truth::default();
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
    // Whether the next step is observed (read at the end of the step before, so that a
    // run without an observer pays nothing for it).
    let mut open = gate.as_ref().is_none_or(StepGate::is_open);
    let table_every = (cfg.steps / 10).max(1);
    // Steps left until the next tables (a countdown, not a division per step).
    let mut tables_left = table_every;
    let (mut w_earned, mut w_received) = (0.0, 0.0);
    // Steps left in the current curve window (a countdown, not a division per step).
    let mut window_left = cfg.window;
    // The next progress check and the next sample of the learner's diagnostics (both at
    // the start of a step), and the earlier of the two: one comparison per step.
    let (mut next_check, mut next_sample) = (CHECK_EVERY, DIAGNOSTICS_EVERY);
    let mut next_event = next_check.min(next_sample);
    let mut pending_progress = 0u64;
    for t in 0..cfg.steps {
        if t == next_event {
            if t == next_sample {
                // The learner has learned from `t` steps.
                sample_diagnostics(&mut traj, &*learner, t);
                next_sample += DIAGNOSTICS_EVERY;
            }
            let check = t == next_check;
            if check {
                next_check += CHECK_EVERY;
            }
            next_event = next_sample.min(next_check);
            if check {
                // Progress in chunks.
                (ctl.progress)(pending_progress);
                pending_progress = 0;
                // An observer that lost output (a failed write) ends the seed: its results
                // could never be reported complete.
                if observer.as_ref().is_some_and(|o| o.error().is_some()) {
                    break;
                }
            }
        }
        // The stop flag every step (one relaxed load: a robot primitive can take long),
        // and whether the learner gave up (an outside agent that raised).
        if ctl.stop.load(Ordering::Relaxed) || learner.failure().is_some() {
            break;
        }
        let d = learner.act(s, &mut rng);
        let st = ch.step(d.action).map_err(env_err)?;
        if needs_truth {
            truth.emitted_now = st.delay.map(|_| st.step.reward);
            truth.delivered.clear();
            truth.delivered.extend(ch.delivered_emissions());
        }
        learner.observe(&Experience {
            t,
            state: s,
            action: d.action,
            next_state: st.step.state,
            reward: st.delivered,
            time_s: st.time_s,
            truth: needs_truth.then_some(&truth),
        });
        traj.visits[s] += 1;
        traj.events[event_index(st.step.event)] += 1;
        traj.earned_total += st.step.reward;
        traj.received_total += st.delivered;
        w_earned += st.step.reward;
        w_received += st.delivered;
        traj.steps_done = t + 1;
        pending_progress += 1;
        if let Some(o) = observer.as_mut() {
            if open {
                ch.env_mut().take_trace(&mut trace);
                o.on_step(&ch.record(s, d.action, d.model, d.explored, &st, &trace));
            }
            tables_left -= 1;
            if tables_left == 0 {
                tables_left = table_every;
                let (visits, values) = cell_tables(ch.env(), &*learner, &traj.visits);
                o.on_tables(t + 1, ch.env().sim_time_s(), &visits, &values);
            }
            if let Some(g) = &gate {
                let was_open = open;
                open = g.is_open();
                if open && !was_open {
                    // Where the run stands before the next step.
                    o.on_resume(&ch.resume_point());
                }
            }
        }
        window_left -= 1;
        if window_left == 0 {
            window_left = cfg.window;
            traj.curve.push(CurveRow {
                step: t + 1,
                earned: w_earned,
                received: w_received,
                earned_cum: traj.earned_total,
                received_cum: traj.received_total,
            });
            w_earned = 0.0;
            w_received = 0.0;
        }
        s = st.step.state;
    }
    if traj.steps_done == next_sample {
        sample_diagnostics(&mut traj, &*learner, next_sample);
    }
    (ctl.progress)(pending_progress);
    traj.delays = ch.delay_stats();
    traj.sim_time_s = ch.env().sim_time_s();
    if !traj.steps_done.is_multiple_of(cfg.window) {
        traj.curve.push(CurveRow {
            step: traj.steps_done,
            earned: w_earned,
            received: w_received,
            earned_cum: traj.earned_total,
            received_cum: traj.received_total,
        });
    }
    Ok((traj, ch.into_inner()))
}

/// Appends the learner's diagnostics after `step` steps to the trajectory (unless it
/// reports none).
fn sample_diagnostics(traj: &mut Trajectory, learner: &dyn Learner, step: u64) {
    let diagnostics = learner.diagnostics();
    if diagnostics != Diagnostics::default() {
        traj.diagnostics.push(DiagnosticsSample { step, diagnostics });
    }
}

fn event_index(e: Event) -> usize {
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

/// Greedy evaluation: `steps` steps of the greedy policy from `S`, no exploration and no
/// updates; returns the average emitted reward per step and the first states visited.
pub fn evaluate<E: Env + Telemetry>(
    env: &mut E,
    learner: &dyn Learner,
    steps: u64,
    seeds: SeedTree,
    seed: u64,
) -> Result<(f64, Vec<usize>), LabError> {
    if steps == 0 {
        return Ok((f64::NAN, Vec::new()));
    }
    let env_err = |source| LabError::Env { seed, source };
    env.set_trace(None);
    let mut s = env.reset(seeds.seed(Stream::Eval), Start::Respawn).map_err(env_err)?;
    let mut rng = seeds.rng(Stream::Eval);
    let mut total = 0.0;
    let mut path = vec![s];
    for _ in 0..steps {
        let a = learner.greedy(s, &mut rng);
        let st = env.step(a).map_err(env_err)?;
        total += st.reward;
        s = st.state;
        if path.len() < 200 {
            path.push(s);
        }
    }
    Ok((total / steps as f64, path))
}

/// Deterministic (bit set of maximisers) and probabilistic policies per state, and
/// whether every state was visited (`stop()` is asked every 1,024 states; states after a
/// stop keep no arrow and a NaN value).
type Policy = (Vec<u8>, Vec<Vec<f64>>, Vec<f64>, bool);
fn policy_of<E: Env>(env: &E, learner: &dyn Learner, stop: &dyn Fn() -> bool) -> Policy {
    let n = env.num_states();
    let na = env.num_actions();
    let mut arrows = vec![0u8; n];
    let mut probs = vec![vec![0.0; na]; n];
    let mut values = vec![f64::NAN; n];
    let mut buf = vec![0.0; na];
    for s in 0..n {
        if s % 1024 == 0 && stop() {
            return (arrows, probs, values, false);
        }
        if !env.world().is_free(env.state_cell(s)) {
            continue;
        }
        learner.action_values(s, &mut buf);
        let m = buf.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        values[s] = m;
        for (a, &q) in buf.iter().enumerate().take(8) {
            if q == m {
                arrows[s] |= 1 << a;
            }
        }
        probs[s] = probabilistic(&buf);
    }
    (arrows, probs, values, true)
}

/// Memory available for tables: MemAvailable from /proc/meminfo (or 8 GiB), shared by
/// `parallel` seeds running at once.
pub fn memory_limit(parallel: usize) -> u128 {
    let avail = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|m| {
            m.lines()
                .find(|l| l.starts_with("MemAvailable:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<u128>().ok())
        })
        .map_or(8u128 << 30, |kb| kb * 1024);
    // Half of what is free, divided among the seeds that run at once (each holds the
    // learner's and the baseline's tables).
    avail / 2 / parallel.max(1) as u128
}

/// The result of many seeds.
#[derive(Debug)]
pub struct RunOutcome {
    /// Results in seed order (only seeds that started).
    pub results: Vec<SeedResult>,
    /// Whether the run was stopped early (or a seed lost output).
    pub interrupted: bool,
}

impl RunOutcome {
    /// Why seeds lost output, one message per seed that did (see [`SeedResult::failure`]).
    pub fn failures(&self) -> Vec<&str> {
        self.results.iter().filter_map(|r| r.failure.as_deref()).collect()
    }
}

/// Runs every seed of `cfg` in parallel (rayon), results in seed order.
pub fn run_all(
    cfg: &RunConfig,
    world: &World,
    observers: &ObserverFactory<'_>,
    ctl: Control<'_>,
) -> Result<RunOutcome, LabError> {
    run_checked(cfg, world, &check_run(cfg, world)?, observers, ctl)
}

/// [`run_all`] of a configuration [`check_run`] passed, with the delay it parsed.
pub(crate) fn run_checked(
    cfg: &RunConfig,
    world: &World,
    dist: &DelayDist,
    observers: &ObserverFactory<'_>,
    ctl: Control<'_>,
) -> Result<RunOutcome, LabError> {
    let seeds = cfg.seed_list();
    let jobs: Vec<Job<'_>> =
        seeds.iter().map(|&seed| Job { cfg, world, dist, seed, learner: None }).collect();
    let out: Vec<SeedResult> =
        run_jobs_in_order(&jobs, Some(observers), ctl)?.into_iter().flatten().collect();
    let interrupted = ctl.stop.load(Ordering::Relaxed) || out.iter().any(|r| !r.complete);
    Ok(RunOutcome { results: out, interrupted })
}

/// Everything [`run_all`] refuses before it allocates or runs anything: the
/// configuration, the robot's (the arena is built once), and the memory the seeds'
/// tables need. Callers that write outputs check it before touching the output folder.
pub fn check_run(cfg: &RunConfig, world: &World) -> Result<DelayDist, LabError> {
    let dist = cfg.validate()?;
    if cfg.env == EnvKind::Robot {
        robot_env(world)?;
    }
    let seeds = cfg.seed_list();
    let parallel = rayon::current_num_threads().min(seeds.len());
    let limit = memory_limit(parallel);
    // Refuse before allocating anything.
    {
        let bytes = check_tables_fit(cfg, world, limit)?;
        // The tables of every seed are kept until the outputs are written: all of them
        // must fit too (`--seeds 1000000` of the 9×9 MMQ would ask for 130 GB).
        let kept = if cfg.save_tables { bytes * seeds.len() as u128 } else { 0 };
        let all = memory_limit(1);
        if kept > all {
            let gib = |b: u128| b as f64 / (1u128 << 30) as f64;
            return Err(LabError::param(
                "seeds",
                cfg.seeds,
                &format!(
                    "the tables of {} seeds ({:.1} GiB) are kept until written, more than the {:.1} GiB allowed; use fewer `seeds` or `save_tables = false`",
                    seeds.len(),
                    gib(kept),
                    gib(all)
                ),
            ));
        }
    }
    Ok(dist)
}

/// The exact optimum of the world (re-exported for summaries).
pub fn optimum_of(world: &World) -> Optimum {
    mmq_core::optimum(world)
}

/// A spec of the learner, for reports.
pub fn describe(spec: &LearnerSpec) -> String {
    spec.describe()
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use super::*;

    #[test]
    fn the_memory_check_counts_the_environments_true_table() {
        let world = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../worlds/paper-9x9.toml"));
        let grid = RunConfig { world, ..RunConfig::default() };
        let heading =
            RunConfig { env: EnvKind::Robot, robot: vec!["actions=heading".into()], ..grid.clone() };
        let (gw, hw) = (grid.load_world().unwrap(), heading.load_world().unwrap());
        // 81 cells: the grid's 81 × 4 pairs; the heading robot's (81 × 4 headings) × 3.
        assert_eq!(table_shape(&grid, &gw).unwrap(), (81, 4));
        assert_eq!(table_shape(&heading, &hw).unwrap(), (324, 3));
        let need = check_tables_fit(&grid, &gw, u128::MAX).unwrap();
        // Three times the pairs (and 4× the states): the 4-action count was a third.
        let h = check_tables_fit(&heading, &hw, u128::MAX).unwrap();
        assert!(h > 2 * need && h < 4 * need, "{h} against {need}");
        assert!(check_tables_fit(&grid, &gw, need).is_ok());
        let e = check_tables_fit(&heading, &hw, need).unwrap_err().to_string();
        assert!(e.contains("mmq"), "{e}");
    }

    /// The runner samples the learner's diagnostics right after it learned from step T
    /// (T a multiple of DIAGNOSTICS_EVERY): the sample at T of a longer run is the final
    /// diagnostics of the same seed's run of T steps, and not those of T − 1 steps (MMQ's
    /// mean chosen model moves with almost every step; deconv-model's delay estimate
    /// only at refits).
    #[test]
    fn diagnostics_are_sampled_right_after_their_step() {
        let world = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../worlds/paper-9x9.toml"));
        let every = DIAGNOSTICS_EVERY;
        let cfg = RunConfig {
            world,
            steps: 2 * every + 500,
            eval_steps: 0,
            baseline: false,
            save_tables: false,
            ..RunConfig::default()
        };
        let (world, dist) = (cfg.load_world().unwrap(), cfg.validate().unwrap());
        let stop = AtomicBool::new(false);
        let ctl = Control { stop: &stop, progress: &|_| {} };
        let run = |kind: mmq_learn::LearnerKind, steps: u64| {
            let learner =
                mmq_learn::LearnerSpec { params: cfg.learner.params, ..mmq_learn::LearnerSpec::new(kind) };
            let c = RunConfig { steps, learner, ..cfg.clone() };
            run_seed(&c, &world, &dist, 3, None, ctl, u128::MAX).unwrap()
        };
        for kind in [mmq_learn::LearnerKind::Mmq, mmq_learn::LearnerKind::DeconvModel] {
            let long = run(kind, cfg.steps);
            let at: Vec<u64> = long.run.diagnostics.iter().map(|s| s.step).collect();
            assert_eq!(at, vec![every, 2 * every], "{kind:?}");
            let sample = &long.run.diagnostics[0].diagnostics;
            assert_eq!(*sample, run(kind, every).diagnostics, "{kind:?}");
            assert_ne!(*sample, long.diagnostics, "{kind:?}");
            if kind == mmq_learn::LearnerKind::Mmq {
                assert_ne!(*sample, run(kind, every - 1).diagnostics);
            } else {
                let delay = sample.delay.as_ref().expect("deconv-model estimates the delay");
                let max_delay = mmq_learn::LearnerSpec::new(kind).settings.max_delay();
                assert!(delay.estimated && Some(delay.pmf.len()) == max_delay.map(|k| k + 1));
            }
        }
    }
}
