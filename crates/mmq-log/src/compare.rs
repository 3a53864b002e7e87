//! [`compare`]: do two logs tell the same run? Decisions, rewards (emitted and
//! delivered) and poses are compared message by message, times included, bit for bit;
//! the first difference in simulated time is reported with its topic, step and field;
//! [`compare_prefix`] does the same for a log that holds only the start of its run.
//! (Re-running a simulation to get the second log is the lab's business.)

use std::fmt;

use serde::Serialize;
use serde_json::Value;

use crate::messages::topics;
use crate::reader::{LogContents, Stamped};

/// The first difference between two logs.
#[derive(Clone, Debug, PartialEq)]
pub struct Mismatch {
    /// Topic.
    pub topic: String,
    /// Index of the message on that topic.
    pub index: usize,
    /// Decision step of the message (for poses: of the last decision before it), if
    /// known.
    pub step: Option<u64>,
    /// Simulated time of the message, ns.
    pub log_time: u64,
    /// The differing field (`log_time`, `action`, `parts[0].delay`, `x`, ...; `(message)`
    /// when one log has the message and the other not).
    pub field: String,
    /// The value in the first log.
    pub a: String,
    /// The value in the second log.
    pub b: String,
}

impl fmt::Display for Mismatch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "logs differ on {} message {}", self.topic, self.index)?;
        if let Some(t) = self.step {
            write!(f, " (step {t})")?;
        }
        write!(f, ", field `{}`: {} vs {}", self.field, self.a, self.b)
    }
}

impl std::error::Error for Mismatch {}

/// The first differing leaf of two JSON values: (path, a, b).
fn first_diff(a: &Value, b: &Value, path: &str) -> Option<(String, String, String)> {
    let join = |k: &str| if path.is_empty() { k.to_string() } else { format!("{path}.{k}") };
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            let mut keys: Vec<&String> = x.keys().chain(y.keys()).collect();
            keys.sort();
            keys.dedup();
            keys.into_iter().find_map(|k| match (x.get(k), y.get(k)) {
                (Some(u), Some(v)) => first_diff(u, v, &join(k)),
                (u, v) => Some((join(k), show(u), show(v))),
            })
        }
        (Value::Array(x), Value::Array(y)) => {
            let n = x.len().max(y.len());
            (0..n).find_map(|i| {
                let p = format!("{path}[{i}]");
                match (x.get(i), y.get(i)) {
                    (Some(u), Some(v)) => first_diff(u, v, &p),
                    (u, v) => Some((p, show(u), show(v))),
                }
            })
        }
        _ => (a != b).then(|| (path.to_string(), a.to_string(), b.to_string())),
    }
}

fn show(v: Option<&Value>) -> String {
    v.map_or_else(|| "(absent)".to_string(), Value::to_string)
}

/// The first difference between two message lists of one topic.
fn compare_topic<T: Serialize>(
    topic: &str,
    a: &[Stamped<T>],
    b: &[Stamped<T>],
    end: Option<u64>,
    step: impl Fn(&Stamped<T>) -> Option<u64>,
) -> Option<Mismatch> {
    let mismatch = |index: usize, s: &Stamped<T>, field: String, x: String, y: String| Mismatch {
        topic: topic.to_string(),
        index,
        step: step(s),
        log_time: s.log_time,
        field,
        a: x,
        b: y,
    };
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        let (vx, vy) = (serde_json::to_value(&x.msg).ok()?, serde_json::to_value(&y.msg).ok()?);
        if let Some((field, u, v)) = first_diff(&vx, &vy, "") {
            return Some(mismatch(i, x, field, u, v));
        }
        if x.log_time != y.log_time {
            return Some(mismatch(i, x, "log_time".into(), x.log_time.to_string(), y.log_time.to_string()));
        }
    }
    let n = a.len().min(b.len());
    match (a.get(n), b.get(n)) {
        (Some(x), None) => Some(mismatch(n, x, "(message)".into(), "present".into(), "absent".into())),
        // Past the end of a file that holds a prefix of its run: not compared.
        (None, Some(y)) if end.is_some_and(|e| y.log_time >= e) => None,
        (None, Some(y)) => Some(mismatch(n, y, "(message)".into(), "absent".into(), "present".into())),
        _ => None,
    }
}

/// Compares the decisions, rewards and poses of two logs and reports the earliest
/// difference in simulated time (ties: decisions, then emitted, delivered, poses).
// Called once per verification: a flat, printable error is worth its size here.
#[allow(clippy::result_large_err)]
pub fn compare(a: &LogContents, b: &LogContents) -> Result<(), Mismatch> {
    compare_to(a, b, None)
}

/// [`compare`] for a log `a` that holds only a prefix of its run (an interrupted write):
/// `b`'s messages at or after `a`'s last compared message in simulated time are beyond
/// what `a` recorded and are not compared; everything before must match as in
/// [`compare`], including every message `a` holds.
#[allow(clippy::result_large_err)]
pub fn compare_prefix(a: &LogContents, b: &LogContents) -> Result<(), Mismatch> {
    let end = [
        a.decisions.last().map(|m| m.log_time),
        a.emitted.last().map(|m| m.log_time),
        a.delivered.last().map(|m| m.log_time),
        a.poses.last().map(|p| p.log_time),
    ]
    .into_iter()
    .flatten()
    .max()
    .unwrap_or(0);
    compare_to(a, b, Some(end))
}

#[allow(clippy::result_large_err)]
fn compare_to(a: &LogContents, b: &LogContents, end: Option<u64>) -> Result<(), Mismatch> {
    #[derive(Serialize)]
    struct P {
        x: f64,
        y: f64,
        theta: f64,
    }
    let poses = |l: &LogContents| -> Vec<Stamped<P>> {
        l.poses
            .iter()
            .map(|p| Stamped { log_time: p.log_time, msg: P { x: p.x, y: p.y, theta: p.theta } })
            .collect()
    };
    let step_at = |time: u64| {
        // The step a pose belongs to: the last decision taken before it.
        let i = a.decisions.partition_point(|d| d.log_time < time);
        i.checked_sub(1).map(|i| a.decisions[i].msg.t)
    };
    let found = [
        compare_topic(topics::DECISION, &a.decisions, &b.decisions, end, |s| Some(s.msg.t)),
        compare_topic(topics::EMITTED, &a.emitted, &b.emitted, end, |s| Some(s.msg.t)),
        compare_topic(topics::DELIVERED, &a.delivered, &b.delivered, end, |s| Some(s.msg.t)),
        compare_topic(topics::POSE, &poses(a), &poses(b), end, |s| step_at(s.log_time)),
    ];
    match found.into_iter().flatten().min_by_key(|m| m.log_time) {
        None => Ok(()),
        Some(m) => Err(m),
    }
}
