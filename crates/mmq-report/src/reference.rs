//! The leaderboard's reference section: per task, what the grid MDP's optimal policy
//! (`grid-optimal`, [`mmq_lab::suite::reference`]) earns on the task's environment, with
//! its 95 % interval, and each agent's mean as a fraction of it. On the grid the
//! reference is the optimum less its exploration; on a robot it is what the grid's best
//! plan is worth there, so the fraction of it is the agent's own share of the losses.

use std::fmt::Write as _;

use mmq_core::stats::mean_ci;
use mmq_lab::suite::SuiteResults;
use mmq_lab::suite::stats::Scores;

use crate::leaderboard::{field, pct};
use crate::{Doc, ReportError};

/// One agent's per-task scores, in its results file's task order.
pub(crate) struct AgentScores<'a> {
    pub agent: &'a str,
    pub tasks: Vec<&'a str>,
    pub scores: &'a Scores,
    pub greedy: &'a Scores,
}

impl AgentScores<'_> {
    fn of(&self, task: &str, greedy: bool) -> Option<f64> {
        let i = self.tasks.iter().position(|t| *t == task)?;
        let m = mean_ci(if greedy { &self.greedy[i] } else { &self.scores[i] });
        (m.n > 0).then_some(m.mean)
    }
}

/// The reference's finished seeds of `task`: (while learning, greedy).
fn reference_scores(r: &SuiteResults, task: &str) -> (Vec<f64>, Vec<f64>) {
    let Some(t) = r.tasks.iter().find(|t| t.task == task) else { return (Vec::new(), Vec::new()) };
    let ok = || t.seeds.iter().filter(|s| !s.failed);
    (
        ok().filter_map(|s| s.fraction_of_optimum).collect(),
        ok().filter_map(|s| s.greedy_fraction_of_optimum).collect(),
    )
}

/// `a / r` when both are known and the reference is positive.
fn ratio(a: Option<f64>, r: f64) -> Option<f64> {
    a.filter(|_| r > 0.0 && r.is_finite()).map(|a| a / r)
}

/// Writes the section and `reference.csv`; `source` says where the reference came from.
pub(crate) fn section(
    doc: &mut Doc,
    agents: &[AgentScores<'_>],
    reference: &SuiteResults,
    tasks: &[String],
    source: &str,
) -> Result<(), ReportError> {
    let _ = write!(
        doc.md,
        "\n## Reference: the grid-optimal policy\n\n\
         The world MDP's optimal policy executed on each task's environment, without learning ({source}). \
         **While learning** it acts ε-greedily around the optimal policy with the task's ε, the most an \
         ε-greedy learner could earn; its **greedy** score is the optimal policy itself over the 1,000-step \
         evaluation. On the grid it is the optimum less exploration; on a robot, what the grid's best plan is \
         worth once primitives slip, last longer or end in another cell, so an agent's **fraction of the \
         reference** there is its own share of the losses, the rest being the robot's. Reference: mean fraction \
         of the optimum in % ± the half-width of its 95 % interval (Student's t over seeds). Agents: mean \
         fraction of the optimum ÷ the reference's mean, in %.\n\n\
         | # | task | reference, while learning | reference, greedy |"
    );
    for a in agents {
        let _ = write!(doc.md, " {} |", a.agent);
    }
    doc.md.push_str("\n|---|---|---|---|");
    doc.md.push_str(&"---|".repeat(agents.len()));
    doc.md.push('\n');
    let mut csv = String::from(
        "agent,task,fraction_of_optimum,reference_fraction_of_optimum,fraction_of_reference,\
         greedy_fraction_of_optimum,reference_greedy_fraction_of_optimum,greedy_fraction_of_reference\n",
    );
    let num = |x: Option<f64>| x.map(|v| v.to_string()).unwrap_or_default();
    for (i, task) in tasks.iter().enumerate() {
        let (learning, greedy) = reference_scores(reference, task);
        let (l, g) = (mean_ci(&learning), mean_ci(&greedy));
        let shown = |m: &mmq_core::stats::MeanCi| {
            if m.n == 0 {
                "–".to_string()
            } else {
                format!("{} ± {} (n={})", pct(m.mean), pct(m.ci95), m.n)
            }
        };
        let _ = write!(doc.md, "| {} | {task} | {} | {} |", i + 1, shown(&l), shown(&g));
        let (rl, rg) = ((l.n > 0).then_some(l.mean), (g.n > 0).then_some(g.mean));
        for a in agents {
            let (al, ag) = (a.of(task, false), a.of(task, true));
            let fl = rl.and_then(|r| ratio(al, r));
            let fg = rg.and_then(|r| ratio(ag, r));
            let _ = write!(doc.md, " {} |", fl.map_or("–".into(), pct));
            let _ = writeln!(
                csv,
                "{},{},{},{},{},{},{},{}",
                field(a.agent),
                field(task),
                num(al),
                num(rl),
                num(fl),
                num(ag),
                num(rg),
                num(fg)
            );
        }
        doc.md.push('\n');
    }
    doc.md.push('\n');
    doc.csv("reference.csv", &csv)
}
