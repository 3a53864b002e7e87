//! `deconv-model`'s diagnostic `told_cells` end to end: on the grid, where the state is
//! no belief, every choice is the agent bit for bit; on the realistic robot and in a
//! realistic swarm, told the true cells, it learns from other pairs than the agent. And
//! the default rewards per outcome against rewards per pair, on both.

use crate::common::*;

/// The metrics of `mmq run --learner deconv-model ARGS --set SET` (one seed).
fn metrics(set: &str, args: &[&str]) -> String {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().to_string_lossy().into_owned();
    let mut all = vec!["run", "-q", "--learner", "deconv-model", "--seeds", "1", "--set", set, "--out", &out];
    all.extend_from_slice(args);
    let o = mmq(&all);
    assert!(o.status.success(), "{}", text(&o).1);
    std::fs::read_to_string(d.path().join("metrics.csv")).unwrap()
}

/// The metrics told the true cells for `told` ([`metrics`]).
fn told(told: &str, args: &[&str]) -> String {
    metrics(&format!("told_cells={told}"), args)
}

#[test]
fn told_cells_changes_nothing_on_the_grid_and_something_on_the_robot() {
    let grid = ["--world", "paper-5x5", "--steps", "2000"];
    let agent = told("none", &grid);
    for choice in ["rewards", "transitions", "both"] {
        assert_eq!(told(choice, &grid), agent, "{choice} on the grid");
    }
    let robot = ["--env", "robot", "--robot", "profile=realistic", "--steps", "1500"];
    assert_ne!(told("both", &robot), told("none", &robot));
    let swarm = ["--env", "swarm", "--robot", "profile=realistic", "--swarm", "robots=2", "--steps", "1500"];
    assert_ne!(told("both", &swarm), told("none", &swarm), "the swarm's robots are told nothing");
}

/// Rewards per outcome are rewards per pair where every move has one outcome (the grid,
/// bit for bit) and differ where a believed cell can be wrong (the realistic robot).
#[test]
fn outcome_rewards_change_nothing_on_the_grid_and_something_on_the_robot() {
    let run = |on: bool, args: &[&str]| metrics(&format!("outcome_rewards={on}"), args);
    let grid = ["--world", "paper-5x5", "--steps", "3000", "--delay", "poisson:3"];
    assert_eq!(run(true, &grid), run(false, &grid));
    let robot = ["--env", "robot", "--robot", "profile=realistic", "--steps", "1500", "--delay", "poisson:3"];
    assert_ne!(run(true, &robot), run(false, &robot));
}
