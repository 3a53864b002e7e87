//! One seed of the swarm: every robot learns, acting whenever its primitive ends; its
//! reward reaches it when the swarm's consultation completes. Then a greedy evaluation of
//! every robot at once, and the seed's result.
//!
//! Learners (`[swarm] learners`): `independent`, a learner of its own per robot; or
//! `shared` (parameter sharing), one learner whose tables every robot updates, each robot
//! with its own memory of its past steps (swapped in before the robot acts or learns:
//! [`mmq_learn::MemorySlots`]). Every learner of mmq can share
//! ([`mmq_learn::Learner::shares_tables`]); an agent from outside mmq may not.
//!
//! The seed's trajectory is the swarm's: rewards and the learning curve are the mean
//! over robots (so fractions of the optimum read as the single robot's), while counts
//! (events, visits, delivered delays) are the swarm's totals. Each robot's own figures
//! and the delays that emerged are in the environment figures under `swarm/`.
//!
//! Recorded (`record`), the learning is written to the seed's MCAP file as it goes
//! (the private module `swarm_record`): frames of every robot's pose at the recording's
//! rate and every robot's step; the greedy evaluation and the baseline are not recorded.
//!
//! Streams: robot 0 uses the seed's own streams, so one robot without consultation is
//! the single robot's run bit for bit; robot `i` uses those of
//! [`mmq_robot::swarm::robot_seed`]`(seed, i)`. The radio draws from the seed's delay
//! stream.

use std::sync::atomic::Ordering;
use std::time::Instant;

use mmq_core::channel::DelayStats;
use mmq_core::{Action, Rng, SeedTree, Start, State, Stream, World};
use mmq_learn::{Experience, Learner, MemorySlots, Truth};
use mmq_robot::swarm::{Learners, RobotDelays, SwarmConfig, SwarmEnv, SwarmStep, robot_seed};
use mmq_robot::{RobotConfig, RobotEnv};

use crate::config::RunConfig;
use crate::error::LabError;
use crate::grid_optimal::GridOptimal;
use crate::stepper::event_index;
use crate::swarm_record::Recording;
use crate::trajectory::{Control, CurveRow, LearnerFactory, SeedResult, Trajectory, policy_of};

/// The swarm of `world` (its `[robot]` and `[swarm]` tables) with `overrides` of its
/// `[swarm]` table applied.
pub fn swarm_env_with(world: &World, overrides: &[String]) -> Result<SwarmEnv, LabError> {
    let file = world.path.as_ref().map_or_else(|| world.name.clone(), |p| p.display().to_string());
    let build = |e: mmq_robot::RobotError| LabError::EnvBuild(format!("{file}: {e}"));
    let cfg = RobotConfig::from_world(world).map_err(build)?;
    let swarm = SwarmConfig::from_world(world, overrides).map_err(build)?;
    SwarmEnv::new(world, cfg, swarm).map_err(build)
}

/// The swarm of `world` as its tables say.
pub fn swarm_env(world: &World) -> Result<SwarmEnv, LabError> {
    swarm_env_with(world, &[])
}

/// The swarm's settings of `cfg` on `world`, checked (the `[swarm]` table).
pub(crate) fn check_swarm(cfg: &RunConfig, world: &World) -> Result<SwarmConfig, LabError> {
    SwarmConfig::from_world(world, &cfg.swarm).map_err(|e| LabError::EnvBuild(e.to_string()))
}

/// A learner from outside mmq that cannot share its tables between robots.
fn unshareable(name: &str) -> LabError {
    LabError::param(
        "swarm",
        "learners=shared",
        &format!(
            "{name} cannot share its tables between robots (it keeps no separate memory per \
             robot); use learners=independent, or one of mmq's learners, which all can"
        ),
    )
}

/// The robots' learners: one each, or one for all with a memory per robot.
enum Minds {
    Own(Vec<Box<dyn Learner>>),
    Shared { learner: Box<dyn Learner>, memories: MemorySlots },
}

impl Minds {
    /// The learners of `n` robots as `cfg` says (from `factory` when given), within
    /// `mem_limit` bytes together.
    fn build(
        cfg: &RunConfig,
        env: &SwarmEnv,
        seed: u64,
        mem_limit: u128,
        factory: Option<&LearnerFactory<'_>>,
    ) -> Result<Minds, LabError> {
        let (n, ns, na) = (env.robots(), env.num_states(), env.num_actions());
        let one = |i: usize, limit: u128| match factory {
            Some(f) => f(ns, na, robot_seed(seed, i)),
            None => Ok(cfg.learner.build(ns, na, limit)?),
        };
        match env.swarm().learners {
            Learners::Independent => {
                Ok(Minds::Own((0..n).map(|i| one(i, mem_limit / n as u128)).collect::<Result<_, _>>()?))
            }
            Learners::Shared => {
                let learner = one(0, mem_limit)?;
                if !learner.shares_tables() {
                    return Err(unshareable(learner.name()));
                }
                Ok(Minds::Shared { learner, memories: MemorySlots::new(n) })
            }
        }
    }

    /// Robot `i`'s learner, holding robot `i`'s memory: for acting and learning.
    fn of(&mut self, i: usize) -> &mut dyn Learner {
        match self {
            Minds::Own(v) => &mut *v[i],
            Minds::Shared { learner, memories } => {
                memories.load(i, |m| learner.swap_memory(m));
                &mut **learner
            }
        }
    }

    /// Robot `i`'s learner for what reads only its tables (greedy actions, the policy).
    fn tables_of(&self, i: usize) -> &dyn Learner {
        match self {
            Minds::Own(v) => &*v[i],
            Minds::Shared { learner, .. } => &**learner,
        }
    }

    /// Why a learner cannot go on, if one cannot.
    fn failure(&self) -> Option<String> {
        match self {
            Minds::Own(v) => v.iter().find_map(|l| l.failure()),
            Minds::Shared { learner, .. } => learner.failure(),
        }
    }
}

/// Where one robot's trajectory stands.
struct Seat {
    rng: Rng,
    s: State,
    a: Action,
    /// How the learner chose `a` (for the recording).
    model: Option<usize>,
    explored: bool,
    traj: Trajectory,
    window_left: u64,
    w_earned: f64,
    w_received: f64,
    truth: Truth,
}

/// One seed of `cfg` on the swarm of `world` (see the module's doc), its learning
/// written to `rec` when given; the baseline, if `own_baseline`, is undelayed Q-learning
/// on the same swarm without consultation.
#[allow(clippy::too_many_arguments)]
pub(crate) fn run_swarm_seed(
    cfg: &RunConfig,
    world: &World,
    seed: u64,
    ctl: Control<'_>,
    mem_limit: u128,
    own_baseline: bool,
    factory: Option<&LearnerFactory<'_>>,
    mut rec: Option<Recording>,
) -> Result<SeedResult, LabError> {
    let clock = Instant::now();
    let mut env = swarm_env_with(world, &cfg.swarm)?;
    let n = env.robots();
    let ns = env.num_states();
    let mut minds = Minds::build(cfg, &env, seed, mem_limit, factory)?;
    let mut seats = Vec::with_capacity(n);
    for i in 0..n {
        let traj = Trajectory { visits: vec![0; ns], ..Trajectory::default() };
        let rng = SeedTree::new(robot_seed(seed, i)).rng(Stream::Explore);
        seats.push(Seat {
            rng,
            s: 0,
            a: 0,
            model: None,
            explored: false,
            traj,
            window_left: cfg.window,
            w_earned: 0.0,
            w_received: 0.0,
            truth: Truth::default(),
        });
    }
    let learn_clock = Instant::now();
    if let Some(r) = &rec {
        r.trace(&mut env);
    }
    let learned = learn(&mut env, &mut seats, &mut minds, cfg, world, seed, ctl, rec.as_mut());
    let complete = learned.is_ok() && seats.iter().all(|s| s.traj.steps_done == cfg.steps);
    // The file is finished on every way out; a write that failed fails the seed.
    let rec_failure = rec.take().and_then(|r| r.finish(complete));
    learned?;
    env.set_trace(None);
    let learn_s = learn_clock.elapsed().as_secs_f64();
    let mut env_stats = swarm_stats(&env, &seats);
    let eval_steps = if complete { cfg.eval_steps } else { 0 };
    let (greedy_per_step, greedy_path) = evaluate(&mut env, &minds, eval_steps, seed)?;
    let stopped = || ctl.stop.load(Ordering::Relaxed);
    let maps_env =
        RobotEnv::new(world, env.config().clone()).map_err(|e| LabError::EnvBuild(e.to_string()))?;
    let (policy_arrows, policy_probs, values, whole) = policy_of(&maps_env, minds.tables_of(0), &stopped);
    let failure = minds.failure().or(rec_failure);
    let complete = complete && whole && failure.is_none();
    let (mut baseline, mut baseline_greedy) = (None, None);
    if own_baseline && complete {
        let base_cfg = cfg.baseline_run();
        let b = run_swarm_seed(&base_cfg, world, seed, ctl, mem_limit, false, None, None)?;
        if b.complete {
            baseline_greedy = Some(b.greedy_per_step);
            baseline = Some(b.run);
        }
    }
    let complete = complete && (!own_baseline || baseline.is_some());
    let reference =
        if cfg.reference && complete { reference_run(cfg, world, seed, ctl, mem_limit)? } else { None };
    let complete = complete && (!cfg.reference || reference.is_some());
    let diagnostics = minds.tables_of(0).diagnostics();
    let tables = if cfg.save_tables { minds.tables_of(0).tables() } else { Vec::new() };
    env_stats.push(("swarm/robots".into(), n as f64));
    Ok(SeedResult {
        seed,
        complete,
        run: swarm_trajectory(&seats, env.time_s()),
        greedy_per_step,
        greedy_path,
        policy_arrows,
        policy_probs,
        values,
        diagnostics,
        env_stats,
        tables,
        baseline,
        baseline_greedy_per_step: baseline_greedy,
        reference,
        wall_time_s: clock.elapsed().as_secs_f64(),
        learn_time_s: learn_s,
        failure,
    })
}

/// The reference: the grid-optimal agent (`grid-optimal`, ε-greedy around the world
/// MDP's optimal policy) on every robot of the same swarm, with the run's steps, ε and
/// streams; what the grid's optimal policy earns on this swarm, crowding included.
/// `None` if stopped.
fn reference_run(
    cfg: &RunConfig,
    world: &World,
    seed: u64,
    ctl: Control<'_>,
    mem_limit: u128,
) -> Result<Option<Trajectory>, LabError> {
    let optimum = mmq_core::optimum(world);
    let name = cfg.world.display().to_string();
    let epsilon = cfg.learner.params.epsilon;
    let make = |ns: usize, na: usize, _: u64| -> Result<Box<dyn Learner>, LabError> {
        Ok(Box::new(GridOptimal::new(&optimum, epsilon, ns, na, &name)?))
    };
    let ref_cfg =
        RunConfig { reference: false, baseline: false, save_tables: false, eval_steps: 0, ..cfg.clone() };
    let r = run_swarm_seed(&ref_cfg, world, seed, ctl, mem_limit, false, Some(&make), None)?;
    Ok(r.complete.then_some(r.run))
}

/// The learning of every robot until each has made `cfg.steps` decisions, the stop
/// flag is set, a learner fails or the recording `rec` cannot be written.
#[allow(clippy::too_many_arguments)]
fn learn(
    env: &mut SwarmEnv,
    seats: &mut [Seat],
    minds: &mut Minds,
    cfg: &RunConfig,
    world: &World,
    seed: u64,
    ctl: Control<'_>,
    mut rec: Option<&mut Recording>,
) -> Result<(), LabError> {
    let seeds = SeedTree::new(seed);
    let env_err = |source| LabError::Env { seed, source };
    let states = env.reset(seeds.seed(Stream::Env), seeds.seed(Stream::Delay)).map_err(env_err)?;
    if let Some(r) = rec.as_deref_mut() {
        r.start(env, cfg, world, seed)?;
    }
    for (i, seat) in seats.iter_mut().enumerate() {
        seat.s = states[i];
        start_decision(env, i, seat, minds.of(i), cfg.steps).map_err(env_err)?;
    }
    let n = seats.len() as u64;
    let (mut decisions, mut reported) = (0u64, 0u64);
    let mut out: Vec<SwarmStep> = Vec::with_capacity(seats.len());
    loop {
        if ctl.stop.load(Ordering::Relaxed) {
            break;
        }
        out.clear();
        env.advance(&mut out).map_err(env_err)?;
        if let Some(r) = rec.as_deref_mut() {
            r.frames(env);
        }
        if out.is_empty() {
            break;
        }
        for st in &out {
            let seat = &mut seats[st.robot];
            if let Some(r) = rec.as_deref_mut() {
                r.step(st, seat.s, seat.a, seat.model, seat.explored);
            }
            let learner = minds.of(st.robot);
            if learner.needs_truth() {
                // Where the primitive that ended took the robot (its start was set when
                // the primitive was chosen).
                seat.truth.true_next_state = env.true_state(st.robot);
            }
            observe(seat, learner, st, cfg.window);
            decisions += 1;
            start_decision(env, st.robot, seat, learner, cfg.steps).map_err(env_err)?;
        }
        // Progress in the single robot's units: decisions per robot.
        if decisions / n >= reported + 1024 {
            (ctl.progress)(decisions / n - reported);
            reported = decisions / n;
            // A recording that cannot be written stops the seed (it fails at its end).
            if rec.as_deref().is_some_and(|r| r.error().is_some()) {
                break;
            }
        }
    }
    (ctl.progress)((decisions / n).saturating_sub(reported));
    for seat in seats.iter_mut() {
        close_curve(seat, cfg.window);
    }
    Ok(())
}

/// Asks robot `i`'s learner for its next action (or parks the robot when its budget is
/// spent or its learner failed).
fn start_decision(
    env: &mut SwarmEnv,
    i: usize,
    seat: &mut Seat,
    learner: &mut dyn Learner,
    steps: u64,
) -> Result<(), mmq_core::EnvError> {
    if seat.traj.steps_done >= steps || learner.failure().is_some() {
        env.park(i);
        return Ok(());
    }
    if learner.needs_truth() {
        seat.truth.true_state = env.true_state(i);
    }
    let d = learner.act(seat.s, &mut seat.rng);
    seat.a = d.action;
    seat.model = d.model;
    seat.explored = d.explored;
    env.act(i, d.action)
}

/// Robot `seat`'s step `st`: the learner's observation and the trajectory's figures,
/// as the single robot's step loop keeps them.
fn observe(seat: &mut Seat, learner: &mut dyn Learner, st: &SwarmStep, window: u64) {
    let t = st.decision;
    let needs_truth = learner.needs_truth();
    if needs_truth {
        seat.truth.emitted_now = st.consultation.map(|_| st.step.reward);
        seat.truth.delivered.clear();
        seat.truth.delivered.extend(st.deliveries.iter().map(|d| (d.decision, d.value)));
    }
    learner.observe(&Experience {
        t,
        state: seat.s,
        action: seat.a,
        next_state: st.step.state,
        reward: st.delivered,
        time_s: st.time_s,
        truth: needs_truth.then_some(&seat.truth),
    });
    let traj = &mut seat.traj;
    traj.visits[seat.s] += 1;
    traj.events[event_index(st.step.event)] += 1;
    traj.earned_total += st.step.reward;
    traj.received_total += st.delivered;
    for d in &st.deliveries {
        traj.delays.delivered += 1;
        traj.delays.sum_steps += (t - d.decision) as f64;
        traj.delays.sum_s += st.time_s - d.emitted_s;
    }
    seat.w_earned += st.step.reward;
    seat.w_received += st.delivered;
    traj.steps_done = t + 1;
    traj.sim_time_s = st.time_s;
    seat.window_left -= 1;
    if seat.window_left == 0 {
        seat.window_left = window;
        push_row(seat);
    }
    seat.s = st.step.state;
}

fn push_row(seat: &mut Seat) {
    let traj = &mut seat.traj;
    traj.curve.push(CurveRow {
        step: traj.steps_done,
        earned: seat.w_earned,
        received: seat.w_received,
        earned_cum: traj.earned_total,
        received_cum: traj.received_total,
    });
    seat.w_earned = 0.0;
    seat.w_received = 0.0;
}

/// The last, partial window of the curve.
fn close_curve(seat: &mut Seat, window: u64) {
    if !seat.traj.steps_done.is_multiple_of(window) {
        push_row(seat);
    }
}

/// The swarm's trajectory: rewards and curve the mean over robots, counts the totals.
fn swarm_trajectory(seats: &[Seat], sim_time_s: f64) -> Trajectory {
    let n = seats.len() as f64;
    let mut out = Trajectory {
        steps_done: seats.iter().map(|s| s.traj.steps_done).min().unwrap_or(0),
        sim_time_s,
        ..Trajectory::default()
    };
    if let [one] = seats {
        return Trajectory { sim_time_s: one.traj.sim_time_s, ..one.traj.clone() };
    }
    out.earned_total = seats.iter().map(|s| s.traj.earned_total).sum::<f64>() / n;
    out.received_total = seats.iter().map(|s| s.traj.received_total).sum::<f64>() / n;
    out.visits = vec![0; seats[0].traj.visits.len()];
    out.delays = DelayStats::default();
    for s in seats {
        for (e, x) in out.events.iter_mut().zip(s.traj.events) {
            *e += x;
        }
        for (v, x) in out.visits.iter_mut().zip(&s.traj.visits) {
            *v += x;
        }
        out.delays.delivered += s.traj.delays.delivered;
        out.delays.sum_steps += s.traj.delays.sum_steps;
        out.delays.sum_s += s.traj.delays.sum_s;
    }
    let rows = seats.iter().map(|s| s.traj.curve.len()).min().unwrap_or(0);
    out.curve = (0..rows)
        .map(|r| {
            let mean = |f: fn(&CurveRow) -> f64| seats.iter().map(|s| f(&s.traj.curve[r])).sum::<f64>() / n;
            CurveRow {
                step: seats[0].traj.curve[r].step,
                earned: mean(|c| c.earned),
                received: mean(|c| c.received),
                earned_cum: mean(|c| c.earned_cum),
                received_cum: mean(|c| c.received_cum),
            }
        })
        .collect();
    out
}

/// Greedy evaluation of the swarm: robot 0 starts at `S` (the single robot's
/// evaluation), the others as the swarm's starts say; every robot acts greedily for
/// `steps` decisions without updates. Returns the mean emitted reward per decision over
/// robots and robot 0's first states.
fn evaluate(env: &mut SwarmEnv, minds: &Minds, steps: u64, seed: u64) -> Result<(f64, Vec<usize>), LabError> {
    if steps == 0 {
        return Ok((f64::NAN, Vec::new()));
    }
    let env_err = |source| LabError::Env { seed, source };
    let seeds = SeedTree::new(seed);
    let states = env
        .reset_from(seeds.seed(Stream::Eval), seeds.seed(Stream::Delay), Start::Respawn)
        .map_err(env_err)?;
    let n = env.robots();
    let mut rngs: Vec<Rng> = (0..n).map(|i| SeedTree::new(robot_seed(seed, i)).rng(Stream::Eval)).collect();
    let mut s = states;
    let mut done = vec![0u64; n];
    let mut total = vec![0.0; n];
    let mut path = vec![s[0]];
    for i in 0..n {
        let a = minds.tables_of(i).greedy(s[i], &mut rngs[i]);
        env.act(i, a).map_err(env_err)?;
    }
    let mut out = Vec::new();
    loop {
        out.clear();
        env.advance(&mut out).map_err(env_err)?;
        if out.is_empty() {
            break;
        }
        for st in &out {
            let i = st.robot;
            total[i] += st.step.reward;
            s[i] = st.step.state;
            done[i] += 1;
            if i == 0 && path.len() < 200 {
                path.push(s[0]);
            }
            if done[i] < steps {
                let a = minds.tables_of(i).greedy(s[i], &mut rngs[i]);
                env.act(i, a).map_err(env_err)?;
            } else {
                env.park(i);
            }
        }
    }
    let per_step = total.iter().map(|t| t / steps as f64).sum::<f64>() / n as f64;
    Ok((per_step, path))
}

/// The environment figures: the robots' own (their mean), each robot's reward, and the
/// delays that emerged, for each robot and for the swarm.
fn swarm_stats(env: &SwarmEnv, seats: &[Seat]) -> Vec<(String, f64)> {
    let n = env.robots();
    let mut out = env.stats(0);
    for i in 1..n {
        for ((_, v), (_, x)) in out.iter_mut().zip(env.stats(i)) {
            *v += x;
        }
    }
    if n > 1 {
        for (_, v) in &mut out {
            *v /= n as f64;
        }
    }
    let delays = env.delays();
    let in_flight = env.in_flight();
    for (i, (seat, d)) in seats.iter().zip(delays).enumerate() {
        let steps = seat.traj.steps_done.max(1) as f64;
        let p = format!("swarm/robot{i}/");
        out.push((format!("{p}earned_per_step"), seat.traj.earned_total / steps));
        out.push((format!("{p}received_per_step"), seat.traj.received_total / steps));
        out.push((format!("{p}robot_bumps"), env.robot_bumps(i) as f64));
        out.push((format!("{p}lost"), d.lost as f64));
        out.push((format!("{p}in_flight"), in_flight[i].0 as f64));
        out.extend(delay_figures(&p, std::slice::from_ref(d)));
    }
    let sum = |f: fn(&RobotDelays) -> u64| delays.iter().map(f).sum::<u64>() as f64;
    out.push(("swarm/emitted".into(), sum(|d| d.emitted)));
    out.push(("swarm/delivered".into(), sum(|d| d.delivered)));
    out.push(("swarm/lost".into(), sum(|d| d.lost)));
    out.push(("swarm/in_flight".into(), in_flight.iter().map(|f| f.0).sum::<u64>() as f64));
    out.push(("swarm/robot_bumps".into(), (0..n).map(|i| env.robot_bumps(i)).sum::<u64>() as f64));
    let emitted = sum(|d| d.emitted);
    if emitted > 0.0 {
        out.push(("swarm/lost_share".into(), sum(|d| d.lost) / emitted));
    }
    out.extend(delay_figures("swarm/", delays));
    out.extend(delay_shape(delays));
    out
}

/// Upper edges of the bins of the emerged delays' histogram, seconds (the last bin is
/// open): doubling from half a second.
pub const DELAY_BINS_S: [f64; 10] = [0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0, 256.0];

/// The name of bin `k` of [`DELAY_BINS_S`] (`0-0.5s`, …, `256s+`).
pub fn delay_bin_name(k: usize) -> String {
    match k {
        0 => format!("0-{}s", DELAY_BINS_S[0]),
        k if k < DELAY_BINS_S.len() => format!("{}-{}s", DELAY_BINS_S[k - 1], DELAY_BINS_S[k]),
        _ => format!("{}s+", DELAY_BINS_S[DELAY_BINS_S.len() - 1]),
    }
}

/// The swarm's histogram of completed consultations' delays (`swarm/delay_share/BIN`,
/// shares of the completed ones), and per hop count the share of consultations that
/// took it and their mean delay (`swarm/hops_share/H`, `swarm/delay_mean_s_by_hops/H`).
fn delay_shape(delays: &[RobotDelays]) -> Vec<(String, f64)> {
    let mut bins = [0u64; DELAY_BINS_S.len() + 1];
    let mut by_hops: Vec<(u64, f64)> = Vec::new();
    let mut n = 0u64;
    for d in delays {
        for (&x, &h) in d.delays_s.iter().zip(&d.hops) {
            let x = x as f64;
            bins[DELAY_BINS_S.iter().position(|&e| x < e).unwrap_or(DELAY_BINS_S.len())] += 1;
            if by_hops.len() <= h as usize {
                by_hops.resize(h as usize + 1, (0, 0.0));
            }
            by_hops[h as usize].0 += 1;
            by_hops[h as usize].1 += x;
            n += 1;
        }
    }
    if n == 0 {
        return Vec::new();
    }
    let mut out: Vec<(String, f64)> = bins
        .iter()
        .enumerate()
        .map(|(k, &c)| (format!("swarm/delay_share/{}", delay_bin_name(k)), c as f64 / n as f64))
        .collect();
    for (h, &(c, s)) in by_hops.iter().enumerate().filter(|(_, x)| x.0 > 0) {
        out.push((format!("swarm/hops_share/{h}"), c as f64 / n as f64));
        out.push((format!("swarm/delay_mean_s_by_hops/{h}"), s / c as f64));
    }
    out
}

/// Mean, quantiles and maximum of the completed consultations' delays, and their mean
/// and largest hop count (nothing when none completed).
fn delay_figures(prefix: &str, delays: &[RobotDelays]) -> Vec<(String, f64)> {
    let mut all: Vec<f64> = delays.iter().flat_map(|d| d.delays_s.iter().map(|&x| x as f64)).collect();
    if all.is_empty() {
        return Vec::new();
    }
    all.sort_by(f64::total_cmp);
    let q = |p: f64| all[((all.len() - 1) as f64 * p).round() as usize];
    let hops: Vec<u8> = delays.iter().flat_map(|d| d.hops.iter().copied()).collect();
    let mean_hops = hops.iter().map(|&h| h as f64).sum::<f64>() / hops.len().max(1) as f64;
    vec![
        (format!("{prefix}delay_mean_s"), all.iter().sum::<f64>() / all.len() as f64),
        (format!("{prefix}delay_p50_s"), q(0.5)),
        (format!("{prefix}delay_p90_s"), q(0.9)),
        (format!("{prefix}delay_p99_s"), q(0.99)),
        (format!("{prefix}delay_max_s"), all[all.len() - 1]),
        (format!("{prefix}hops_mean"), mean_hops),
        (format!("{prefix}hops_max"), hops.iter().copied().max().unwrap_or(0) as f64),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn robot(delays: &[f32], hops: &[u8], lost: u64) -> RobotDelays {
        RobotDelays {
            emitted: delays.len() as u64 + lost,
            delivered: delays.len() as u64,
            lost,
            delays_s: delays.to_vec(),
            hops: hops.to_vec(),
        }
    }

    fn get(xs: &[(String, f64)], k: &str) -> f64 {
        xs.iter().find(|x| x.0 == k).map_or(f64::NAN, |x| x.1)
    }

    /// Hand-computed: delays 0.25, 1, 3 and 300 s over 1, 1, 2 and 3 hops.
    #[test]
    fn the_delay_figures_and_histogram_are_the_hand_computed_ones() {
        let ds = [robot(&[0.25, 3.0], &[1, 2], 1), robot(&[1.0, 300.0], &[1, 3], 0)];
        let f = delay_figures("swarm/", &ds);
        assert_eq!(get(&f, "swarm/delay_mean_s"), (0.25 + 1.0 + 3.0 + 300.0) / 4.0);
        // Sorted 0.25, 1, 3, 300: index round(3 p).
        assert_eq!(get(&f, "swarm/delay_p50_s"), 3.0); // round(1.5) = 2
        assert_eq!(get(&f, "swarm/delay_p90_s"), 300.0);
        assert_eq!(get(&f, "swarm/delay_max_s"), 300.0);
        assert_eq!((get(&f, "swarm/hops_mean"), get(&f, "swarm/hops_max")), (7.0 / 4.0, 3.0));
        let h = delay_shape(&ds);
        assert_eq!(get(&h, "swarm/delay_share/0-0.5s"), 0.25);
        assert_eq!(get(&h, "swarm/delay_share/1-2s"), 0.25); // 1 s is in [1, 2)
        assert_eq!(get(&h, "swarm/delay_share/2-4s"), 0.25);
        assert_eq!(get(&h, "swarm/delay_share/256s+"), 0.25);
        assert_eq!(get(&h, "swarm/delay_share/0.5-1s"), 0.0);
        let shares: f64 = h.iter().filter(|x| x.0.starts_with("swarm/delay_share/")).map(|x| x.1).sum();
        assert_eq!(shares, 1.0);
        assert_eq!((get(&h, "swarm/hops_share/1"), get(&h, "swarm/delay_mean_s_by_hops/1")), (0.5, 0.625));
        assert_eq!(get(&h, "swarm/delay_mean_s_by_hops/3"), 300.0);
        assert!(h.iter().all(|x| x.0 != "swarm/hops_share/0"));
        // Nothing completed: no figures (a mean of nothing is not 0).
        assert!(delay_figures("swarm/", &[robot(&[], &[], 3)]).is_empty());
        assert!(delay_shape(&[robot(&[], &[], 3)]).is_empty());
    }
}
