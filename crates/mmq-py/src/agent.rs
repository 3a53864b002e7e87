//! A Python agent as a learner of mmq: [`PyAgent`] calls the object's `act(state)`,
//! `observe(state, action, reward, next_state, info)` and, if it has one,
//! `greedy(state)` (else `act`) from the lab's runner. Every action is checked: an
//! exception, an answer that is not an int, or an action out of range ends the seed as
//! failed with that text ([`Learner::failure`]); `KeyboardInterrupt` and `SystemExit`
//! stop the whole evaluation instead, and are raised again once it has stopped.

use std::cell::RefCell;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Instant;

use mmq_core::{Action, Rng, State};
use mmq_learn::{Decision, Experience, Learner, Table};
use pyo3::exceptions::{PyKeyboardInterrupt, PySystemExit};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict};

/// What the agents of one evaluation share with its driver: the stop flag and the
/// interruption to raise again.
#[derive(Debug, Default)]
pub struct Shared {
    /// Set to stop every seed at its next step (Ctrl-C, an agent's `KeyboardInterrupt`).
    pub stop: AtomicBool,
    /// The first `KeyboardInterrupt` or `SystemExit`, raised again after the stop.
    pub interrupt: Mutex<Option<PyErr>>,
}

impl Shared {
    /// Stops the evaluation, keeping `e` (the first one) to raise again.
    pub fn interrupt(&self, e: PyErr) {
        self.stop.store(true, Ordering::SeqCst);
        self.interrupt.lock().unwrap_or_else(PoisonError::into_inner).get_or_insert(e);
    }

    /// The interruption to raise again, if any.
    pub fn take_interrupt(&self) -> Option<PyErr> {
        self.interrupt.lock().unwrap_or_else(PoisonError::into_inner).take()
    }
}

/// A Python agent driven by the runner for one seed.
#[derive(Debug)]
pub struct PyAgent {
    /// The agent; None when it was never built (the evaluation stopped first).
    agent: Option<Py<PyAny>>,
    /// Whether it has `greedy(state)`.
    has_greedy: bool,
    n_actions: usize,
    /// Why the seed failed (set from `&self` calls too: `greedy`).
    failure: RefCell<Option<String>>,
    shared: Arc<Shared>,
    /// The seed's wall-clock limit: (when it ends, its length in seconds).
    deadline: Option<(Instant, f64)>,
}

impl PyAgent {
    /// The agent `make()` returns, checked to have `act` and `observe`; a `make` that
    /// raises gives an agent that failed with its error.
    pub fn build(
        py: Python<'_>,
        make: impl FnOnce() -> PyResult<Py<PyAny>>,
        n_actions: usize,
        shared: Arc<Shared>,
        time_limit_s: Option<f64>,
    ) -> PyAgent {
        let deadline = time_limit_s.map(|s| (Instant::now() + std::time::Duration::from_secs_f64(s), s));
        let mut me = PyAgent {
            agent: None,
            has_greedy: false,
            n_actions,
            failure: RefCell::new(None),
            shared,
            deadline,
        };
        match make() {
            Ok(a) => {
                let b = a.bind(py);
                let callable = |m: &str| b.getattr(m).is_ok_and(|f| f.is_callable());
                if let Some(m) = ["act", "observe"].into_iter().find(|m| !callable(m)) {
                    let what = b.get_type().name().map_or_else(|_| "?".into(), |n| n.to_string());
                    // A batched agent here: the first agent made was not one (or raised).
                    let batched = if callable("act_batch") {
                        "; it has act_batch, but this evaluation drives agents of one seed, as the first agent made was not batched (or make_agent raised)"
                    } else {
                        ""
                    };
                    me.fail(format!(
                        "make_agent returned an object of type {what} without a method `{m}`; an agent has act(state) and observe(state, action, reward, next_state, info){batched}"
                    ));
                } else {
                    me.has_greedy = callable("greedy");
                    me.agent = Some(a);
                }
            }
            Err(e) => me.raised(py, "make_agent", e),
        }
        me
    }

    fn fail(&self, why: String) {
        self.failure.borrow_mut().get_or_insert(why);
    }

    /// Whether the agent may be called: built, not failed, the evaluation not stopped.
    fn live(&self) -> Option<&Py<PyAny>> {
        let stopped = self.shared.stop.load(Ordering::Relaxed) || self.failure.borrow().is_some();
        self.agent.as_ref().filter(|_| !stopped)
    }

    /// An exception from the agent: an interruption stops the evaluation, anything else
    /// fails the seed with its text and traceback.
    fn raised(&self, py: Python<'_>, call: &str, e: PyErr) {
        if e.is_instance_of::<PyKeyboardInterrupt>(py) || e.is_instance_of::<PySystemExit>(py) {
            return self.shared.interrupt(e);
        }
        let tb = e.traceback(py).and_then(|t| t.format().ok()).unwrap_or_default();
        self.fail(format!("{call} raised {e}\n{tb}").trim_end().to_string());
    }

    /// Calls `method(state)` and checks the action: an int in 0..n_actions.
    fn choose(&self, method: &str, state: State) -> Action {
        let Some(agent) = self.live() else { return 0 };
        if let Some((end, limit)) = self.deadline
            && Instant::now() > end
        {
            self.fail(format!("the seed ran out of time: over its limit of {limit} s (time_limit_s)"));
            return 0;
        }
        Python::attach(|py| match agent.call_method1(py, method, (state,)) {
            Ok(v) => self.check_action(method, state, v.bind(py)),
            Err(e) => {
                self.raised(py, &format!("{method}({state})"), e);
                0
            }
        })
    }

    fn check_action(&self, method: &str, state: State, v: &Bound<'_, PyAny>) -> Action {
        let n = self.n_actions;
        match v.extract::<i64>() {
            Ok(a) if !v.is_instance_of::<PyBool>() && (0..n as i64).contains(&a) => a as Action,
            Ok(a) if !v.is_instance_of::<PyBool>() => {
                self.fail(format!("{method}({state}) returned {a}; the actions are 0..{}", n - 1));
                0
            }
            _ => {
                let what = v.repr().map_or_else(|_| "?".into(), |r| r.to_string());
                let ty = v.get_type().name().map_or_else(|_| "?".into(), |t| t.to_string());
                self.fail(format!(
                    "{method}({state}) returned {what} ({ty}), not an int action in 0..{}",
                    n - 1
                ));
                0
            }
        }
    }
}

impl Learner for PyAgent {
    fn name(&self) -> &'static str {
        "python"
    }

    fn act(&mut self, state: State, _rng: &mut Rng) -> Decision {
        Decision { action: self.choose("act", state), model: None, explored: false }
    }

    fn observe(&mut self, exp: &Experience<'_>) {
        let Some(agent) = self.live() else { return };
        Python::attach(|py| {
            let info = PyDict::new(py);
            let call =
                info.set_item("t", exp.t).and_then(|()| info.set_item("time_s", exp.time_s)).and_then(|()| {
                    agent.call_method1(
                        py,
                        "observe",
                        (exp.state, exp.action, exp.reward, exp.next_state, info),
                    )
                });
            if let Err(e) = call {
                self.raised(py, &format!("observe({}, {}, ...)", exp.state, exp.action), e);
            }
        });
    }

    fn greedy(&self, state: State, _rng: &mut Rng) -> Action {
        self.choose(if self.has_greedy { "greedy" } else { "act" }, state)
    }

    /// A Python agent shows no values: zeros (every action is a maximiser in policy maps).
    fn action_values(&self, _state: State, out: &mut [f64]) {
        out.fill(0.0);
    }

    fn tables(&self) -> Vec<Table> {
        Vec::new()
    }

    fn failure(&self) -> Option<String> {
        self.failure.borrow().clone()
    }
}
