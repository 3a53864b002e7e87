//! End-to-end tests of `mmq run --env swarm`: one robot without consultation is the
//! single robot's run bit for bit, a swarm's results (independent or shared learners)
//! do not depend on the thread count, and a recorded swarm (served live or not) writes
//! its MCAP file without changing its results.

use crate::common::*;

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
    // With the grid-optimal reference: the swarm's reference is the single robot's too.
    let common =
        ["--learner", "mmq", "--steps", "1500", "--seeds", "2", "--eval-steps", "100", "--reference"];
    run(
        d1.path(),
        &[&["--env", "robot", "--delay", "none", "--robot", "profile=realistic"][..], &common].concat(),
    );
    run(d2.path(), &[&["--env", "swarm", "--robot", "profile=realistic"][..], &common].concat());
    let ((s1, _), (s2, _)) = (results(d1.path()), results(d2.path()));
    assert!(s1["mean"]["perf/fraction_of_reference"]["mean"].is_f64());
    same_common_figures(&s1, &s2);
    for f in ["q_seed0.npy", "q_seed1.npy", "policy.csv"] {
        assert_eq!(
            std::fs::read(d1.path().join(f)).unwrap(),
            std::fs::read(d2.path().join(f)).unwrap(),
            "{f}"
        );
    }
}

/// Three robots consulting their peers, `learners` independent or shared, on `threads`
/// threads: the results without timings.
fn consulting_swarm(threads: &str, learner: &str, learners: &str) -> (serde_json::Value, String) {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().to_string_lossy().into_owned();
    let learners = format!("learners={learners}");
    #[rustfmt::skip]
    let o = mmq(&[
        "--threads", threads, "run", "-q", "--env", "swarm",
        "--swarm", "robots=3", "--swarm", "consult=peers", "--swarm", "k=1",
        "--swarm", "hop_delay=exponential:0.5s", "--swarm", &learners,
        "--learner", learner, "--steps", "400", "--seeds", "2", "--eval-steps", "50", "--out", &out,
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
    results(d.path())
}

#[test]
fn a_swarms_results_do_not_depend_on_the_thread_count() {
    let runs = [consulting_swarm("1", "q", "independent"), consulting_swarm("2", "q", "independent")];
    assert_eq!(runs[0], runs[1]);
    // The consultation delayed rewards: some were delivered, with a delay in seconds.
    let mean = runs[0].0["mean"].as_object().unwrap().clone();
    assert!(mean["env/swarm/delivered"]["mean"].as_f64().unwrap() > 0.0, "{mean:?}");
    assert!(mean["env/swarm/delay_mean_s"]["mean"].as_f64().unwrap() > 0.0);
}

/// Parameter sharing: deterministic on any thread count, and not the independent
/// learners' results (one table learns from every robot); for a tabular learner and for
/// a deconvolving one (one reward fit and delay estimate, a stream per robot).
#[test]
fn a_shared_learner_is_deterministic_and_learns_from_every_robot() {
    for learner in ["q-lambda", "deconv-model"] {
        let shared = [consulting_swarm("1", learner, "shared"), consulting_swarm("2", learner, "shared")];
        assert_eq!(shared[0], shared[1], "{learner}");
        let own = consulting_swarm("1", learner, "independent");
        assert_ne!(shared[0].1, own.1, "{learner}: the shared run's metrics equal the independent run's");
    }
}

/// A sweep takes swarm settings as an axis, and its report has the swarm's section with
/// the histogram of the emerged delays and the delay against hops.
#[test]
fn a_sweep_takes_swarm_settings_as_an_axis_and_reports_the_emerged_delays() {
    let d = tempfile::tempdir().unwrap();
    let spec = d.path().join("s.toml");
    let world = root().join("worlds/paper-9x9.toml");
    std::fs::write(
        &spec,
        format!(
            "name = \"s\"\nworld = {:?}\nenv = \"swarm\"\ndelay = \"none\"\nlearner = \"q\"\nsteps = 300\nwindow = 100\neval_steps = 20\nbaseline = false\nseeds = 1\nswarm = [\"robots=3 consult=peers k=1 hop_delay=const:1s radio_range_m=9\", \"robots=2 consult=server hop_delay=const:1s radio_range_m=9\"]\n",
            world.to_string_lossy()
        ),
    )
    .unwrap();
    let out = d.path().join("out");
    let o = mmq(&["sweep", &spec.to_string_lossy(), "--out", &out.to_string_lossy(), "-q"]);
    assert!(o.status.success(), "{}", text(&o).1);
    let o = mmq(&["sweep", "report", &out.to_string_lossy()]);
    assert!(o.status.success(), "{}", text(&o).1);
    let md = std::fs::read_to_string(out.join("report/report.md")).unwrap();
    assert!(md.contains("## The swarm") && md.contains("robots=3 consult=peers"), "{md}");
    for f in ["swarm-delays.png", "swarm-delay-hops.png"] {
        assert!(out.join("report").join(f).is_file(), "{f}");
    }
    // Everyone in range with a constant hop: one hop there and back, 2 s.
    let csv = std::fs::read_to_string(out.join("report/summary.csv")).unwrap();
    assert!(csv.contains("env/swarm/delay_mean_s_by_hops/1"), "{csv}");

    // A swarm setting where no cell runs the swarm, and a bad swarm value, are refused
    // naming the field.
    let bad = d.path().join("bad.toml");
    for (body, expect) in [
        ("env = \"robot\"\nswarm = \"robots=2\"\n", "no cell runs the swarm"),
        ("env = \"swarm\"\ndelay = \"none\"\nswarm = \"robots=0\"\n", "field `robots` = 0"),
        ("env = \"swarm\"\nswarm = \"robots=2\"\n", "delay none"),
    ] {
        std::fs::write(
            &bad,
            format!("name = \"b\"\nworld = {:?}\nlearner = \"q\"\n{body}", world.to_string_lossy()),
        )
        .unwrap();
        let o = mmq(&[
            "sweep",
            &bad.to_string_lossy(),
            "--out",
            &d.path().join("b").to_string_lossy(),
            "--dry-run",
        ]);
        assert_eq!(o.status.code(), Some(3), "{body}: {}", text(&o).1);
        assert!(text(&o).1.contains(expect), "{body}: {}", text(&o).1);
    }
}

#[test]
fn a_recorded_swarm_writes_its_mcap_file_and_learns_as_unrecorded() {
    let (d1, d2) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let common = [
        "--steps",
        "100",
        "--swarm",
        "robots=2",
        "--swarm",
        "consult=server",
        "--robot",
        "profile=realistic",
        "--eval-steps",
        "20",
    ];
    run(d1.path(), &[&["--env", "swarm"][..], &common].concat());
    run(d2.path(), &[&["--env", "swarm", "--record", "--record-rate", "5"][..], &common].concat());
    // Served live with no viewer: the same recording, byte for byte.
    let d3 = tempfile::tempdir().unwrap();
    let live = ["--env", "swarm", "--record", "--record-rate", "5", "--live", "0"];
    run(d3.path(), &[&live[..], &common].concat());
    let file = |d: &tempfile::TempDir| std::fs::read(d.path().join("trajectory-seed0.mcap")).unwrap();
    assert!(file(&d2) == file(&d3), "the recording differs with --live");
    let ((mut s1, m1), (mut s2, m2)) = (results(d1.path()), results(d2.path()));
    assert_eq!(s2["config"]["record"]["pose_rate_hz"], 5.0);
    for s in [&mut s1, &mut s2] {
        s["config"].as_object_mut().unwrap().remove("record");
    }
    assert_eq!((s1, m1), (s2, m2), "recording changed the run");
    for f in ["q_seed0.npy", "policy.csv"] {
        assert_eq!(
            std::fs::read(d1.path().join(f)).unwrap(),
            std::fs::read(d2.path().join(f)).unwrap(),
            "{f}"
        );
    }
    assert!(!d1.path().join("trajectory-seed0.mcap").exists());
    let log = mmq_log::read_log(d2.path().join("trajectory-seed0.mcap")).unwrap();
    assert!(log.complete, "{:?}", log.problems);
    assert_eq!(log.swarm_steps.len(), 200);
    assert_eq!(log.out_of_order, 0);
    assert_eq!(log.run_fact("robots"), Some("2"));
    assert_eq!(log.metadata["end"]["complete"], "true");
    assert!(log.topics["/tf"].count > 0 && log.topics["/swarm/bodies"].count == 1);
    let cfg = String::from_utf8_lossy(&log.attachment("config.toml").unwrap().data).into_owned();
    assert!(cfg.contains("env = \"swarm\""), "{cfg}");
    // `mmq replay FILE` counts every robot's steps as decisions.
    let f = d2.path().join("trajectory-seed0.mcap");
    let o = mmq(&["replay", f.to_str().unwrap()]);
    assert!(text(&o).0.contains("200 decisions recorded"), "{}", text(&o).0);
}
