//! Per-cell statistics of a sweep's results: the mean and 95 % interval of every metric
//! of a cell over its finished seeds, and several sweeps' plans and statistics as one,
//! for reports that read them side by side.

use std::collections::BTreeMap;

use mmq_core::stats::MeanCi;

use super::Metrics;
use super::plan::{Plan, PlanCell};
use crate::metric::MetricId;

/// Whether a metric is a result (a column of `results.csv`, a statistic of a cell):
/// run-to-run timings and the bookkeeping keys are not.
pub(super) fn is_result_metric(k: &str) -> bool {
    k != "seed" && k != "complete" && !k.starts_with("time/")
}

/// Mean and 95 % interval of every metric of one cell over its finished seeds.
#[derive(Clone, Debug)]
pub struct CellStats {
    /// Cell index in the plan.
    pub cell: usize,
    /// Finished seeds.
    pub n: usize,
    /// Per metric (results only, non-finite values left out).
    pub metrics: BTreeMap<MetricId, MeanCi>,
    /// Why a metric is absent (relative performance where a baseline earned ≤ 0).
    pub notes: Vec<String>,
}

/// Per-cell statistics of `results`.
pub fn cell_stats(plan: &Plan, results: &[Option<Metrics>]) -> Vec<CellStats> {
    (0..plan.cells.len())
        .map(|c| {
            let done: Vec<&Metrics> = results[plan.cell_jobs(c)].iter().flatten().collect();
            let (metrics, notes) = crate::summary::aggregate(&done, is_result_metric);
            CellStats { cell: c, n: done.len(), metrics, notes }
        })
        .collect()
}

/// Several sweeps' plans and statistics as one: the union of their fields (a field a
/// sweep lacks reads `–` in its cells), every field whose value differs between cells
/// an axis, the cells one after the other.
pub fn combine(parts: &[(Plan, Vec<CellStats>)]) -> (Plan, Vec<CellStats>) {
    let mut fields: Vec<String> = Vec::new();
    for (p, _) in parts {
        for f in &p.fields {
            if !fields.contains(f) {
                fields.push(f.clone());
            }
        }
    }
    let mut cells = Vec::new();
    let mut stats = Vec::new();
    let mut seeds = Vec::new();
    // Cells keep their own seeds unless every sweep runs the same seeds in every cell.
    let same_seeds = parts.iter().all(|(p, _)| p.uniform() && p.seeds == parts[0].0.seeds);
    for (p, st) in parts {
        let offset = cells.len();
        for c in 0..p.cells.len() {
            let params = fields
                .iter()
                .map(|f| if p.fields.contains(f) { p.param(c, f).to_string() } else { "–".to_string() })
                .collect();
            let own = (!same_seeds).then(|| p.seeds_of(c).to_vec());
            cells.push(PlanCell { id: p.cells[c].id.clone(), params, seeds: own });
        }
        for s in st {
            stats.push(CellStats { cell: s.cell + offset, ..s.clone() });
        }
        for s in &p.seeds {
            if !seeds.contains(s) {
                seeds.push(*s);
            }
        }
    }
    let axes = (0..fields.len())
        .filter(|&i| cells.iter().any(|c: &PlanCell| c.params[i] != cells[0].params[i]))
        .map(|i| fields[i].clone())
        .collect();
    let name = parts.iter().map(|p| p.0.name.as_str()).collect::<Vec<_>>().join(" + ");
    let plan = Plan::new(name, String::new(), fields, axes, seeds, cells);
    (plan, stats)
}
