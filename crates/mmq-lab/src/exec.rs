//! One executor for every study: jobs (a resolved run configuration × a master seed) in,
//! results out. It refuses tables that cannot fit before running anything, runs the jobs
//! on rayon's threads, stops on the stop flag or at the first error, and computes each
//! undelayed baseline once: the first job that needs it runs it, jobs that need it
//! meanwhile wait for it, and it is dropped after its last user. `mmq run`, `mmq paper`
//! and `mmq sweep` run through it; the results do not depend on the order jobs run in.

use std::collections::{HashMap, HashSet};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use rayon::prelude::*;

use crate::config::{EnvKind, RunConfig};
use crate::error::LabError;
use crate::resolved::Resolved;
use crate::resolved::run_seed;
use crate::runner::{check_tables_fit, memory_limit, run_seed_as};
use crate::trajectory::{Control, LearnerFactory, ObserverFactory, SeedResult, Trajectory};

/// One run to make: a configuration, its world and delay, a master seed and, for a
/// learner not built from a name, how to build it.
#[derive(Clone, Copy)]
pub struct Job<'a> {
    /// The resolved run; with `baseline` set in its configuration the job also gets the
    /// undelayed Q-learning baseline of the same world, parameters, horizon and seed.
    pub run: &'a Resolved,
    /// The master seed.
    pub seed: u64,
    /// Builds the job's learner in place of `cfg`'s (None: `cfg`'s learner).
    pub learner: Option<&'a LearnerFactory<'a>>,
}

impl std::fmt::Debug for Job<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Job")
            .field("cfg", self.run.cfg())
            .field("world", &self.run.world().name)
            .field("dist", self.run.dist())
            .field("seed", &self.seed)
            .field("learner", &self.learner.map(|_| "given"))
            .finish()
    }
}

/// Everything an undelayed baseline depends on: jobs with equal keys share one.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct BaselineKey {
    world: PathBuf,
    env: EnvKind,
    robot: Vec<String>,
    swarm: Vec<String>,
    /// α, γ, ε, q0 as bits.
    params: [u64; 4],
    steps: u64,
    window: u64,
    eval_steps: u64,
    seed: u64,
}

impl BaselineKey {
    /// The key of the baseline of `cfg` with master seed `seed`.
    pub fn of(cfg: &RunConfig, seed: u64) -> Self {
        let p = cfg.learner.params;
        BaselineKey {
            world: cfg.world.clone(),
            env: cfg.env,
            robot: cfg.robot.clone(),
            swarm: cfg.swarm.clone(),
            params: [p.alpha.to_bits(), p.gamma.to_bits(), p.epsilon.to_bits(), p.q0.to_bits()],
            steps: cfg.steps,
            window: cfg.window,
            eval_steps: cfg.eval_steps,
            seed,
        }
    }
}

/// The undelayed Q-learning run that is `cfg`'s baseline, as a run of its own.
pub fn baseline_config(cfg: &RunConfig) -> RunConfig {
    cfg.baseline_run()
}

/// The distinct baselines the jobs need (each job whose configuration asks for one).
pub fn baselines_needed(jobs: &[Job<'_>]) -> Vec<(BaselineKey, u64)> {
    let mut seen = HashSet::new();
    jobs.iter()
        .filter(|j| j.run.cfg().baseline)
        .map(|j| (BaselineKey::of(j.run.cfg(), j.seed), j.run.cfg().steps))
        .filter(|(k, _)| seen.insert(k.clone()))
        .collect()
}

/// An undelayed baseline shared by the jobs that need it.
struct Shared {
    /// Jobs still to use it.
    users: AtomicUsize,
    slot: Mutex<Slot>,
}

/// The state of a shared baseline.
enum Slot {
    /// Not computed yet.
    Pending,
    /// The trajectory and its greedy evaluation.
    Ready(Arc<(Trajectory, f64)>),
    /// Unavailable: interrupted, failed, or no longer needed.
    Gone,
}

/// The most worker threads [`set_threads`] accepts: far more than any machine this runs on
/// needs for seeds in parallel, and few enough that starting them cannot exhaust the
/// process.
pub const MAX_THREADS: usize = 256;

/// Starts the worker pool (rayon's global pool, before any job runs) with `n` threads: a
/// bad count is bad input, a pool that cannot start (a memory or process limit) a runtime
/// failure; neither panics.
pub fn set_threads(n: usize) -> Result<(), LabError> {
    if !(1..=MAX_THREADS).contains(&n) {
        return Err(LabError::Threads { n, max: MAX_THREADS });
    }
    let pool = rayon::ThreadPoolBuilder::new().num_threads(n).build_global();
    pool.map_err(|e| LabError::Pool { n, reason: e.to_string() })
}

/// Runs `jobs` in parallel and hands each run to `done` with its index, its baseline
/// attached where the configuration asks for one. As one seed of `mmq run` does: the run
/// first, then (if it finished) its baseline; a run cut short by the stop flag, or whose
/// baseline was, is handed over with `complete` false; a job that has not started when
/// the stop flag is set is not run. The first error (of a run or of `done`) stops the
/// jobs not yet started and is returned.
pub fn run_jobs(
    jobs: &[Job<'_>],
    ctl: Control<'_>,
    done: &(dyn Fn(usize, SeedResult) -> Result<(), LabError> + Sync),
) -> Result<(), LabError> {
    run_jobs_observed(jobs, None, ctl, done)
}

/// [`run_jobs`] with an observer per master seed for the learning runs (recorders, the
/// live view; baselines are never observed).
pub fn run_jobs_observed(
    jobs: &[Job<'_>],
    observers: Option<&ObserverFactory<'_>>,
    ctl: Control<'_>,
    done: &(dyn Fn(usize, SeedResult) -> Result<(), LabError> + Sync),
) -> Result<(), LabError> {
    let parallel = rayon::current_num_threads().min(jobs.len()).max(1);
    let limit = memory_limit(parallel);
    // Refuse tables that cannot fit before running anything (once per configuration; a
    // learner built by a factory is its own business).
    let mut checked = HashSet::new();
    for j in jobs.iter().filter(|j| j.learner.is_none()) {
        if checked.insert(std::ptr::from_ref(j.run)) {
            check_tables_fit(j.run.cfg(), j.run.world(), limit)?;
        }
    }
    let mut shared: HashMap<BaselineKey, Shared> = HashMap::new();
    for j in jobs.iter().filter(|j| j.run.cfg().baseline) {
        let s = shared
            .entry(BaselineKey::of(j.run.cfg(), j.seed))
            .or_insert_with(|| Shared { users: AtomicUsize::new(0), slot: Mutex::new(Slot::Pending) });
        s.users.fetch_add(1, Ordering::Relaxed);
    }

    let failed = AtomicBool::new(false);
    let first_error = Mutex::new(None::<LabError>);
    let fail = |e: LabError| {
        failed.store(true, Ordering::SeqCst);
        let mut g = first_error.lock().unwrap_or_else(|p| p.into_inner());
        if g.is_none() {
            *g = Some(e);
        }
    };
    let halted = || ctl.stop.load(Ordering::Relaxed) || failed.load(Ordering::Relaxed);

    // The baseline of a job: computed by the first job that asks, awaited by the others
    // that ask meanwhile, dropped after its last user (a job that does not want it any
    // more, its own run cut short, only lets go of it).
    let baseline_of = |j: &Job<'_>, want: bool| -> Option<Arc<(Trajectory, f64)>> {
        let s = &shared[&BaselineKey::of(j.run.cfg(), j.seed)];
        let mut slot = s.slot.lock().unwrap_or_else(|p| p.into_inner());
        if want && matches!(*slot, Slot::Pending) {
            *slot = match run_seed(&j.run.baseline(), j.seed, None, ctl, limit) {
                Ok(r) if r.complete => Slot::Ready(Arc::new((r.run, r.greedy_per_step))),
                Ok(_) => Slot::Gone,
                Err(e) => {
                    fail(e);
                    Slot::Gone
                }
            };
        }
        let b = match &*slot {
            Slot::Ready(b) if want => Some(b.clone()),
            _ => None,
        };
        if s.users.fetch_sub(1, Ordering::AcqRel) == 1 {
            *slot = Slot::Gone;
        }
        b
    };

    jobs.par_iter().enumerate().for_each(|(i, j)| {
        if halted() {
            return;
        }
        let observer = match observers.map(|f| f(j.seed)).transpose() {
            Ok(o) => o.flatten(),
            Err(e) => return fail(e),
        };
        let (cfg, world, dist) = (j.run.cfg(), j.run.world(), j.run.dist());
        let mut r = match run_seed_as(cfg, world, dist, j.seed, observer, ctl, limit, false, j.learner) {
            Ok(r) => r,
            Err(e) => {
                if cfg.baseline {
                    baseline_of(j, false);
                }
                return fail(e);
            }
        };
        if cfg.baseline {
            match baseline_of(j, r.complete) {
                Some(b) => {
                    r.baseline = Some(b.0.clone());
                    r.baseline_greedy_per_step = Some(b.1);
                }
                None => r.complete = false,
            }
        }
        if let Err(e) = done(i, r) {
            fail(e);
        }
    });
    match first_error.into_inner().unwrap_or_else(|p| p.into_inner()) {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// [`run_jobs_observed`] with the results in job order: `None` for a job that was not
/// run (the stop flag was set before it started).
pub fn run_jobs_in_order(
    jobs: &[Job<'_>],
    observers: Option<&ObserverFactory<'_>>,
    ctl: Control<'_>,
) -> Result<Vec<Option<SeedResult>>, LabError> {
    let slots: Mutex<Vec<Option<SeedResult>>> = Mutex::new((0..jobs.len()).map(|_| None).collect());
    run_jobs_observed(jobs, observers, ctl, &|i, r| {
        slots.lock().unwrap_or_else(|p| p.into_inner())[i] = Some(r);
        Ok(())
    })?;
    Ok(slots.into_inner().unwrap_or_else(|p| p.into_inner()))
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

/// Runs every seed of `run` in parallel (rayon), results in seed order.
pub fn run_all(
    run: &Resolved,
    observers: &ObserverFactory<'_>,
    ctl: Control<'_>,
) -> Result<RunOutcome, LabError> {
    let seeds = run.cfg().seed_list();
    let jobs: Vec<Job<'_>> = seeds.iter().map(|&seed| Job { run, seed, learner: None }).collect();
    let out: Vec<SeedResult> =
        run_jobs_in_order(&jobs, Some(observers), ctl)?.into_iter().flatten().collect();
    let interrupted = ctl.stop.load(Ordering::Relaxed) || out.iter().any(|r| !r.complete);
    Ok(RunOutcome { results: out, interrupted })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_thread_count_out_of_range_is_bad_input_naming_the_field() {
        for n in [0, MAX_THREADS + 1] {
            let e = set_threads(n).unwrap_err();
            assert!(e.is_input_error() && e.names_fields(), "{e}");
            assert_eq!(
                e.to_string(),
                format!(
                    "`threads` {n}: use a number of worker threads from 1 to 256 (default: one per core)"
                )
            );
        }
    }

    fn cfg() -> RunConfig {
        RunConfig { world: "paper-3x3".into(), steps: 300, window: 100, ..RunConfig::default() }
    }

    #[test]
    fn the_baseline_key_holds_what_the_baseline_depends_on_and_nothing_else() {
        let a = cfg();
        let key = |c: &RunConfig| BaselineKey::of(c, 3);
        // Shared across what the undelayed Q-learning baseline ignores.
        let mut b = a.clone();
        b.learner.settings =
            mmq_learn::LearnerSettings::Mmq(mmq_learn::settings::MmqSettings { max_delay: 7 });
        b.delay = "poisson:5".into();
        assert_eq!(key(&a), key(&b));
        // Not shared across anything it depends on.
        let changed: [fn(&mut RunConfig); 8] = [
            |c| c.learner.params.epsilon = 0.2,
            |c| c.learner.params.q0 = 1.0,
            |c| c.steps = 600,
            |c| c.window = 50,
            |c| c.eval_steps = 10,
            |c| c.env = EnvKind::Robot,
            |c| c.robot = vec!["profile=realistic".into()],
            |c| c.world = "paper-5x5".into(),
        ];
        for f in changed {
            let mut c = a.clone();
            f(&mut c);
            assert_ne!(key(&a), key(&c), "{c:?}");
        }
        assert_ne!(BaselineKey::of(&a, 3), BaselineKey::of(&a, 4));
    }

    #[test]
    fn jobs_get_the_baseline_run_seed_computes_and_share_it() {
        let c = Resolved::new(cfg()).unwrap();
        let stop = AtomicBool::new(false);
        let ctl = Control { stop: &stop, progress: &|_| {} };
        let mut other = c.cfg().clone();
        other.learner.settings = mmq_learn::LearnerSettings::of(mmq_learn::LearnerKind::Mmq);
        let other = Resolved::new(other).unwrap();
        let jobs = [Job { run: &c, seed: 5, learner: None }, Job { run: &other, seed: 5, learner: None }];
        assert_eq!(baselines_needed(&jobs).len(), 1);
        let got = run_jobs_in_order(&jobs, None, ctl).unwrap();
        // run_seed with the baseline flag runs the same baseline itself.
        let own = run_seed(&c, 5, None, ctl, 1 << 30).unwrap();
        let own_base = own.baseline.as_ref().unwrap();
        for r in got.iter().map(|r| r.as_ref().unwrap()) {
            let b = r.baseline.as_ref().unwrap();
            assert_eq!(b.earned_total.to_bits(), own_base.earned_total.to_bits());
            assert_eq!(b.curve.len(), own_base.curve.len());
            assert_eq!(
                r.baseline_greedy_per_step.map(f64::to_bits),
                own.baseline_greedy_per_step.map(f64::to_bits)
            );
        }
        assert_eq!(got[0].as_ref().unwrap().run.earned_total.to_bits(), own.run.earned_total.to_bits());
    }

    #[test]
    fn an_error_of_done_is_returned() {
        let c = Resolved::new(RunConfig { baseline: false, ..cfg() }).unwrap();
        let stop = AtomicBool::new(false);
        let ctl = Control { stop: &stop, progress: &|_| {} };
        let jobs = [Job { run: &c, seed: 0, learner: None }];
        let e = run_jobs(&jobs, ctl, &|_, _| Err(LabError::EnvBuild("cannot keep it".into())));
        assert!(e.unwrap_err().to_string().contains("cannot keep it"));
    }
}
