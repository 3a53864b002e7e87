//! mmq-py: the native module `mmq._mmq` behind the Python package `mmq` — environments
//! behind the delay channel ([`env`](mod@env)), vector environments batched in Rust ([`vector`]),
//! learners and the lab's runner ([`learn`]), the MCAP reader ([`read`]), the robot
//! swarm behind PettingZoo ([`swarm`]), and Python agents on the benchmark suite
//! ([`suite`], [`agent`]).
//!
//! The Python package (`python/mmq/`) wraps these in Gymnasium classes; everything that
//! can fail on user input raises `mmq.ConfigError` (a `ValueError`) naming the keyword
//! argument and the fix, and no Rust panic crosses the boundary.
//!
//! Architecture invariant: this is the only crate of mmq that knows pyo3 and NumPy.

pub mod agent;
pub mod batch;
pub mod config;
pub mod env;
pub mod learn;
pub mod read;
pub mod suite;
pub mod swarm;
pub mod vector;

use pyo3::prelude::*;

pyo3::create_exception!(
    _mmq,
    ConfigError,
    pyo3::exceptions::PyValueError,
    "A bad argument: the message names the keyword argument and the fix."
);

/// An environment failure during a step (robot physics) as a Python `RuntimeError`.
pub fn env_err(e: mmq_core::EnvError) -> PyErr {
    match e {
        mmq_core::EnvError::InvalidAction { .. } | mmq_core::EnvError::InvalidStart(_) => {
            pyo3::exceptions::PyValueError::new_err(e.to_string())
        }
        mmq_core::EnvError::Physics { .. } => pyo3::exceptions::PyRuntimeError::new_err(e.to_string()),
    }
}

/// A master seed from Python: an integer in 0..2^64.
pub fn seed_arg(seed: &Bound<'_, PyAny>) -> PyResult<u64> {
    if seed.is_instance_of::<pyo3::types::PyBool>() {
        return Err(config::config_err("seed", "use an integer in 0..2**64, not a bool"));
    }
    seed.extract::<u64>().map_err(|_| config::config_err("seed", "use an integer in 0..2**64"))
}

/// The master seed of the episode after one seeded with `seed` (a reset without a seed,
/// and the vector environments' autoreset, follow this chain).
#[pyfunction]
pub fn next_seed(seed: u64) -> u64 {
    mmq_core::seed::splitmix64(seed)
}

/// The names of the worlds shipped with the package.
#[pyfunction]
fn world_names() -> Vec<&'static str> {
    config::shipped_names()
}

/// The exact optimum of a world: (gain per step, optimal-action bit set per cell,
/// free cells).
#[pyfunction]
fn optimum(world: &str) -> PyResult<(f64, Vec<u8>, Vec<bool>)> {
    let w = config::load_world(world)?;
    let o = mmq_core::optimum(&w);
    let free = (0..w.num_cells()).map(|c| w.is_free(c)).collect();
    Ok((o.gain, o.actions, free))
}

/// The learner names and one-line descriptions.
#[pyfunction]
fn learners() -> Vec<(&'static str, &'static str)> {
    mmq_learn::catalogue().into_iter().map(|(_, n, d)| (n, d)).collect()
}

/// The native module.
#[pymodule]
fn _mmq(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("ConfigError", m.py().get_type::<ConfigError>())?;
    m.add_class::<env::EnvCore>()?;
    m.add_class::<vector::VecCore>()?;
    m.add_class::<learn::LearnerCore>()?;
    m.add_class::<swarm::SwarmCore>()?;
    m.add_function(wrap_pyfunction!(next_seed, m)?)?;
    m.add_function(wrap_pyfunction!(world_names, m)?)?;
    m.add_function(wrap_pyfunction!(optimum, m)?)?;
    m.add_function(wrap_pyfunction!(learners, m)?)?;
    m.add_function(wrap_pyfunction!(learn::run_json, m)?)?;
    m.add_function(wrap_pyfunction!(read::read_recording_columns, m)?)?;
    m.add_function(wrap_pyfunction!(suite::suite_evaluate, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
