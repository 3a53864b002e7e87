//! End-to-end tests of `mmq run --env swarm`: one robot without consultation is the
//! single robot's run bit for bit, and a swarm's results do not depend on the thread
//! count.

mod common;
use common::*;

use std::path::Path;

/// The run's summary without timings, and its metrics table.
fn results(dir: &Path) -> (serde_json::Value, String) {
    let mut s = read_json(&dir.join("summary.json"));
    for seed in s["seeds"].as_array_mut().unwrap() {
        seed.as_object_mut().unwrap().retain(|k, _| !k.starts_with("time/"));
    }
    s["mean"].as_object_mut().unwrap().retain(|k, _| !k.starts_with("time/"));
    (s, std::fs::read_to_string(dir.join("metrics.csv")).unwrap())
}

fn run(out: &Path, args: &[&str]) {
    let out = out.to_string_lossy().into_owned();
    let mut all = vec!["run", "-q", "--out", &out];
    all.extend_from_slice(args);
    let o = mmq(&all);
    assert!(o.status.success(), "{:?}: {}", args, text(&o).1);
}

/// Every figure of `b`'s summary that `a` has too is equal (the swarm adds its own
/// `env/swarm/*` figures and names its environment).
fn same_common_figures(a: &serde_json::Value, b: &serde_json::Value) {
    let (a, b) = (a["mean"].as_object().unwrap(), b["mean"].as_object().unwrap());
    assert!(a.len() > 20);
    for (k, v) in a {
        assert_eq!(Some(v), b.get(k), "{k}");
    }
    assert!(b.keys().all(|k| a.contains_key(k) || k.starts_with("env/swarm/")));
}

#[test]
fn one_robot_without_consultation_is_the_single_robot_run_bit_for_bit() {
    let (d1, d2) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let common = ["--learner", "mmq", "--steps", "1500", "--seeds", "2", "--eval-steps", "100"];
    run(
        d1.path(),
        &[&["--env", "robot", "--delay", "none", "--robot", "profile=realistic"][..], &common].concat(),
    );
    run(d2.path(), &[&["--env", "swarm", "--robot", "profile=realistic"][..], &common].concat());
    let ((s1, _), (s2, _)) = (results(d1.path()), results(d2.path()));
    same_common_figures(&s1, &s2);
    for f in ["q_seed0.npy", "q_seed1.npy", "policy.csv"] {
        assert_eq!(
            std::fs::read(d1.path().join(f)).unwrap(),
            std::fs::read(d2.path().join(f)).unwrap(),
            "{f}"
        );
    }
}

#[test]
fn a_swarms_results_do_not_depend_on_the_thread_count() {
    let mut runs = Vec::new();
    for threads in ["1", "2"] {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().to_string_lossy().into_owned();
        let o = mmq(&[
            "--threads",
            threads,
            "run",
            "-q",
            "--env",
            "swarm",
            "--swarm",
            "robots=3",
            "--swarm",
            "consult=peers",
            "--swarm",
            "k=1",
            "--swarm",
            "hop_delay=exponential:0.5s",
            "--learner",
            "q",
            "--steps",
            "400",
            "--seeds",
            "2",
            "--eval-steps",
            "50",
            "--out",
            &out,
        ]);
        assert!(o.status.success(), "{}", text(&o).1);
        runs.push(results(d.path()));
    }
    assert_eq!(runs[0], runs[1]);
    // The consultation delayed rewards: some were delivered, with a delay in seconds.
    let mean = runs[0].0["mean"].as_object().unwrap().clone();
    assert!(mean["env/swarm/delivered"]["mean"].as_f64().unwrap() > 0.0, "{mean:?}");
    assert!(mean["env/swarm/delay_mean_s"]["mean"].as_f64().unwrap() > 0.0);
}
