//! Many seeds of one configuration in lockstep, for a learner that decides for all of
//! them at once (a batched agent from outside mmq, vectorised over its seeds): every
//! seed's step `t`, then every seed's step `t + 1`. Each seed keeps its own environment,
//! delays and streams and runs through the runner's own step loop
//! ([`crate::stepper`]), so its trajectory, evaluation and metrics are those the same
//! decisions would give one seed at a time ([`crate::run_seed`]).
//!
//! The learner sees the batch as [`Seat`]s, one per seed in the order given: it reads
//! their states and writes their actions ([`BatchLearner::act`],
//! [`BatchLearner::greedy`]), reads what their steps gave ([`BatchLearner::observe`]),
//! and fails a seed by setting its [`Seat::failure`], which ends that seed as failed
//! while the others go on.

use std::time::Instant;

use mmq_core::{Action, DelayDist, Env, Rng, SeedTree, State, Telemetry};
use mmq_grid::GridEnv;
use mmq_learn::{Decision, Experience, Learner, Table};

use crate::config::{EnvKind, RunConfig};
use crate::error::LabError;
use crate::runner::{Control, Learned, SeedResult, conclude, robot_env};
use crate::stepper::{Evaluation, Stepper};

/// One seed's place in a batch: what the batched learner reads and writes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Seat {
    /// Whether the seed takes this step (false once it ended: all its steps ran, it
    /// failed, or the run was stopped); the learner's answer for a seat that does not
    /// is ignored.
    pub live: bool,
    /// The state the seed acts in (`act`, `greedy`) or acted in (`observe`).
    pub state: State,
    /// The action: written by the learner in `act` and `greedy`; read in `observe`.
    pub action: Action,
    /// The step (0, 1, 2, …) (`observe`).
    pub t: u64,
    /// The reward delivered at the step: a sum of delayed rewards, often 0 (`observe`).
    pub reward: f64,
    /// The state the step led to (`observe`).
    pub next_state: State,
    /// Simulated time at the end of the step, seconds (`observe`).
    pub time_s: f64,
    /// Why the seed failed, set by the learner: the seed ends as failed with it (its
    /// step under way is still taken, with `action`).
    pub failure: Option<String>,
}

/// A learner for a batch of seeds in lockstep. Each call gets every seat of the batch,
/// the seats that do not take the step included (their `live` is false).
pub trait BatchLearner {
    /// Chooses the action of every live seat while learning.
    fn act(&mut self, seats: &mut [Seat]);
    /// Learns from the step every live seat just took.
    fn observe(&mut self, seats: &mut [Seat]);
    /// Chooses the action of every live seat in the greedy evaluation (no learning).
    fn greedy(&mut self, seats: &mut [Seat]);
}

/// Builds the batched learner of the seeds given (in that order), with the numbers of
/// states and actions of the environment.
pub type BatchFactory<'a> = dyn Fn(usize, usize, &[u64]) -> Result<Box<dyn BatchLearner>, LabError> + 'a;

/// One seat as the learner of the step loop: it acts as the batch decided and keeps
/// what the step gave for the batch's `observe`.
#[derive(Debug)]
struct SeatLearner<'s>(&'s mut Seat);

impl Learner for SeatLearner<'_> {
    fn name(&self) -> &'static str {
        "batch"
    }

    fn act(&mut self, _state: State, _rng: &mut Rng) -> Decision {
        Decision { action: self.0.action, model: None, explored: false }
    }

    fn observe(&mut self, exp: &Experience<'_>) {
        let seat = &mut *self.0;
        seat.t = exp.t;
        seat.reward = exp.reward;
        seat.next_state = exp.next_state;
        seat.time_s = exp.time_s;
    }

    fn greedy(&self, _state: State, _rng: &mut Rng) -> Action {
        self.0.action
    }

    /// A batched learner shows no values: zeros (every action is a maximiser in policy
    /// maps), as an outside agent of one seed.
    fn action_values(&self, _state: State, out: &mut [f64]) {
        out.fill(0.0);
    }

    fn tables(&self) -> Vec<Table> {
        Vec::new()
    }

    fn failure(&self) -> Option<String> {
        self.0.failure.clone()
    }
}

/// Runs the seeds `seeds` of `cfg` in lockstep with the batched learner `factory`
/// builds: learning, the greedy evaluation (of the seeds whose learning ran to its end),
/// then each seed's end as [`crate::run_seed`] does it (its own baseline when the
/// configuration asks for one). Results in the order of `seeds`; the times of a seed are
/// its batch's. A seed cut short by the stop flag is returned incomplete.
pub fn run_batch(
    run: &crate::Resolved,
    seeds: &[u64],
    factory: &BatchFactory<'_>,
    ctl: Control<'_>,
    mem_limit: u128,
) -> Result<Vec<SeedResult>, LabError> {
    let (cfg, world, dist) = (run.cfg(), run.world(), run.dist());
    match cfg.env {
        EnvKind::Grid => run_batch_on(cfg, dist, seeds, factory, ctl, mem_limit, &|| Ok(GridEnv::new(world))),
        EnvKind::Robot => run_batch_on(cfg, dist, seeds, factory, ctl, mem_limit, &|| robot_env(world)),
        EnvKind::Swarm => Err(LabError::param(
            "env",
            "swarm",
            "batched agents run on the grid and the single robot; give the swarm an agent without act_batch",
        )),
    }
}

/// [`run_batch`] on environments made by `make`.
fn run_batch_on<E: Env + Telemetry>(
    cfg: &RunConfig,
    dist: &DelayDist,
    seeds: &[u64],
    factory: &BatchFactory<'_>,
    ctl: Control<'_>,
    mem_limit: u128,
    make: &dyn Fn() -> Result<E, LabError>,
) -> Result<Vec<SeedResult>, LabError> {
    if seeds.is_empty() {
        return Ok(Vec::new());
    }
    let clock = Instant::now();
    let envs = seeds.iter().map(|_| make()).collect::<Result<Vec<E>, _>>()?;
    let mut learner = factory(envs[0].num_states(), envs[0].num_actions(), seeds)?;
    let mut seats = vec![Seat { live: true, ..Seat::default() }; seeds.len()];
    let learn_clock = Instant::now();
    let name = cfg.learner.kind().name();
    let mut steppers = Vec::with_capacity(seeds.len());
    for ((env, &seed), seat) in envs.into_iter().zip(seeds).zip(&mut seats) {
        let learner = SeatLearner(seat);
        steppers.push(Stepper::start(env, &learner, dist, cfg, SeedTree::new(seed), None, ctl, None, name)?);
    }
    loop {
        let mut any = false;
        for (st, seat) in steppers.iter_mut().zip(&mut seats) {
            if seat.live {
                match st.begin(&SeatLearner(seat)) {
                    Some(s) => {
                        seat.state = s;
                        any = true;
                    }
                    None => seat.live = false,
                }
            }
        }
        if !any {
            break;
        }
        learner.act(&mut seats);
        for (st, seat) in steppers.iter_mut().zip(&mut seats) {
            if seat.live {
                let d = Decision { action: seat.action, model: None, explored: false };
                st.advance(d, &mut SeatLearner(seat))?;
            }
        }
        learner.observe(&mut seats);
    }
    let learn_s = learn_clock.elapsed().as_secs_f64();
    let mut runs = Vec::with_capacity(seeds.len());
    let mut evals = Vec::with_capacity(seeds.len());
    for ((st, seat), &seed) in steppers.into_iter().zip(&mut seats).zip(seeds) {
        let (run, mut env) = st.finish(&SeatLearner(seat));
        // Physics figures of the learning run (before evaluation resets the environment).
        let env_stats = env.stats();
        // A stopped run is not evaluated (as one seed's).
        let eval_steps = if run.steps_done == cfg.steps { cfg.eval_steps } else { 0 };
        evals.push(Evaluation::start(&mut env, eval_steps, SeedTree::new(seed), seed)?);
        runs.push((run, env, env_stats));
    }
    loop {
        let mut any = false;
        for (ev, seat) in evals.iter().zip(&mut seats) {
            seat.live = match ev.begin() {
                Some(s) => {
                    seat.state = s;
                    true
                }
                None => false,
            };
            any |= seat.live;
        }
        if !any {
            break;
        }
        learner.greedy(&mut seats);
        for ((ev, seat), (_, env, _)) in evals.iter_mut().zip(&seats).zip(&mut runs) {
            if seat.live {
                ev.advance(env, seat.action)?;
            }
        }
    }
    let mut out = Vec::with_capacity(seeds.len());
    for ((((run, env, env_stats), ev), seat), &seed) in runs.into_iter().zip(evals).zip(&mut seats).zip(seeds)
    {
        let learned = Learned { run, env, env_stats, greedy: ev.finish(), learn_s, clock };
        out.push(conclude(cfg, seed, learned, &SeatLearner(seat), None, ctl, mem_limit, cfg.baseline, make)?);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;
    use std::sync::atomic::AtomicBool;

    use mmq_core::Stream;
    use mmq_learn::{LearnerKind, LearnerSpec};

    use super::*;
    use crate::run_seed;

    /// One built-in learner per seat, each with its seed's exploration and evaluation
    /// streams (those the runner hands a learner of one seed); fails seat `fail.0` after
    /// it observed step `fail.1`.
    #[derive(Debug)]
    struct Each {
        learners: Vec<Box<dyn Learner>>,
        explore: Vec<Rng>,
        eval: Vec<Rng>,
        fail: Option<(usize, u64)>,
        calls: usize,
    }

    impl BatchLearner for Each {
        fn act(&mut self, seats: &mut [Seat]) {
            self.calls += 1;
            for (i, seat) in seats.iter_mut().enumerate().filter(|(_, s)| s.live) {
                seat.action = self.learners[i].act(seat.state, &mut self.explore[i]).action;
            }
        }
        fn observe(&mut self, seats: &mut [Seat]) {
            for (i, seat) in seats.iter_mut().enumerate().filter(|(_, s)| s.live) {
                self.learners[i].observe(&Experience {
                    t: seat.t,
                    state: seat.state,
                    action: seat.action,
                    next_state: seat.next_state,
                    reward: seat.reward,
                    time_s: seat.time_s,
                    truth: None,
                });
                if self.fail == Some((i, seat.t)) {
                    seat.failure = Some(format!("seat {i} gave up at step {}", seat.t));
                }
            }
        }
        fn greedy(&mut self, seats: &mut [Seat]) {
            for (i, seat) in seats.iter_mut().enumerate().filter(|(_, s)| s.live) {
                seat.action = self.learners[i].greedy(seat.state, &mut self.eval[i]);
            }
        }
    }

    fn cfg() -> RunConfig {
        let world = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../worlds/paper-5x5.toml"));
        let base = RunConfig::default();
        RunConfig {
            world,
            delay: "poisson:3".into(),
            steps: 4000,
            window: 500,
            eval_steps: 300,
            save_tables: false,
            learner: LearnerSpec { params: base.learner.params, ..LearnerSpec::new(LearnerKind::Q) },
            ..base
        }
    }

    fn batch(cfg: &RunConfig, seeds: &[u64], fail: Option<(usize, u64)>) -> Vec<SeedResult> {
        let stop = AtomicBool::new(false);
        let ctl = Control { stop: &stop, progress: &|_| {} };
        let factory = |n_s: usize, n_a: usize, seeds: &[u64]| {
            let trees: Vec<SeedTree> = seeds.iter().map(|&s| SeedTree::new(s)).collect();
            Ok(Box::new(Each {
                learners: seeds.iter().map(|_| cfg.learner.build(n_s, n_a, u128::MAX).unwrap()).collect(),
                explore: trees.iter().map(|t| t.rng(Stream::Explore)).collect(),
                eval: trees.iter().map(|t| t.rng(Stream::Eval)).collect(),
                fail,
                calls: 0,
            }) as Box<dyn BatchLearner>)
        };
        run_batch(&crate::Resolved::new(cfg.clone()).unwrap(), seeds, &factory, ctl, u128::MAX).unwrap()
    }

    fn same(a: &SeedResult, b: &SeedResult) {
        assert_eq!(a.seed, b.seed);
        assert_eq!((a.complete, &a.failure), (b.complete, &b.failure));
        let (x, y) = (&a.run, &b.run);
        assert_eq!(
            (x.steps_done, x.events, &x.visits, x.delays),
            (y.steps_done, y.events, &y.visits, y.delays)
        );
        assert_eq!(x.earned_total.to_bits(), y.earned_total.to_bits());
        assert_eq!(x.received_total.to_bits(), y.received_total.to_bits());
        assert_eq!(x.curve, y.curve);
        assert_eq!(x.sim_time_s.to_bits(), y.sim_time_s.to_bits());
        assert_eq!(a.greedy_per_step.to_bits(), b.greedy_per_step.to_bits());
        assert_eq!(a.greedy_path, b.greedy_path);
        let base = |r: &SeedResult| r.baseline.as_ref().map(|t| (t.earned_total.to_bits(), t.curve.clone()));
        assert_eq!(base(a), base(b));
        assert_eq!(
            a.baseline_greedy_per_step.map(f64::to_bits),
            b.baseline_greedy_per_step.map(f64::to_bits)
        );
    }

    /// Seeds in lockstep give each seed the trajectory, evaluation and baseline of the
    /// same learner run one seed at a time.
    #[test]
    fn a_batch_gives_every_seed_its_run_alone() {
        for baseline in [false, true] {
            let cfg = RunConfig { baseline, ..cfg() };
            let run = crate::Resolved::new(cfg.clone()).unwrap();
            let stop = AtomicBool::new(false);
            let ctl = Control { stop: &stop, progress: &|_| {} };
            let seeds = [4, 0, 9];
            let got = batch(&cfg, &seeds, None);
            assert_eq!(got.len(), 3);
            for (r, &seed) in got.iter().zip(&seeds) {
                let alone = run_seed(&run, seed, None, ctl, u128::MAX).unwrap();
                let what = (alone.complete, alone.run.earned_total, alone.greedy_per_step);
                assert!(what.0 && what.1 != 0.0 && what.2.is_finite(), "{what:?}");
                assert_eq!(alone.baseline.is_some(), baseline);
                same(r, &alone);
            }
        }
    }

    /// A seat the learner fails ends as failed with its error; the others go on to the
    /// results they have in a batch without the failure.
    #[test]
    fn a_failed_seat_ends_alone() {
        let cfg = cfg();
        let seeds = [1, 2, 3];
        let whole = batch(&cfg, &seeds, None);
        let cut = batch(&cfg, &seeds, Some((1, 99)));
        assert_eq!(cut[1].failure.as_deref(), Some("seat 1 gave up at step 99"));
        assert!(!cut[1].complete && cut[1].run.steps_done == 100 && cut[1].greedy_per_step.is_nan());
        same(&cut[0], &whole[0]);
        same(&cut[2], &whole[2]);
    }

    /// The stop flag ends every seat; an empty batch builds no learner.
    #[test]
    fn a_stopped_batch_is_incomplete_and_an_empty_one_is_nothing() {
        let run = crate::Resolved::new(cfg()).unwrap();
        let stop = AtomicBool::new(true);
        let ctl = Control { stop: &stop, progress: &|_| {} };
        let factory = |_: usize, _: usize, seeds: &[u64]| {
            assert!(!seeds.is_empty());
            Ok(Box::new(Each {
                learners: Vec::new(),
                explore: Vec::new(),
                eval: Vec::new(),
                fail: None,
                calls: 0,
            }) as Box<dyn BatchLearner>)
        };
        let r = run_batch(&run, &[0, 1], &factory, ctl, u128::MAX).unwrap();
        assert!(r.iter().all(|r| !r.complete && r.run.steps_done == 0 && r.failure.is_none()));
        assert!(run_batch(&run, &[], &factory, ctl, u128::MAX).unwrap().is_empty());
    }
}
