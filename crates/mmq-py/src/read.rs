//! Reading an MCAP recording (`mmq run --record`) with mmq-log's reader, flattened into
//! columns that the Python side turns into NumPy structured arrays.

use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::config::config_err;

fn col<'py, T: numpy::Element>(py: Python<'py>, v: Vec<T>) -> Bound<'py, PyArray1<T>> {
    PyArray1::from_vec(py, v)
}

/// Reads `path`; returns a dict of column dicts (`decisions`, `emitted`, `delivered`,
/// `poses`) plus `metadata`, `complete` and `stop`.
#[pyfunction]
pub fn read_recording_columns<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
) -> PyResult<Bound<'py, PyDict>> {
    let log = py.detach(|| mmq_log::read_log(&path)).map_err(|e| {
        config_err("file", format!("{e}; pass the path of an .mcap file written by --record"))
    })?;
    let out = PyDict::new(py);

    let d = &log.decisions;
    let dec = PyDict::new(py);
    dec.set_item("time_ns", col(py, d.iter().map(|m| m.log_time).collect()))?;
    dec.set_item("t", col(py, d.iter().map(|m| m.msg.t).collect()))?;
    dec.set_item("state", col(py, d.iter().map(|m| m.msg.state as i64).collect()))?;
    dec.set_item("action", col(py, d.iter().map(|m| m.msg.action as i64).collect()))?;
    dec.set_item("model", col(py, d.iter().map(|m| m.msg.model.map_or(-1, |x| x as i64)).collect()))?;
    dec.set_item("explored", col(py, d.iter().map(|m| m.msg.explored).collect()))?;
    dec.set_item("next_state", col(py, d.iter().map(|m| m.msg.next_state as i64).collect()))?;
    dec.set_item("event", d.iter().map(|m| m.msg.event.clone()).collect::<Vec<_>>())?;
    out.set_item("decisions", dec)?;

    let e = &log.emitted;
    let em = PyDict::new(py);
    em.set_item("time_ns", col(py, e.iter().map(|m| m.log_time).collect()))?;
    em.set_item("id", col(py, e.iter().map(|m| m.msg.id).collect()))?;
    em.set_item("t", col(py, e.iter().map(|m| m.msg.t).collect()))?;
    em.set_item("value", col(py, e.iter().map(|m| m.msg.value).collect()))?;
    // A delay in seconds has no steps at emission: -1 there; its times in seconds are
    // NaN for a delay in steps.
    em.set_item("delay", col(py, e.iter().map(|m| m.msg.delay.map_or(-1, i64::from)).collect()))?;
    em.set_item("due", col(py, e.iter().map(|m| m.msg.due.map_or(-1, |d| d as i64)).collect()))?;
    let secs = |f: fn(&mmq_log::messages::RewardEmitted) -> Option<f64>| -> Vec<f64> {
        e.iter().map(|m| f(&m.msg).unwrap_or(f64::NAN)).collect()
    };
    em.set_item("t_emit_s", col(py, secs(|m| m.t_emit_s)))?;
    em.set_item("delay_s", col(py, secs(|m| m.delay_s)))?;
    em.set_item("due_s", col(py, secs(|m| m.due_s)))?;
    em.set_item("cause", e.iter().map(|m| m.msg.cause.clone()).collect::<Vec<_>>())?;
    out.set_item("emitted", em)?;

    // One row per emission inside a delivery (a delivery of several emissions gives
    // several rows with the same `t`).
    let mut rows: Vec<(u64, u64, u64, u64, i64, f64)> = Vec::new();
    for m in &log.delivered {
        for p in &m.msg.parts {
            rows.push((m.log_time, m.msg.t, p.id, p.t_emit, i64::from(p.delay), p.value));
        }
    }
    let dl = PyDict::new(py);
    dl.set_item("time_ns", col(py, rows.iter().map(|r| r.0).collect()))?;
    dl.set_item("t", col(py, rows.iter().map(|r| r.1).collect()))?;
    dl.set_item("id", col(py, rows.iter().map(|r| r.2).collect()))?;
    dl.set_item("t_emit", col(py, rows.iter().map(|r| r.3).collect()))?;
    dl.set_item("delay", col(py, rows.iter().map(|r| r.4).collect()))?;
    dl.set_item("value", col(py, rows.iter().map(|r| r.5).collect()))?;
    out.set_item("deliveries", dl)?;

    let sums = PyDict::new(py);
    sums.set_item("time_ns", col(py, log.delivered.iter().map(|m| m.log_time).collect()))?;
    sums.set_item("t", col(py, log.delivered.iter().map(|m| m.msg.t).collect()))?;
    sums.set_item("sum", col(py, log.delivered.iter().map(|m| m.msg.sum).collect()))?;
    out.set_item("delivered", sums)?;

    let p = &log.poses;
    let po = PyDict::new(py);
    po.set_item("time_ns", col(py, p.iter().map(|m| m.log_time).collect()))?;
    po.set_item("x", col(py, p.iter().map(|m| m.x).collect()))?;
    po.set_item("y", col(py, p.iter().map(|m| m.y).collect()))?;
    po.set_item("theta", col(py, p.iter().map(|m| m.theta).collect()))?;
    out.set_item("poses", po)?;

    let meta = PyDict::new(py);
    for (k, v) in &log.metadata {
        meta.set_item(k, v.clone().into_iter().collect::<Vec<_>>())?;
    }
    out.set_item("metadata", meta)?;
    out.set_item("complete", log.complete)?;
    out.set_item("stop", log.stop.as_ref().map(|s| s.to_string()))?;
    Ok(out)
}
