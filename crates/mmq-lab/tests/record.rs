//! Recording and verification: a recorded robot run replays bit for bit, and a log with
//! one altered action fails verification naming the step.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use mmq_lab::config::{EnvKind, RecordSettings};
use mmq_lab::record::{Verdict, recorder_factory, trajectory_path, verify};
use mmq_lab::{Control, RunConfig, run_all};

fn world() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../worlds/paper-9x9.toml"))
}

#[test]
fn robot_run_verifies_and_an_altered_action_is_caught() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = RunConfig {
        world: world(),
        env: EnvKind::Robot,
        steps: 300,
        seed: 7,
        baseline: false,
        save_tables: false,
        eval_steps: 0,
        record: Some(RecordSettings::default()),
        ..RunConfig::default()
    };
    let w = cfg.load_world().unwrap();
    let stop = AtomicBool::new(false);
    let ctl = Control { stop: &stop, progress: &|_| {} };
    let factory = recorder_factory(&cfg, dir.path());
    let out = run_all(&cfg, &w, &factory, ctl).unwrap();
    assert!(!out.interrupted);
    let log = mmq_log::read_log(trajectory_path(dir.path(), 7)).unwrap();
    assert!(log.complete);
    assert_eq!(log.decisions.len(), 300);
    // Message counts match the run: one decision per step, one emission per non-zero reward.
    let r = &out.results[0];
    let nonzero = r.run.events[1] + r.run.events[2];
    assert_eq!(log.emitted.len() as u64, nonzero);
    let scratch = tempfile::tempdir().unwrap();
    match verify(&log, scratch.path(), &stop).unwrap() {
        Verdict::Identical { decisions, poses, steps, truncated } => {
            assert!(decisions == 300 && poses > 300 && steps == 300 && !truncated)
        }
        v => panic!("a faithful re-run: {v:?}"),
    }
    assert_eq!(std::fs::read_dir(scratch.path()).unwrap().count(), 0, "the scratch log is removed");
    let mut altered = log.clone();
    let a = altered.decisions[120].msg.action;
    altered.decisions[120].msg.action = (a + 1) % 4;
    match verify(&altered, scratch.path(), &stop).unwrap() {
        Verdict::Differs(m) => {
            assert_eq!(m.topic, "/rl/decision");
            assert_eq!(m.step, Some(120), "{m}");
        }
        v => panic!("an altered action went unnoticed: {v:?}"),
    }
    assert_eq!(std::fs::read_dir(scratch.path()).unwrap().count(), 0, "the scratch log is removed");
}

/// A grid run recorded with frequent flushes, and its log.
fn recorded_grid(dir: &std::path::Path, steps: u64) -> (PathBuf, mmq_log::LogContents) {
    let cfg = RunConfig {
        world: world(),
        env: EnvKind::Grid,
        steps,
        seed: 3,
        baseline: false,
        save_tables: false,
        eval_steps: 0,
        record: Some(RecordSettings::default()),
        ..RunConfig::default()
    };
    let w = cfg.load_world().unwrap();
    let stop = AtomicBool::new(false);
    let factory = recorder_factory(&cfg, dir);
    run_all(&cfg, &w, &factory, Control { stop: &stop, progress: &|_| {} }).unwrap();
    let path = trajectory_path(dir, 3);
    let log = mmq_log::read_log(&path).unwrap();
    assert!(log.complete);
    (path, log)
}

/// A file cut short (an interrupted write: the MCAP holds a prefix) verifies as far as it
/// goes, and a prefix with an altered decision still fails.
#[test]
fn a_truncated_recording_verifies_what_it_holds() {
    let dir = tempfile::tempdir().unwrap();
    // 30,000 steps flush every 10,000 steps: chunks to cut between and inside.
    let (path, full) = recorded_grid(dir.path(), 30_000);
    let bytes = std::fs::read(&path).unwrap();
    let scratch = tempfile::tempdir().unwrap();
    let stop = AtomicBool::new(false);
    for frac in [0.5, 0.8] {
        let cut = dir.path().join("cut.mcap");
        std::fs::write(&cut, &bytes[..(bytes.len() as f64 * frac) as usize]).unwrap();
        let log = mmq_log::read_log(&cut).unwrap();
        assert!(!log.complete && !log.decisions.is_empty() && log.decisions.len() < full.decisions.len());
        let last = log.decisions.last().unwrap().msg.t;
        match verify(&log, scratch.path(), &stop).unwrap() {
            Verdict::Identical { decisions, steps, truncated, .. } => {
                assert!(truncated, "cut at {frac}");
                assert_eq!(decisions, log.decisions.len());
                assert_eq!(steps, last + 1, "the re-run stops at the file's last recorded step");
            }
            v => panic!("cut at {frac}: {v:?}"),
        }
        let mut altered = log.clone();
        let k = altered.decisions.len() / 2;
        altered.decisions[k].msg.state += 1;
        match verify(&altered, scratch.path(), &stop).unwrap() {
            Verdict::Differs(m) => assert_eq!(m.step, Some(altered.decisions[k].msg.t), "{m}"),
            v => panic!("cut at {frac}, altered: {v:?}"),
        }
    }
    assert_eq!(std::fs::read_dir(scratch.path()).unwrap().count(), 0, "the scratch logs are removed");
}

/// Bad input and interruptions: an absurd step count is refused before anything runs, a
/// missing scratch folder is named, and a raised stop flag ends the re-run early; no
/// scratch file stays behind.
#[test]
fn verify_refuses_absurd_runs_names_paths_and_stops() {
    let dir = tempfile::tempdir().unwrap();
    let (_, log) = recorded_grid(dir.path(), 2_000);
    let scratch = tempfile::tempdir().unwrap();
    let stop = AtomicBool::new(false);
    let mut absurd = log.clone();
    let cfg = absurd.attachments.iter_mut().find(|a| a.name == "config.toml").unwrap();
    let text = String::from_utf8(cfg.data.clone()).unwrap().replace("steps = 2000", "steps = 10000000000");
    assert!(text.contains("steps = 10000000000"), "{text}");
    cfg.data = text.into_bytes();
    let e = verify(&absurd, scratch.path(), &stop).unwrap_err();
    let msg = e.to_string();
    assert!(e.is_input_error() && msg.contains("steps = 10000000000") && msg.contains("at most"), "{msg}");
    let missing = scratch.path().join("no-such-folder");
    let msg = verify(&log, &missing, &stop).unwrap_err().to_string();
    assert!(msg.contains(&missing.display().to_string()), "{msg}");
    let raised = AtomicBool::new(true);
    match verify(&log, scratch.path(), &raised).unwrap() {
        Verdict::Interrupted { steps } => assert!(steps < 2_000, "{steps}"),
        v => panic!("a raised stop flag: {v:?}"),
    }
    assert_eq!(std::fs::read_dir(scratch.path()).unwrap().count(), 0, "the scratch logs are removed");
}

/// The realistic robot profile (a `--robot` override, kept in the file's config, not in
/// its world) re-runs bit for bit, with rewards delayed in seconds.
#[test]
fn a_realistic_robot_run_with_delays_in_seconds_verifies() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = RunConfig {
        world: world(),
        env: EnvKind::Robot,
        steps: 120,
        seed: 5,
        delay: "exponential:3s".into(),
        baseline: false,
        save_tables: false,
        eval_steps: 0,
        record: Some(RecordSettings::default()),
        robot: vec!["profile=realistic".into()],
        ..RunConfig::default()
    };
    let w = cfg.load_world().unwrap();
    let stop = AtomicBool::new(false);
    let factory = recorder_factory(&cfg, dir.path());
    run_all(&cfg, &w, &factory, Control { stop: &stop, progress: &|_| {} }).unwrap();
    let log = mmq_log::read_log(trajectory_path(dir.path(), 5)).unwrap();
    // Delays in seconds are recorded as drawn: no steps at emission, the due time in seconds.
    assert!(!log.emitted.is_empty());
    for e in &log.emitted {
        let m = &e.msg;
        assert_eq!((m.delay, m.due), (None, None));
        let (t, d, due) = (m.t_emit_s.unwrap(), m.delay_s.unwrap(), m.due_s.unwrap());
        assert!(d >= 0.0 && due == t + d, "{m:?}");
    }
    let scratch = tempfile::tempdir().unwrap();
    match verify(&log, scratch.path(), &stop).unwrap() {
        Verdict::Identical { decisions, .. } => assert_eq!(decisions, 120),
        v => panic!("a realistic robot run: {v:?}"),
    }
}
