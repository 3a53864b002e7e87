//! Learners and runs from Python: `mmq.Learner` drives any learner of mmq-learn step by
//! step (exploration from the CLI's seed tree), and `mmq.run` runs the lab's runner with
//! the CLI's configuration.

use std::sync::atomic::AtomicBool;
use std::sync::{Mutex, MutexGuard, PoisonError};

use mmq_core::{Rng, SeedTree, Stream};
use mmq_lab::config::{EnvKind, RecordSettings};
use mmq_lab::{Control, Resolved, RunConfig, run_all};
use mmq_learn::{Experience, LearnerKind, LearnerSpec};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::config::{config_err, load_world, robot_world, to_toml};
use crate::seed_arg;

/// Turns the fields (`` `max_delay` ``) and flags (`--max-delay`) a message names into keyword
/// names (`max_delay`).
pub fn kwarg_names(msg: &str) -> String {
    let mut out = String::with_capacity(msg.len());
    let mut rest = msg;
    while let Some(i) = rest.find("--") {
        out.push_str(&rest[..i]);
        let tail = &rest[i + 2..];
        let end = tail.find(|c: char| !(c.is_ascii_alphanumeric() || c == '-')).unwrap_or(tail.len());
        out.push_str(&tail[..end].replace('-', "_"));
        rest = &tail[end..];
    }
    out.push_str(rest);
    mmq_lab::fields::as_names(&out)
}

/// A learner spec from a name and keyword settings: the shared parameters (`alpha`,
/// `gamma`, `epsilon`, `q0`) and the learner's own settings, by their config names; a
/// setting the learner does not have is an error naming it.
pub fn learner_spec(name: &str, settings: Option<&Bound<'_, PyDict>>) -> PyResult<LearnerSpec> {
    let kind = LearnerKind::parse(name).map_err(|e| config_err("learner", e))?;
    let mut pairs: Vec<(String, toml::Value)> = Vec::new();
    if let Some(settings) = settings {
        for (k, v) in settings.iter() {
            let key: String = k.extract()?;
            let v = to_toml(&key, &v)?;
            pairs.push((key, v));
        }
    }
    let refs: Vec<(&str, &toml::Value)> = pairs.iter().map(|(k, v)| (k.as_str(), v)).collect();
    mmq_lab::settings::with_settings(&LearnerSpec::new(kind), &refs).map_err(|e| match &e {
        mmq_lab::LabError::Setting { field, message } => config_err(field, kwarg_names(message)),
        _ => {
            let msg = kwarg_names(&e.to_string());
            let field = msg.split_whitespace().next().unwrap_or("settings").to_string();
            config_err(&field, msg)
        }
    })
}

/// The learner behind its mutex, reached through exclusive access (no locking).
fn owned(m: &mut Mutex<Box<dyn mmq_learn::Learner>>) -> &mut dyn mmq_learn::Learner {
    m.get_mut().unwrap_or_else(PoisonError::into_inner).as_mut()
}

/// A learner driven from Python, usable from any thread (one call at a time: pyo3's
/// borrow check refuses a second one while a call runs).
#[pyclass(module = "mmq._mmq")]
#[derive(Debug)]
pub struct LearnerCore {
    /// The learner (`Send`, not `Sync`): the mutex makes the class `Sync`; calls that own
    /// the object (`&mut self`) reach it without locking.
    learner: Mutex<Box<dyn mmq_learn::Learner>>,
    explore: Rng,
    eval: Rng,
    t: u64,
    n_states: usize,
    n_actions: usize,
    buf: Vec<f64>,
}

impl LearnerCore {
    /// The learner, locked for a shared call.
    fn learner(&self) -> MutexGuard<'_, Box<dyn mmq_learn::Learner>> {
        self.learner.lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn check_state(&self, arg: &str, s: i64) -> PyResult<usize> {
        if s < 0 || s as u64 >= self.n_states as u64 {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "{arg} = {s} is out of range; use a state in 0..{}",
                self.n_states
            )));
        }
        Ok(s as usize)
    }
}

#[pymethods]
impl LearnerCore {
    /// A learner `name` for `n_states` × `n_actions`, exploring from seed `seed`'s stream.
    #[new]
    #[pyo3(signature = (name, n_states, n_actions, seed, settings=None))]
    fn new(
        name: &str,
        n_states: i64,
        n_actions: i64,
        seed: &Bound<'_, PyAny>,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        if !(1..=1i64 << 32).contains(&n_states) {
            return Err(config_err("n_states", format!("{n_states} is not accepted; use a positive count")));
        }
        if !(1..=64).contains(&n_actions) {
            return Err(config_err("n_actions", format!("{n_actions} is not accepted; use 1..=64")));
        }
        let spec = learner_spec(name, settings)?;
        let learner = spec
            .build(n_states as usize, n_actions as usize, mmq_lab::runner::memory_limit(1))
            .map_err(|e| config_err("learner", kwarg_names(&e.to_string())))?;
        if learner.needs_truth() {
            return Err(config_err(
                "learner",
                "the oracle reads the channel's ground truth, which a learner outside the runner does not have; use mmq.run(learner=\"oracle\")",
            ));
        }
        let tree = SeedTree::new(seed_arg(seed)?);
        Ok(LearnerCore {
            learner: Mutex::new(learner),
            explore: tree.rng(Stream::Explore),
            eval: tree.rng(Stream::Eval),
            t: 0,
            n_states: n_states as usize,
            n_actions: n_actions as usize,
            buf: vec![0.0; n_actions as usize],
        })
    }

    /// The ε-greedy action in `state`: (action, model acted on or None, explored).
    fn act(&mut self, state: i64) -> PyResult<(usize, Option<usize>, bool)> {
        let s = self.check_state("state", state)?;
        let d = owned(&mut self.learner).act(s, &mut self.explore);
        Ok((d.action, d.model, d.explored))
    }

    /// Learns from one step (s, a, delivered reward, s'); steps are numbered in call order.
    /// `time_s` is the simulated time at the end of the step (`info["time_s"]` of the
    /// environment; default: the step count × 0.1 s, the grid's default step period).
    #[pyo3(signature = (state, action, reward, next_state, time_s = None))]
    fn observe(
        &mut self,
        state: i64,
        action: i64,
        reward: f64,
        next_state: i64,
        time_s: Option<f64>,
    ) -> PyResult<()> {
        let s = self.check_state("state", state)?;
        let s2 = self.check_state("next_state", next_state)?;
        if action < 0 || action as u64 >= self.n_actions as u64 {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "action = {action} is out of range; use 0..{}",
                self.n_actions
            )));
        }
        if !reward.is_finite() {
            return Err(pyo3::exceptions::PyValueError::new_err(format!("reward = {reward} is not finite")));
        }
        owned(&mut self.learner).observe(&Experience {
            t: self.t,
            state: s,
            action: action as usize,
            next_state: s2,
            reward,
            time_s: time_s.unwrap_or((self.t + 1) as f64 * 0.1),
            truth: None,
        });
        self.t += 1;
        Ok(())
    }

    /// The greedy action in `state` (ties broken from the evaluation stream).
    fn greedy(&mut self, state: i64) -> PyResult<usize> {
        let s = self.check_state("state", state)?;
        Ok(owned(&mut self.learner).greedy(s, &mut self.eval))
    }

    /// The action values the policy acts on in `state`.
    fn action_values<'py>(&mut self, py: Python<'py>, state: i64) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let s = self.check_state("state", state)?;
        owned(&mut self.learner).action_values(s, &mut self.buf);
        Ok(PyArray1::from_slice(py, &self.buf))
    }

    /// The learner's tables: [(name, shape, flat data in C order)].
    #[allow(clippy::type_complexity)]
    fn tables<'py>(&self, py: Python<'py>) -> Vec<(String, Vec<usize>, Bound<'py, PyArray1<f64>>)> {
        self.learner()
            .tables()
            .into_iter()
            .map(|t| (t.name, t.shape, PyArray1::from_vec(py, t.data)))
            .collect()
    }

    /// Learner-specific figures now (its delay estimate among them), under the metric
    /// names of a run's summary.
    fn metrics(&self) -> Vec<(String, f64)> {
        let entries = mmq_lab::summary::diagnostics_entries(&self.learner().diagnostics());
        entries.into_iter().map(|(k, v)| (k.to_string(), v)).collect()
    }

    /// Steps observed so far.
    #[getter]
    fn steps(&self) -> u64 {
        self.t
    }

    /// The learner's command-line name.
    #[getter]
    fn name(&self) -> &'static str {
        self.learner().name()
    }
}

/// Runs the lab's runner (what `mmq run` does) and returns the summary as JSON text.
#[pyfunction]
#[pyo3(signature = (world, env, learner, delay, steps, seeds, seed, window, eval_steps, baseline, save_tables, out=None, record=false, preset=None, profile=None, overrides=None, settings=None))]
#[allow(clippy::too_many_arguments)]
pub fn run_json(
    py: Python<'_>,
    world: &str,
    env: &str,
    learner: &str,
    delay: &str,
    steps: u64,
    seeds: u64,
    seed: &Bound<'_, PyAny>,
    window: u64,
    eval_steps: u64,
    baseline: bool,
    save_tables: bool,
    out: Option<std::path::PathBuf>,
    record: bool,
    preset: Option<&str>,
    profile: Option<&str>,
    overrides: Option<&Bound<'_, PyDict>>,
    settings: Option<&Bound<'_, PyDict>>,
) -> PyResult<String> {
    let env = match env {
        "grid" => EnvKind::Grid,
        "robot" => EnvKind::Robot,
        _ => {
            return Err(config_err(
                "env",
                format!("`{env}` is not an environment; use \"grid\" or \"robot\""),
            ));
        }
    };
    if record && out.is_none() {
        return Err(config_err("record", "a recording needs an output folder; pass out=\"DIR\""));
    }
    let base = load_world(world)?;
    let w = robot_world(&base, preset, profile, overrides)?;
    let path = w.path.clone().unwrap_or_else(|| std::path::PathBuf::from(world));
    let cfg = RunConfig {
        world: path,
        env,
        learner: learner_spec(learner, settings)?,
        delay: delay.to_string(),
        steps,
        seed: seed_arg(seed)?,
        seeds,
        window,
        eval_steps,
        baseline,
        save_tables,
        record: record.then(RecordSettings::default),
        ..RunConfig::default()
    };
    let lab_err = |e: mmq_lab::LabError| {
        if e.is_input_error() {
            let msg = kwarg_names(&e.to_string());
            let field = msg.split([' ', ':']).next().unwrap_or("settings").to_string();
            config_err(&field, msg)
        } else {
            pyo3::exceptions::PyRuntimeError::new_err(e.to_string())
        }
    };
    if env == EnvKind::Robot {
        crate::config::robot_env(&w, &crate::config::Edits::of(preset, profile, overrides))?;
    }
    // Resolved once: the world as edited, the delay parsed, what the run refuses checked.
    let run = Resolved::with_world(cfg, w).map_err(lab_err)?;
    let summary = py.detach(|| -> Result<String, mmq_lab::LabError> {
        let stop = AtomicBool::new(false);
        let progress = |_: u64| {};
        let ctl = Control { stop: &stop, progress: &progress };
        if let Some(dir) = &out {
            let written = mmq_lab::record::run_recorded(dir, &run, None, ctl, &|_| {})?;
            // A seed that lost a file is an error, never a complete run.
            written.check(dir)?;
            Ok(serde_json::to_string(&written.summary).unwrap_or_default())
        } else {
            let none = |_: u64| Ok(None);
            let outcome = run_all(&run, &none, ctl)?;
            let summary =
                mmq_lab::Summary::new(run.cfg(), run.world(), &outcome.results, !outcome.interrupted);
            Ok(serde_json::to_string(&summary).unwrap_or_default())
        }
    });
    summary.map_err(lab_err)
}
