//! End-to-end tests of `mmq suite`: a tier runs through the sweep engine into one
//! results file that validates against the shipped JSON Schema; an interrupted run
//! resumed and two shards merged give the results of one uninterrupted run; the
//! leaderboard of two agents is written; bad tiers, learners and results files exit 3
//! naming them. A tiny suite file stands in for v1 (whose tiers take minutes).

use std::path::{Path, PathBuf};
use std::process::Output;

use crate::common::*;

/// Two grid tasks and a robot task, a few hundred steps each.
const TINY: &str = r#"suite = "v1"
[tier.lite]
description = "tiny"
[tier.full]
description = "tiny, more seeds"

[[task]]
name = "five-poisson2"
world = "paper-5x5"
delay = "poisson:2"
max_delay = 6
epsilon = 0.05
q0 = 10
lite = { steps = 3000, seeds = [0, 1, 2] }
full = { steps = 3000, seeds = 5 }

[[task]]
name = "three-uniform"
world = "paper-3x3"
delay = "uniform:0:4"
max_delay = 6
epsilon = 0.05
q0 = 10
lite = { steps = 2000, seeds = [0, 1, 2] }
full = { steps = 2000, seeds = 5 }

[[task]]
name = "robot-five"
world = "paper-5x5"
env = "robot"
robot = "profile=ideal"
delay = "poisson:2"
max_delay = 6
epsilon = 0.05
q0 = 10
eval_steps = 50
lite = { steps = 300, seeds = [0, 1, 2] }
full = { steps = 300, seeds = 5 }
"#;

fn s(p: &Path) -> String {
    p.to_string_lossy().into_owned()
}

fn ok(o: Output) -> String {
    let (out, err) = text(&o);
    assert!(o.status.success(), "exit {:?}\nstdout: {out}\nstderr: {err}", o.status.code());
    out
}

fn tiny(dir: &Path) -> String {
    let p = dir.join("tiny.toml");
    std::fs::write(&p, TINY).unwrap();
    s(&p)
}

fn run(suite: &str, learner: &str, out: &Path, extra: &[&str]) -> Output {
    let o = s(out);
    let mut args =
        vec!["suite", "run", "--suite", suite, "--learner", learner, "--tier", "lite", "--out", &o, "-q"];
    args.extend_from_slice(extra);
    mmq(&args)
}

/// Validates `file` against worlds/suites/results.schema.json with Python's jsonschema.
/// Without python3 and jsonschema the check is skipped with a notice, except under
/// CI=true, where it must run.
fn validate_with_schema(file: &Path) {
    let schema = root().join("worlds/suites/results.schema.json");
    let code = "import json, sys, jsonschema\n\
                jsonschema.Draft202012Validator.check_schema(json.load(open(sys.argv[1])))\n\
                jsonschema.validate(json.load(open(sys.argv[2])), json.load(open(sys.argv[1])), cls=jsonschema.Draft202012Validator)\n";
    let py = std::env::var("PYTHON").unwrap_or_else(|_| "python3".into());
    let has = std::process::Command::new(&py).args(["-c", "import jsonschema"]).output();
    if !has.as_ref().is_ok_and(|o| o.status.success()) {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "CI=true: the schema check needs python3 with jsonschema (pip install -r tools/requirements.txt)"
        );
        eprintln!("notice: python3 with jsonschema not found; schema check of {} skipped", file.display());
        return;
    }
    let o = std::process::Command::new(&py).args(["-c", code, &s(&schema), &s(file)]).output().unwrap();
    assert!(
        o.status.success(),
        "{} does not validate: {}",
        file.display(),
        String::from_utf8_lossy(&o.stderr)
    );
}

fn results(dir: &Path) -> serde_json::Value {
    read_json(&dir.join("results.json"))
}

/// Everything but the version tag, which a results file of another build may differ in.
fn scores(v: &serde_json::Value) -> serde_json::Value {
    v["tasks"].clone()
}

#[test]
fn a_tier_runs_into_one_results_file_that_validates() {
    let tmp = tempfile::tempdir().unwrap();
    let suite = tiny(tmp.path());
    let out = tmp.path().join("mmq");
    let said = ok(run(&suite, "mmq", &out, &[]));
    assert!(said.contains("wrote"), "{said}");
    let r = results(&out);
    assert_eq!(r["suite"], "v1");
    assert_eq!(r["tier"], "lite");
    assert_eq!(r["agent"], "mmq");
    assert_eq!(r["complete"], true);
    assert_eq!(r["mmq_version"], env!("CARGO_PKG_VERSION"));
    let tasks = r["tasks"].as_array().unwrap();
    let names: Vec<&str> = tasks.iter().map(|t| t["task"].as_str().unwrap()).collect();
    assert_eq!(names, ["five-poisson2", "three-uniform", "robot-five"]);
    for t in tasks {
        let seeds = t["seeds"].as_array().unwrap();
        assert_eq!(seeds.iter().map(|s| s["seed"].as_u64().unwrap()).collect::<Vec<_>>(), [0, 1, 2]);
        for s in seeds {
            let f = s["fraction_of_optimum"].as_f64().unwrap();
            let (steps, earned, opt) = (
                s["steps"].as_f64().unwrap(),
                s["earned_per_step"].as_f64().unwrap(),
                s["optimum_per_step"].as_f64().unwrap(),
            );
            assert!(f < 1.0 + 1e-9, "{s}");
            // Regret is the optimum's reward over the steps minus the reward earned.
            let regret = s["regret"].as_f64().unwrap();
            assert!((regret - (opt - earned) * steps).abs() < 1e-6 * steps.max(1.0), "{s}");
            assert!(s["greedy_fraction_of_optimum"].is_number());
        }
    }
    // The 5×5 world's optimum is +10 every 9 steps (its world file).
    assert!((tasks[0]["seeds"][0]["optimum_per_step"].as_f64().unwrap() - 10.0 / 9.0).abs() < 1e-9);
    validate_with_schema(&out.join("results.json"));

    // Run again: nothing to do, the same file.
    let again = ok(run(&suite, "mmq", &out, &[]));
    assert!(again.contains("ran 0 seed(s), skipped 9"), "{again}");
    assert_eq!(scores(&results(&out)), scores(&r));
}

/// Interrupted (job files lost) then resumed, and two shards merged, give the results of
/// one uninterrupted run.
#[test]
fn resumed_and_sharded_runs_give_the_same_results() {
    let tmp = tempfile::tempdir().unwrap();
    let suite = tiny(tmp.path());
    let whole = tmp.path().join("whole");
    ok(run(&suite, "q", &whole, &[]));
    let reference = scores(&results(&whole));

    // Lose two finished seeds (as a run stopped before them would), then resume.
    let part = tmp.path().join("part");
    ok(run(&suite, "q", &part, &[]));
    let cells: Vec<PathBuf> =
        std::fs::read_dir(part.join("cells")).unwrap().map(|e| e.unwrap().path()).collect();
    std::fs::remove_file(cells[0].join("seed-1.json")).unwrap();
    std::fs::remove_file(cells[1].join("seed-2.json")).unwrap();
    let again = ok(run(&suite, "q", &part, &[]));
    assert!(again.contains("ran 2 seed(s), skipped 7"), "{again}");
    assert_eq!(scores(&results(&part)), reference);

    let (a, b, merged) = (tmp.path().join("s1"), tmp.path().join("s2"), tmp.path().join("merged"));
    ok(run(&suite, "q", &a, &["--shard", "1/2"]));
    ok(run(&suite, "q", &b, &["--shard", "2/2"]));
    let shard = results(&a);
    assert_eq!(shard["complete"], false);
    ok(mmq(&["suite", "merge", &s(&a), &s(&b), "--out", &s(&merged)]));
    let m = results(&merged);
    assert_eq!(m["complete"], true);
    assert_eq!(scores(&m), reference);
    validate_with_schema(&merged.join("results.json"));
    // Another agent's shard is not merged with these.
    let other = tmp.path().join("other");
    ok(run(&suite, "mmq", &other, &["--shard", "1/2"]));
    let o = mmq(&["suite", "merge", &s(&a), &s(&other), "--out", &s(&tmp.path().join("m2"))]);
    assert_eq!(o.status.code(), Some(3), "{}", text(&o).1);
}

#[test]
fn the_leaderboard_compares_two_agents() {
    let tmp = tempfile::tempdir().unwrap();
    let suite = tiny(tmp.path());
    let (q, m, board) = (tmp.path().join("q"), tmp.path().join("mmq"), tmp.path().join("board"));
    ok(run(&suite, "q", &q, &[]));
    ok(run(&suite, "mmq", &m, &["--set", "max_delay=4"]));
    assert_eq!(results(&m)["agent"], "mmq[max_delay=4]");
    let said = ok(mmq(&[
        "suite",
        "report",
        &s(&q.join("results.json")),
        &s(&m.join("results.json")),
        "--out",
        &s(&board),
    ]));
    assert!(said.contains("2 agent(s) on 3 task(s)"), "{said}");
    let md = std::fs::read_to_string(board.join("leaderboard.md")).unwrap();
    for needle in ["IQM", "P(agent > q)", "five-poisson2", "robot-five", "per-task.png", "profiles.png"] {
        assert!(md.contains(needle), "{needle} missing:\n{md}");
    }
    let agg = std::fs::read_to_string(board.join("aggregates.csv")).unwrap();
    assert!(
        agg.lines().any(|l| l.starts_with("mmq[max_delay=4],probability_of_improvement_over_q,")),
        "{agg}"
    );
    let rows = std::fs::read_to_string(board.join("scores.csv")).unwrap();
    assert_eq!(rows.lines().count(), 1 + 2 * 9, "{rows}");
    assert!(board.join("profiles.png").is_file() && board.join("per-task.svg").is_file());
}

/// `mmq suite reference` runs the grid-optimal policy on every task; given to the
/// leaderboard beside an agent, it is not ranked but shown per task with each agent's
/// mean as a fraction of it. Two references, or only a reference, are refused.
#[test]
fn the_reference_is_shown_beside_the_agents() {
    let tmp = tempfile::tempdir().unwrap();
    let suite = tiny(tmp.path());
    let (q, r, board) = (tmp.path().join("q"), tmp.path().join("ref"), tmp.path().join("board"));
    ok(run(&suite, "q", &q, &[]));
    ok(mmq(&["suite", "reference", "--suite", &suite, "--tier", "lite", "--out", &s(&r), "-q"]));
    let refs = results(&r);
    assert_eq!(refs["agent"], "grid-optimal");
    validate_with_schema(&r.join("results.json"));
    // On the grid the optimal policy with ε = 0.05 earns close to the optimum.
    for t in refs["tasks"].as_array().unwrap() {
        for seed in t["seeds"].as_array().unwrap() {
            let f = seed["fraction_of_optimum"].as_f64().unwrap();
            assert!(f > 0.8 && f < 1.05, "{}: {f}", t["task"]);
        }
    }
    let (qf, rf) = (s(&q.join("results.json")), s(&r.join("results.json")));
    let said = ok(mmq(&["suite", "report", &qf, &rf, "--out", &s(&board)]));
    assert!(said.contains("1 agent(s) on 3 task(s)"), "{said}");
    let md = std::fs::read_to_string(board.join("leaderboard.md")).unwrap();
    assert!(md.contains("## Reference: the grid-optimal policy") && md.contains("ref/results.json"), "{md}");
    let csv = std::fs::read_to_string(board.join("reference.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 3, "{csv}");
    let mean = |v: &serde_json::Value, task: usize| {
        let seeds = v["tasks"][task]["seeds"].as_array().unwrap();
        seeds.iter().map(|x| x["fraction_of_optimum"].as_f64().unwrap()).sum::<f64>() / seeds.len() as f64
    };
    let row: Vec<f64> =
        csv.lines().nth(1).unwrap().split(',').skip(2).take(3).map(|x| x.parse().unwrap()).collect();
    let (agent, reference) = (mean(&results(&q), 0), mean(&refs, 0));
    assert!((row[0] - agent).abs() < 1e-12 && (row[1] - reference).abs() < 1e-12, "{row:?}");
    assert!((row[2] - agent / reference).abs() < 1e-12, "{row:?}");
    let two = mmq(&["suite", "report", &qf, &rf, &rf, "--out", &s(&board)]);
    assert_eq!(two.status.code(), Some(3), "{}", text(&two).1);
    assert!(text(&two).1.contains("second reference"), "{}", text(&two).1);
    let alone = mmq(&["suite", "report", &rf, "--out", &s(&board)]);
    assert_eq!(alone.status.code(), Some(3), "{}", text(&alone).1);
}

#[test]
fn bad_tier_learner_setting_and_results_file_exit_3_naming_them() {
    let tmp = tempfile::tempdir().unwrap();
    let out = s(&tmp.path().join("x"));
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["suite", "run", "--learner", "mmq", "--tier", "medium", "--out", &out], "medium"),
        (vec!["suite", "run", "--learner", "mmqq", "--tier", "lite", "--out", &out], "mmqq"),
        (
            vec![
                "suite",
                "run",
                "--learner",
                "q",
                "--set",
                "trace_decay=0.5",
                "--tier",
                "lite",
                "--out",
                &out,
            ],
            "trace_decay",
        ),
        (vec!["suite", "run", "--learner", "q", "--suite", "v7", "--tier", "lite", "--out", &out], "v7"),
    ];
    for (args, needle) in cases {
        let o = mmq(&args);
        let err = text(&o).1;
        assert_eq!(o.status.code(), Some(3), "{args:?}: {err}");
        assert!(err.contains(needle) && err.lines().count() == 1, "{args:?}: {err}");
    }
    let bad = tmp.path().join("bad.json");
    std::fs::write(&bad, "{\"suite\": \"v1\"}").unwrap();
    let o = mmq(&["suite", "report", &s(&bad), "--out", &out]);
    assert_eq!(o.status.code(), Some(3));
    assert!(text(&o).1.contains("bad.json"), "{}", text(&o).1);
}
