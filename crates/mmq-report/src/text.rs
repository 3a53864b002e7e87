//! Short plain-text reports for a terminal: a run's summary table (`mmq run`) and a
//! world's map, optimal policy and optimum, or its file's text (`mmq world show`).

use std::fmt::Write as _;

use crate::format;
use mmq_core::{Move, World, optimum};
use mmq_lab::Summary;

/// A run's summary as a short table: the setting, then each headline metric the run has
/// (mean ± 95 % interval), its notes and the horizon.
pub fn run_summary(s: &Summary) -> String {
    let mut t = String::new();
    let ceiling = s.ceiling_per_step.map_or(String::new(), |c| format!(", ε-soft ceiling {c:.4}/step"));
    let _ = writeln!(
        t,
        "{} on {} (optimum {:.4}/step{ceiling}), {}, {} steps × {} seeds",
        s.learner,
        s.world,
        s.optimum_per_step,
        if s.config.env == mmq_lab::config::EnvKind::Swarm {
            match s.config.swarm.as_slice() {
                [] => "swarm as the world's [swarm] table sets it".to_string(),
                over => format!("swarm {}", over.join(" ")),
            }
        } else {
            format!("delay {}", s.config.delay)
        },
        s.config.steps,
        s.config.seeds
    );
    for (key, label, pct) in [
        ("perf/relative", "relative performance vs undelayed Q", true),
        ("perf/fraction_of_ceiling", "fraction of the ε-soft ceiling", true),
        ("perf/fraction_of_optimum", "fraction of the exact optimum", true),
        ("perf/fraction_of_reference", "fraction of the grid-optimal reference", true),
        ("reference/fraction_of_optimum", "the reference, fraction of the optimum", true),
        ("perf/regret", "regret against the optimum (reward)", false),
        ("reward/earned_per_step", "earned reward per step", false),
        ("eval/greedy_per_step", "greedy evaluation, reward per step", false),
        ("baseline/earned_per_step", "undelayed Q-learning, reward per step", false),
        ("delay/delivered_mean_steps", "mean delay delivered, steps", false),
        ("delay/delivered_mean_s", "mean delay delivered, seconds", false),
        ("env/swarm/delay_mean_s", "swarm: consultation delay, seconds", false),
        ("env/swarm/hops_mean", "swarm: hops of the completing reply", false),
        ("env/swarm/lost_share", "swarm: rewards lost (never delivered)", true),
        ("env/swarm/robot_bumps", "swarm: bumps into other robots", false),
    ] {
        if let Some(m) = s.get(key) {
            let text = if key == "perf/regret" { format::mean_num(&m, 1) } else { format::mean(&m, pct) };
            let _ = writeln!(t, "  {label:<40} {text:>18}");
        }
    }
    for note in &s.notes {
        let _ = writeln!(t, "  note: {note}");
    }
    let _ = writeln!(t, "  (horizon: {} steps; relative performance depends on it)", s.config.steps);
    t
}

/// A world's file as read (a shipped world's own text), ending in a newline: valid TOML
/// that loads as this world.
pub fn world_toml(w: &World) -> String {
    format!("{}{}", w.source, if w.source.ends_with('\n') { "" } else { "\n" })
}

/// A world: its map, every optimal move of every cell (· where all four are), and the
/// exact optimal average reward with the settings it depends on.
pub fn world(w: &World) -> String {
    let o = optimum(w);
    let mut t = String::new();
    let _ = writeln!(t, "{} ({}×{}): {}", w.name, w.width, w.height, w.description);
    let _ = writeln!(t, "\nmap:");
    t.push_str(&indent(&w.ascii()));
    let _ = writeln!(t, "\noptimal policy (all optimal moves; · = any):");
    let mut s = String::new();
    for r in 0..w.height {
        for c in 0..w.width {
            let i = w.index(r, c);
            let cell = if !w.is_free(i) {
                "#".to_string()
            } else if i == w.goal {
                "G".to_string()
            } else {
                let arrows: String = Move::ALL
                    .iter()
                    .enumerate()
                    .filter(|(a, _)| o.is_optimal(i, *a))
                    .map(|(_, m)| m.arrow())
                    .collect();
                if arrows.chars().count() == 4 { "·".to_string() } else { arrows }
            };
            let _ = write!(s, "{cell:<3}");
        }
        s.push('\n');
    }
    t.push_str(&indent(&s));
    let _ = writeln!(
        t,
        "\noptimal average reward: {:.6} per step (rewards: goal {}, wall {}, step {}; cell {} m; start {:?})",
        o.gain, w.rewards.goal, w.rewards.wall, w.rewards.step, w.cell_size, w.start
    );
    t
}

fn indent(s: &str) -> String {
    s.lines().map(|l| format!("  {l}\n")).collect()
}
