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
    (0..plan.cells.len())
        .map(|c| {
            let done: Vec<&Metrics> = results[plan.cell_jobs(c)].iter().flatten().collect();
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
        "{}; {done} finished. Means over seeds with 95 % confidence intervals (Student's t).\n",
        plan.size()
    );
    out.push_str(&cells_markdown(plan, stats));
    out
}

/// The report of several sweeps read together ([`combine`]): a line per sweep, then the
/// table of every cell as in [`summary_markdown`].
pub fn combined_markdown(parts: &[(Plan, Vec<CellStats>)], plan: &Plan, stats: &[CellStats]) -> String {
    let names: Vec<String> = parts.iter().map(|p| format!("`{}`", p.0.name)).collect();
    let mut out = format!("# Sweeps {}\n\n", names.join(" + "));
    for (p, st) in parts {
        let done: usize = st.iter().map(|s| s.n).sum();
        let _ = writeln!(out, "- `{}`: {}; {done} finished. {}", p.name, p.size(), p.description.trim());
    }
    out.push_str("\nMeans over seeds with 95 % confidence intervals (Student's t).\n\n");
    out.push_str(&cells_markdown(plan, stats));
    out
}

/// Fixed parameters, the table of headline metrics per cell, and the notes.
fn cells_markdown(plan: &Plan, stats: &[CellStats]) -> String {
    let mut out = String::new();
    let fixed = plan.fixed();
    if !fixed.is_empty() {
        out.push_str("Fixed: ");
        let parts: Vec<String> = fixed.iter().map(|(k, v)| format!("{k} = `{v}`")).collect();
        out.push_str(&parts.join(", "));
        out.push_str(".\n\n");
    }
    let shown: Vec<_> =
        HEADLINE.iter().filter(|h| stats.iter().any(|s| s.metrics.contains_key(h.0))).collect();
    let headers: Vec<&str> = shown.iter().map(|h| h.1).collect();
    cell_table(&mut out, plan, stats.iter(), &headers, |s, i| {
        let h = shown[i];
        s.metrics.get(h.0).map_or("–".into(), |m| crate::format::mean(m, h.2))
    });
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
            cells.push(super::PlanCell { id: p.cells[c].id.clone(), params, seeds: own });
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
        .filter(|&i| cells.iter().any(|c: &super::PlanCell| c.params[i] != cells[0].params[i]))
        .map(|i| fields[i].clone())
        .collect();
    let name = parts.iter().map(|p| p.0.name.as_str()).collect::<Vec<_>>().join(" + ");
    let plan = Plan::new(name, String::new(), fields, axes, seeds, cells);
    (plan, stats)
}

/// Axes that belong to the learner rather than to the setting it learns in.
const LEARNER_SIDE: [&str; 8] =
    ["learner", "max_delay", "lambda_hat", "alpha", "gamma", "epsilon", "q0", "baseline"];

/// The learner setting a field of the `[settings]` table names (`settings.lasso` →
/// `lasso`; also under the prefix `beyond.` of stored specs).
fn setting_of(field: &str) -> Option<&str> {
    field.strip_prefix("settings.").or_else(|| field.strip_prefix("beyond."))
}

/// The settings of a sweep with a `learner` axis: every combination of the values of the
/// other axes (world, env, delay, robot, steps, ...), in order of first appearance, with
/// its cells as `(label, [(learner label, cell index)])`. A learner's label is its name,
/// with the learner-side axes (`max_delay`, `alpha`, ..., `settings.*`; not `baseline`)
/// whose values differ between its cells, e.g. `deconv-model-time (max_delay=200,
/// time_bin_s=1)`. The robot override `cell_diagnostics=true` (diagnostics, not a
/// setting) is left out of labels. Empty without a `learner` axis.
pub fn settings(plan: &Plan) -> Vec<(String, Vec<(String, usize)>)> {
    if !plan.axes.iter().any(|a| a == "learner") {
        return Vec::new();
    }
    let learner_side = |a: &str| LEARNER_SIDE.contains(&a) || setting_of(a).is_some();
    let others: Vec<&String> = plan.axes.iter().filter(|a| !learner_side(a)).collect();
    let tuning: Vec<&String> =
        plan.axes.iter().filter(|a| learner_side(a) && *a != "learner" && *a != "baseline").collect();
    let learner_label = |c: usize| -> String {
        let name = plan.param(c, "learner");
        let varied: Vec<String> = tuning
            .iter()
            .filter(|a| {
                (0..plan.cells.len())
                    .any(|d| plan.param(d, "learner") == name && plan.param(d, a) != plan.param(c, a))
            })
            .map(|a| format!("{}={}", setting_of(a).unwrap_or(a), plan.param(c, a)))
            .collect();
        if varied.is_empty() { name.to_string() } else { format!("{name} ({})", varied.join(", ")) }
    };
    let mut out: Vec<(String, Vec<(String, usize)>)> = Vec::new();
    for c in 0..plan.cells.len() {
        let label: Vec<String> =
            others.iter().map(|a| plan.param(c, a).replace(" cell_diagnostics=true", "")).collect();
        let label = if label.is_empty() { plan.name.clone() } else { label.join(" · ") };
        let learner = learner_label(c);
        match out.iter_mut().find(|s| s.0 == label) {
            Some(s) => s.1.push((learner, c)),
            None => out.push((label, vec![(learner, c)])),
        }
    }
    out
}

/// The learner labels of [`settings`], in order of first appearance.
pub fn learner_labels(sets: &[(String, Vec<(String, usize)>)]) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for (_, cells) in sets {
        for (l, _) in cells {
            if !out.contains(l) {
                out.push(l.clone());
            }
        }
    }
    out
}

/// A metric per setting (rows) and learner (columns), then its change from the first
/// setting in the same layout: the difference of the means ± √(a² + b²) of the two 95 %
/// half-widths (independent seeds); a learner variant the first setting lacks is
/// compared with the first setting's cell of the same learner name. None without a `learner` axis, with one setting, or
/// when no cell has the metric.
pub fn learner_markdown(
    plan: &Plan,
    stats: &[CellStats],
    metric: &str,
    label: &str,
    pct: bool,
) -> Option<String> {
    let sets = settings(plan);
    if sets.len() < 2 || !stats.iter().any(|s| s.metrics.contains_key(metric)) {
        return None;
    }
    let learners = learner_labels(&sets);
    let get = |set: &[(String, usize)], l: &str| -> Option<MeanCi> {
        let c = set.iter().find(|x| x.0 == l)?.1;
        stats.iter().find(|s| s.cell == c)?.metrics.get(metric).copied()
    };
    let head = |out: &mut String, first: &str| {
        let _ = write!(out, "| {first} |");
        for l in &learners {
            let _ = write!(out, " {l} |");
        }
        out.push_str("\n|---|");
        for _ in &learners {
            out.push_str("---|");
        }
        out.push('\n');
    };
    let scale = if pct { 100.0 } else { 1.0 };
    let mut out = format!("### {label}\n\n");
    head(&mut out, "setting");
    for (name, set) in &sets {
        let _ = write!(out, "| {} |", name.replace('|', "\\|"));
        for l in &learners {
            let _ = write!(out, " {} |", get(set, l).map_or("–".into(), |m| crate::format::mean(&m, pct)));
        }
        out.push('\n');
    }
    let _ =
        writeln!(out, "\nChange from `{}`{}:\n", sets[0].0, if pct { " (percentage points)" } else { "" });
    head(&mut out, "setting");
    for (name, set) in &sets[1..] {
        let _ = write!(out, "| {} |", name.replace('|', "\\|"));
        for l in &learners {
            // A learner variant absent from the first setting (e.g. tuned for the robot)
            // is compared with the first setting's cell of the same learner.
            let first = get(&sets[0].1, l).or_else(|| {
                let name = l.split(" (").next().unwrap_or(l);
                let c = sets[0].1.iter().find(|x| x.0.split(" (").next() == Some(name))?.1;
                stats.iter().find(|s| s.cell == c)?.metrics.get(metric).copied()
            });
            let text = match (first, get(set, l)) {
                (Some(a), Some(b)) if a.mean.is_finite() && b.mean.is_finite() => {
                    let d = scale * (b.mean - a.mean);
                    let h = scale * a.ci95.hypot(b.ci95);
                    format!(
                        "{} ± {}",
                        crate::format::signed(d, if pct { 1 } else { 4 }),
                        crate::format::signed(h, if pct { 1 } else { 4 })
                    )
                }
                _ => "–".into(),
            };
            let _ = write!(out, " {text} |");
        }
        out.push('\n');
    }
    out.push('\n');
    Some(out)
}

/// The robot's diagnostics shown in reports: (metric, label, shown as a percentage).
pub const ROBOT_COLUMNS: [(&str, &str, bool); 6] = [
    ("env/robot/grid_mismatch", "grid mismatch", true),
    ("env/robot/belief_error", "belief error", true),
    ("env/robot/loc_error_m_mean", "localisation error (m)", false),
    ("env/robot/primitive_s_mean", "primitive (s)", false),
    ("env/robot/reward_per_hour", "reward / h", false),
    ("perf/fraction_of_optimum", "fraction of optimum", true),
];

/// A table of the robot's diagnostics per robot cell; None when no cell has them.
pub fn robot_markdown(plan: &Plan, stats: &[CellStats]) -> Option<String> {
    let rows: Vec<&CellStats> =
        stats.iter().filter(|s| s.metrics.contains_key("env/robot/grid_mismatch")).collect();
    if rows.is_empty() {
        return None;
    }
    let mut out = String::new();
    let headers: Vec<&str> = ROBOT_COLUMNS.iter().map(|c| c.1).collect();
    cell_table(&mut out, plan, rows.into_iter(), &headers, |s, i| {
        let c = ROBOT_COLUMNS[i];
        s.metrics.get(c.0).map_or("–".into(), |m| {
            if c.2 { crate::format::mean_pct(m) } else { crate::format::mean_num(m, 3) }
        })
    });
    Some(out)
}

/// A markdown table with one row per cell: its id, its axis values, its seed count, then
/// one column per header, filled by `text(cell, column)`.
fn cell_table<'a>(
    out: &mut String,
    plan: &Plan,
    rows: impl Iterator<Item = &'a CellStats>,
    headers: &[&str],
    text: impl Fn(&CellStats, usize) -> String,
) {
    out.push_str("| cell |");
    for a in &plan.axes {
        let _ = write!(out, " {a} |");
    }
    out.push_str(" seeds |");
    for h in headers {
        let _ = write!(out, " {h} |");
    }
    out.push_str("\n|---|");
    for _ in 0..plan.axes.len() + 1 + headers.len() {
        out.push_str("---|");
    }
    out.push('\n');
    for s in rows {
        let _ = write!(out, "| `{}` |", plan.cells[s.cell].id);
        for a in &plan.axes {
            let _ = write!(out, " {} |", plan.param(s.cell, a).replace('|', "\\|"));
        }
        let _ = write!(out, " {} |", s.n);
        for i in 0..headers.len() {
            let _ = write!(out, " {} |", text(s, i));
        }
        out.push('\n');
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
