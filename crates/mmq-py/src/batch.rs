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
use numpy::{PyArray1, PyArrayMethods, PyUntypedArrayMethods};
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

/// One of the driver's arrays: written by Rust, handed to Python as a read-only view.
#[derive(Debug)]
struct Shown<T: numpy::Element> {
    own: Py<PyArray1<T>>,
    view: Py<PyAny>,
}

impl<T: numpy::Element + Copy> Shown<T> {
    /// An array of `n` zeros and its read-only view.
    fn new(py: Python<'_>, n: usize) -> PyResult<Shown<T>> {
        let own = PyArray1::<T>::zeros(py, n, false);
        let view = own.call_method0("view")?;
        let ro = PyDict::new(py);
        ro.set_item("write", false)?;
        view.call_method("setflags", (), Some(&ro))?;
        Ok(Shown { own: own.unbind(), view: view.unbind() })
    }

    /// Writes `f(seat)` of every seat.
    fn fill(&self, py: Python<'_>, seats: &[Seat], f: impl Fn(&Seat) -> T) {
        let mut w = self.own.bind(py).readwrite();
        let out = w.as_slice_mut().expect("the driver's arrays are contiguous");
        for (o, s) in out.iter_mut().zip(seats) {
            *o = f(s);
        }
    }

    fn arg(&self, py: Python<'_>) -> Py<PyAny> {
        self.view.clone_ref(py)
    }
}

/// The arrays handed to the agent (length: the batch's seeds), allocated once.
#[derive(Debug)]
struct Arrays {
    states: Shown<i64>,
    actions: Shown<i64>,
    rewards: Shown<f64>,
    next_states: Shown<i64>,
    t: Shown<i64>,
    time_s: Shown<f64>,
    /// `{"t": t, "time_s": time_s}` (the views).
    infos: Py<PyDict>,
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
        let n = self.seeds.len();
        let (t, time_s) = (Shown::new(py, n)?, Shown::new(py, n)?);
        let infos = PyDict::new(py);
        infos.set_item("t", t.arg(py))?;
        infos.set_item("time_s", time_s.arg(py))?;
        let arrays = Arrays {
            states: Shown::new(py, n)?,
            actions: Shown::new(py, n)?,
            rewards: Shown::new(py, n)?,
            next_states: Shown::new(py, n)?,
            t,
            time_s,
            infos: infos.unbind(),
        };
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
            a.states.fill(py, seats, |s| s.state as i64);
            let method = if greedy { &m.greedy } else { &m.act };
            match method.call1(py, (a.states.arg(py),)) {
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
            let read = arr.try_readonly();
            if let Some(acts) = read.as_ref().ok().and_then(|r| r.as_slice().ok()) {
                for (i, (seat, &a)) in seats.iter_mut().zip(acts).enumerate() {
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
            a.actions.fill(py, seats, |s| s.action as i64);
            a.rewards.fill(py, seats, |s| s.reward);
            a.next_states.fill(py, seats, |s| s.next_state as i64);
            a.t.fill(py, seats, |s| s.t as i64);
            a.time_s.fill(py, seats, |s| s.time_s);
            let args = (
                a.states.arg(py),
                a.actions.arg(py),
                a.rewards.arg(py),
                a.next_states.arg(py),
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
