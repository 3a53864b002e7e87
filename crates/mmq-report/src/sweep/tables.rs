//! The tables of a sweep report: per-cell means with 95 % intervals in tidy CSV
//! (`summary.csv`), the markdown of one sweep or of several side by side (the fixed
//! parameters and a table of the headline metrics per cell), a metric per learner and
//! setting with its change from the first setting, and the robot's diagnostics.

use std::fmt::Write as _;

use mmq_core::stats::MeanCi;
use mmq_lab::output::{csv_field, csv_number};
use mmq_lab::sweep::{CellStats, Plan};

use super::groups::{learner_labels, settings};
use crate::format;

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
                csv_field(k.as_str()),
                m.n,
                csv_number(m.mean),
                csv_number(m.ci95),
                csv_number(m.std)
            );
        }
    }
    out
}

/// A plan's size in words: `6 cells × 3 seeds = 18 jobs`, or for cells with seeds of
/// their own `16 cells, 410 jobs (seeds per part)`, with `jobs` jobs (the whole plan's
/// or a shard's).
pub fn plan_size(plan: &Plan, jobs: usize) -> String {
    if plan.uniform() {
        format!("{} cells × {} seeds = {jobs} jobs", plan.cells.len(), plan.seeds.len())
    } else {
        format!("{} cells, {jobs} jobs (seeds per part)", plan.cells.len())
    }
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
        plan_size(plan, plan.jobs())
    );
    out.push_str(&cells_markdown(plan, stats));
    out
}

/// The report of several sweeps read together ([`mmq_lab::sweep::combine`]): a line per sweep, then the
/// table of every cell as in [`summary_markdown`].
pub fn combined_markdown(parts: &[(Plan, Vec<CellStats>)], plan: &Plan, stats: &[CellStats]) -> String {
    let names: Vec<String> = parts.iter().map(|p| format!("`{}`", p.0.name)).collect();
    let mut out = format!("# Sweeps {}\n\n", names.join(" + "));
    for (p, st) in parts {
        let done: usize = st.iter().map(|s| s.n).sum();
        let _ = writeln!(
            out,
            "- `{}`: {}; {done} finished. {}",
            p.name,
            plan_size(p, p.jobs()),
            p.description.trim()
        );
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
        s.metrics.get(h.0).map_or("–".into(), |m| format::mean(m, h.2))
    });
    for s in stats {
        for note in &s.notes {
            let _ = writeln!(out, "\n- `{}`: {note}", plan.cells[s.cell].id);
        }
    }
    out.push_str("\nEvery metric of every cell: `summary.csv`; every seed: `results.csv`.\n");
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
            let _ = write!(out, " {} |", get(set, l).map_or("–".into(), |m| format::mean(&m, pct)));
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
                        format::signed(d, if pct { 1 } else { 4 }),
                        format::signed(h, if pct { 1 } else { 4 })
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
        s.metrics
            .get(c.0)
            .map_or("–".into(), |m| if c.2 { format::mean_pct(m) } else { format::mean_num(m, 3) })
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
    use mmq_lab::sweep::PlanCell;

    use super::*;

    fn plan(seeds: &[Option<Vec<u64>>]) -> Plan {
        let cells = seeds
            .iter()
            .enumerate()
            .map(|(i, s)| PlanCell { id: format!("c{i}"), params: vec![], seeds: s.clone() })
            .collect();
        Plan::new("s".into(), String::new(), vec![], vec![], vec![0, 1], cells)
    }

    /// A plan's size reads as a product when every cell runs the same seeds, and as cells
    /// and jobs when cells have seeds of their own.
    #[test]
    fn plan_sizes_read_as_products_or_parts() {
        let same = plan(&[None, None, None]);
        assert_eq!(plan_size(&same, same.jobs()), "3 cells × 2 seeds = 6 jobs");
        assert_eq!(plan_size(&same, 2), "3 cells × 2 seeds = 2 jobs");
        let parts = plan(&[None, Some(vec![7, 8, 9])]);
        assert_eq!(plan_size(&parts, parts.jobs()), "2 cells, 5 jobs (seeds per part)");
    }
}
