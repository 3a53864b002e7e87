//! The delay channel: every non-zero reward emitted at step t gets an independent delay
//! d ~ D and is delivered at step t + d; all deliveries due at one step are summed (out
//! of order and overlapping, the paper's setting).
//!
//! A delay in seconds ([`DelayDist::Seconds`]) counts simulated time instead: a reward
//! emitted at the end of a step, at time t_e = `Telemetry::sim_time_s()`, with delay d seconds is
//! delivered with the first decision that *ends* at or after t_e + d (times compared to
//! the nanosecond), summed with whatever else is due, exactly like step delays. A delay
//! of 0 s is delivered at once, like a delay of 0 steps.
//!
//! Conservation holds at every step: emitted = delivered + in flight. The optional
//! ground-truth [`Ledger`] records which emission fed which delivery, with times in steps
//! and seconds; it is for evaluation, logging and the oracle learner only. Without a
//! ledger the channel still keeps the mean delay of what it delivered
//! ([`DelayedReward::delay_stats`]).

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use crate::delay::{DelayDist, DelaySampler, SecondsSampler};
use crate::env::{Action, Env, EnvError, Start, State, Step, StepTrace, Telemetry};
use crate::observer::{Resume, StepRecord};
use crate::seed::{Rng, rng_from_seed};

/// Times closer than this are equal when the channel compares a due time with the end
/// of a decision, seconds (the grid's clock is a product t·period, not exact).
pub const TIME_TOLERANCE_S: f64 = 1e-9;

/// One emitted reward as the ledger knows it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Emission {
    /// Sequential id, from 0.
    pub id: u64,
    /// Step at which the environment emitted it.
    pub t_emit: u64,
    /// Its value.
    pub value: f64,
    /// The delay in steps: drawn (a delay in steps), or the steps from emission to
    /// delivery (a delay in seconds; [`Emission::PENDING`] while in flight).
    pub delay: u32,
    /// Step at which it is delivered (t_emit + delay; for a delay in seconds
    /// `u64::MAX` while in flight).
    pub due: u64,
    /// Simulated time of the emission (the end of step `t_emit`), seconds.
    pub t_emit_s: f64,
    /// The delay drawn in seconds (a delay in seconds); NaN for a delay in steps.
    pub drawn_s: f64,
    /// Simulated time at the end of the delivery step, seconds (NaN while in flight).
    pub due_s: f64,
}

impl Emission {
    /// `delay` of an emission delayed in seconds that is still in flight.
    pub const PENDING: u32 = u32::MAX;

    /// The delay from emission to delivery in seconds (`due_s − t_emit_s`; NaN while in
    /// flight). For a delay in seconds it is the drawn delay plus the wait for the end of
    /// the decision that delivers it.
    pub fn delay_s(&self) -> f64 {
        self.due_s - self.t_emit_s
    }

    /// Whether it has been delivered.
    pub fn delivered(&self) -> bool {
        !self.due_s.is_nan()
    }
}

/// Ground truth of the channel: every emission, by id; or, trimmed
/// ([`DelayedReward::trim_ledger`]), the emissions from the oldest one still in flight on.
#[derive(Clone, Debug, Default)]
pub struct Ledger {
    /// The emissions kept, by id from `first`.
    emissions: Vec<Emission>,
    /// Id of `emissions[0]` (0 unless trimmed).
    first: u64,
    /// Drop the delivered emissions older than every one in flight.
    trim: bool,
}

impl Ledger {
    /// The emission with this id (`None` if unknown, or trimmed away).
    pub fn get(&self, id: u64) -> Option<&Emission> {
        self.emissions.get(usize::try_from(id.checked_sub(self.first)?).ok()?)
    }
    /// The emissions kept, by id from [`Ledger::first_id`]: every emission so far,
    /// unless trimmed.
    pub fn emissions(&self) -> &[Emission] {
        &self.emissions
    }
    /// Id of the first emission kept (0 unless trimmed).
    pub fn first_id(&self) -> u64 {
        self.first
    }
    fn get_mut(&mut self, id: u64) -> &mut Emission {
        &mut self.emissions[(id - self.first) as usize]
    }
    /// Adds the next emission (its id is `first_id() + emissions().len()`). Trimmed,
    /// before the list grows, the delivered emissions older than every one in flight
    /// are dropped when they are at least half of it (so each emission is moved at most
    /// about once). The emissions delivered at the last step stay until an emission is
    /// made at the next step: pushes come before deliveries within a step, so a step's
    /// record always finds its deliveries and its emission.
    fn push(&mut self, e: Emission) {
        let n = self.emissions.len();
        if self.trim && n == self.emissions.capacity() && n >= 64 {
            let done = self.emissions.iter().take_while(|e| e.delivered()).count();
            if done >= n / 2 {
                self.emissions.drain(..done);
                self.first += done as u64;
            }
        }
        self.emissions.push(e);
    }
    fn clear(&mut self) {
        self.emissions.clear();
        self.first = 0;
    }
}

/// One step through the channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DelayedStep {
    /// Decision step t at which the action was taken.
    pub t: u64,
    /// The environment's transition, with the reward as emitted.
    pub step: Step,
    /// The delay drawn for this step's reward (`None` when the reward was zero); for a
    /// delay in seconds [`Emission::PENDING`] (the steps are known at delivery).
    pub delay: Option<u32>,
    /// The delay drawn in seconds for this step's reward (a delay in seconds only).
    pub delay_s: Option<f64>,
    /// The reward delivered at this step: the sum of every emission due at t.
    pub delivered: f64,
    /// Simulated time at the end of the step, seconds.
    pub time_s: f64,
}

/// The delays of the rewards delivered so far.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DelayStats {
    /// Emissions delivered.
    pub delivered: u64,
    /// Sum of their delays in steps (delivery step − emission step).
    pub sum_steps: f64,
    /// Sum of their delays in seconds (end of the delivery step − emission time).
    pub sum_s: f64,
}

impl DelayStats {
    /// Mean delivered delay in steps (NaN when nothing was delivered).
    pub fn mean_steps(&self) -> f64 {
        self.sum_steps / self.delivered as f64
    }
    /// Mean delivered delay in seconds (NaN when nothing was delivered).
    pub fn mean_s(&self) -> f64 {
        self.sum_s / self.delivered as f64
    }
}

/// Pending rewards of a step delay, by due step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Slot {
    /// Sum of the values due.
    sum: f64,
    /// How many emissions are due.
    n: u32,
    /// Sum of their emission steps and emission times (for [`DelayStats`]).
    sum_t: f64,
    sum_time: f64,
}

/// A reward in flight with a delay in seconds.
#[derive(Clone, Copy, Debug)]
struct InFlight {
    due_s: f64,
    seq: u64,
    value: f64,
    t_emit: u64,
    t_emit_s: f64,
}

impl PartialEq for InFlight {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == std::cmp::Ordering::Equal
    }
}
impl Eq for InFlight {}
impl PartialOrd for InFlight {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for InFlight {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.due_s.total_cmp(&o.due_s).then(self.seq.cmp(&o.seq))
    }
}

/// The channel's state for a delay in seconds.
#[derive(Clone, Debug)]
struct SecondsChannel {
    sampler: SecondsSampler,
    /// Rewards in flight, earliest due first.
    heap: BinaryHeap<Reverse<InFlight>>,
    /// Emissions made (the next sequence number, = the ledger id).
    seq: u64,
    /// Those delivered at the last step (scratch).
    due: Vec<InFlight>,
}

/// An environment whose rewards pass through a delay channel.
#[derive(Debug)]
pub struct DelayedReward<E> {
    env: E,
    dist: DelayDist,
    sampler: DelaySampler,
    rng: Rng,
    t: u64,
    /// Pending rewards by due step modulo the capacity (a power of two).
    ring: Vec<Slot>,
    /// Pending emission ids by due step (only with a ledger).
    ring_ids: Vec<Vec<u64>>,
    /// The channel of a delay in seconds (then the ring stays empty).
    seconds: Option<SecondsChannel>,
    ledger: Option<Ledger>,
    delivered_ids: Vec<u64>,
    emitted_total: f64,
    delivered_total: f64,
    stats: DelayStats,
}

impl<E: Env + Telemetry> DelayedReward<E> {
    /// Wraps `env`; `ledger` keeps the ground truth of every emission.
    pub fn new(env: E, dist: &DelayDist, ledger: bool) -> Self {
        let seconds = dist.as_seconds().map(|d| SecondsChannel {
            sampler: d.sampler(),
            heap: BinaryHeap::new(),
            seq: 0,
            due: Vec::new(),
        });
        Self {
            env,
            dist: dist.clone(),
            sampler: dist.sampler(),
            rng: rng_from_seed(0),
            t: 0,
            ring: vec![Slot::default(); 64],
            ring_ids: if ledger { vec![Vec::new(); 64] } else { Vec::new() },
            seconds,
            ledger: ledger.then(Ledger::default),
            delivered_ids: Vec::new(),
            emitted_total: 0.0,
            delivered_total: 0.0,
            stats: DelayStats::default(),
        }
    }

    /// Resets the environment (with `env_seed`) and empties the channel (its delays then
    /// come from `delay_seed`).
    pub fn reset(&mut self, env_seed: u64, delay_seed: u64, start: Start) -> Result<State, EnvError> {
        self.rng = rng_from_seed(delay_seed);
        self.t = 0;
        self.ring.iter_mut().for_each(|x| *x = Slot::default());
        self.ring_ids.iter_mut().for_each(Vec::clear);
        if let Some(sc) = &mut self.seconds {
            sc.heap.clear();
            sc.seq = 0;
            sc.due.clear();
        }
        if let Some(l) = &mut self.ledger {
            l.clear();
        }
        self.delivered_ids.clear();
        self.emitted_total = 0.0;
        self.delivered_total = 0.0;
        self.stats = DelayStats::default();
        self.env.reset(env_seed, start)
    }

    /// Takes one action: the environment emits, the channel schedules, and whatever is
    /// due now is delivered.
    ///
    /// Small enough to inline into a learning loop: drawing a delay, the ledger's
    /// bookkeeping and the channel of a delay in seconds are out of line (most steps emit
    /// nothing).
    #[inline]
    pub fn step(&mut self, action: Action) -> Result<DelayedStep, EnvError> {
        let step = self.env.step(action)?;
        let t = self.t;
        if self.seconds.is_some() {
            return Ok(self.step_seconds(t, step));
        }
        let delay = if step.reward != 0.0 { Some(self.emit(t, step.reward)) } else { None };
        let slot = (t as usize) & (self.ring.len() - 1);
        let delivered = self.ring[slot].sum;
        if self.ring[slot].n != 0 {
            self.deliver_slot(t, slot);
        } else if self.ledger.is_some() {
            self.delivered_ids.clear();
        }
        self.delivered_total += delivered;
        self.t += 1;
        Ok(DelayedStep { t, step, delay, delay_s: None, delivered, time_s: self.env.sim_time_s() })
    }

    /// Draws the delay of a non-zero reward emitted at `t` and schedules it.
    #[inline(never)]
    fn emit(&mut self, t: u64, value: f64) -> u32 {
        let d = self.sampler.sample(&mut self.rng);
        self.schedule(t, d, value);
        d
    }

    /// Delivers the emissions due at `slot` (step `t`): the statistics, and the ledger's
    /// ids become the delivered ones.
    #[inline(never)]
    fn deliver_slot(&mut self, t: u64, slot: usize) {
        let now = self.env.sim_time_s();
        let s = std::mem::take(&mut self.ring[slot]);
        let n = f64::from(s.n);
        self.stats.delivered += u64::from(s.n);
        self.stats.sum_steps += n * t as f64 - s.sum_t;
        self.stats.sum_s += n * now - s.sum_time;
        if let Some(l) = &mut self.ledger {
            self.delivered_ids.clear();
            std::mem::swap(&mut self.delivered_ids, &mut self.ring_ids[slot]);
            for &id in &self.delivered_ids {
                l.get_mut(id).due_s = now;
            }
        }
    }

    fn schedule(&mut self, t: u64, d: u32, value: f64) {
        while d as usize >= self.ring.len() {
            self.grow();
        }
        let now = self.env.sim_time_s();
        let due = t + u64::from(d);
        let slot = (due as usize) & (self.ring.len() - 1);
        let r = &mut self.ring[slot];
        r.sum += value;
        r.n += 1;
        r.sum_t += t as f64;
        r.sum_time += now;
        self.emitted_total += value;
        if let Some(l) = &mut self.ledger {
            let id = l.first + l.emissions.len() as u64;
            l.push(Emission {
                id,
                t_emit: t,
                value,
                delay: d,
                due,
                t_emit_s: now,
                drawn_s: f64::NAN,
                due_s: f64::NAN,
            });
            self.ring_ids[slot].push(id);
        }
    }

    /// Doubles the ring, keeping every pending entry at its due step.
    fn grow(&mut self) {
        let old = self.ring.len();
        let new = old * 2;
        let mut ring = vec![Slot::default(); new];
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

    /// One step of the channel of a delay in seconds: the reward emitted now (at the end
    /// of step `t`) is scheduled at now + d, then everything due by now is delivered,
    /// summed in emission order.
    #[inline(never)]
    fn step_seconds(&mut self, t: u64, step: Step) -> DelayedStep {
        let now = self.env.sim_time_s();
        let sc = self.seconds.as_mut().expect("a channel in seconds");
        let mut delay_s = None;
        if step.reward != 0.0 {
            let d = sc.sampler.sample(&mut self.rng);
            delay_s = Some(d);
            let seq = sc.seq;
            sc.seq += 1;
            sc.heap.push(Reverse(InFlight {
                due_s: now + d,
                seq,
                value: step.reward,
                t_emit: t,
                t_emit_s: now,
            }));
            self.emitted_total += step.reward;
            if let Some(l) = &mut self.ledger {
                l.push(Emission {
                    id: seq,
                    t_emit: t,
                    value: step.reward,
                    delay: Emission::PENDING,
                    due: u64::MAX,
                    t_emit_s: now,
                    drawn_s: d,
                    due_s: f64::NAN,
                });
            }
        }
        sc.due.clear();
        while let Some(Reverse(top)) = sc.heap.peek()
            && top.due_s <= now + TIME_TOLERANCE_S
        {
            sc.due.push(*top);
            sc.heap.pop();
        }
        sc.due.sort_unstable_by_key(|e| e.seq);
        let mut delivered = 0.0;
        self.delivered_ids.clear();
        for e in &sc.due {
            delivered += e.value;
            self.stats.delivered += 1;
            self.stats.sum_steps += (t - e.t_emit) as f64;
            self.stats.sum_s += now - e.t_emit_s;
            if let Some(l) = &mut self.ledger {
                let em = l.get_mut(e.seq);
                em.due = t;
                em.delay = u32::try_from(t - e.t_emit).unwrap_or(u32::MAX - 1);
                em.due_s = now;
                self.delivered_ids.push(e.seq);
            }
        }
        self.delivered_total += delivered;
        self.t += 1;
        DelayedStep { t, step, delay: delay_s.map(|_| Emission::PENDING), delay_s, delivered, time_s: now }
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
        match &self.seconds {
            Some(sc) => {
                let mut v: Vec<&InFlight> = sc.heap.iter().map(|r| &r.0).collect();
                v.sort_unstable_by_key(|e| e.seq);
                v.iter().map(|e| e.value).sum()
            }
            None => self.ring.iter().map(|s| s.sum).sum(),
        }
    }
    /// How many emissions are in flight.
    pub fn in_flight_count(&self) -> u64 {
        match &self.seconds {
            Some(sc) => sc.heap.len() as u64,
            None => self.ring.iter().map(|s| u64::from(s.n)).sum(),
        }
    }
    /// The delays of everything delivered so far (kept with or without a ledger).
    pub fn delay_stats(&self) -> DelayStats {
        self.stats
    }
    /// Keeps only what a step's record needs of the ledger (`trim` = true): the
    /// emissions from the oldest one still in flight on, which hold those in flight and
    /// those delivered at the last step, instead of every emission of the run (a long
    /// run's ledger grows by 64 bytes an emission). What [`Self::delivered_ids`],
    /// [`Self::delivered_emissions`] and [`StepRecord::emission`] see is unchanged.
    pub fn trim_ledger(&mut self, trim: bool) {
        if let Some(l) = &mut self.ledger {
            l.trim = trim;
        }
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
    /// Where the run stands before the next step, for an observer that skipped steps
    /// ([`crate::Observer::on_resume`]): the same totals an observer summing every
    /// step's emitted and delivered rewards would hold.
    pub fn resume_point(&self) -> Resume {
        Resume {
            t: self.t,
            sim_time_s: self.env.sim_time_s(),
            emitted_total: self.emitted_total,
            delivered_total: self.delivered_total,
            emissions: self.stats.delivered + self.in_flight_count(),
        }
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
    ) -> StepRecord<'a> {
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
    }

    impl Telemetry for Script {
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
    fn a_trimmed_ledger_shows_every_step_the_same_and_stays_small() {
        for spec in ["poisson:13", "mix:0.5*poisson:3+0.5*poisson:500", "const:2.5s", "const:0"] {
            let dist = DelayDist::parse(spec).unwrap();
            let make = |trim| {
                let mut ch = DelayedReward::new(Script::new(vec![10.0, -1.0, 0.0, -1.0]), &dist, true);
                ch.trim_ledger(trim);
                ch.reset(0, 9, Start::World).unwrap();
                ch
            };
            let (mut full, mut trimmed) = (make(false), make(true));
            let trace = StepTrace::default();
            let mut longest = 0;
            for _ in 0..20_000 {
                let (a, b) = (full.step(0).unwrap(), trimmed.step(0).unwrap());
                assert_eq!(a, b, "{spec}");
                let parts = |ch: &DelayedReward<Script>| {
                    let l = ch.ledger().unwrap();
                    // Debug text: the NaN fields compare equal.
                    format!("{:?}", ch.delivered_ids().iter().map(|&i| l.get(i).unwrap()).collect::<Vec<_>>())
                };
                assert_eq!(parts(&full), parts(&trimmed), "{spec}");
                let (ra, rb) = (
                    full.record(0, 0, None, false, &a, &trace),
                    trimmed.record(0, 0, None, false, &b, &trace),
                );
                assert_eq!(format!("{:?}", ra.emission()), format!("{:?}", rb.emission()), "{spec}");
                assert_eq!(ra.emission().is_some(), a.step.reward != 0.0, "{spec}");
                longest = longest.max(trimmed.ledger().unwrap().emissions().len());
            }
            let l = trimmed.ledger().unwrap();
            assert_eq!(full.ledger().unwrap().emissions().len(), 15_000, "{spec}");
            assert_eq!(l.first_id() + l.emissions().len() as u64, 15_000, "{spec}");
            // Bounded by the emissions in flight (a few thousand at most for the mixture's
            // 500-step delays), not by the run's 15,000.
            assert!(longest < 8_192, "{spec}: {longest} kept");
            assert!(l.first_id() > 0, "{spec}");
        }
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
