//! The swarm's section of a sweep report: per cell, how the learner did and the delays
//! that emerged from the consultation; then, per swarm setting (the mean over the
//! cells that share it), the histogram of the emerged delays and the mean delay
//! against the hops the completing reply took.

use std::fmt::Write as _;
use std::path::Path;

use crate::format::{mean_num, mean_pct};
use mmq_lab::swarm::{DELAY_BINS_S, delay_bin_name};
use mmq_lab::sweep::{CellStats, Plan};
use mmq_plot::{LineChart, Series};

use crate::ReportError;

/// Columns of the per-cell table: metric, header, shown as a percentage.
const COLUMNS: [(&str, &str, bool); 9] = [
    ("perf/fraction_of_optimum", "fraction of optimum", true),
    ("perf/relative", "relative", true),
    ("env/swarm/delay_mean_s", "delay mean, s", false),
    ("env/swarm/delay_p50_s", "delay median, s", false),
    ("env/swarm/delay_p90_s", "delay p90, s", false),
    ("env/swarm/hops_mean", "hops, mean", false),
    ("env/swarm/lost_share", "rewards lost", true),
    ("env/swarm/robot_bumps", "robot bumps", false),
    ("env/robot/primitive_s_mean", "primitive, s", false),
];

/// Appends the swarm's section to `md` and writes its figures to `out`, if any cell ran
/// the swarm; returns the number of figures written.
pub fn swarm_section(
    plan: &Plan,
    stats: &[CellStats],
    out: &Path,
    md: &mut String,
) -> Result<usize, ReportError> {
    let rows: Vec<&CellStats> = stats.iter().filter(|s| s.metrics.contains_key("env/swarm/robots")).collect();
    if rows.is_empty() {
        return Ok(0);
    }
    md.push_str("\n## The swarm\n\nPer cell, means over seeds: the learner's share of the optimum (per robot), and the delays that emerged from the consultation (seconds from a reward to its completed consultation; lost: rewards whose consultation could never complete).\n\n");
    md.push_str("| cell | swarm | learner | seeds |");
    for c in COLUMNS {
        let _ = write!(md, " {} |", c.1);
    }
    md.push_str("\n|---|---|---|---|");
    md.push_str(&"---|".repeat(COLUMNS.len()));
    md.push('\n');
    for s in &rows {
        let _ = write!(
            md,
            "| `{}` | {} | {} | {} |",
            plan.cells[s.cell].id,
            plan.param(s.cell, "swarm"),
            plan.param(s.cell, "learner"),
            s.n
        );
        for (m, _, pct) in COLUMNS {
            let text =
                s.metrics.get(m).map_or("–".into(), |v| if pct { mean_pct(v) } else { mean_num(v, 2) });
            let _ = write!(md, " {text} |");
        }
        md.push('\n');
    }
    let groups = by_setting(plan, &rows);
    let mut n = 0;
    if histogram(plan, &groups, out)? {
        md.push_str("\n![the emerged delays per swarm setting](swarm-delays.png)\n");
        n += 1;
    }
    if by_hops(plan, &groups, out)? {
        md.push_str("\n![mean emerged delay against hops](swarm-delay-hops.png)\n");
        n += 1;
    }
    Ok(n)
}

/// The cells of each swarm setting, in the plan's order.
fn by_setting<'a>(plan: &Plan, rows: &[&'a CellStats]) -> Vec<(String, Vec<&'a CellStats>)> {
    let mut out: Vec<(String, Vec<&CellStats>)> = Vec::new();
    for s in rows {
        let name = plan.param(s.cell, "swarm").to_string();
        match out.iter_mut().find(|g| g.0 == name) {
            Some(g) => g.1.push(s),
            None => out.push((name, vec![s])),
        }
    }
    out
}

/// The mean of `metric` over the cells that have it (None if none has).
fn mean_over(cells: &[&CellStats], metric: &str) -> Option<f64> {
    let xs: Vec<f64> = cells.iter().filter_map(|s| s.metrics.get(metric)).map(|m| m.mean).collect();
    (!xs.is_empty()).then(|| xs.iter().sum::<f64>() / xs.len() as f64)
}

/// The share of completed consultations per delay bin, a series per swarm setting.
fn histogram(plan: &Plan, groups: &[(String, Vec<&CellStats>)], out: &Path) -> Result<bool, ReportError> {
    let bins = DELAY_BINS_S.len() + 1;
    let mut chart = LineChart::new(
        format!("{}: the emerged delays", plan.name),
        "delay from the reward to its completed consultation",
        "share of the completed consultations (%)",
    );
    chart.x_categories = (0..bins).map(delay_bin_name).collect();
    for (name, cells) in groups {
        let pts: Vec<(f64, f64)> = (0..bins)
            .filter_map(|k| {
                let share = mean_over(cells, &format!("env/swarm/delay_share/{}", delay_bin_name(k)))?;
                Some(((k + 1) as f64, 100.0 * share))
            })
            .collect();
        if pts.is_empty() {
            continue;
        }
        let (x, y) = pts.into_iter().unzip();
        chart.series.push(Series::new(name.clone(), x, y).with_markers());
    }
    if chart.series.is_empty() {
        return Ok(false);
    }
    chart.write(&out.join("swarm-delays"))?;
    Ok(true)
}

/// The mean delay of the consultations completed by a reply over `h` hops, against
/// `h`, a series per swarm setting.
fn by_hops(plan: &Plan, groups: &[(String, Vec<&CellStats>)], out: &Path) -> Result<bool, ReportError> {
    let mut chart = LineChart::new(
        format!("{}: delay against hops", plan.name),
        "hops of the completing reply",
        "mean delay (s)",
    );
    for (name, cells) in groups {
        let pts: Vec<(f64, f64)> = (0..=64u32)
            .filter_map(|h| {
                Some((h as f64, mean_over(cells, &format!("env/swarm/delay_mean_s_by_hops/{h}"))?))
            })
            .collect();
        if pts.is_empty() {
            continue;
        }
        let (x, y) = pts.into_iter().unzip();
        chart.series.push(Series::new(name.clone(), x, y).with_markers());
    }
    if chart.series.is_empty() {
        return Ok(false);
    }
    chart.write(&out.join("swarm-delay-hops"))?;
    Ok(true)
}
