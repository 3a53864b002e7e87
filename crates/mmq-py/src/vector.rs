//! N environments stepped in one call: NumPy actions in, NumPy observations and rewards
//! out, the GIL released while stepping, robots stepped on threads (rayon). Episodes are
//! cut at `max_episode_steps` and reset on the next step (Gymnasium's next-step
//! autoreset) from the chained seed, so environment i equals a single environment with
//! the same seeds, step for step.

use mmq_core::Start;
use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;

use crate::config::{EnvSpec, Kind, config_err, parse_start};
use crate::env::{Channel, InFlight};
use crate::{env_err, next_seed};

/// One sub-environment and its episode bookkeeping.
#[derive(Debug)]
struct Slot {
    chan: Channel,
    /// Master seed of the current episode.
    seed: u64,
    /// Steps since the episode's reset.
    elapsed: u64,
    /// The last step ended the episode: the next step resets.
    done: bool,
}

/// What one sub-environment's step produced.
#[derive(Clone, Copy, Debug, Default)]
struct Out {
    state: i64,
    reward: f64,
    emitted: f64,
    truncated: bool,
}

impl Slot {
    #[inline]
    fn step(&mut self, action: usize, limit: u64) -> Result<Out, mmq_core::EnvError> {
        if self.done {
            self.seed = next_seed(self.seed);
            let s = self.chan.reset(self.seed)?;
            self.elapsed = 0;
            self.done = false;
            return Ok(Out { state: s as i64, ..Out::default() });
        }
        let st = self.chan.step(action)?;
        self.elapsed += 1;
        let mut reward = st.delivered;
        let truncated = self.elapsed >= limit;
        if truncated {
            self.done = true;
            if self.chan.in_flight == InFlight::Flush {
                reward += self.chan.ch.in_flight();
            }
        }
        Ok(Out { state: st.step.state as i64, reward, emitted: st.step.reward, truncated })
    }
}

/// The native side of `mmq.vector.MmqVectorEnv`, usable from any thread (one call at a
/// time: pyo3's borrow check refuses a second one while a step runs).
#[pyclass(module = "mmq._mmq")]
#[derive(Debug)]
pub struct VecCore {
    slots: Vec<Slot>,
    kind: Kind,
    limit: u64,
    n_actions: usize,
    n_states: usize,
    threads: bool,
}

#[pymethods]
impl VecCore {
    /// `num_envs` environments of one spec.
    #[new]
    #[pyo3(signature = (env, world, delay, start, in_flight, num_envs, max_episode_steps=None, preset=None, profile=None, overrides=None, threads=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        env: &str,
        world: &str,
        delay: &str,
        start: &Bound<'_, PyAny>,
        in_flight: &str,
        num_envs: i64,
        max_episode_steps: Option<i64>,
        preset: Option<&str>,
        profile: Option<&str>,
        overrides: Option<&Bound<'_, PyDict>>,
        threads: Option<bool>,
    ) -> PyResult<Self> {
        if !(1..=1_000_000).contains(&num_envs) {
            return Err(config_err("num_envs", format!("{num_envs} is not accepted; use 1..=1000000")));
        }
        let limit = match max_episode_steps {
            None => u64::MAX,
            Some(m) if m >= 1 => m as u64,
            Some(m) => {
                return Err(config_err(
                    "max_episode_steps",
                    format!("{m} is not accepted; use a positive number of steps or None"),
                ));
            }
        };
        let spec = EnvSpec::resolve(env, world, preset, profile, overrides)?;
        let start: Start = parse_start(start)?;
        let in_flight = InFlight::parse(in_flight)?;
        let slots = (0..num_envs)
            .map(|_| {
                Ok(Slot {
                    chan: Channel::with_ledger(&spec, delay, start, in_flight, false)?,
                    seed: 0,
                    elapsed: 0,
                    done: false,
                })
            })
            .collect::<PyResult<Vec<_>>>()?;
        let env0 = spec.build()?;
        use mmq_core::Env;
        Ok(VecCore {
            slots,
            kind: spec.kind,
            limit,
            n_actions: env0.num_actions(),
            n_states: env0.num_states(),
            threads: threads.unwrap_or(spec.kind == Kind::Robot),
        })
    }

    /// Number of sub-environments.
    #[getter]
    fn num_envs(&self) -> usize {
        self.slots.len()
    }

    /// Number of states of each.
    #[getter]
    fn n_states(&self) -> usize {
        self.n_states
    }

    /// Number of actions of each.
    #[getter]
    fn n_actions(&self) -> usize {
        self.n_actions
    }

    /// The master seed of every sub-environment's current episode.
    #[getter]
    fn seeds(&self) -> Vec<u64> {
        self.slots.iter().map(|s| s.seed).collect()
    }

    /// Whether the sub-environments are robots.
    #[getter]
    fn is_robot(&self) -> bool {
        self.kind == Kind::Robot
    }

    /// Resets every sub-environment from its master seed; returns the states.
    fn reset<'py>(&mut self, py: Python<'py>, seeds: Vec<u64>) -> PyResult<Bound<'py, PyArray1<i64>>> {
        if seeds.len() != self.slots.len() {
            return Err(config_err(
                "seed",
                format!("{} seeds for {} environments", seeds.len(), self.slots.len()),
            ));
        }
        let mut states = Vec::with_capacity(seeds.len());
        for (slot, &seed) in self.slots.iter_mut().zip(&seeds) {
            slot.seed = seed;
            slot.elapsed = 0;
            slot.done = false;
            states.push(slot.chan.reset(seed).map_err(env_err)? as i64);
        }
        Ok(PyArray1::from_vec(py, states))
    }

    /// Steps every sub-environment: (states, delivered rewards, truncated, emitted
    /// rewards). A sub-environment whose last step was truncated is reset instead and
    /// reports its new state with reward 0.
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        actions: PyReadonlyArray1<'py, i64>,
    ) -> PyResult<(
        Bound<'py, PyArray1<i64>>,
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyArray1<f64>>,
    )> {
        let n = self.slots.len();
        let acts = actions.as_slice().map_err(|e| config_err("actions", e))?;
        if acts.len() != n {
            return Err(config_err("actions", format!("{} actions for {n} environments", acts.len())));
        }
        let na = self.n_actions;
        if let Some(&bad) = acts.iter().find(|&&a| a < 0 || a as u64 >= na as u64) {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "action {bad} is out of range; use integers in 0..{na}"
            )));
        }
        let (limit, threads) = (self.limit, self.threads && n > 1);
        let slots = &mut self.slots;
        let mut states = vec![0i64; n];
        let mut rewards = vec![0.0f64; n];
        let mut truncated = vec![false; n];
        let mut emitted = vec![0.0f64; n];
        let res: Result<(), mmq_core::EnvError> = py.detach(|| {
            type Row<'a> =
                (((((&'a mut Slot, &'a i64), &'a mut i64), &'a mut f64), &'a mut bool), &'a mut f64);
            let one = |(((((s, &a), st), r), tr), em): Row<'_>| {
                let o = s.step(a as usize, limit)?;
                (*st, *r, *tr, *em) = (o.state, o.reward, o.truncated, o.emitted);
                Ok(())
            };
            if threads {
                slots
                    .par_iter_mut()
                    .zip(acts.par_iter())
                    .zip(states.par_iter_mut())
                    .zip(rewards.par_iter_mut())
                    .zip(truncated.par_iter_mut())
                    .zip(emitted.par_iter_mut())
                    .try_for_each(one)
            } else {
                slots
                    .iter_mut()
                    .zip(acts)
                    .zip(states.iter_mut())
                    .zip(rewards.iter_mut())
                    .zip(truncated.iter_mut())
                    .zip(emitted.iter_mut())
                    .try_for_each(one)
            }
        });
        res.map_err(env_err)?;
        Ok((
            PyArray1::from_vec(py, states),
            PyArray1::from_vec(py, rewards),
            PyArray1::from_vec(py, truncated),
            PyArray1::from_vec(py, emitted),
        ))
    }

    /// Steps every sub-environment `steps` times with actions drawn uniformly from a
    /// seeded stream, entirely in Rust (a benchmark of the batched step without Python
    /// in the loop); returns the total delivered reward.
    fn random_steps(&mut self, py: Python<'_>, steps: u64, seed: u64) -> PyResult<f64> {
        let (limit, threads, na) = (self.limit, self.threads && self.slots.len() > 1, self.n_actions);
        let slots = &mut self.slots;
        let run = |i: usize, s: &mut Slot| -> Result<f64, mmq_core::EnvError> {
            use rand::RngExt;
            let mut rng = mmq_core::seed::rng_from_seed(seed ^ (i as u64).wrapping_mul(0x9E37_79B9));
            let mut total = 0.0;
            for _ in 0..steps {
                total += s.step(rng.random_range(0..na), limit)?.reward;
            }
            Ok(total)
        };
        let totals: Result<Vec<f64>, _> = py.detach(|| {
            if threads {
                slots.par_iter_mut().enumerate().map(|(i, s)| run(i, s)).collect()
            } else {
                slots.iter_mut().enumerate().map(|(i, s)| run(i, s)).collect()
            }
        });
        Ok(totals.map_err(env_err)?.iter().sum())
    }
}
