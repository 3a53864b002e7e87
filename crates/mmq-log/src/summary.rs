//! [`summary`]: the figures of a log at a glance (what `mmq log summary` prints).

use std::collections::BTreeMap;
use std::fmt;
use std::path::PathBuf;

use crate::reader::{LogContents, ReadStop};

/// Figures of one log.
#[derive(Clone, Debug, PartialEq)]
pub struct LogSummary {
    /// The file.
    pub path: PathBuf,
    /// Its size, bytes.
    pub file_len: u64,
    /// Read to the end without a problem.
    pub complete: bool,
    /// Where reading stopped early, if it did.
    pub stop: Option<ReadStop>,
    /// What disagrees in a file read to its end (see [`LogContents::problems`]).
    pub problems: Vec<String>,
    /// Facts of the `run` metadata record.
    pub run: BTreeMap<String, String>,
    /// Simulated time covered by the messages, seconds.
    pub duration_s: f64,
    /// Steps of the run (from the end record; otherwise the last decision recorded + 1).
    pub steps: u64,
    /// The run was finished normally (from the end record; `None` without one).
    pub run_complete: Option<bool>,
    /// Decisions recorded.
    pub decisions: u64,
    /// Emissions recorded, and the sum of their values.
    pub emitted_count: u64,
    /// See `emitted_count`.
    pub emitted_sum: f64,
    /// Deliveries recorded, and the sum of their values.
    pub delivered_count: u64,
    /// See `delivered_count`.
    pub delivered_sum: f64,
    /// Whole-run reward totals (end record, else the last running total read), which
    /// differ from the sums above when only windows of the run were recorded.
    pub emitted_total: Option<f64>,
    /// See `emitted_total`.
    pub delivered_total: Option<f64>,
    /// Contacts that started.
    pub contacts: u64,
    /// Teleports.
    pub teleports: u64,
    /// Messages per topic.
    pub per_topic: BTreeMap<String, u64>,
}

/// Summarises a log.
pub fn summary(log: &LogContents) -> LogSummary {
    let end = log.metadata.get("end");
    let end_f64 = |k: &str| end.and_then(|e| e.get(k)).and_then(|v| v.parse::<f64>().ok());
    let (first, last) = log
        .topics
        .values()
        .filter(|t| t.count > 0)
        .fold((u64::MAX, 0), |(lo, hi), t| (lo.min(t.first_ns), hi.max(t.last_ns)));
    let duration_s = if first <= last { (last - first) as f64 * 1e-9 } else { 0.0 };
    let steps = end
        .and_then(|e| e.get("steps"))
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| log.decisions.last().map_or(0, |d| d.msg.t + 1));
    LogSummary {
        path: log.path.clone(),
        file_len: log.file_len,
        complete: log.complete,
        stop: log.stop.clone(),
        problems: log.problems.clone(),
        run: log.metadata.get("run").cloned().unwrap_or_default(),
        duration_s,
        steps,
        run_complete: end.and_then(|e| e.get("complete")).and_then(|v| v.parse().ok()),
        // A swarm's recording holds every robot's steps on their own topic.
        decisions: (log.decisions.len() + log.swarm_steps.len()) as u64,
        emitted_count: log.emitted.len() as u64,
        emitted_sum: log.emitted.iter().map(|e| e.msg.value).sum(),
        delivered_count: log.delivered.len() as u64,
        delivered_sum: log.delivered.iter().map(|d| d.msg.sum).sum(),
        emitted_total: end_f64("emitted_total").or(log.emitted.last().map(|e| e.msg.total)),
        delivered_total: end_f64("delivered_total").or(log.delivered.last().map(|d| d.msg.total)),
        contacts: log.contacts.iter().filter(|c| c.msg.started).count() as u64,
        teleports: log.teleports.len() as u64,
        per_topic: log.topics.iter().map(|(k, v)| (k.clone(), v.count)).collect(),
    }
}

impl fmt::Display for LogSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{} ({} bytes)", self.path.display(), self.file_len)?;
        match &self.stop {
            None if self.problems.is_empty() => writeln!(f, "  file:       complete")?,
            None => writeln!(f, "  file:       DAMAGED: {}", self.problems.join("; "))?,
            Some(s) => writeln!(f, "  file:       INCOMPLETE: {s}")?,
        }
        if self.stop.is_some() && !self.problems.is_empty() {
            writeln!(f, "  damaged:    {}", self.problems.join("; "))?;
        }
        let fact = |k: &str| self.run.get(k).map_or("?", String::as_str);
        writeln!(
            f,
            "  run:        {} on {} ({}), seed {}",
            fact("learner"),
            fact("world"),
            fact("env_kind"),
            fact("seed")
        )?;
        let ended = match self.run_complete {
            Some(true) => "finished",
            Some(false) => "interrupted",
            None => "no end record",
        };
        writeln!(f, "  steps:      {} ({ended}), {} decisions recorded", self.steps, self.decisions)?;
        writeln!(f, "  duration:   {:.3} s simulated", self.duration_s)?;
        writeln!(f, "  emitted:    {} rewards recorded, sum {}", self.emitted_count, self.emitted_sum)?;
        writeln!(
            f,
            "  delivered:  {} deliveries recorded, sum {}",
            self.delivered_count, self.delivered_sum
        )?;
        if let (Some(e), Some(d)) = (self.emitted_total, self.delivered_total) {
            writeln!(f, "  run totals: emitted {e}, delivered {d}, in flight {}", e - d)?;
        }
        writeln!(f, "  contacts:   {}  teleports: {}", self.contacts, self.teleports)?;
        writeln!(f, "  messages per topic:")?;
        for (topic, n) in &self.per_topic {
            writeln!(f, "    {topic:<24} {n}")?;
        }
        Ok(())
    }
}
