//! The suite's leaderboard: results files of several agents on one tier in, a markdown
//! page, two CSV files and figures out. Per task, each agent's mean fraction of the
//! optimum with its 95 % interval (Student's t over seeds); across tasks, the
//! interquartile mean with stratified-bootstrap intervals, performance profiles and the
//! probability of improvement over `mmq` (the methods of Agarwal et al., NeurIPS 2021;
//! the numbers come from [`mmq_lab::suite::stats`]); and the reference, the grid-optimal
//! policy on each task, with each agent's fraction of it (the `reference` module).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use mmq_core::stats::mean_ci;
use mmq_lab::LabError;
use mmq_lab::suite::stats::{
    Bootstrap, Interval, Scores, iqm_interval, probability_of_improvement_interval, profile_interval,
    with_interval,
};
use mmq_lab::suite::{SuiteResults, read_results, reference};
use mmq_plot::{LineChart, RefLine, Series};

use crate::{Doc, ReportError};

/// The agent the probability of improvement is measured against, when present (else the
/// first file's agent).
pub const IMPROVEMENT_OVER: &str = "mmq";

/// Resamples of the bootstrap of the interquartile mean, the mean and the probability of
/// improvement.
pub const REPS: usize = 10_000;
/// Resamples of the bands of the performance profiles.
pub const PROFILE_REPS: usize = 2_000;
/// Seed of every bootstrap.
pub const SEED: u64 = 0;

/// What [`report`] wrote.
#[derive(Debug, Clone)]
pub struct LeaderboardReport {
    /// Agents compared.
    pub agents: usize,
    /// Tasks.
    pub tasks: usize,
    /// `leaderboard.md`.
    pub markdown: PathBuf,
    /// Every file written.
    pub files: Vec<PathBuf>,
}

/// One agent's scores.
struct Entry {
    results: SuiteResults,
    /// Per task: the finished seeds' fraction of the optimum.
    scores: Scores,
    /// Per task: the finished seeds' greedy fraction of the optimum.
    greedy: Scores,
    failed: usize,
}

fn entry(results: SuiteResults) -> Entry {
    let finished = |t: &mmq_lab::suite::TaskResults, f: fn(&mmq_lab::suite::SeedScore) -> Option<f64>| {
        t.seeds.iter().filter(|s| !s.failed).filter_map(f).collect::<Vec<f64>>()
    };
    let scores = results.tasks.iter().map(|t| finished(t, |s| s.fraction_of_optimum)).collect();
    let greedy = results.tasks.iter().map(|t| finished(t, |s| s.greedy_fraction_of_optimum)).collect();
    let failed = results.tasks.iter().flat_map(|t| &t.seeds).filter(|s| s.failed).count();
    Entry { results, scores, greedy, failed }
}

/// Reads the results files, checks that they are one suite, one tier and the same tasks,
/// and writes the leaderboard into `out`.
pub fn report(files: &[PathBuf], out: &Path) -> Result<LeaderboardReport, ReportError> {
    let first = files.first().ok_or_else(|| LabError::Config {
        file: "results".into(),
        message: "give at least one results file (results.json of `mmq suite run`)".into(),
    })?;
    let mut entries: Vec<Entry> = Vec::new();
    let mut given_reference: Option<(SuiteResults, &PathBuf)> = None;
    for f in files {
        let r = read_results(f)?;
        if reference::is_reference(&r) {
            if let Some((_, other)) = &given_reference {
                return Err(LabError::Config {
                    file: f.display().to_string(),
                    message: format!(
                        "is a second reference ({} is one); give one results file of `mmq suite reference`",
                        other.display()
                    ),
                }
                .into());
            }
            given_reference = Some((r, f));
            continue;
        }
        if let Some(e) = entries.first() {
            let e = &e.results;
            let tasks = |r: &SuiteResults| r.tasks.iter().map(|t| t.task.clone()).collect::<Vec<_>>();
            let why = if (r.suite.as_str(), r.tier.as_str()) != (e.suite.as_str(), e.tier.as_str()) {
                Some(format!(
                    "is suite {} tier {}, but {} is suite {} tier {}; a leaderboard compares one suite and tier",
                    r.suite,
                    r.tier,
                    first.display(),
                    e.suite,
                    e.tier
                ))
            } else if tasks(&r) != tasks(e) {
                Some(format!(
                    "holds other tasks than {}; were they written by different suites?",
                    first.display()
                ))
            } else if entries.iter().any(|x| x.results.agent == r.agent) {
                Some(format!("agent `{}` is given twice; give each agent's results once", r.agent))
            } else {
                None
            };
            if let Some(message) = why {
                return Err(LabError::Config { file: f.display().to_string(), message }.into());
            }
        }
        entries.push(entry(r));
    }
    if entries.is_empty() {
        return Err(LabError::Config {
            file: first.display().to_string(),
            message: "holds only the reference; give at least one agent's results file".into(),
        }
        .into());
    }
    let head = &entries[0].results;
    let reference = match given_reference {
        Some((r, f)) if (r.suite.as_str(), r.tier.as_str()) != (head.suite.as_str(), head.tier.as_str()) => {
            return Err(LabError::Config {
                file: f.display().to_string(),
                message: format!(
                    "is the reference of suite {} tier {}, but the agents' files are suite {} tier {}",
                    r.suite, r.tier, head.suite, head.tier
                ),
            }
            .into());
        }
        Some((r, f)) => Some((r, format!("from {}", f.display()))),
        // The shipped reference of a suite of that version, when it has every task (a
        // suite file of one's own that reuses a version's name has other tasks).
        None => reference::shipped(&head.suite, &head.tier)
            .filter(|r| head.tasks.iter().all(|t| r.tasks.iter().any(|x| x.task == t.task)))
            .map(|r| {
                let file = format!("worlds/suites/{}/reference-{}.json", head.suite, head.tier);
                (r, format!("the suite's own, `{file}`, made by `mmq suite reference --tier {}`", head.tier))
            }),
    };
    std::fs::create_dir_all(out).map_err(|source| LabError::Io { path: out.to_path_buf(), source })?;
    let mut doc = Doc::new(out);
    let tasks: Vec<String> = head.tasks.iter().map(|t| t.task.clone()).collect();
    let _ = writeln!(doc.md, "# Leaderboard: suite {}, tier {}\n", head.suite, head.tier);
    if head.tier == "lite" {
        doc.md.push_str(
            "The `lite` tier: a few seeds and short budgets, a check rather than a result to publish.\n\n",
        );
    }
    doc.md.push_str(
        "Score: the **fraction of the optimum**, reward earned while learning over the budget ÷ the exact \
         optimum's reward over as many steps (on robot tasks the optimum is the grid MDP's). Failed seeds \
         are left out of every statistic and counted below.\n\n",
    );
    for e in &entries {
        if !e.results.complete {
            let _ = writeln!(
                doc.md,
                "- **{}**: incomplete results (seeds not run yet are missing).",
                e.results.agent
            );
        }
    }
    aggregates(&mut doc, &entries)?;
    per_task(&mut doc, &entries, &tasks)?;
    if let Some((r, source)) = &reference {
        crate::reference::section(&mut doc, &entries_view(&entries), r, &tasks, source)?;
    }
    profiles(&mut doc, &entries)?;
    scores_csv(&mut doc, &entries)?;
    let md_path = out.join("leaderboard.md");
    mmq_lab::output::write_atomic(&md_path, doc.md.as_bytes())?;
    doc.files.push(md_path.clone());
    Ok(LeaderboardReport { agents: entries.len(), tasks: tasks.len(), markdown: md_path, files: doc.files })
}

/// The agents' results and per-task scores, for the reference section.
fn entries_view(entries: &[Entry]) -> Vec<crate::reference::AgentScores<'_>> {
    entries
        .iter()
        .map(|e| crate::reference::AgentScores {
            agent: &e.results.agent,
            tasks: e.results.tasks.iter().map(|t| t.task.as_str()).collect(),
            scores: &e.scores,
            greedy: &e.greedy,
        })
        .collect()
}

pub(crate) fn pct(x: f64) -> String {
    if x.is_finite() { format!("{:.1}", 100.0 * x) } else { "–".into() }
}

fn interval(i: &Interval) -> String {
    format!("{} [{}, {}]", pct(i.estimate), pct(i.lo), pct(i.hi))
}

/// The aggregate table and `aggregates.csv`.
fn aggregates(doc: &mut Doc, entries: &[Entry]) -> Result<(), ReportError> {
    let b = Bootstrap { reps: REPS, seed: SEED };
    let reference = entries.iter().find(|e| e.results.agent == IMPROVEMENT_OVER).or(entries.first());
    let ref_name = reference.map(|e| e.results.agent.clone()).unwrap_or_default();
    let _ = writeln!(
        doc.md,
        "## Across tasks\n\n\
         Interquartile mean (IQM: the mean of the middle half of all runs of all tasks) and mean of the \
         fraction of the optimum, in %, the greedy policy's IQM, and the probability that the agent beats \
         `{ref_name}` on a task chosen at random (P(X > Y) over pairs of runs, ties ½, averaged over tasks). \
         Intervals: 95 % percentile intervals of the stratified bootstrap (runs resampled within each task; \
         {REPS} resamples, seed {SEED}).\n\n\
         | agent | runs | failed | IQM | mean | greedy IQM | P(agent > {ref_name}) |\n|---|---|---|---|---|---|---|"
    );
    let mut csv = String::from("agent,metric,estimate,lo,hi\n");
    for e in entries {
        let runs: usize = e.scores.iter().map(Vec::len).sum();
        let iqm = iqm_interval(&e.scores, b);
        let mean = with_interval(&e.scores, mmq_lab::suite::stats::mean, b);
        let greedy = iqm_interval(&e.greedy, b);
        let poi = reference.map(|r| probability_of_improvement_interval(&e.scores, &r.scores, b));
        let poi_text = match (&poi, reference) {
            (_, Some(r)) if r.results.agent == e.results.agent => "–".to_string(),
            (Some(p), _) => format!("{:.2} [{:.2}, {:.2}]", p.estimate, p.lo, p.hi),
            _ => "–".into(),
        };
        let _ = writeln!(
            doc.md,
            "| {} | {runs} | {} | {} | {} | {} | {poi_text} |",
            e.results.agent,
            e.failed,
            interval(&iqm),
            interval(&mean),
            interval(&greedy)
        );
        let mut row = |metric: &str, i: &Interval| {
            let _ = writeln!(csv, "{},{metric},{},{},{}", field(&e.results.agent), i.estimate, i.lo, i.hi);
        };
        row("iqm", &iqm);
        row("mean", &mean);
        row("greedy_iqm", &greedy);
        if let Some(p) = &poi {
            row(&format!("probability_of_improvement_over_{ref_name}"), p);
        }
    }
    doc.md.push('\n');
    doc.csv("aggregates.csv", &csv)
}

/// The per-task table and figure.
fn per_task(doc: &mut Doc, entries: &[Entry], tasks: &[String]) -> Result<(), ReportError> {
    doc.md.push_str(
        "## Per task\n\nMean fraction of the optimum in % ± the half-width of its 95 % interval (Student's t over \
         the finished seeds), and the number of seeds.\n\n| # | task |",
    );
    for e in entries {
        let _ = write!(doc.md, " {} |", e.results.agent);
    }
    doc.md.push_str("\n|---|---|");
    doc.md.push_str(&"---|".repeat(entries.len()));
    doc.md.push('\n');
    let mut chart = LineChart::new(
        "Fraction of the optimum per task",
        "task (numbered as in the table)",
        "fraction of optimum (%)",
    );
    chart.ref_lines.push(RefLine::new("optimum", 100.0));
    // Per agent: x, mean, lower and upper edge of the interval.
    let mut series: Vec<[Vec<f64>; 4]> = vec![Default::default(); entries.len()];
    for (i, t) in tasks.iter().enumerate() {
        let _ = write!(doc.md, "| {} | {t} |", i + 1);
        for (e, s) in entries.iter().zip(&mut series) {
            let m = mean_ci(&e.scores[i]);
            if m.n == 0 {
                doc.md.push_str(" – |");
                continue;
            }
            let _ = write!(doc.md, " {} ± {} (n={}) |", pct(m.mean), pct(m.ci95), m.n);
            s[0].push((i + 1) as f64);
            s[1].push(100.0 * m.mean);
            s[2].push(100.0 * (m.mean - m.ci95));
            s[3].push(100.0 * (m.mean + m.ci95));
        }
        doc.md.push('\n');
    }
    for (e, [x, y, lo, hi]) in entries.iter().zip(series) {
        chart.series.push(Series::new(e.results.agent.clone(), x, y).with_band(lo, hi).with_markers());
    }
    let written = chart.write(&doc.path("per-task"))?;
    doc.figure(written, "Mean fraction of the optimum per task with 95 % intervals");
    Ok(())
}

/// The performance profiles: the fraction of runs above each score, with bootstrap bands.
fn profiles(doc: &mut Doc, entries: &[Entry]) -> Result<(), ReportError> {
    // From the lowest score (or 0) to the highest (or the optimum, 1).
    let all = || entries.iter().flat_map(|e| e.scores.iter().flatten());
    let (low, top) = (all().fold(0.0_f64, |a, &b| a.min(b)), all().fold(1.0_f64, |a, &b| a.max(b)));
    let taus: Vec<f64> = (0..=100).map(|i| low + (top - low) * i as f64 / 100.0).collect();
    let mut chart = LineChart::new(
        "Performance profiles",
        "fraction of optimum τ (%)",
        "fraction of runs with score > τ",
    );
    let b = Bootstrap { reps: PROFILE_REPS, seed: SEED };
    for e in entries {
        let p = profile_interval(&e.scores, &taus, b);
        let x: Vec<f64> = taus.iter().map(|t| 100.0 * t).collect();
        let y = p.iter().map(|i| i.estimate).collect();
        let (lo, hi) = (p.iter().map(|i| i.lo).collect(), p.iter().map(|i| i.hi).collect());
        chart.series.push(Series::new(e.results.agent.clone(), x, y).with_band(lo, hi));
    }
    chart.y_range = Some((0.0, 1.0));
    doc.md.push_str(
        "\n## Performance profiles\n\nFor each score τ, the fraction of all runs (every task, every seed) whose \
         fraction of the optimum exceeds τ; a curve above another is better everywhere. Bands: pointwise 95 % \
         intervals of the stratified bootstrap.\n",
    );
    let written = chart.write(&doc.path("profiles"))?;
    doc.figure(written, "Performance profiles (score distributions) with 95 % bands");
    Ok(())
}

/// A CSV field, quoted when it holds a comma, a quote or a line break (RFC 4180).
pub(crate) fn field(s: &str) -> String {
    if s.contains([',', '"', '\n']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s.to_string() }
}

/// Every seed's scores, tidy: `scores.csv`.
fn scores_csv(doc: &mut Doc, entries: &[Entry]) -> Result<(), ReportError> {
    let mut csv =
        String::from("agent,task,seed,failed,fraction_of_optimum,greedy_fraction_of_optimum,regret\n");
    let num = |x: Option<f64>| x.map(|v| v.to_string()).unwrap_or_default();
    for e in entries {
        for t in &e.results.tasks {
            for s in &t.seeds {
                let _ = writeln!(
                    csv,
                    "{},{},{},{},{},{},{}",
                    field(&e.results.agent),
                    field(&t.task),
                    s.seed,
                    s.failed,
                    num(s.fraction_of_optimum),
                    num(s.greedy_fraction_of_optimum),
                    num(s.regret)
                );
            }
        }
    }
    doc.md.push_str("\n## Data\n\n");
    doc.csv("scores.csv", &csv)
}
