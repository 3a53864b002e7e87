//! `mmq sweep`: run a spec's product of parameters over seeds (resumable, shardable),
//! merge shard outputs, and report per-cell means with 95 % intervals, as CSV, markdown
//! and a figure per numeric swept axis (drawn here, through mmq-plot).

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use mmq_lab::sweep::{
    CellStats, HEADLINE, Plan, Shard, SweepEvent, SweepSpec, axis_number, cell_stats, load_results, merge,
    read_manifest, run_sweep, summary_csv, summary_markdown,
};
use mmq_lab::{Control, LabError};
use mmq_plot::{LineChart, RefLine, Series};

use crate::cli::{SweepAction, SweepArgs};
use crate::{Failure, progress};

/// Runs `mmq sweep`.
pub fn sweep(a: SweepArgs, stop: &AtomicBool) -> Result<(), Failure> {
    match a.action {
        Some(SweepAction::Report { dir, out }) => report(&dir, out.as_deref()),
        Some(SweepAction::Merge { dirs, out }) => merge_cmd(&dirs, &out),
        None => {
            let spec = a
                .spec
                .ok_or_else(|| crate::input_error("give a sweep spec: mmq sweep SPEC.toml --out DIR"))?;
            let out = a.out.ok_or_else(|| crate::input_error("give an output directory: --out DIR"))?;
            let shard = a.shard.as_deref().map(Shard::parse).transpose()?;
            run(&spec, &out, shard, a.dry_run, a.quiet, stop)
        }
    }
}

fn run(
    spec: &Path,
    out: &Path,
    shard: Option<Shard>,
    dry_run: bool,
    quiet: bool,
    stop: &AtomicBool,
) -> Result<(), Failure> {
    let spec = SweepSpec::load(spec)?;
    let plan = &spec.plan;
    let shard_text = shard.map_or(String::new(), |s| format!(", shard {s}"));
    if dry_run {
        print_plan(plan, shard);
        return Ok(());
    }
    let clock = Instant::now();
    let pb = progress::bar(0, "sweep", quiet);
    let progress = |n: u64| pb.inc(n);
    let ctl = Control { stop, progress: &progress };
    let name = plan.name.clone();
    let events = |e: &SweepEvent<'_>| match e {
        SweepEvent::Planned { jobs_total, jobs_here, done, baselines, steps } => {
            pb.set_length(*steps);
            println!(
                "sweep {name}: {} cells × {} seeds = {jobs_total} jobs{shard_text}: {jobs_here} here, {done} already finished, {} to run ({baselines} shared baselines)",
                plan.cells.len(),
                plan.seeds.len(),
                jobs_here - done,
            );
        }
        SweepEvent::JobDone { cell, cell_index, seed, finished, of, wall_s } => {
            if !quiet {
                let axes: Vec<String> =
                    plan.axes.iter().map(|a| format!("{a}={}", plan.param(*cell_index, a))).collect();
                pb.suspend(|| {
                    eprintln!("[{finished}/{of}] cell {cell} ({}) seed {seed}: {wall_s:.2} s", axes.join(" "))
                });
            }
        }
    };
    let outcome = run_sweep(&spec, out, shard, ctl, &events)?;
    pb.finish_and_clear();
    println!(
        "ran {} job(s), skipped {} already finished, {} left; {} rows in {} ({:.1} s)",
        outcome.ran,
        outcome.skipped,
        outcome.left,
        outcome.rows,
        outcome.results_csv.display(),
        clock.elapsed().as_secs_f64()
    );
    if outcome.left > 0 {
        eprintln!(
            "interrupted: {} job(s) of this {} unfinished; run the same command again to resume",
            outcome.left,
            if shard.is_some() { "shard" } else { "sweep" }
        );
    }
    Ok(())
}

fn print_plan(plan: &Plan, shard: Option<Shard>) {
    // One write, errors ignored: `mmq sweep ... --dry-run | head` must not panic.
    let mut t = format!(
        "sweep {}: {} cells × {} seeds = {} jobs\n",
        plan.name,
        plan.cells.len(),
        plan.seeds.len(),
        plan.jobs()
    );
    if let Some(s) = shard {
        let n = (0..plan.jobs()).filter(|&j| s.contains(j)).count();
        let _ = writeln!(t, "shard {s}: {n} jobs");
    }
    for (k, v) in plan.fixed() {
        let _ = writeln!(t, "  {k:<11} = {v}");
    }
    for a in &plan.axes {
        let _ = writeln!(t, "  {a:<11} ∈ {{{}}}", plan.axis_values(a).join(", "));
    }
    let seeds: Vec<String> = plan.seeds.iter().map(u64::to_string).collect();
    let _ = writeln!(t, "  {:<11} ∈ {{{}}}", "seed", seeds.join(", "));
    t.push_str("cells:\n");
    for (i, c) in plan.cells.iter().enumerate() {
        let axes: Vec<String> = plan.axes.iter().map(|a| format!("{a}={}", plan.param(i, a))).collect();
        let _ = writeln!(t, "  {} {}", c.id, axes.join(" "));
    }
    let _ = std::io::stdout().lock().write_all(t.as_bytes());
}

fn merge_cmd(dirs: &[PathBuf], out: &Path) -> Result<(), Failure> {
    let m = merge(dirs, out)?;
    println!(
        "merged {} director{}: {} of {} jobs finished ({} copied); wrote {}",
        dirs.len(),
        if dirs.len() == 1 { "y" } else { "ies" },
        m.done,
        m.jobs_total,
        m.copied,
        m.results_csv.display()
    );
    if m.done < m.jobs_total {
        eprintln!("warning: {} job(s) missing from every input; rerun their shards", m.jobs_total - m.done);
    }
    Ok(())
}

fn plot_err(e: mmq_plot::PlotError) -> Failure {
    Failure { code: crate::exit::RUNTIME, error: anyhow::anyhow!("{e}") }
}

fn report(dir: &Path, out: Option<&Path>) -> Result<(), Failure> {
    let manifest = read_manifest(dir)?;
    let plan = &manifest.plan;
    let results = load_results(dir, plan);
    let stats = cell_stats(plan, &results);
    let out = out.map_or_else(|| dir.join("report"), Path::to_path_buf);
    std::fs::create_dir_all(&out).map_err(|source| LabError::Io { path: out.clone(), source })?;
    let mut md = summary_markdown(plan, &stats);
    let figures = figures(plan, &stats, &out)?;
    if !figures.is_empty() {
        md.push_str("\n## Figures\n\n");
        for (axis, file) in &figures {
            let _ = writeln!(md, "![{axis}]({file})\n");
        }
    }
    let csv_path = out.join("summary.csv");
    mmq_lab::output::write_atomic(&csv_path, summary_csv(plan, &stats).as_bytes())?;
    let md_path = out.join("report.md");
    mmq_lab::output::write_atomic(&md_path, md.as_bytes())?;
    let done: usize = stats.iter().map(|s| s.n).sum();
    println!(
        "sweep {}: {} cells, {done} of {} jobs finished; wrote {}, {} and {} figure(s)",
        plan.name,
        plan.cells.len(),
        plan.jobs(),
        csv_path.display(),
        md_path.display(),
        figures.len()
    );
    Ok(())
}

/// At most this many series per figure; beyond, the other axes are averaged out.
const MAX_SERIES: usize = 10;

/// A figure per swept axis whose values are numbers (delays by their mean): the
/// headline metric against the axis, one series per combination of the other axes.
fn figures(plan: &Plan, stats: &[CellStats], out: &Path) -> Result<Vec<(String, String)>, Failure> {
    let Some(&(metric, label, pct)) =
        HEADLINE.iter().find(|h| stats.iter().any(|s| s.metrics.contains_key(h.0)))
    else {
        return Ok(Vec::new());
    };
    let scale = if pct { 100.0 } else { 1.0 };
    let mut files = Vec::new();
    for axis in &plan.axes {
        let values = plan.axis_values(axis);
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
        chart.write(&base).map_err(plot_err)?;
        files.push((axis.clone(), format!("by-{axis}.png")));
    }
    Ok(files)
}
