//! The benchmark suite from Python: `mmq.suite.evaluate` runs a Python agent
//! ([`crate::agent::PyAgent`]) on every task and seed of a tier through the lab's sweep
//! engine and store (so it resumes where it stopped) and writes `results.json` with the
//! writer of `mmq suite run`.
//!
//! The seeds run one after another on a worker thread, or, for a batched agent
//! ([`crate::batch::PyBatch`], seen on the first agent made), the pending seeds of each
//! task together in lockstep ([`mmq_lab::sweep::run_sweep_batched`]). The worker holds
//! the GIL only while it calls the agent; the calling thread waits without the GIL and
//! checks for Ctrl-C (`KeyboardInterrupt`) meanwhile, which stops the run at the next
//! step, keeping every finished seed.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use mmq_lab::batch::BatchLearner;
use mmq_lab::runner::table_shape;
use mmq_lab::suite::{Suite, SuiteRun, results_of_dir, write_results};
use mmq_lab::sweep::{pending_jobs, run_sweep_batched, run_sweep_with};
use mmq_lab::{Control, LabError};
use mmq_learn::Learner;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::agent::{PyAgent, Shared};
use crate::batch::PyBatch;
use crate::config::config_err;

/// What an agent is told about its task (besides its table's shape and its seed).
#[derive(Clone, Debug)]
struct TaskInfo {
    name: String,
    max_delay: Option<i64>,
    epsilon: f64,
    q0: f64,
}

/// A lab error as a Python exception: bad input names `arg` (a `ConfigError`), the rest
/// is a `RuntimeError`.
fn lab_err(arg: &str, e: LabError) -> PyErr {
    if e.is_input_error() { config_err(arg, e) } else { PyRuntimeError::new_err(e.to_string()) }
}

/// The suite `suite` (a shipped version or a suite file), with only `tasks` when given.
fn load_suite(suite: &str, tasks: Option<&[String]>) -> PyResult<(Suite, bool)> {
    let s = Suite::open(suite).map_err(|e| config_err("suite", e))?;
    match tasks {
        Some(t) => {
            let only = s.only(t).map_err(|e| config_err("tasks", e))?;
            let subset = only.tasks.len() < s.tasks.len();
            Ok((only, subset))
        }
        None => Ok((s, false)),
    }
}

/// Calls `build` for the agent of `seeds` of task `t` (`seed`: the first).
fn make(
    py: Python<'_>,
    build: &Py<PyAny>,
    t: &TaskInfo,
    n_states: usize,
    n_actions: usize,
    seeds: &[u64],
) -> PyResult<Py<PyAny>> {
    let kw = PyDict::new(py);
    kw.set_item("name", &t.name)?;
    kw.set_item("n_states", n_states)?;
    kw.set_item("n_actions", n_actions)?;
    kw.set_item("seed", seeds[0])?;
    kw.set_item("seeds", seeds)?;
    kw.set_item("max_delay", t.max_delay)?;
    kw.set_item("epsilon", t.epsilon)?;
    kw.set_item("q0", t.q0)?;
    build.call(py, (), Some(&kw))
}

/// Whether `agent` is batched: it has `act_batch` and `observe_batch`.
fn is_batched(agent: &Bound<'_, PyAny>) -> bool {
    ["act_batch", "observe_batch"].iter().all(|m| agent.getattr(*m).is_ok_and(|f| f.is_callable()))
}

/// Runs `work` on a worker thread of a one-thread pool, attached to Python but without
/// the GIL; meanwhile this thread waits without the GIL and turns Ctrl-C into a stop.
fn in_worker<T: Send>(py: Python<'_>, shared: &Shared, work: impl FnOnce() -> T + Send) -> PyResult<T> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(|e| PyRuntimeError::new_err(format!("cannot start the worker thread: {e}")))?;
    std::thread::scope(|s| {
        let h = s.spawn(|| pool.install(|| Python::attach(|py| py.detach(work))));
        while !h.is_finished() {
            py.detach(|| std::thread::sleep(Duration::from_millis(5)));
            if let Err(e) = py.check_signals() {
                shared.interrupt(e);
            }
        }
        h.join().map_err(|_| PyRuntimeError::new_err("the evaluation's worker thread panicked"))
    })
}

/// Runs the agent `build` makes on every pending seed of `tier`, writes
/// `out/results.json` and returns its path. `build(name=, n_states=, n_actions=, seed=,
/// seeds=, max_delay=, epsilon=, q0=)` returns the agent of `seeds` (`seed` the first):
/// of one seed, or batched.
#[pyfunction]
#[pyo3(signature = (build, tier, out, name, suite, tasks=None, time_limit_s=None))]
pub fn suite_evaluate(
    py: Python<'_>,
    build: Py<PyAny>,
    tier: &str,
    out: PathBuf,
    name: &str,
    suite: &str,
    tasks: Option<Vec<String>>,
    time_limit_s: Option<f64>,
) -> PyResult<String> {
    let (suite, subset) = load_suite(suite, tasks.as_deref())?;
    suite.tier(tier).map_err(|e| config_err("tier", e))?;
    if name.trim().is_empty() {
        return Err(config_err("name", "give the agent a name (it names the agent in results)"));
    }
    if time_limit_s.is_some_and(|s| !(s.is_finite() && s > 0.0)) {
        return Err(config_err("time_limit_s", "use a number of seconds > 0, or None for no limit"));
    }
    let spec = suite.external_spec(tier, name).map_err(|e| lab_err("suite", e))?;
    let run = SuiteRun {
        suite: suite.version.clone(),
        tier: tier.into(),
        agent: name.into(),
        tasks: suite.task_names(),
        subset,
    };
    std::fs::create_dir_all(&out).map_err(|e| config_err("out", format!("{}: {e}", out.display())))?;
    run.claim(&out).map_err(|e| lab_err("out", e))?;
    let infos: Vec<TaskInfo> = suite
        .tasks
        .iter()
        .enumerate()
        .map(|(c, t)| {
            let p = spec.config(c).learner.params;
            let max_delay = t.fields.get("max_delay").and_then(toml::Value::as_integer);
            TaskInfo { name: t.name.clone(), max_delay, epsilon: p.epsilon, q0: p.q0 }
        })
        .collect();
    let shared = Arc::new(Shared::default());
    // Whether the agent is batched is known once one is made: the first pending task's
    // agent is made for all its pending seeds, and kept as the agent of its first seed
    // if it is not batched.
    let pending = pending_jobs(&spec, &out, None);
    let probe = match pending.first() {
        Some(&(c, _)) => {
            let seeds: Vec<u64> = pending.iter().filter(|j| j.0 == c).map(|j| j.1).collect();
            let (n_states, n_actions) =
                table_shape(spec.config(c), spec.world(c)).map_err(|e| lab_err("suite", e))?;
            let made = make(py, &build, &infos[c], n_states, n_actions, &seeds);
            let batched = made.as_ref().is_ok_and(|a| is_batched(a.bind(py)));
            Some((c, seeds, batched, made))
        }
        None => None,
    };
    let batched = probe.as_ref().is_some_and(|p| p.2);
    let probe = std::sync::Mutex::new(probe);
    // The probe's agent, if it is the one for (cell, seeds).
    let take_probe = |c: usize, seeds: &[u64]| -> Option<PyResult<Py<PyAny>>> {
        let mut g = probe.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let hit = g.as_ref().is_some_and(|p| p.0 == c && (if p.2 { &p.1[..] } else { &p.1[..1] }) == seeds);
        if hit { g.take().map(|p| p.3) } else { None }
    };
    let factory = |c: usize, n_states: usize, n_actions: usize, seed: u64| {
        Python::attach(|py| -> Result<Box<dyn Learner>, LabError> {
            let made = take_probe(c, &[seed])
                .unwrap_or_else(|| make(py, &build, &infos[c], n_states, n_actions, &[seed]));
            Ok(Box::new(PyAgent::build(py, || made, n_actions, shared.clone(), time_limit_s)))
        })
    };
    let batches = |c: usize, n_states: usize, n_actions: usize, seeds: &[u64]| {
        Python::attach(|py| -> Result<Box<dyn BatchLearner>, LabError> {
            let made = take_probe(c, seeds)
                .unwrap_or_else(|| make(py, &build, &infos[c], n_states, n_actions, seeds));
            Ok(Box::new(PyBatch::new(py, made, seeds, n_actions, shared.clone(), time_limit_s)))
        })
    };
    drop(pending);
    let outcome = in_worker(py, &shared, || {
        let progress = |_: u64| {};
        let ctl = Control { stop: &shared.stop, progress: &progress };
        if batched {
            run_sweep_batched(&spec, &out, None, ctl, &|_| {}, &batches)
        } else {
            run_sweep_with(&spec, &out, None, ctl, &|_| {}, Some(&factory))
        }
    })?;
    let results = results_of_dir(&out).map_err(|e| lab_err("out", e))?;
    let path = write_results(&out, &results).map_err(|e| lab_err("out", e))?;
    if let Some(e) = shared.take_interrupt() {
        return Err(e);
    }
    if shared.stop.load(Ordering::SeqCst) {
        return Err(pyo3::exceptions::PyKeyboardInterrupt::new_err("the evaluation was stopped"));
    }
    outcome.map_err(|e| lab_err("out", e))?;
    Ok(path.display().to_string())
}
