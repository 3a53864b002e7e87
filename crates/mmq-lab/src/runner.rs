//! The runner: one seed of learning (environment → delay channel → learner), its
//! metrics, the greedy evaluation and the undelayed baseline; and many seeds in
//! parallel, in seed order, so results never depend on the thread count.

use std::sync::atomic::Ordering;
use std::time::Instant;

use mmq_core::{DelayDist, Env, Move, Observer, Optimum, SeedTree, Telemetry, World};
use mmq_grid::GridEnv;
use mmq_learn::{Learner, LearnerSpec};
use mmq_robot::{RobotConfig, RobotEnv};

use crate::config::{EnvKind, RunConfig};
use crate::error::LabError;
use crate::grid_optimal::{GridOptimal, NAME};
use crate::stepper::{Evaluation, Stepper};
use crate::trajectory::policy_of;
pub use crate::trajectory::{
    Control, CurveRow, DIAGNOSTICS_EVERY, DiagnosticsSample, LearnerFactory, ObserverFactory, SeedResult,
    Trajectory,
};

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
        EnvKind::Robot | EnvKind::Swarm => match robot_env(world) {
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
pub(crate) fn robot_config(world: &World) -> Result<RobotConfig, LabError> {
    RobotConfig::from_world(world).map_err(|e| env_build(world, e))
}

/// An environment that cannot be built from `world`, naming its file.
pub(crate) fn env_build(world: &World, e: impl std::fmt::Display) -> LabError {
    let file = world.path.as_ref().map_or_else(|| world.name.clone(), |p| p.display().to_string());
    LabError::EnvBuild(format!("{file}: {e}"))
}

/// The learner's table shape, (states, actions), in `cfg`'s environment on `world`,
/// without building the environment.
pub fn table_shape(cfg: &RunConfig, world: &World) -> Result<(usize, usize), LabError> {
    match cfg.env {
        EnvKind::Grid => Ok((world.num_cells(), Move::ALL.len())),
        EnvKind::Robot | EnvKind::Swarm => Ok(robot_config(world)?.actions.table_shape(world.num_cells())),
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
        EnvKind::Swarm => {
            // The swarm's recorder comes as the seed's observer; its loop feeds it.
            let rec = observer
                .map(|o| crate::swarm_record::Recording::new(o, run_facts(cfg, world)))
                .transpose()?;
            crate::swarm::run_swarm_seed(cfg, world, seed, ctl, mem_limit, own_baseline, learner, rec)
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
    let (run, mut env) = learn(
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
    // Physics figures of the learning run (before evaluation resets the environment).
    let env_stats = env.stats();
    // A stopped run is not evaluated: the evaluation's steps would delay the stop (a
    // robot's thousand primitives take seconds), and a partial policy's score means little.
    let eval_steps = if run.steps_done == cfg.steps { cfg.eval_steps } else { 0 };
    let greedy = evaluate(&mut env, &*learner, eval_steps, seeds, seed)?;
    let learned = Learned { run, env, env_stats, greedy, learn_s, clock };
    conclude(cfg, seed, learned, &*learner, observer, ctl, mem_limit, own_baseline, &make)
}

/// What a seed's learning and greedy evaluation left for [`conclude`].
pub(crate) struct Learned<E> {
    /// The learning trajectory.
    pub run: Trajectory,
    /// The environment after the evaluation.
    pub env: E,
    /// Its figures after learning.
    pub env_stats: Vec<(String, f64)>,
    /// The greedy evaluation's reward per step and path.
    pub greedy: (f64, Vec<usize>),
    /// Wall-clock seconds of learning.
    pub learn_s: f64,
    /// Started with the seed.
    pub clock: Instant,
}

/// The rest of a seed after its greedy evaluation: the policy maps, the learner's or the
/// observer's failure, the baseline (if `own_baseline`, on an environment of `make`) and
/// the seed's result.
#[allow(clippy::too_many_arguments)]
pub(crate) fn conclude<E: Env + Telemetry>(
    cfg: &RunConfig,
    seed: u64,
    learned: Learned<E>,
    learner: &dyn Learner,
    mut observer: Option<Box<dyn Observer + Send>>,
    ctl: Control<'_>,
    mem_limit: u128,
    own_baseline: bool,
    make: &dyn Fn() -> Result<E, LabError>,
) -> Result<SeedResult, LabError> {
    let Learned { run, env, env_stats, greedy: (greedy_per_step, greedy_path), learn_s, clock } = learned;
    let seeds = SeedTree::new(seed);
    let complete = run.steps_done == cfg.steps;
    // The policy maps visit every state (a second on the largest worlds): a stop cuts them
    // short, and the seed is then incomplete.
    let stopped = || ctl.stop.load(Ordering::Relaxed);
    let (policy_arrows, policy_probs, values, whole) = policy_of(&env, learner, &stopped);
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
    let reference = if cfg.reference && complete { reference_run(cfg, seed, ctl, make)? } else { None };
    let complete = complete && (!cfg.reference || reference.is_some());
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
        reference,
        wall_time_s: clock.elapsed().as_secs_f64(),
        learn_time_s: learn_s,
        failure,
    })
}

/// The reference `grid-optimal` on an environment of `make` with `cfg`'s steps, ε and
/// the seed's streams (no delay: it does not learn); `None` if stopped.
fn reference_run<E: Env + Telemetry>(
    cfg: &RunConfig,
    seed: u64,
    ctl: Control<'_>,
    make: &dyn Fn() -> Result<E, LabError>,
) -> Result<Option<Trajectory>, LabError> {
    let env = make()?;
    let optimum = optimum_of(env.world());
    let name = cfg.world.display().to_string();
    let mut agent =
        GridOptimal::new(&optimum, cfg.learner.params.epsilon, env.num_states(), env.num_actions(), &name)?;
    let seeds = SeedTree::new(seed);
    let (traj, _) = learn(env, &mut agent, &DelayDist::None, cfg, seeds, None, ctl, None, NAME)?;
    Ok((traj.steps_done == cfg.steps).then_some(traj))
}

/// The learning loop of one trajectory ([`Stepper`] to its end).
#[allow(clippy::too_many_arguments)]
fn learn<E: Env + Telemetry>(
    env: E,
    learner: &mut dyn Learner,
    dist: &DelayDist,
    cfg: &RunConfig,
    seeds: SeedTree,
    observer: Option<&mut Box<dyn Observer + Send>>,
    ctl: Control<'_>,
    info: Option<(&str, &[(String, String)])>,
    learner_name: &str,
) -> Result<(Trajectory, E), LabError> {
    let mut st = Stepper::start(env, &*learner, dist, cfg, seeds, observer, ctl, info, learner_name)?;
    while let Some(s) = st.begin(&*learner) {
        let d = learner.act(s, st.rng());
        st.advance(d, learner)?;
    }
    Ok(st.finish(&*learner))
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
    let mut ev = Evaluation::start(env, steps, seeds, seed)?;
    while let Some(s) = ev.begin() {
        let a = learner.greedy(s, ev.rng());
        ev.advance(env, a)?;
    }
    Ok(ev.finish())
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

/// What a run of a validated configuration refuses before it allocates or runs
/// anything: the robot's or swarm's arena (built once) and the memory of the seeds'
/// tables ([`crate::Resolved`] checks it once).
pub(crate) fn check_fits(cfg: &RunConfig, world: &World) -> Result<(), LabError> {
    match cfg.env {
        EnvKind::Grid => {}
        EnvKind::Robot => {
            robot_env(world)?;
        }
        EnvKind::Swarm => {
            crate::swarm::swarm_env_with(world, &cfg.swarm)?;
        }
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
    Ok(())
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
    use std::sync::atomic::AtomicBool;

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
            run_seed_as(&c, &world, &dist, 3, None, ctl, u128::MAX, false, None).unwrap()
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

    /// `reference = true` runs the grid-optimal agent on the same environment and
    /// streams, exactly as the benchmark suite runs it through a learner factory; the
    /// fraction of it is the learner's earned reward ÷ the reference's. On the realistic
    /// robot the reference earns less than the grid's optimum.
    #[test]
    fn the_reference_is_the_grid_optimal_agent_on_the_runs_environment_and_streams() {
        let world = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../worlds/paper-9x9.toml"));
        let stop = AtomicBool::new(false);
        let ctl = Control { stop: &stop, progress: &|_| {} };
        for (env, robot, steps) in
            [(EnvKind::Grid, vec![], 5000), (EnvKind::Robot, vec!["profile=realistic".into()], 400)]
        {
            let cfg = RunConfig {
                world: world.clone(),
                env,
                robot,
                learner: mmq_learn::LearnerSpec::new(mmq_learn::LearnerKind::Q),
                steps,
                window: 100,
                eval_steps: 0,
                baseline: false,
                reference: true,
                save_tables: false,
                ..RunConfig::default()
            };
            let (w, dist) = (&cfg.load_world().unwrap(), cfg.validate().unwrap());
            let r = run_seed_as(&cfg, w, &dist, 5, None, ctl, u128::MAX, true, None).unwrap();
            let reference = r.reference.clone().expect("asked for");
            let optimum = optimum_of(w);
            let eps = cfg.learner.params.epsilon;
            let factory = |ns: usize, na: usize, _seed: u64| {
                Ok(Box::new(GridOptimal::new(&optimum, eps, ns, na, "w")?) as Box<dyn Learner>)
            };
            let plain = RunConfig { reference: false, ..cfg.clone() };
            let agent =
                run_seed_as(&plain, w, &dist, 5, None, ctl, u128::MAX, false, Some(&factory)).unwrap();
            assert_eq!(reference.earned_total, agent.run.earned_total, "{env:?}");
            // It earns the same (what it receives depends on the delay it runs under).
            let earned = |c: &[CurveRow]| c.iter().map(|r| (r.step, r.earned)).collect::<Vec<_>>();
            assert_eq!(earned(&reference.curve), earned(&agent.run.curve), "{env:?}");
            assert_eq!(r.fraction_of_reference(), Some(r.run.earned_total / reference.earned_total));
            let per_step = reference.earned_total / steps as f64;
            if env == EnvKind::Robot {
                assert!(per_step < optimum.gain, "{per_step} vs {}", optimum.gain);
            }
            assert!(per_step > 0.0);
        }
    }
}
