//! Typed ids of the per-seed metrics a run reports: a named figure
//! (`perf/relative`, `events/goal`, a learner's [`mmq_learn::Figure`]), a point of the
//! learning curve at a decision step, or a figure of the learner's diagnostics sampled at
//! a step. Every id has the text its outputs name it by (`curve/2500`,
//! `delay/median_est@10000`), made from its parts; the step of a curve point or a
//! sample is kept as a number and read as one, never parsed back from the text. Ids
//! order, compare and hash by their text, so a map of them lists columns as the text
//! sorts, and a named one is found by its name (`metrics.get("perf/relative")`).

use std::borrow::Borrow;
use std::cmp::Ordering;
use std::fmt;
use std::hash::{Hash, Hasher};

use serde::{Serialize, Serializer};

/// The id of a per-seed metric.
#[derive(Clone, Debug)]
pub struct MetricId {
    text: String,
    kind: MetricKind,
}

/// What a metric is, beside its text.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MetricKind {
    /// A named figure of the seed.
    Named,
    /// Earned reward per step in the part of the run that ends at this decision step.
    Curve {
        /// The part's last decision step.
        step: u64,
    },
    /// A figure of the learner's diagnostics as sampled after this many steps.
    At {
        /// Steps learned from when the sample was taken.
        step: u64,
        /// Length of the figure's name (the text before `@`).
        name_len: usize,
    },
}

impl MetricId {
    /// The named metric `name`.
    pub fn named(name: impl Into<String>) -> MetricId {
        MetricId { text: name.into(), kind: MetricKind::Named }
    }

    /// The learning-curve point of the part ending at `step` (`curve/<step>`).
    pub fn curve(step: u64) -> MetricId {
        MetricId { text: format!("curve/{step}"), kind: MetricKind::Curve { step } }
    }

    /// The diagnostics figure `name` sampled after `step` steps (`<name>@<step>`).
    pub fn at(name: &str, step: u64) -> MetricId {
        MetricId { text: format!("{name}@{step}"), kind: MetricKind::At { step, name_len: name.len() } }
    }

    /// Its text, as outputs name it.
    pub fn as_str(&self) -> &str {
        &self.text
    }

    /// What it is.
    pub fn kind(&self) -> MetricKind {
        self.kind
    }

    /// The step of a learning-curve point.
    pub fn curve_step(&self) -> Option<u64> {
        match self.kind {
            MetricKind::Curve { step } => Some(step),
            _ => None,
        }
    }

    /// The figure's name and step of a diagnostics sample.
    pub fn sample(&self) -> Option<(&str, u64)> {
        match self.kind {
            MetricKind::At { step, name_len } => Some((&self.text[..name_len], step)),
            _ => None,
        }
    }
}

impl From<&str> for MetricId {
    fn from(name: &str) -> MetricId {
        MetricId::named(name)
    }
}

impl From<String> for MetricId {
    fn from(name: String) -> MetricId {
        MetricId::named(name)
    }
}

impl fmt::Display for MetricId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text)
    }
}

impl PartialEq for MetricId {
    fn eq(&self, o: &MetricId) -> bool {
        self.text == o.text
    }
}

impl Eq for MetricId {}

impl PartialOrd for MetricId {
    fn partial_cmp(&self, o: &MetricId) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

impl Ord for MetricId {
    fn cmp(&self, o: &MetricId) -> Ordering {
        self.text.cmp(&o.text)
    }
}

impl Hash for MetricId {
    fn hash<H: Hasher>(&self, h: &mut H) {
        self.text.hash(h);
    }
}

impl Borrow<str> for MetricId {
    fn borrow(&self) -> &str {
        &self.text
    }
}

impl Serialize for MetricId {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.text)
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::*;

    /// Ids read their step as the number they were made with, sort as their texts do, and
    /// a named one is found by its name.
    #[test]
    fn ids_keep_their_parts_and_sort_as_text() {
        let c = MetricId::curve(2500);
        assert_eq!((c.as_str(), c.curve_step(), c.sample()), ("curve/2500", Some(2500), None));
        let a = MetricId::at("delay/median_est", 10_000);
        assert_eq!(
            (a.as_str(), a.sample(), a.curve_step()),
            ("delay/median_est@10000", Some(("delay/median_est", 10_000)), None)
        );
        // A name that reads like a curve point is still only a name.
        assert_eq!(MetricId::named("curve/7").curve_step(), None);
        let m: BTreeMap<MetricId, f64> = [
            (MetricId::curve(10_000), 1.0),
            (MetricId::curve(2500), 2.0),
            ("perf/relative".into(), 3.0),
            (a, 4.0),
        ]
        .into_iter()
        .collect();
        let order: Vec<&str> = m.keys().map(MetricId::as_str).collect();
        assert_eq!(order, ["curve/10000", "curve/2500", "delay/median_est@10000", "perf/relative"]);
        assert_eq!(m.get("perf/relative"), Some(&3.0));
        assert_eq!(m.get("curve/2500"), Some(&2.0));
    }
}
