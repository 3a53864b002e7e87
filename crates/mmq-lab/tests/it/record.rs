//! Recording and verification: a recorded robot run replays bit for bit, and a log with
//! one altered action fails verification naming the step.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use mmq_lab::config::{EnvKind, RecordSettings};
use mmq_lab::record::{Verdict, read_recording, recorder_factory, trajectory_path, verify};
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
    let w = mmq_lab::Resolved::new(cfg.clone()).unwrap();
    let stop = AtomicBool::new(false);
    let ctl = Control { stop: &stop, progress: &|_| {} };
    let factory = recorder_factory(&cfg, dir.path());
    let out = run_all(&w, &factory, ctl).unwrap();
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
    let w = mmq_lab::Resolved::new(cfg.clone()).unwrap();
    let stop = AtomicBool::new(false);
    let factory = recorder_factory(&cfg, dir);
    run_all(&w, &factory, Control { stop: &stop, progress: &|_| {} }).unwrap();
    let path = trajectory_path(dir, 3);
    let log = mmq_log::read_log(&path).unwrap();
    assert!(log.complete);
    (path, log)
}

/// A recording reads back as one; a file that is not MCAP is bad input naming the file
/// (an MCAP file of another program: `tests/it/cli.rs`).
#[test]
fn recordings_read_back_and_other_files_are_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let (path, log) = recorded_grid(dir.path(), 50);
    assert_eq!(read_recording(&path).unwrap().decisions.len(), log.decisions.len());
    let text = dir.path().join("notes.mcap");
    std::fs::write(&text, "not an MCAP file").unwrap();
    let e = read_recording(&text).unwrap_err();
    assert!(e.is_input_error() && e.to_string().contains("notes.mcap"), "{e}");
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
    // A file that says it records more steps than verify re-runs (its config and end
    // record edited) is refused before anything runs.
    let mut absurd = log.clone();
    let cfg = absurd.attachments.iter_mut().find(|a| a.name == "config.toml").unwrap();
    let text = String::from_utf8(cfg.data.clone()).unwrap().replace("steps = 2000", "steps = 10000000000");
    assert!(text.contains("steps = 10000000000"), "{text}");
    cfg.data = text.into_bytes();
    absurd.metadata.get_mut("end").unwrap().insert("steps".into(), "10000000000".into());
    let e = verify(&absurd, scratch.path(), &stop).unwrap_err();
    let msg = e.to_string();
    assert!(
        e.is_input_error() && msg.contains("records 10000000000 steps") && msg.contains("at most"),
        "{msg}"
    );
    // A file with a problem inside (here: a message count that disagrees with its
    // statistics) is reported as damaged, not checked as far as it goes.
    let mut damaged = log.clone();
    damaged.complete = false;
    damaged.problems.push("the chunk at byte 1234 cannot be read (damaged chunk: crc mismatch)".into());
    let e = verify(&damaged, scratch.path(), &stop).unwrap_err();
    assert!(
        e.is_input_error() && e.to_string().contains("damaged") && e.to_string().contains("byte 1234"),
        "{e}"
    );
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
    let w = mmq_lab::Resolved::new(cfg.clone()).unwrap();
    let stop = AtomicBool::new(false);
    let factory = recorder_factory(&cfg, dir.path());
    run_all(&w, &factory, Control { stop: &stop, progress: &|_| {} }).unwrap();
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

/// What an observer was told: each step's (t, emitted, delivered, end time), and each
/// resume.
#[derive(Default)]
struct Seen {
    steps: Vec<(u64, f64, f64, f64)>,
    resumes: Vec<mmq_core::Resume>,
}

/// Records what it is told; with a gate, closes it after step `close` and opens it
/// again after step `reopen` (at the tables, which come every tenth of the run).
struct Watcher {
    seen: std::sync::Arc<std::sync::Mutex<Seen>>,
    gate: Option<(mmq_core::StepGate, u64, u64)>,
}

impl mmq_core::Observer for Watcher {
    fn on_step(&mut self, r: &mmq_core::StepRecord<'_>) {
        self.seen.lock().unwrap().steps.push((r.t, r.emitted, r.delivered, r.sim_time_s));
    }
    fn step_gate(&self) -> Option<mmq_core::StepGate> {
        self.gate.as_ref().map(|g| g.0.clone())
    }
    fn on_resume(&mut self, at: &mmq_core::Resume) {
        self.seen.lock().unwrap().resumes.push(*at);
    }
    fn on_tables(&mut self, t: u64, _: f64, _: &[f64], _: &[f64]) {
        if let Some((g, close, reopen)) = &self.gate {
            if t == *close {
                g.close();
            } else if t == *reopen {
                g.open();
            }
        }
    }
}

/// A gated observer is told nothing while its gate is closed, then where the run
/// stands: the totals and the emission count an observer of every step summed, and the
/// time the last skipped step ended. The run's results are those of an ungated run.
#[test]
fn a_closed_gate_skips_steps_and_the_resume_point_is_exact() {
    for env in [EnvKind::Grid, EnvKind::Robot] {
        let steps = if env == EnvKind::Grid { 3000 } else { 200 };
        let cfg = RunConfig {
            world: world(),
            env,
            steps,
            seed: 11,
            baseline: false,
            save_tables: false,
            eval_steps: 0,
            delay: "uniform:0:40".into(),
            ..RunConfig::default()
        };
        let w = mmq_lab::Resolved::new(cfg.clone()).unwrap();
        let stop = AtomicBool::new(false);
        let ctl = Control { stop: &stop, progress: &|_| {} };
        let run = |gated: bool| {
            let seen = std::sync::Arc::new(std::sync::Mutex::new(Seen::default()));
            let gate = gated.then(|| {
                let g = mmq_core::StepGate::new();
                g.open();
                (g, steps / 10 * 2, steps / 10 * 6)
            });
            let obs = std::sync::Mutex::new(Some(Watcher { seen: seen.clone(), gate }));
            let factory = move |_| {
                Ok(obs.lock().unwrap().take().map(|o| Box::new(o) as Box<dyn mmq_core::Observer + Send>))
            };
            let out = run_all(&w, &factory, ctl).unwrap();
            let seen = std::mem::take(&mut *seen.lock().unwrap());
            (out, seen)
        };
        let (all_out, all) = run(false);
        let (gated_out, gated) = run(true);
        let (a, b) = (&all_out.results[0].run, &gated_out.results[0].run);
        assert_eq!(
            (a.steps_done, a.earned_total, a.received_total),
            (b.steps_done, b.earned_total, b.received_total)
        );
        assert_eq!(a.visits, b.visits);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&all_out.results[0].values), bits(&gated_out.results[0].values));
        // Steps 0..close and reopen..steps are seen, as an ungated observer saw them.
        let (close, reopen) = (steps / 10 * 2, steps / 10 * 6);
        let expected: Vec<_> = all.steps.iter().filter(|s| s.0 < close || s.0 >= reopen).copied().collect();
        assert_eq!(gated.steps, expected, "{env:?}");
        assert!(all.resumes.is_empty());
        assert_eq!(gated.resumes.len(), 1, "{env:?}");
        let r = gated.resumes[0];
        let before = &all.steps[..reopen as usize];
        let emitted: f64 = before.iter().filter(|s| s.1 != 0.0).fold(0.0, |acc, s| acc + s.1);
        let delivered: f64 = before.iter().fold(0.0, |acc, s| acc + s.2);
        let emissions = before.iter().filter(|s| s.1 != 0.0).count() as u64;
        assert!(emissions > 3 && delivered != 0.0, "{env:?}: a run with rewards in flight");
        assert_eq!(r.t, reopen);
        assert_eq!(r.sim_time_s, before.last().unwrap().3, "{env:?}");
        assert_eq!(r.emitted_total.to_bits(), emitted.to_bits(), "{env:?}");
        assert_eq!(r.delivered_total.to_bits(), delivered.to_bits(), "{env:?}");
        assert_eq!(r.emissions, emissions, "{env:?}");
    }
}

/// Raises a stop flag after a number of steps, as a Ctrl-C would.
struct StopAfter {
    rec: Box<dyn mmq_core::Observer + Send>,
    at: u64,
    stop: &'static AtomicBool,
}

impl mmq_core::Observer for StopAfter {
    fn trace_period_s(&self) -> Option<f64> {
        self.rec.trace_period_s()
    }
    fn ledger_history(&self) -> bool {
        self.rec.ledger_history()
    }
    fn on_start(&mut self, info: &mmq_core::RunInfo<'_>, s: mmq_core::State, t: f64) {
        self.rec.on_start(info, s, t);
    }
    fn on_step(&mut self, r: &mmq_core::StepRecord<'_>) {
        self.rec.on_step(r);
        if r.t + 1 == self.at {
            self.stop.store(true, std::sync::atomic::Ordering::SeqCst);
        }
    }
    fn on_tables(&mut self, t: u64, s: f64, v: &[f64], q: &[f64]) {
        self.rec.on_tables(t, s, v, q);
    }
    fn on_finish(&mut self, t: u64, complete: bool) {
        self.rec.on_finish(t, complete);
    }
}

/// A run with a horizon far past what verify re-runs (2·10⁹ steps), stopped as by Ctrl-C
/// after 3,000 steps: its file holds 3,000 steps, and those verify.
#[test]
fn an_interrupted_run_with_a_huge_horizon_verifies_what_it_holds() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = RunConfig {
        world: world(),
        env: EnvKind::Grid,
        steps: 2_000_000_000,
        seed: 4,
        baseline: false,
        save_tables: false,
        eval_steps: 0,
        record: Some(RecordSettings::default()),
        ..RunConfig::default()
    };
    let w = mmq_lab::Resolved::new(cfg.clone()).unwrap();
    let stop: &'static AtomicBool = Box::leak(Box::new(AtomicBool::new(false)));
    let recorders = recorder_factory(&cfg, dir.path());
    let factory = |seed: u64| {
        recorders(seed).map(|r| {
            r.map(|rec| Box::new(StopAfter { rec, at: 3_000, stop }) as Box<dyn mmq_core::Observer + Send>)
        })
    };
    let out = run_all(&w, &factory, Control { stop, progress: &|_| {} }).unwrap();
    assert!(out.interrupted);
    let log = mmq_log::read_log(trajectory_path(dir.path(), 4)).unwrap();
    assert!(log.complete, "{:?} {:?}", log.stop, log.problems);
    let scratch = tempfile::tempdir().unwrap();
    let keep_going = AtomicBool::new(false);
    match verify(&log, scratch.path(), &keep_going).unwrap() {
        Verdict::Identical { decisions, steps, .. } => {
            assert_eq!(decisions, log.decisions.len());
            assert_eq!(steps, log.decisions.last().unwrap().msg.t + 1);
            assert!((3_000..3_100).contains(&steps), "{steps}");
        }
        v => panic!("an interrupted run of a huge horizon: {v:?}"),
    }
}
