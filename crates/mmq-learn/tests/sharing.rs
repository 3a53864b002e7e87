//! Parameter sharing: two trajectories learning into one learner, each with its own
//! memory ([`mmq_learn::MemorySlots`]), leave each trajectory's part of the tables
//! exactly as that trajectory alone would, when the two never meet.
//!
//! Trajectory A lives on states 0..5, B on 5..10 (two rings; action a moves 1 + a cells
//! on). Each earns a reward on one cell of its ring, delivered three steps later. The
//! learners update only the pairs a trajectory took and bootstrap from its own states, so
//! with separate memories A's action values and A's actions are those of A alone, bit for
//! bit, however the turns interleave. A memory shared by mistake would credit A's rewards
//! to B's recent pairs (and the other way round), which the second test shows changes
//! them. (mmq-kernel is an exception by design: its kernel is centred on a leader that
//! all trajectories elect; its memory is checked by the second test. So are the
//! deconvolving learners, whose delay estimate and refit times pool every trajectory's
//! steps: the last test checks that each reward is credited to its own trajectory's
//! pairs.)

use mmq_core::seed::rng_from_seed;
use mmq_core::{Rng, State};
use mmq_learn::{Experience, Learner, LearnerKind, LearnerSpec, MemorySlots, Truth, catalogue};

const RING: usize = 5;
const DELAY: u64 = 3;

/// One trajectory on its ring: where it is, its step, its rewards in flight, its stream.
struct Walker {
    base: usize,
    goal: usize,
    value: f64,
    s: State,
    t: u64,
    in_flight: Vec<(u64, f64)>,
    rng: Rng,
    actions: Vec<usize>,
}

impl Walker {
    fn new(base: usize, goal: usize, value: f64, seed: u64) -> Self {
        let rng = rng_from_seed(seed);
        Self { base, goal, value, s: base, t: 0, in_flight: Vec::new(), rng, actions: Vec::new() }
    }

    /// One step of this walker with `learner`.
    fn step(&mut self, learner: &mut dyn Learner) {
        let a = learner.act(self.s, &mut self.rng).action;
        let s2 = self.base + (self.s - self.base + 1 + a) % RING;
        let earned = if s2 == self.base + self.goal { self.value } else { 0.0 };
        let mut truth = Truth::default();
        if earned != 0.0 {
            self.in_flight.push((self.t, earned));
            truth.emitted_now = Some(earned);
        }
        let due: Vec<(u64, f64)> =
            self.in_flight.iter().copied().filter(|&(u, _)| u + DELAY == self.t).collect();
        self.in_flight.retain(|&(u, _)| u + DELAY != self.t);
        truth.delivered = due.clone();
        let reward = due.iter().map(|&(_, v)| v).sum();
        let needs = learner.needs_truth();
        learner.observe(&Experience {
            t: self.t,
            state: self.s,
            action: a,
            next_state: s2,
            reward,
            time_s: (self.t + 1) as f64,
            truth: needs.then_some(&truth),
        });
        self.actions.push(a);
        self.s = s2;
        self.t += 1;
    }
}

fn build(kind: LearnerKind) -> Box<dyn Learner> {
    let mut spec = LearnerSpec::new(kind);
    spec.params.epsilon = 0.3;
    spec.params.q0 = 1.0;
    spec.build(2 * RING, 2, 1 << 30).unwrap()
}

/// A's action values over its ring.
fn values_of_a(learner: &dyn Learner) -> Vec<u64> {
    let mut out = vec![0.0; 2];
    let mut v = Vec::new();
    for s in 0..RING {
        learner.action_values(s, &mut out);
        v.extend(out.iter().map(|x| x.to_bits()));
    }
    v
}

/// The turns: A or B, irregularly interleaved.
fn turns(n: usize) -> Vec<usize> {
    (0..n).map(|k| usize::from((k * 7 + k / 3) % 5 < 2)).collect()
}

/// A's actions and its action values (bits).
type Outcome = (Vec<usize>, Vec<u64>);

/// A alone, then A and B sharing the learner (with separate memories when `separate`).
fn runs(kind: LearnerKind, separate: bool) -> (Outcome, Outcome) {
    let mut alone = build(kind);
    let mut a = Walker::new(0, 3, 10.0, 7);
    for _ in 0..400 {
        a.step(&mut *alone);
    }
    let solo = (a.actions, values_of_a(&*alone));

    let mut shared = build(kind);
    let mut walkers = [Walker::new(0, 3, 10.0, 7), Walker::new(RING, 2, -4.0, 8)];
    let mut slots = MemorySlots::new(2);
    for i in turns(1000) {
        if walkers[0].t == 400 && i == 0 {
            continue;
        }
        if separate {
            slots.load(i, |m| shared.swap_memory(m));
        }
        walkers[i].step(&mut *shared);
    }
    let [a, _] = walkers;
    (solo, (a.actions, values_of_a(&*shared)))
}

fn shareable() -> Vec<LearnerKind> {
    catalogue().into_iter().map(|(k, _, _)| k).filter(|&k| build(k).shares_tables()).collect()
}

/// The deconvolving learners: their delay estimate and refit times pool every
/// trajectory's steps by design, so A's outcome depends on B; checked by their reward fit.
fn deconvolving(kind: LearnerKind) -> bool {
    kind.name().starts_with("deconv")
}

#[test]
fn every_learner_shares() {
    let all: Vec<LearnerKind> = catalogue().into_iter().map(|(k, _, _)| k).collect();
    assert_eq!(shareable(), all, "a learner stopped sharing its tables; update docs/swarm.md");
}

#[test]
fn a_shared_learner_with_separate_memories_learns_each_trajectory_as_alone() {
    // mmq-kernel's credit is centred on the model chosen most often by every trajectory
    // (its leader): B's choices move it, so A's updates depend on B by design.
    for kind in shareable().into_iter().filter(|&k| k.name() != "mmq-kernel" && !deconvolving(k)) {
        let (solo, shared) = runs(kind, true);
        assert_eq!(solo.0.len(), 400, "{}", kind.name());
        assert_eq!(solo, shared, "{}: A's actions and values differ from A alone", kind.name());
    }
}

#[test]
fn one_memory_for_both_trajectories_would_change_them() {
    // Q-learning keeps no memory of past steps; every other learner credits or traces
    // past pairs, so mixing B's steps into A's memory shows.
    for kind in shareable().into_iter().filter(|k| k.name() != "q") {
        let (solo, mixed) = runs(kind, false);
        assert_ne!(solo, mixed, "{}: the test cannot see a shared memory", kind.name());
    }
}

/// R̂ of a deconvolving learner shared by A and B: A's +10 on pairs of A's ring, B's −4
/// on pairs of B's ring, nothing else. (Which pairs of a ring: the move into the goal
/// cell, or, one step less delayed, the goal cell's own moves, which always follow it;
/// the fit prefers the latter, [`mmq_learn::deconv`]'s successor groups.) With one
/// memory for both, B's steps stand between A's and their rewards, and the fit credits
/// the other ring's pairs.
#[test]
fn a_shared_deconvolving_learner_credits_each_reward_to_its_own_trajectory() {
    // Per ring: its largest and smallest R̂.
    let ranges = |r: &[f64]| {
        let range = |v: &[f64]| v.iter().fold((f64::MAX, f64::MIN), |(lo, hi), &x| (lo.min(x), hi.max(x)));
        (range(&r[..2 * RING]), range(&r[2 * RING..]))
    };
    for kind in shareable().into_iter().filter(|&k| deconvolving(k)) {
        let fit = |separate: bool| {
            let mut shared = build(kind);
            let mut walkers = [Walker::new(0, 3, 10.0, 7), Walker::new(RING, 2, -4.0, 8)];
            let mut slots = MemorySlots::new(2);
            for i in turns(6000) {
                if separate {
                    slots.load(i, |m| shared.swap_memory(m));
                }
                walkers[i].step(&mut *shared);
            }
            let tables = shared.tables();
            tables.into_iter().find(|t| t.name == "r_hat").expect("R̂ is exported").data
        };
        let own = fit(true);
        let ((a_lo, a_hi), (b_lo, b_hi)) = ranges(&own);
        let near = |x: f64, v: f64| (x - v).abs() < 0.5 + 0.1 * v.abs();
        assert!(
            near(a_lo, 0.0) && near(a_hi, 10.0) && near(b_lo, -4.0) && near(b_hi, 0.0),
            "{}: R̂ = {own:?}",
            kind.name()
        );
        let mixed = fit(false);
        let ((a_lo, a_hi), (b_lo, b_hi)) = ranges(&mixed);
        assert!(
            !(near(a_lo, 0.0) && near(a_hi, 10.0) && near(b_lo, -4.0) && near(b_hi, 0.0)),
            "{}: one memory for both went unseen: R̂ = {mixed:?}",
            kind.name()
        );
    }
}
