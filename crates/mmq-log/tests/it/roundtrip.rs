//! Everything recorded is read back equal: per-topic counts and byte digests match the
//! recorder's, and every decision, reward, teleport and pose matches what the run did.

use std::collections::BTreeMap;

use mmq_core::Event;
use mmq_log::messages::topics;
use mmq_log::{McapRecorder, RecorderConfig, StepWindow, read_log, summary};

use crate::common::{self, CONFIG_TOML, record_grid};

const PERIOD_NS: u64 = 100_000_000;

fn assert_same_topics(stats: &mmq_log::RecordStats, log: &mmq_log::LogContents) {
    let read: BTreeMap<&str, (u64, u64)> =
        log.topics.iter().map(|(k, v)| (k.as_str(), (v.count, v.digest))).collect();
    let written: BTreeMap<&str, (u64, u64)> =
        stats.topics.iter().map(|(k, v)| (k.as_str(), (v.count, v.digest))).collect();
    assert_eq!(read, written, "per-topic counts and digests");
    for (topic, info) in &log.topics {
        assert_eq!(info.undecodable, 0, "{topic}");
        assert_eq!(info.message_encoding, "json");
        assert_eq!(info.schema_encoding, "jsonschema");
    }
}

#[test]
fn grid_run_reads_back_equal() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sub/grid.mcap");
    let (stats, steps) = record_grid(&path, |_| {}, 3000, 11);
    assert!(stats.finished);
    assert_eq!(stats.steps_seen, 3000);
    let log = read_log(&path).unwrap();
    assert!(log.complete, "{:?}", log.stop);
    assert_eq!(log.stop, None);
    assert_eq!(stats.bytes, log.file_len);
    assert_same_topics(&stats, &log);

    // Decisions: one per step, at the step's start.
    assert_eq!(log.decisions.len(), steps.len());
    for (d, s) in log.decisions.iter().zip(&steps) {
        assert_eq!(d.log_time, s.t * PERIOD_NS);
        let m = &d.msg;
        assert_eq!(
            (m.t, m.state, m.action, m.next_state),
            (s.t, s.state as u64, s.action as u64, s.next_state as u64)
        );
        assert_eq!(m.action_name, ["N", "E", "S", "W"][s.action]);
        assert_eq!(m.model, s.model.map(|x| x as u64));
        assert_eq!(m.explored, s.explored);
        assert_eq!(m.event, s.event.name());
    }
    // Emissions: every non-zero reward, ids in order, due = t + delay, running total.
    let emitted: Vec<_> = steps.iter().filter(|s| s.emitted != 0.0).collect();
    assert_eq!(log.emitted.len(), emitted.len());
    let mut total = 0.0;
    for (i, (e, s)) in log.emitted.iter().zip(&emitted).enumerate() {
        total += s.emitted;
        let m = &e.msg;
        assert_eq!((m.id, m.t, m.value, m.delay), (i as u64, s.t, s.emitted, s.delay));
        assert_eq!(m.due, Some(s.t + u64::from(s.delay.unwrap())));
        // A delay in steps: the emission's time, no delay drawn in seconds.
        assert_eq!((m.t_emit_s, m.delay_s, m.due_s), (Some(s.sim_time_s), None, None));
        assert_eq!(m.total, total);
        assert_eq!(
            m.cause,
            match s.event {
                Event::WallBump => "wall",
                Event::Teleport => "goal",
                _ => "step",
            }
        );
        assert_eq!(e.log_time, (s.t + 1) * PERIOD_NS);
    }
    // Deliveries: what the channel delivered, each part matching its emission.
    let delivered: Vec<_> = steps.iter().filter(|s| s.delivered != 0.0 || !s.ids.is_empty()).collect();
    assert_eq!(log.delivered.len(), delivered.len());
    assert!(delivered.len() > 100);
    for (d, s) in log.delivered.iter().zip(&delivered) {
        let m = &d.msg;
        assert_eq!((m.t, m.sum, &m.ids), (s.t, s.delivered, &s.ids));
        assert_eq!(m.parts.len(), m.ids.len());
        let mut sum = 0.0;
        for p in &m.parts {
            let e = &log.emitted[p.id as usize].msg;
            assert_eq!((p.t_emit, Some(p.delay), p.value), (e.t, e.delay, e.value));
            assert_eq!(e.due, Some(m.t));
            // In seconds: emitted at the end of step t_emit, delivered at the end of step t
            // (0.1 s per step), nothing drawn in seconds.
            assert_eq!(p.t_emit_s, e.t_emit_s);
            let delay_s = p.delay_s.unwrap();
            assert!((delay_s - 0.1 * f64::from(p.delay)).abs() < 1e-9, "{delay_s} s for {} steps", p.delay);
            assert_eq!(p.drawn_s, None);
            sum += p.value;
        }
        assert_eq!(sum, m.sum);
    }
    // Teleports; the static scenes are written once, at the start, however many goals.
    let teleports = steps.iter().filter(|s| s.event == Event::Teleport).count();
    assert!(teleports > 5);
    assert_eq!(log.teleports.len(), teleports);
    assert_eq!(log.topics[topics::ARENA].count, 1);
    assert_eq!(log.topics[topics::ROBOT].count, 1);
    assert_eq!((log.topics[topics::ARENA].first_ns, log.topics[topics::ROBOT].first_ns), (0, 0));
    let world = common::world("paper-9x9");
    for tp in &log.teleports {
        assert_eq!(tp.msg.from_state, world.goal as u64);
        assert_eq!(tp.msg.to_state, world.respawn as u64);
    }
    // Poses: the initial state, then s_{t+1} at the end of every step, at cell centres.
    assert_eq!(log.poses.len(), steps.len() + 1);
    assert_eq!(log.topics[topics::TF].count, steps.len() as u64 + 1);
    for (p, s) in log.poses[1..].iter().zip(&steps) {
        assert_eq!((p.x, p.y), world.cell_center(s.next_state));
        assert_eq!(p.log_time, (s.t + 1) * PERIOD_NS);
    }
    assert_eq!((log.poses[0].x, log.poses[0].y), world.cell_center(steps[0].state));
    // Heat maps every 250 steps.
    assert_eq!(log.topics[topics::VISITS].count, 12);
    assert_eq!(log.topics[topics::VALUE].count, 12);
    let g = &log.last_visits.as_ref().unwrap().msg;
    assert_eq!((g.column_count, g.row_stride, g.cell_stride), (9, 36, 4));
    // Metadata and attachments.
    assert_eq!(log.run_fact("seed"), Some("11"));
    assert_eq!(log.run_fact("env_kind"), Some("grid"));
    assert_eq!(log.run_fact("learner"), Some("test-learner"));
    assert_eq!(log.run_fact("grid_step_period_s"), Some("0.1"));
    assert_eq!(log.metadata["end"]["complete"], "true");
    assert_eq!(log.metadata["end"]["steps"], "3000");
    assert_eq!(log.attachment("world.toml").unwrap().data, world.source.as_bytes());
    assert_eq!(log.attachment("config.toml").unwrap().data, CONFIG_TOML.as_bytes());
    assert_eq!(log.world().unwrap().ascii(), world.ascii());

    let s = summary(&log);
    assert_eq!(s.steps, 3000);
    assert_eq!(s.decisions, 3000);
    assert_eq!(s.teleports, teleports as u64);
    let total_emitted: f64 = steps.iter().map(|s| s.emitted).sum();
    let total_delivered: f64 = steps.iter().map(|s| s.delivered).sum();
    assert_eq!(s.emitted_total, Some(total_emitted));
    assert_eq!(s.delivered_total, Some(total_delivered));
    assert_eq!(s.delivered_sum, total_delivered);
    assert_eq!(s.duration_s, 300.0);
    let text = s.to_string();
    assert!(text.contains("/rl/decision") && text.contains("seed 11"), "{text}");
}

#[test]
fn windows_record_first_and_last_steps_with_exact_totals() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("w.mcap");
    let (stats, steps) =
        record_grid(&path, |c| c.window = Some(StepWindow { first: 100, last: 50, total: 1000 }), 1000, 3);
    assert_eq!(stats.steps_recorded, 150);
    let log = read_log(&path).unwrap();
    assert_same_topics(&stats, &log);
    let ts: Vec<u64> = log.decisions.iter().map(|d| d.msg.t).collect();
    let want: Vec<u64> = (0..100).chain(950..1000).collect();
    assert_eq!(ts, want);
    // One extra pose where the second window starts.
    assert_eq!(log.poses.len(), 1 + 150 + 1);
    assert_eq!(log.poses[101].log_time, 950 * PERIOD_NS);
    let total: f64 = steps.iter().map(|s| s.emitted).sum();
    assert_eq!(summary(&log).emitted_total, Some(total));
    if let Some(last) = log.emitted.last() {
        let upto: f64 = steps.iter().filter(|s| s.t <= last.msg.t).map(|s| s.emitted).sum();
        assert_eq!(last.msg.total, upto);
    }
}

#[test]
fn robot_run_thins_poses_and_records_contacts() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("robot.mcap");
    let world = common::world("room-12x6");
    let mut rec = McapRecorder::create(RecorderConfig::new(&path)).unwrap();
    let outcome = rec.outcome_handle();
    let steps = common::run_robot(&world, &mut rec, 200, 5);
    let stats = rec.stats().clone();
    drop(rec);
    let outcome = outcome.lock().unwrap().clone();
    assert_eq!((outcome.stats.as_ref(), outcome.error), (Some(&stats), None));
    let log = read_log(&path).unwrap();
    assert!(log.complete);
    assert_same_topics(&stats, &log);
    // 60 samples a second thinned to 10 Hz: 10 per step, plus the initial pose.
    assert_eq!(log.poses.len(), 1 + 10 * steps.len());
    for w in log.poses.windows(2) {
        assert!(w[1].log_time > w[0].log_time);
        assert!((w[1].log_time - w[0].log_time).abs_diff(100_000_000) <= 1, "{w:?}");
    }
    // Decisions at the start of the step, on the robot's clock.
    for (d, s) in log.decisions.iter().zip(&steps) {
        assert_eq!(d.log_time, s.t * 1_000_000_000);
    }
    let bumps = steps.iter().filter(|s| s.event == Event::WallBump).count();
    assert!(bumps > 0);
    assert_eq!(log.contacts.len(), 2 * bumps);
    for c in &log.contacts {
        assert_eq!(c.log_time, (c.msg.time_s * 1e9).round() as u64);
        let s = &steps[c.msg.t as usize];
        assert_eq!(s.event, Event::WallBump);
        assert!(c.msg.wall.starts_with("wall-"));
    }
    assert_eq!(summary(&log).contacts, bumps as u64);
    // Log times never go back on any topic.
    for t in [topics::POSE, topics::DECISION, topics::CONTACT, topics::EMITTED] {
        assert!(log.topics[t].first_ns <= log.topics[t].last_ns);
    }
    assert_eq!(log.metadata["recorder"]["robot_radius_m"], "0.2");
}

#[test]
fn every_sample_when_rate_is_zero() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("robot0.mcap");
    let world = common::world("room-12x6");
    let mut cfg = RecorderConfig::new(&path);
    cfg.pose_rate_hz = 0.0;
    let mut rec = McapRecorder::create(cfg).unwrap();
    let steps = common::run_robot(&world, &mut rec, 20, 5);
    drop(rec);
    let log = read_log(&path).unwrap();
    assert_eq!(log.poses.len(), 1 + 60 * steps.len());
    let want: Vec<(f64, f64)> = steps.iter().flat_map(|s| s.poses.iter().map(|p| (p.x, p.y))).collect();
    let got: Vec<(f64, f64)> = log.poses[1..].iter().map(|p| (p.x, p.y)).collect();
    assert_eq!(got, want);
}

#[test]
fn dropped_recorder_still_finishes_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("drop.mcap");
    {
        let mut rec = McapRecorder::create(RecorderConfig::new(&path)).unwrap();
        let world = common::world("paper-3x3");
        // Start and step, but never call on_finish.
        struct NoFinish<'a>(&'a mut McapRecorder);
        impl mmq_core::Observer for NoFinish<'_> {
            fn on_start(&mut self, i: &mmq_core::RunInfo<'_>, s: usize, t: f64) {
                self.0.on_start(i, s, t)
            }
            fn on_step(&mut self, r: &mmq_core::StepRecord<'_>) {
                self.0.on_step(r)
            }
        }
        common::run_grid(&world, &mut NoFinish(&mut rec), 100, 1, 0);
    }
    let log = read_log(&path).unwrap();
    assert!(log.complete);
    assert_eq!(log.decisions.len(), 100);
    assert_eq!(log.metadata["end"]["complete"], "false");
}

#[test]
fn creating_in_an_impossible_place_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let blocker = dir.path().join("file");
    std::fs::write(&blocker, "x").unwrap();
    let err = McapRecorder::create(RecorderConfig::new(blocker.join("run.mcap"))).unwrap_err();
    assert!(err.to_string().contains("run.mcap") || err.to_string().contains("file"), "{err}");
    let err = read_log(dir.path().join("missing.mcap")).unwrap_err();
    assert!(err.to_string().contains("missing.mcap"), "{err}");
    let err = read_log(&blocker).unwrap_err();
    assert!(matches!(err, mmq_log::LogError::NotMcap { .. }) || err.to_string().contains("file"), "{err}");
}

#[test]
fn a_failing_disk_is_reported_not_panicked() {
    if !std::path::Path::new("/dev/full").exists() {
        println!("note: skipped: no /dev/full on this system");
        return;
    }
    for thread in [true, false] {
        let mut cfg = RecorderConfig::new("/dev/full");
        cfg.flush_every_steps = 10;
        cfg.writer_thread = thread;
        let Ok(mut rec) = McapRecorder::create(cfg) else { return };
        let outcome = rec.outcome_handle();
        common::run_grid(&common::world("paper-3x3"), &mut rec, 50, 1, 0);
        let e = outcome.lock().unwrap().error.clone().expect("an error on a full disk");
        assert!(e.contains("/dev/full") && e.contains("flush the log"), "{e}");
        assert!(matches!(rec.take_error(), Some(mmq_log::LogError::Mcap { .. })));
    }
}

/// The writer thread (the default) and the inline writer (`writer_thread = false`) write
/// the same file byte for byte: chunks closed when full (a robot-like run with every pose
/// sample fills several 1 MiB chunks), at flushes (every 37 steps) and before metadata;
/// heat maps and an unfinished run (a dropped recorder) included. (The inline writer's
/// files were checked against the pre-thread recorder's by the sha256 of a 20 000-primitive
/// `mmq run --env robot --record` when the thread was introduced.)
#[test]
fn the_writer_thread_writes_the_same_bytes() {
    struct NoFinish<'a>(&'a mut McapRecorder);
    impl mmq_core::Observer for NoFinish<'_> {
        fn on_start(&mut self, i: &mmq_core::RunInfo<'_>, s: usize, t: f64) {
            self.0.on_start(i, s, t)
        }
        fn on_step(&mut self, r: &mmq_core::StepRecord<'_>) {
            self.0.on_step(r)
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let record = |kind: &str, thread: bool| {
        let path = dir.path().join(format!("{kind}-{thread}.mcap"));
        let mut cfg = RecorderConfig::new(&path);
        cfg.writer_thread = thread;
        match kind {
            "robot-every-sample" => cfg.pose_rate_hz = 0.0,
            "grid-flushes" | "grid-unfinished" => cfg.flush_every_steps = 37,
            _ => {}
        }
        let mut rec = McapRecorder::create(cfg).unwrap();
        match kind {
            "grid-unfinished" => {
                common::run_grid(&common::world("paper-9x9"), &mut NoFinish(&mut rec), 500, 3, 100);
            }
            "grid-flushes" => {
                common::run_grid(&common::world("paper-9x9"), &mut rec, 3000, 5, 250);
            }
            _ => {
                common::run_robot(&common::world("room-12x6"), &mut rec, 150, 7);
            }
        }
        let stats = rec.stats().clone();
        drop(rec);
        (std::fs::read(&path).unwrap(), stats)
    };
    for kind in ["robot-every-sample", "robot", "grid-flushes", "grid-unfinished"] {
        let (threaded, s1) = record(kind, true);
        let (inline, s2) = record(kind, false);
        assert_eq!(s1, s2, "{kind}: stats");
        assert!(
            threaded == inline,
            "{kind}: the files differ ({} and {} bytes)",
            threaded.len(),
            inline.len()
        );
        let log = read_log(dir.path().join(format!("{kind}-true.mcap"))).unwrap();
        assert!(log.complete && log.stop.is_none(), "{kind}: {:?}", log.stop);
        let chunks = mcap::Summary::read(&threaded).unwrap().unwrap().chunk_indexes.len();
        if kind == "robot-every-sample" {
            assert_eq!(log.poses.len(), 1 + 60 * 150);
            assert!(chunks >= 4, "{kind}: {chunks} chunks");
        }
        if kind == "grid-flushes" {
            assert!(chunks >= 3000 / 37, "{kind}: {chunks} chunks");
        }
    }
}
