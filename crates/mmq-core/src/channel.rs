//! The delay channel: every non-zero reward emitted at step t gets an independent delay
//! d ~ D and is delivered at step t + d; all deliveries due at one step are summed (out
//! of order and overlapping, the paper's setting).
//!
//! Conservation holds at every step: emitted = delivered + in flight. The optional
//! ground-truth [`Ledger`] records which emission fed which delivery; it is for
//! evaluation, logging and the oracle learner only.

use crate::delay::{DelayDist, DelaySampler};
use crate::env::{Action, Env, EnvError, Start, State, Step, StepTrace};
use crate::observer::StepRecord;
use crate::seed::{Rng, rng_from_seed};

/// One emitted reward as the ledger knows it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Emission {
    /// Sequential id, from 0.
    pub id: u64,
    /// Step at which the environment emitted it.
    pub t_emit: u64,
    /// Its value.
    pub value: f64,
    /// The delay drawn, in steps.
    pub delay: u32,
    /// Step at which it is delivered (t_emit + delay).
    pub due: u64,
}

/// Ground truth of the channel: every emission, by id.
#[derive(Clone, Debug, Default)]
pub struct Ledger {
    emissions: Vec<Emission>,
}

impl Ledger {
    /// The emission with this id.
    pub fn get(&self, id: u64) -> Option<&Emission> {
        self.emissions.get(id as usize)
    }
    /// All emissions so far, by id.
    pub fn emissions(&self) -> &[Emission] {
        &self.emissions
    }
}

/// One step through the channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DelayedStep {
    /// Decision step t at which the action was taken.
    pub t: u64,
    /// The environment's transition, with the reward as emitted.
    pub step: Step,
    /// The delay drawn for this step's reward (`None` when the reward was zero).
    pub delay: Option<u32>,
    /// The reward delivered at this step: the sum of every emission due at t.
    pub delivered: f64,
}

/// An environment whose rewards pass through a delay channel.
#[derive(Debug)]
pub struct DelayedReward<E> {
    env: E,
    dist: DelayDist,
    sampler: DelaySampler,
    rng: Rng,
    t: u64,
    /// Pending sums by due step modulo the capacity (a power of two).
    ring: Vec<f64>,
    /// Pending emission ids by due step (only with a ledger).
    ring_ids: Vec<Vec<u64>>,
    ledger: Option<Ledger>,
    delivered_ids: Vec<u64>,
    emitted_total: f64,
    delivered_total: f64,
}

impl<E: Env> DelayedReward<E> {
    /// Wraps `env`; `ledger` keeps the ground truth of every emission.
    pub fn new(env: E, dist: &DelayDist, ledger: bool) -> Self {
        Self {
            env,
            dist: dist.clone(),
            sampler: dist.sampler(),
            rng: rng_from_seed(0),
            t: 0,
            ring: vec![0.0; 64],
            ring_ids: if ledger { vec![Vec::new(); 64] } else { Vec::new() },
            ledger: ledger.then(Ledger::default),
            delivered_ids: Vec::new(),
            emitted_total: 0.0,
            delivered_total: 0.0,
        }
    }

    /// Resets the environment (with `env_seed`) and empties the channel (its delays then
    /// come from `delay_seed`).
    pub fn reset(&mut self, env_seed: u64, delay_seed: u64, start: Start) -> Result<State, EnvError> {
        self.rng = rng_from_seed(delay_seed);
        self.t = 0;
        self.ring.iter_mut().for_each(|x| *x = 0.0);
        self.ring_ids.iter_mut().for_each(Vec::clear);
        if let Some(l) = &mut self.ledger {
            l.emissions.clear();
        }
        self.delivered_ids.clear();
        self.emitted_total = 0.0;
        self.delivered_total = 0.0;
        self.env.reset(env_seed, start)
    }

    /// Takes one action: the environment emits, the channel schedules, and whatever is
    /// due now is delivered.
    ///
    /// Small enough to inline into a learning loop: drawing a delay and the ledger's
    /// bookkeeping are out of line (most steps emit nothing).
    #[inline]
    pub fn step(&mut self, action: Action) -> Result<DelayedStep, EnvError> {
        let step = self.env.step(action)?;
        let t = self.t;
        let delay = if step.reward != 0.0 { Some(self.emit(t, step.reward)) } else { None };
        let slot = (t as usize) & (self.ring.len() - 1);
        let delivered = std::mem::take(&mut self.ring[slot]);
        if self.ledger.is_some() {
            self.deliver_ids(slot);
        }
        self.delivered_total += delivered;
        self.t += 1;
        Ok(DelayedStep { t, step, delay, delivered })
    }

    /// Draws the delay of a non-zero reward emitted at `t` and schedules it.
    #[inline(never)]
    fn emit(&mut self, t: u64, value: f64) -> u32 {
        let d = self.sampler.sample(&mut self.rng);
        self.schedule(t, d, value);
        d
    }

    /// The ledger's ids of the emissions due at `slot` become the delivered ones.
    #[inline(never)]
    fn deliver_ids(&mut self, slot: usize) {
        self.delivered_ids.clear();
        std::mem::swap(&mut self.delivered_ids, &mut self.ring_ids[slot]);
    }

    fn schedule(&mut self, t: u64, d: u32, value: f64) {
        while d as usize >= self.ring.len() {
            self.grow();
        }
        let due = t + u64::from(d);
        let slot = (due as usize) & (self.ring.len() - 1);
        self.ring[slot] += value;
        self.emitted_total += value;
        if let Some(l) = &mut self.ledger {
            let id = l.emissions.len() as u64;
            l.emissions.push(Emission { id, t_emit: t, value, delay: d, due });
            self.ring_ids[slot].push(id);
        }
    }

    /// Doubles the ring, keeping every pending entry at its due step.
    fn grow(&mut self) {
        let old = self.ring.len();
        let new = old * 2;
        let mut ring = vec![0.0; new];
        let mut ids = if self.ledger.is_some() { vec![Vec::new(); new] } else { Vec::new() };
        for due in self.t..self.t + old as u64 {
            let (o, n) = ((due as usize) & (old - 1), (due as usize) & (new - 1));
            ring[n] = self.ring[o];
            if self.ledger.is_some() {
                ids[n] = std::mem::take(&mut self.ring_ids[o]);
            }
        }
        self.ring = ring;
        self.ring_ids = ids;
    }

    /// The next decision step.
    pub fn t(&self) -> u64 {
        self.t
    }
    /// The wrapped environment.
    pub fn env(&self) -> &E {
        &self.env
    }
    /// The wrapped environment, mutably.
    pub fn env_mut(&mut self) -> &mut E {
        &mut self.env
    }
    /// The delay distribution.
    pub fn dist(&self) -> &DelayDist {
        &self.dist
    }
    /// Sum of all rewards emitted so far.
    pub fn emitted_total(&self) -> f64 {
        self.emitted_total
    }
    /// Sum of all rewards delivered so far.
    pub fn delivered_total(&self) -> f64 {
        self.delivered_total
    }
    /// Sum of the rewards emitted but not yet delivered.
    pub fn in_flight(&self) -> f64 {
        self.ring.iter().sum()
    }
    /// The ground-truth ledger, when kept.
    pub fn ledger(&self) -> Option<&Ledger> {
        self.ledger.as_ref()
    }
    /// Ids of the emissions delivered at the last step (with a ledger), in emission order.
    pub fn delivered_ids(&self) -> &[u64] {
        &self.delivered_ids
    }
    /// (emission step, value) of every emission delivered at the last step, in emission
    /// order (empty without a ledger): the ground truth the oracle learns from.
    pub fn delivered_emissions(&self) -> impl Iterator<Item = (u64, f64)> + '_ {
        let ledger = self.ledger.as_ref();
        self.delivered_ids.iter().filter_map(move |&i| ledger?.get(i)).map(|e| (e.t_emit, e.value))
    }
    /// What an observer is told of the step `st` just taken from `state` with `action`
    /// (`model`, `explored`: the learner's decision; `trace`: the step's continuous-time
    /// detail, taken from the environment).
    pub fn record<'a>(
        &'a self,
        state: State,
        action: Action,
        model: Option<usize>,
        explored: bool,
        st: &DelayedStep,
        trace: &'a StepTrace,
    ) -> StepRecord<'a>
    where
        E: Env,
    {
        StepRecord {
            t: st.t,
            state,
            action,
            model,
            explored,
            next_state: st.step.state,
            emitted: st.step.reward,
            event: st.step.event,
            delay: st.delay,
            delivered: st.delivered,
            delivered_ids: &self.delivered_ids,
            ledger: self.ledger.as_ref(),
            sim_time_s: self.env.sim_time_s(),
            trace,
        }
    }
    /// Unwraps the environment.
    pub fn into_inner(self) -> E {
        self.env
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::{Event, PoseSample};
    use crate::world::World;

    /// A scripted environment: the reward at step t is `rewards[t % len]`.
    #[derive(Debug)]
    struct Script {
        rewards: Vec<f64>,
        t: usize,
        world: World,
    }

    impl Script {
        fn new(rewards: Vec<f64>) -> Self {
            Self { rewards, t: 0, world: World::parse("map = \"G.S\"", "s").unwrap() }
        }
    }

    impl Env for Script {
        fn num_states(&self) -> usize {
            1
        }
        fn num_actions(&self) -> usize {
            1
        }
        fn action_names(&self) -> Vec<String> {
            vec!["x".into()]
        }
        fn world(&self) -> &World {
            &self.world
        }
        fn reset(&mut self, _seed: u64, _start: Start) -> Result<State, EnvError> {
            self.t = 0;
            Ok(0)
        }
        fn step(&mut self, _a: Action) -> Result<Step, EnvError> {
            let r = self.rewards[self.t % self.rewards.len()];
            self.t += 1;
            Ok(Step { state: 0, reward: r, event: Event::Moved, terminated: false, truncated: false })
        }
        fn sim_time_s(&self) -> f64 {
            self.t as f64
        }
        fn pose(&self) -> PoseSample {
            PoseSample::default()
        }
    }

    #[test]
    fn no_delay_delivers_at_once() {
        let mut ch = DelayedReward::new(Script::new(vec![1.0, 0.0, -1.0]), &DelayDist::None, true);
        ch.reset(0, 0, Start::World).unwrap();
        let got: Vec<f64> = (0..6).map(|_| ch.step(0).unwrap().delivered).collect();
        assert_eq!(got, vec![1.0, 0.0, -1.0, 1.0, 0.0, -1.0]);
    }

    #[test]
    fn constant_delay_shifts_and_overlaps_sum() {
        // Every step emits 1; with a constant delay of 3 the first three steps deliver
        // nothing and every later one delivers exactly one emission.
        let mut ch = DelayedReward::new(Script::new(vec![1.0]), &DelayDist::Constant(3), true);
        ch.reset(0, 0, Start::World).unwrap();
        let got: Vec<f64> = (0..6).map(|_| ch.step(0).unwrap().delivered).collect();
        assert_eq!(got, vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0]);
        assert_eq!(ch.delivered_ids(), &[2]);
        // A histogram with delays 0 or 2 makes emissions from t and t−2 meet.
        let mut ch =
            DelayedReward::new(Script::new(vec![1.0, 10.0]), &DelayDist::parse("hist:1,0,1").unwrap(), true);
        ch.reset(0, 5, Start::World).unwrap();
        for _ in 0..200 {
            let s = ch.step(0).unwrap();
            let ids = ch.delivered_ids().to_vec();
            let l = ch.ledger().unwrap();
            let sum: f64 = ids.iter().map(|&i| l.get(i).unwrap().value).sum();
            assert_eq!(s.delivered, sum);
            for &i in &ids {
                assert_eq!(l.get(i).unwrap().due, s.t);
            }
        }
        assert!(ch.ledger().unwrap().emissions().iter().any(|e| e.delay == 2));
    }

    #[test]
    fn conservation_at_every_step_with_growth() {
        // Large Poisson delays force the ring to grow several times.
        for (ledger, spec) in
            [(true, "poisson:13"), (false, "poisson:300"), (true, "mix:0.5*poisson:3+0.5*poisson:500")]
        {
            let mut ch = DelayedReward::new(
                Script::new(vec![10.0, -1.0, 0.0, -1.0]),
                &DelayDist::parse(spec).unwrap(),
                ledger,
            );
            ch.reset(0, 9, Start::World).unwrap();
            let mut emitted = 0.0;
            let mut delivered = 0.0;
            for _ in 0..5000 {
                let s = ch.step(0).unwrap();
                emitted += s.step.reward;
                delivered += s.delivered;
                assert_eq!(emitted, delivered + ch.in_flight(), "{spec}");
                assert_eq!(ch.emitted_total(), emitted);
                assert_eq!(ch.delivered_total(), delivered);
            }
        }
    }

    #[test]
    fn ledger_delays_follow_the_distribution() {
        let mut ch = DelayedReward::new(Script::new(vec![1.0]), &DelayDist::Poisson(13.0), true);
        ch.reset(0, 3, Start::World).unwrap();
        for _ in 0..50_000 {
            ch.step(0).unwrap();
        }
        let d: Vec<f64> = ch.ledger().unwrap().emissions().iter().map(|e| e.delay as f64).collect();
        let n = d.len() as f64;
        let m = d.iter().sum::<f64>() / n;
        let v = d.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0);
        assert!((m - 13.0).abs() < 5.0 * (13.0 / n).sqrt(), "mean {m}");
        assert!((v - 13.0).abs() < 5.0 * ((2.0 * 169.0 + 13.0) / n).sqrt(), "var {v}");
    }

    #[test]
    fn same_seed_same_deliveries() {
        let run = |seed| {
            let mut ch =
                DelayedReward::new(Script::new(vec![10.0, -1.0, 0.0]), &DelayDist::Poisson(5.0), false);
            ch.reset(0, seed, Start::World).unwrap();
            (0..1000).map(|_| ch.step(0).unwrap().delivered.to_bits()).collect::<Vec<_>>()
        };
        assert_eq!(run(4), run(4));
        assert_ne!(run(4), run(5));
    }
}
