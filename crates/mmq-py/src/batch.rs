//! A batched Python agent as a batch learner of mmq: [`PyBatch`] drives an object with
//! `act_batch(states)`, `observe_batch(states, actions, rewards, next_states, infos)`
//! and, if it has one, `greedy_batch(states)` (else `act_batch`) for all the seeds of
//! one task in lockstep ([`mmq_lab::batch`]).
//!
//! The arrays it hands over are its own, allocated once per batch, read-only for Python
//! and overwritten at the next call: a call costs no allocation but the call's own
//! argument tuple. The GIL is held only during the calls. An exception fails every seed
//! of the batch with its text; an action that is not an int or is out of range fails its
//! seed only; a batch over its time limit fails all its seeds; `KeyboardInterrupt` and
//! `SystemExit` stop the whole evaluation (as for an agent of one seed,
//! [`crate::agent`]).

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Instant;

use mmq_lab::batch::{BatchLearner, Seat};
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::{PyKeyboardInterrupt, PySystemExit};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict};

use crate::agent::Shared;

/// The agent's methods, looked up once.
#[derive(Debug)]
struct Methods {
    act: Py<PyAny>,
    observe: Py<PyAny>,
    /// `greedy_batch`, or `act_batch` when it has none.
    greedy: Py<PyAny>,
}

/// The driver's arrays: two blocks written by Rust (one borrow per call), handed to
/// Python as read-only views of their rows.
#[derive(Debug)]
struct Arrays {
    /// Rows: states, actions, next states, steps.
    ints: Py<PyArray2<i64>>,
    /// Rows: rewards, simulated times.
    floats: Py<PyArray2<f64>>,
    states: Py<PyAny>,
    actions: Py<PyAny>,
    next_states: Py<PyAny>,
    rewards: Py<PyAny>,
    /// `{"t": steps, "time_s": simulated times}`.
    infos: Py<PyDict>,
}

/// Rows of `ints` and `floats`.
const STATES: usize = 0;
const ACTIONS: usize = 1;
const NEXT_STATES: usize = 2;
const T: usize = 3;
const REWARDS: usize = 0;
const TIME_S: usize = 1;

impl Arrays {
    /// The arrays of a batch of `n` seeds.
    fn new(py: Python<'_>, n: usize) -> PyResult<Arrays> {
        let ints = PyArray2::<i64>::zeros(py, [4, n], false);
        let floats = PyArray2::<f64>::zeros(py, [2, n], false);
        let ro = PyDict::new(py);
        ro.set_item("write", false)?;
        let row = |block: &Bound<'_, PyAny>, k: usize| -> PyResult<Py<PyAny>> {
            let v = block.get_item(k)?;
            v.call_method("setflags", (), Some(&ro))?;
            Ok(v.unbind())
        };
        let infos = PyDict::new(py);
        infos.set_item("t", row(ints.as_any(), T)?)?;
        infos.set_item("time_s", row(floats.as_any(), TIME_S)?)?;
        Ok(Arrays {
            states: row(ints.as_any(), STATES)?,
            actions: row(ints.as_any(), ACTIONS)?,
            next_states: row(ints.as_any(), NEXT_STATES)?,
            rewards: row(floats.as_any(), REWARDS)?,
            ints: ints.unbind(),
            floats: floats.unbind(),
            infos: infos.unbind(),
        })
    }

    /// Writes the seats' states (for `act_batch` and `greedy_batch`).
    fn fill_states(&self, py: Python<'_>, seats: &[Seat]) {
        let mut w = self.ints.bind(py).readwrite();
        let all = w.as_slice_mut().expect("the driver's arrays are contiguous");
        for (o, s) in all[STATES * seats.len()..].iter_mut().zip(seats) {
            *o = s.state as i64;
        }
    }

    /// Writes what the seats' steps gave (for `observe_batch`; the states are those
    /// acted in, written for `act_batch`).
    fn fill_steps(&self, py: Python<'_>, seats: &[Seat]) {
        let n = seats.len();
        let mut w = self.ints.bind(py).readwrite();
        let all = w.as_slice_mut().expect("the driver's arrays are contiguous");
        let (_, rest) = all.split_at_mut(ACTIONS * n);
        let (actions, rest) = rest.split_at_mut(n);
        let (next_states, t) = rest.split_at_mut(n);
        for (i, s) in seats.iter().enumerate() {
            (actions[i], next_states[i], t[i]) = (s.action as i64, s.next_state as i64, s.t as i64);
        }
        let mut w = self.floats.bind(py).readwrite();
        let all = w.as_slice_mut().expect("the driver's arrays are contiguous");
        let (rewards, time_s) = all.split_at_mut(n);
        for (i, s) in seats.iter().enumerate() {
            (rewards[i], time_s[i]) = (s.reward, s.time_s);
        }
    }
}

/// A batched Python agent driven for the seeds of one task.
#[derive(Debug)]
pub struct PyBatch {
    /// The agent's methods and the arrays; None when it could not be made (the seeds
    /// fail with `failure` at the first step).
    live: Option<(Methods, Arrays)>,
    /// Why every seed fails (the agent could not be made).
    failure: Option<String>,
    seeds: Vec<u64>,
    n_actions: usize,
    shared: Arc<Shared>,
    /// The batch's wall-clock limit: (when it ends, its length, the limit per seed).
    deadline: Option<(Instant, f64, f64)>,
}

impl PyBatch {
    /// Drives `agent` (`make_agent`'s answer, or its exception) for `seeds`; an object
    /// without `act_batch` and `observe_batch` fails them all. The batch's time limit is
    /// `time_limit_s` per seed.
    pub fn new(
        py: Python<'_>,
        agent: PyResult<Py<PyAny>>,
        seeds: &[u64],
        n_actions: usize,
        shared: Arc<Shared>,
        time_limit_s: Option<f64>,
    ) -> PyBatch {
        let n = seeds.len();
        let deadline = time_limit_s.map(|s| {
            let all = s * n as f64;
            (Instant::now() + std::time::Duration::from_secs_f64(all), all, s)
        });
        let mut me =
            PyBatch { live: None, failure: None, seeds: seeds.to_vec(), n_actions, shared, deadline };
        match agent.and_then(|a| me.prepare(py, a.bind(py))) {
            Ok(Ok(live)) => me.live = Some(live),
            Ok(Err(why)) => me.failure = Some(why),
            Err(e) => me.raised(py, "make_agent", e, &mut []),
        }
        me
    }

    /// The agent's methods and the driver's arrays, or why the agent cannot be driven.
    fn prepare(&self, py: Python<'_>, a: &Bound<'_, PyAny>) -> PyResult<Result<(Methods, Arrays), String>> {
        let method = |m: &str| a.getattr(m).ok().filter(|f| f.is_callable()).map(Bound::unbind);
        let (Some(act), Some(observe)) = (method("act_batch"), method("observe_batch")) else {
            let what = a.get_type().name().map_or_else(|_| "?".into(), |n| n.to_string());
            let m = if method("act_batch").is_none() { "act_batch" } else { "observe_batch" };
            return Ok(Err(format!(
                "make_agent returned an object of type {what} without a method `{m}`; a batched agent has act_batch(states) and observe_batch(states, actions, rewards, next_states, infos)"
            )));
        };
        let greedy = method("greedy_batch").unwrap_or_else(|| act.clone_ref(py));
        let arrays = Arrays::new(py, self.seeds.len())?;
        Ok(Ok((Methods { act, observe, greedy }, arrays)))
    }

    /// Fails every live seat (of `seats`) with `why`, and the batch.
    fn fail_all(&mut self, why: String, seats: &mut [Seat]) {
        for s in seats.iter_mut().filter(|s| s.live && s.failure.is_none()) {
            s.failure = Some(why.clone());
        }
        self.failure.get_or_insert(why);
    }

    /// An exception from the agent: an interruption stops the evaluation, anything else
    /// fails every seed of the batch with its text and traceback.
    fn raised(&mut self, py: Python<'_>, call: &str, e: PyErr, seats: &mut [Seat]) {
        if e.is_instance_of::<PyKeyboardInterrupt>(py) || e.is_instance_of::<PySystemExit>(py) {
            return self.shared.interrupt(e);
        }
        let tb = e.traceback(py).and_then(|t| t.format().ok()).unwrap_or_default();
        self.fail_all(format!("{call} raised {e}\n{tb}").trim_end().to_string(), seats);
    }

    /// Whether the agent may be called for `seats`: it was made and has not failed, the
    /// evaluation was not stopped, and some seat takes the step. A batch that failed
    /// before (its agent could not be made) fails the seats now.
    fn callable(&mut self, seats: &mut [Seat]) -> bool {
        if let Some(why) = self.failure.clone() {
            self.fail_all(why, seats);
            return false;
        }
        !self.shared.stop.load(Ordering::Relaxed) && seats.iter().any(|s| s.live && s.failure.is_none())
    }

    /// Calls `act_batch` or `greedy_batch` with the seats' states and checks the actions.
    fn choose(&mut self, greedy: bool, seats: &mut [Seat]) {
        for s in seats.iter_mut() {
            s.action = 0;
        }
        if !self.callable(seats) {
            return;
        }
        if let Some((end, all, each)) = self.deadline
            && Instant::now() > end
        {
            return self.fail_all(
                format!(
                    "the batch of {} seeds ran out of time: over its limit of {all} s ({each} s per seed, time_limit_s)",
                    seats.len()
                ),
                seats,
            );
        }
        let name = if greedy { "greedy_batch(states)" } else { "act_batch(states)" };
        Python::attach(|py| {
            let Some((m, a)) = &self.live else { return };
            a.fill_states(py, seats);
            let method = if greedy { &m.greedy } else { &m.act };
            match method.call1(py, (a.states.clone_ref(py),)) {
                Ok(v) => {
                    if let Err(why) = self.check_actions(name, v.bind(py), seats) {
                        self.fail_all(why, seats);
                    }
                }
                Err(e) => self.raised(py, name, e, seats),
            }
        });
    }

    /// Reads the actions of `v` into the seats: a bad action fails its seat; an answer
    /// that is not n actions is the batch's error.
    fn check_actions(&self, call: &str, v: &Bound<'_, PyAny>, seats: &mut [Seat]) -> Result<(), String> {
        let n = seats.len();
        let na = self.n_actions as i64;
        let what = |v: &Bound<'_, PyAny>| {
            let r = v.repr().map_or_else(|_| "?".into(), |r| r.to_string());
            let ty = v.get_type().name().map_or_else(|_| "?".into(), |t| t.to_string());
            (r, ty)
        };
        let bad_len = |len: Option<usize>| {
            let (r, ty) = what(v);
            let got = len.map_or_else(|| "no sequence".to_string(), |l| format!("{l} values"));
            let r: String = r.chars().take(200).collect();
            format!(
                "{call} returned {r} ({ty}): {got}; give one int action per seed ({n}), as a NumPy array or a list"
            )
        };
        let seat_msg = |i: usize, a: i64| {
            let seed = self.seeds[i];
            format!("{call} returned {a} for seed {seed} (index {i}); the actions are 0..{}", na - 1)
        };
        // The fast path: a one-dimensional int64 array.
        if let Ok(arr) = v.cast::<PyArray1<i64>>() {
            if arr.len() != n {
                return Err(bad_len(Some(arr.len())));
            }
            // A copy (no borrow to register: nothing else holds it meanwhile).
            if let Ok(acts) = arr.to_vec() {
                for (i, (seat, &a)) in seats.iter_mut().zip(&acts).enumerate() {
                    if !seat.live || seat.failure.is_some() {
                        continue;
                    }
                    if (0..na).contains(&a) {
                        seat.action = a as usize;
                    } else {
                        seat.failure = Some(seat_msg(i, a));
                    }
                }
                return Ok(());
            }
        }
        let len = v.len().ok();
        if len != Some(n) || v.is_instance_of::<pyo3::types::PyString>() {
            return Err(bad_len(len));
        }
        for (i, seat) in seats.iter_mut().enumerate() {
            if !seat.live || seat.failure.is_some() {
                continue;
            }
            let x = v.get_item(i).map_err(|e| format!("{call}: cannot read its action {i}: {e}"))?;
            match x.extract::<i64>() {
                Ok(a) if !x.is_instance_of::<PyBool>() && (0..na).contains(&a) => seat.action = a as usize,
                Ok(a) if !x.is_instance_of::<PyBool>() => seat.failure = Some(seat_msg(i, a)),
                _ => {
                    let (r, ty) = what(&x);
                    seat.failure = Some(format!(
                        "{call} returned {r} ({ty}) for seed {} (index {i}), not an int action in 0..{}",
                        self.seeds[i],
                        na - 1
                    ));
                }
            }
        }
        Ok(())
    }
}

impl BatchLearner for PyBatch {
    fn act(&mut self, seats: &mut [Seat]) {
        self.choose(false, seats);
    }

    fn observe(&mut self, seats: &mut [Seat]) {
        if !self.callable(seats) {
            return;
        }
        Python::attach(|py| {
            let Some((m, a)) = &self.live else { return };
            // `states` holds the states acted in since `act_batch`.
            a.fill_steps(py, seats);
            let args = (
                a.states.clone_ref(py),
                a.actions.clone_ref(py),
                a.rewards.clone_ref(py),
                a.next_states.clone_ref(py),
                a.infos.clone_ref(py),
            );
            if let Err(e) = m.observe.call1(py, args) {
                self.raised(py, "observe_batch(states, actions, ...)", e, seats);
            }
        });
    }

    fn greedy(&mut self, seats: &mut [Seat]) {
        self.choose(true, seats);
    }
}
