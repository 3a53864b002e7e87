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
    match verify(&log, dir.path()).unwrap() {
        Verdict::Identical { decisions, poses } => assert!(decisions == 300 && poses > 300),
        Verdict::Differs(m) => panic!("a faithful re-run differs: {m}"),
    }
    let mut altered = log.clone();
    let a = altered.decisions[120].msg.action;
    altered.decisions[120].msg.action = (a + 1) % 4;
    match verify(&altered, dir.path()).unwrap() {
        Verdict::Identical { .. } => panic!("an altered action went unnoticed"),
        Verdict::Differs(m) => {
            assert_eq!(m.topic, "/rl/decision");
            assert_eq!(m.step, Some(120), "{m}");
        }
    }
}
