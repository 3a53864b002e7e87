//! The figures of a sweep report: the headline metric against every numeric swept axis
//! (delays by their mean), the fraction of the optimum per setting, the learning curves
//! of each setting, and the robot's per-cell heat maps. Each function writes its figures
//! (SVG and PNG) and returns what the markdown links.

use std::path::{Path, PathBuf};

use mmq_core::stats::MeanCi;
use mmq_core::{DelayDist, World};
use mmq_lab::sweep::{CellStats, Plan};
use mmq_plot::{GridHeatmap, LineChart, RefLine, Series};

use super::groups::learner_labels;
use super::tables::HEADLINE;
use crate::ReportError;

/// The value of an axis as a number for plots: numeric fields as they are, `delay` as
/// its mean in steps; None for names (world, env, learner).
pub fn axis_number(field: &str, value: &str) -> Option<f64> {
    match field {
        "delay" => DelayDist::parse(value).ok().map(|d| d.mean()),
        "world" | "env" | "learner" | "baseline" => None,
        _ => value.parse::<f64>().ok(),
    }
}

/// The mean of `metric` in cell `c`, if finite.
fn mean_of(stats: &[CellStats], c: usize, metric: &str) -> Option<MeanCi> {
    stats.iter().find(|s| s.cell == c)?.metrics.get(metric).copied().filter(|m| m.mean.is_finite())
}

/// Fraction of the optimum per setting (a categorical x axis labelled by the settings'
/// names), a series per learner.
pub(super) fn gap_figure(
    plan: &Plan,
    stats: &[CellStats],
    sets: &[(String, Vec<(String, usize)>)],
    out: &Path,
) -> Result<bool, ReportError> {
    let metric = "perf/fraction_of_optimum";
    let mut chart = LineChart::new(
        format!("{}: fraction of the optimum per setting", plan.name),
        "setting",
        "fraction of optimum (%)",
    );
    // Names as in the tables, without the placeholder of an axis a setting does not have.
    chart.x_categories = sets
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let parts: Vec<&str> = s.0.split(" · ").filter(|p| *p != "–").collect();
            format!("{}. {}", i + 1, parts.join(" · "))
        })
        .collect();
    for l in learner_labels(sets) {
        let pts: Vec<(f64, MeanCi)> = sets
            .iter()
            .enumerate()
            .filter_map(|(i, s)| {
                let c = s.1.iter().find(|x| x.0 == l)?.1;
                Some(((i + 1) as f64, mean_of(stats, c, metric)?))
            })
            .collect();
        if pts.is_empty() {
            continue;
        }
        let x = pts.iter().map(|p| p.0).collect();
        let y = pts.iter().map(|p| 100.0 * p.1.mean).collect();
        let lo = pts.iter().map(|p| 100.0 * (p.1.mean - p.1.ci95)).collect();
        let hi = pts.iter().map(|p| 100.0 * (p.1.mean + p.1.ci95)).collect();
        chart.series.push(Series::new(l, x, y).with_band(lo, hi).with_markers());
    }
    if chart.series.is_empty() {
        return Ok(false);
    }
    chart.write(&out.join("by-setting"))?;
    Ok(true)
}

/// A learning-curve figure per setting, a series per learner, from the learning-curve
/// metrics (their steps as stored, [`mmq_lab::metric::MetricId::curve_step`]); `(caption, file)`.
pub(super) fn curve_figures(
    stats: &[CellStats],
    sets: &[(String, Vec<(String, usize)>)],
    out: &Path,
) -> Result<Vec<(String, String)>, ReportError> {
    let mut files = Vec::new();
    for (i, (label, cells)) in sets.iter().enumerate() {
        let mut chart = LineChart::new(format!("{}. {label}", i + 1), "decision step", "reward per decision");
        let mut optimum = None;
        for (learner, c) in cells {
            let Some(st) = stats.iter().find(|s| s.cell == *c) else { continue };
            let mut pts: Vec<(f64, MeanCi)> = st
                .metrics
                .iter()
                .filter_map(|(k, m)| Some((k.curve_step()? as f64, *m)))
                .filter(|p| p.1.mean.is_finite())
                .collect();
            if pts.is_empty() {
                continue;
            }
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            if let (Some(e), Some(f)) =
                (mean_of(stats, *c, "reward/earned_per_step"), mean_of(stats, *c, "perf/fraction_of_optimum"))
                && f.mean > 0.0
            {
                optimum = Some(e.mean / f.mean);
            }
            let x = pts.iter().map(|p| p.0).collect();
            let y = pts.iter().map(|p| p.1.mean).collect();
            let lo = pts.iter().map(|p| p.1.mean - p.1.ci95).collect();
            let hi = pts.iter().map(|p| p.1.mean + p.1.ci95).collect();
            chart.series.push(Series::new(learner.clone(), x, y).with_band(lo, hi));
        }
        if chart.series.is_empty() {
            continue;
        }
        if let Some(o) = optimum {
            chart.ref_lines.push(RefLine::new("optimum", o));
        }
        let name = format!("curves-{}", i + 1);
        chart.write(&out.join(&name))?;
        files.push((format!("{}. {label}", i + 1), format!("{name}.png")));
    }
    Ok(files)
}

/// Heat maps of the per-cell grid mismatch and belief error (`env/robot/cells/...`), per
/// setting, averaged over the learners; `(caption, file)`.
pub(super) fn heat_maps(
    plan: &Plan,
    stats: &[CellStats],
    sets: &[(String, Vec<(String, usize)>)],
    out: &Path,
    base_of: impl Fn(usize) -> PathBuf,
) -> Result<Vec<(String, String)>, ReportError> {
    let groups: Vec<(String, Vec<usize>)> = if sets.is_empty() {
        (0..plan.cells.len()).map(|c| (plan.cells[c].id.clone(), vec![c])).collect()
    } else {
        sets.iter().map(|s| (s.0.clone(), s.1.iter().map(|x| x.1).collect())).collect()
    };
    let mut files = Vec::new();
    for (i, (label, cells)) in groups.iter().enumerate() {
        let Some(&c0) = cells.first() else { continue };
        let world_text = plan.param(c0, "world");
        let p = base_of(c0).join(world_text);
        let Ok(world) = World::load(&p).or_else(|_| World::load(world_text)) else { continue };
        for (what, caption) in [("grid_mismatch", "grid mismatch"), ("belief_error", "belief error")] {
            let prefix = format!("env/robot/cells/{what}/");
            let mut sum = vec![0.0; world.num_cells()];
            let mut count = vec![0usize; world.num_cells()];
            for &c in cells {
                let Some(st) = stats.iter().find(|s| s.cell == c) else { continue };
                for (k, m) in &st.metrics {
                    let Some(rc) = k.as_str().strip_prefix(&prefix) else { continue };
                    let Some((r, col)) = rc.strip_prefix('r').and_then(|x| x.split_once('c')) else {
                        continue;
                    };
                    let (Ok(r), Ok(col)) = (r.parse::<usize>(), col.parse::<usize>()) else { continue };
                    if r >= 1 && col >= 1 && r <= world.height && col <= world.width && m.mean.is_finite() {
                        let idx = (r - 1) * world.width + (col - 1);
                        sum[idx] += m.mean;
                        count[idx] += 1;
                    }
                }
            }
            if count.iter().all(|&k| k == 0) {
                continue;
            }
            let values: Vec<f64> = sum
                .iter()
                .zip(&count)
                .map(|(s, &k)| if k > 0 { 100.0 * s / k as f64 } else { f64::NAN })
                .collect();
            let title = format!("{}. {label}: {caption}", i + 1);
            let name = format!("cells-{}-{}", i + 1, what.replace('_', "-"));
            GridHeatmap::new(title.clone(), &world, values, format!("{caption} (%)"))
                .write(&out.join(&name))?;
            files.push((title, format!("{name}.png")));
        }
    }
    Ok(files)
}

/// At most this many series per figure; beyond, the other axes are averaged out.
const MAX_SERIES: usize = 10;

/// A figure per swept axis whose values are numbers (delays by their mean): the
/// headline metric against the axis, one series per combination of the other axes.
pub(super) fn figures(
    plan: &Plan,
    stats: &[CellStats],
    out: &Path,
) -> Result<Vec<(String, String)>, ReportError> {
    let Some(&(metric, label, pct)) =
        HEADLINE.iter().find(|h| stats.iter().any(|s| s.metrics.contains_key(h.0)))
    else {
        return Ok(Vec::new());
    };
    let scale = if pct { 100.0 } else { 1.0 };
    let mut files = Vec::new();
    for axis in &plan.axes {
        let values = plan.axis_values(axis);
        if axis == "delay" && mixed_units(&values) {
            continue;
        }
        let xs: Option<Vec<f64>> = values.iter().map(|v| axis_number(axis, v)).collect();
        let Some(xs) = xs else { continue };
        let mut distinct = xs.clone();
        distinct.sort_by(f64::total_cmp);
        distinct.dedup();
        if distinct.len() < 2 || distinct.len() != xs.len() {
            continue;
        }
        let others: Vec<&String> = plan.axes.iter().filter(|a| *a != axis).collect();
        // Group cells by the values of the other axes.
        let mut groups: Vec<(String, Vec<(f64, &CellStats)>)> = Vec::new();
        for s in stats {
            let Some(m) = s.metrics.get(metric) else { continue };
            if !m.mean.is_finite() {
                continue;
            }
            let key: Vec<String> = others.iter().map(|a| format!("{a}={}", plan.param(s.cell, a))).collect();
            let key = key.join(", ");
            let x = axis_number(axis, plan.param(s.cell, axis)).unwrap_or(f64::NAN);
            match groups.iter_mut().find(|g| g.0 == key) {
                Some(g) => g.1.push((x, s)),
                None => groups.push((key, vec![(x, s)])),
            }
        }
        if groups.is_empty() {
            continue;
        }
        let x_label = match axis.as_str() {
            "delay" => "mean delay λ (steps)".to_string(),
            "max_delay" => "λ̂max (steps)".to_string(),
            "lambda_hat" => "λ̂ (steps)".to_string(),
            "steps" | "window" | "eval_steps" => format!("{axis} (steps)"),
            other => other.to_string(),
        };
        let y_label = if pct { format!("{label} (%)") } else { label.to_string() };
        let mut chart = LineChart::new(format!("{}: {label} vs {axis}", plan.name), x_label, y_label);
        if groups.len() <= MAX_SERIES {
            for (key, mut pts) in groups {
                pts.sort_by(|a, b| a.0.total_cmp(&b.0));
                let x: Vec<f64> = pts.iter().map(|p| p.0).collect();
                let m: Vec<_> = pts.iter().map(|p| p.1.metrics[metric]).collect();
                let y = m.iter().map(|m| scale * m.mean).collect();
                let lo = m.iter().map(|m| scale * (m.mean - m.ci95)).collect();
                let hi = m.iter().map(|m| scale * (m.mean + m.ci95)).collect();
                let name = if key.is_empty() { plan.name.clone() } else { key };
                chart.series.push(Series::new(name, x, y).with_band(lo, hi).with_markers());
            }
        } else {
            let y: Vec<f64> = distinct
                .iter()
                .map(|&x| {
                    let ms: Vec<f64> = groups
                        .iter()
                        .flat_map(|g| g.1.iter())
                        .filter(|p| p.0 == x)
                        .map(|p| p.1.metrics[metric].mean)
                        .collect();
                    scale * ms.iter().sum::<f64>() / ms.len().max(1) as f64
                })
                .collect();
            let name = format!("mean over the other axes ({} combinations)", groups.len());
            chart.series.push(Series::new(name, distinct.clone(), y).with_markers());
        }
        if metric == "perf/relative" {
            chart.ref_lines.push(RefLine::new("undelayed Q-learning (100 %)", 100.0));
        }
        let base = out.join(format!("by-{axis}"));
        chart.write(&base)?;
        files.push((axis.clone(), format!("by-{axis}.png")));
    }
    Ok(files)
}

/// Whether delays in steps and delays in seconds are mixed (no common axis).
fn mixed_units(values: &[String]) -> bool {
    let units: Vec<_> = values.iter().filter_map(|v| DelayDist::parse(v).ok()).map(|d| d.unit()).collect();
    units.windows(2).any(|w| w[0] != w[1])
}
