//! The report of finished sweeps: per-cell means with 95 % intervals as CSV and
//! markdown, a figure per numeric swept axis, and, where the sweep has them, the tables
//! per learner and setting, learning curves and the robot's diagnostics with per-cell
//! heat maps. Several sweeps (e.g. a grid sweep with 20 seeds and a robot sweep with 5)
//! are reported side by side.

mod figures;
mod groups;
mod tables;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use mmq_lab::LabError;
use mmq_lab::sweep::{CellStats, Plan, cell_stats, combine, load_results, read_manifest};

use crate::ReportError;
use figures::{curve_figures, figures, gap_figure, heat_maps};

pub use figures::axis_number;
pub use groups::{learner_labels, settings};
pub use tables::{
    HEADLINE, ROBOT_COLUMNS, combined_markdown, learner_markdown, plan_size, robot_markdown, summary_csv,
    summary_markdown,
};

/// What a sweep report wrote.
#[derive(Debug, Clone)]
pub struct SweepReport {
    /// The sweep's name (the combined name for several).
    pub name: String,
    /// Cells reported.
    pub cells: usize,
    /// Jobs finished, of `jobs`.
    pub done: usize,
    /// Jobs planned.
    pub jobs: usize,
    /// `summary.csv`.
    pub csv: PathBuf,
    /// `report.md`.
    pub markdown: PathBuf,
    /// Figures written.
    pub figures: usize,
}

/// Writes the report of the sweeps in `dirs` (one, or several side by side) to `out`
/// (default: `report/` in the first).
pub fn report(dirs: &[PathBuf], out: Option<&Path>) -> Result<SweepReport, ReportError> {
    // Per sweep: its plan, statistics, and the directory its world paths are relative to.
    let mut parts = Vec::new();
    let mut bases = Vec::new();
    for dir in dirs {
        let manifest = read_manifest(dir)?;
        let results = load_results(dir, &manifest.plan);
        let stats = cell_stats(&manifest.plan, &results);
        bases.push(Path::new(&manifest.spec_file).parent().map(Path::to_path_buf).unwrap_or_default());
        parts.push((manifest.plan, stats));
    }
    let first = dirs.first().ok_or(ReportError::NoSweep)?;
    let out = out.map_or_else(|| first.join("report"), Path::to_path_buf);
    std::fs::create_dir_all(&out).map_err(|source| LabError::Io { path: out.clone(), source })?;
    let (plan, stats, mut md) = if let [(p, s)] = parts.as_slice() {
        (p.clone(), s.clone(), summary_markdown(p, s))
    } else {
        let (p, s) = combine(&parts);
        let md = combined_markdown(&parts, &p, &s);
        (p, s, md)
    };
    // The sweep (index into `bases`) of every cell of `plan`.
    let part_of: Vec<usize> =
        parts.iter().enumerate().flat_map(|(k, p)| std::iter::repeat_n(k, p.0.cells.len())).collect();
    // Figures against an axis assume a product of axes: one sweep only.
    let figures = if parts.len() == 1 { figures(&plan, &stats, &out)? } else { Vec::new() };
    let mut n_figures = figures.len();
    if !figures.is_empty() {
        md.push_str("\n## Figures\n\n");
        for (axis, file) in &figures {
            let _ = writeln!(md, "![{axis}]({file})\n");
        }
    }
    n_figures += bridge_sections(&plan, &stats, &out, &mut md, |c| {
        bases.get(part_of.get(c).copied().unwrap_or(0)).cloned().unwrap_or_default()
    })?;
    n_figures += crate::swarm::swarm_section(&plan, &stats, &out, &mut md)?;
    let csv_path = out.join("summary.csv");
    mmq_lab::output::write_atomic(&csv_path, summary_csv(&plan, &stats).as_bytes())?;
    let md_path = out.join("report.md");
    mmq_lab::output::write_atomic(&md_path, md.as_bytes())?;
    let done: usize = stats.iter().map(|s| s.n).sum();
    let jobs: usize = parts.iter().map(|p| p.0.jobs()).sum();
    Ok(SweepReport {
        name: plan.name.clone(),
        cells: plan.cells.len(),
        done,
        jobs,
        csv: csv_path,
        markdown: md_path,
        figures: n_figures,
    })
}

/// Sections for sweeps with a learner axis, learning curves or robot diagnostics: the
/// tables per learner and setting, the change from the first setting as a figure, the
/// learning curves side by side, the robot's diagnostics and their per-cell heat maps.
/// Returns the number of figures written.
fn bridge_sections(
    plan: &Plan,
    stats: &[CellStats],
    out: &Path,
    md: &mut String,
    base_of: impl Fn(usize) -> PathBuf,
) -> Result<usize, ReportError> {
    let sets = settings(plan);
    let mut n = 0;
    let tables: Vec<String> = [
        (
            "perf/fraction_of_optimum",
            "Fraction of the optimum (reward per decision ÷ the grid's optimal gain)",
            true,
        ),
        ("perf/relative", "Relative performance (÷ undelayed Q-learning in the same setting, eq. 3)", true),
        (
            "perf/fraction_of_reference",
            "Fraction of the grid-optimal reference (what the environment allows: the grid's optimal policy run on it)",
            true,
        ),
        ("eval/greedy_fraction_of_optimum", "Greedy evaluation from S after learning (of optimum)", true),
    ]
    .iter()
    .filter_map(|(m, label, pct)| learner_markdown(plan, stats, m, label, *pct))
    .collect();
    if !tables.is_empty() {
        md.push_str("\n## Per learner and setting\n\n");
        let names: Vec<String> =
            sets.iter().enumerate().map(|(i, s)| format!("{} = `{}`", i + 1, s.0)).collect();
        let _ = writeln!(md, "Settings: {}.\n", names.join("; "));
        for t in &tables {
            md.push_str(t);
        }
        if gap_figure(plan, stats, &sets, out)? {
            md.push_str("![fraction of the optimum per setting](by-setting.png)\n\n");
            n += 1;
        }
    }
    let curves = curve_figures(stats, &sets, out)?;
    if !curves.is_empty() {
        md.push_str("\n## Learning curves\n\nReward earned per decision in equal parts of the run, mean over seeds with its 95 % interval (band), per setting.\n\n");
        image_table(md, &curves);
        n += curves.len();
    }
    if let Some(t) = robot_markdown(plan, stats) {
        md.push_str("\n## Robot diagnostics\n\nPer cell, means over seeds (see docs/robot.md for the definitions).\n\n");
        md.push_str(&t);
        let maps = heat_maps(plan, stats, &sets, out, base_of)?;
        if !maps.is_empty() {
            md.push_str("\nPer grid cell, mean over the learners (each a mean over its seeds): grid mismatch of the steps that started in the cell, belief error of the steps that ended in it; light grey: no step.\n\n");
            image_table(md, &maps);
            n += maps.len();
        }
    }
    Ok(n)
}

/// Images two to a row, each with its caption.
fn image_table(md: &mut String, images: &[(String, String)]) {
    for row in images.chunks(2) {
        md.push('|');
        for (caption, _) in row {
            let _ = write!(md, " {} |", caption.replace('|', "\\|"));
        }
        md.push_str(if row.len() == 2 { "\n|---|---|\n|" } else { "\n|---|\n|" });
        for (caption, file) in row {
            let _ = write!(md, " ![{}]({file}) |", caption.replace('|', "\\|"));
        }
        md.push_str("\n\n");
    }
}
