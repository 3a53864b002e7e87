//! Tables and reports of a sweep's results: the tidy per-job CSV, per-cell means with
//! 95 % intervals (CSV and markdown), and axis values as numbers for figures.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;

use mmq_core::DelayDist;
use mmq_core::stats::MeanCi;

use super::Metrics;
use super::plan::Plan;

/// Whether a metric is a result (a column of `results.csv`): run-to-run timings and the
/// bookkeeping keys are not.
pub(super) fn is_result_metric(k: &str) -> bool {
    k != "seed" && k != "complete" && !k.starts_with("time/")
}

/// A CSV field, quoted when needed.
pub(crate) fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) || s.starts_with(' ') || s.ends_with(' ') {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// A number for CSV: shortest round-trip form, empty for NaN, `inf`/`-inf`.
pub(super) fn csv_num(x: f64) -> String {
    if x.is_nan() { String::new() } else { x.to_string() }
}

/// The tidy results table: a row per finished job in plan order (cells in product
/// order, seeds in spec order); columns `cell`, the swept parameters in [`super::FIELDS`]
/// order, `seed`, then every metric present in any row, in name order (empty where a
/// cell has no such metric, and for NaN). Returns the text and the number of rows.
pub fn results_csv(plan: &Plan, results: &[Option<Metrics>]) -> (String, usize) {
    let metrics: BTreeSet<&str> = results
        .iter()
        .flatten()
        .flat_map(|m| m.keys())
        .map(String::as_str)
        .filter(|k| is_result_metric(k))
        .collect();
    let axes: Vec<usize> = plan.axes.iter().filter_map(|a| plan.fields.iter().position(|f| f == a)).collect();
    let mut out = String::from("cell");
    for &a in &axes {
        out.push(',');
        out.push_str(&csv_field(&plan.fields[a]));
    }
    out.push_str(",seed");
    for m in &metrics {
        out.push(',');
        out.push_str(&csv_field(m));
    }
    out.push('\n');
    let mut rows = 0;
    for (j, r) in results.iter().enumerate() {
        let Some(r) = r else { continue };
        let (c, seed) = plan.job(j);
        out.push_str(&plan.cells[c].id);
        for &a in &axes {
            out.push(',');
            out.push_str(&csv_field(&plan.cells[c].params[a]));
        }
        let _ = write!(out, ",{seed}");
        for m in &metrics {
            out.push(',');
            out.push_str(&r.get(*m).map_or(String::new(), |&x| csv_num(x)));
        }
        out.push('\n');
        rows += 1;
    }
    (out, rows)
}

/// Mean and 95 % interval of every metric of one cell over its finished seeds.
#[derive(Clone, Debug)]
pub struct CellStats {
    /// Cell index in the plan.
    pub cell: usize,
    /// Finished seeds.
    pub n: usize,
    /// Per metric (results only, non-finite values left out).
    pub metrics: BTreeMap<String, MeanCi>,
    /// Why a metric is absent (relative performance where a baseline earned ≤ 0).
    pub notes: Vec<String>,
}

/// Per-cell statistics of `results`.
pub fn cell_stats(plan: &Plan, results: &[Option<Metrics>]) -> Vec<CellStats> {
    let ns = plan.seeds.len();
    (0..plan.cells.len())
        .map(|c| {
            let done: Vec<&Metrics> = results[c * ns..(c + 1) * ns].iter().flatten().collect();
            let (metrics, notes) = crate::summary::aggregate(&done, is_result_metric);
            CellStats { cell: c, n: done.len(), metrics, notes }
        })
        .collect()
}

/// The per-cell table in tidy (long) form: `cell`, the swept parameters, `metric`,
/// `n`, `mean`, `ci95` (half-width of the 95 % interval), `std`.
pub fn summary_csv(plan: &Plan, stats: &[CellStats]) -> String {
    let mut out = String::from("cell");
    for a in &plan.axes {
        out.push(',');
        out.push_str(&csv_field(a));
    }
    out.push_str(",metric,n,mean,ci95,std\n");
    for s in stats {
        for (k, m) in &s.metrics {
            out.push_str(&plan.cells[s.cell].id);
            for a in &plan.axes {
                out.push(',');
                out.push_str(&csv_field(plan.param(s.cell, a)));
            }
            let _ = writeln!(
                out,
                ",{},{},{},{},{}",
                csv_field(k),
                m.n,
                csv_num(m.mean),
                csv_num(m.ci95),
                csv_num(m.std)
            );
        }
    }
    out
}

/// Headline metrics of reports: (name, label, shown as a percentage).
pub const HEADLINE: [(&str, &str, bool); 6] = [
    ("perf/relative", "relative performance", true),
    ("perf/fraction_of_ceiling", "fraction of ε-soft ceiling", true),
    ("perf/fraction_of_optimum", "fraction of optimum", true),
    ("perf/regret", "regret (reward)", false),
    ("eval/greedy_fraction_of_optimum", "greedy eval. (of optimum)", true),
    ("reward/earned_per_step", "earned / step", false),
];

/// A markdown report: the fixed parameters and a table of the headline metrics per cell.
pub fn summary_markdown(plan: &Plan, stats: &[CellStats]) -> String {
    let mut out = format!("# Sweep `{}`\n\n", plan.name);
    if !plan.description.is_empty() {
        let _ = writeln!(out, "{}\n", plan.description.trim());
    }
    let done: usize = stats.iter().map(|s| s.n).sum();
    let _ = writeln!(
        out,
        "{} cells × {} seeds = {} jobs; {done} finished. Means over seeds with 95 % confidence intervals (Student's t).\n",
        plan.cells.len(),
        plan.seeds.len(),
        plan.jobs()
    );
    let fixed = plan.fixed();
    if !fixed.is_empty() {
        out.push_str("Fixed: ");
        let parts: Vec<String> = fixed.iter().map(|(k, v)| format!("{k} = `{v}`")).collect();
        out.push_str(&parts.join(", "));
        out.push_str(".\n\n");
    }
    let shown: Vec<_> =
        HEADLINE.iter().filter(|h| stats.iter().any(|s| s.metrics.contains_key(h.0))).collect();
    out.push_str("| cell |");
    for a in &plan.axes {
        let _ = write!(out, " {a} |");
    }
    out.push_str(" seeds |");
    for h in &shown {
        let _ = write!(out, " {} |", h.1);
    }
    out.push_str("\n|---|");
    for _ in 0..plan.axes.len() + 1 + shown.len() {
        out.push_str("---|");
    }
    out.push('\n');
    for s in stats {
        let _ = write!(out, "| `{}` |", plan.cells[s.cell].id);
        for a in &plan.axes {
            let _ = write!(out, " {} |", plan.param(s.cell, a).replace('|', "\\|"));
        }
        let _ = write!(out, " {} |", s.n);
        for h in &shown {
            let _ =
                write!(out, " {} |", s.metrics.get(h.0).map_or("–".into(), |m| crate::format::mean(m, h.2)));
        }
        out.push('\n');
    }
    for s in stats {
        for note in &s.notes {
            let _ = writeln!(out, "\n- `{}`: {note}", plan.cells[s.cell].id);
        }
    }
    out.push_str("\nEvery metric of every cell: `summary.csv`; every seed: `results.csv`.\n");
    out
}

/// The value of an axis as a number for plots: numeric fields as they are, `delay` as
/// its mean in steps; None for names (world, env, learner).
pub fn axis_number(field: &str, value: &str) -> Option<f64> {
    match field {
        "delay" => DelayDist::parse(value).ok().map(|d| d.mean()),
        "world" | "env" | "learner" | "baseline" => None,
        _ => value.parse::<f64>().ok(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::store::encode;

    #[test]
    fn csv_quotes_and_numbers() {
        assert_eq!(csv_field("hist:1,2"), "\"hist:1,2\"");
        assert_eq!(csv_num(f64::NAN), "");
        assert_eq!(csv_num(0.1), "0.1");
        assert_eq!(encode(f64::INFINITY).parse::<f64>().unwrap(), f64::INFINITY);
        assert!(encode(f64::NAN).parse::<f64>().unwrap().is_nan());
    }
}
