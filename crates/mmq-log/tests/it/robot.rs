//! The real robot (rapier2d) through the real delay channel, recorded: times only go
//! forward, poses stay in the arena, every message validates, and the decisions match
//! the run.

use mmq_core::Telemetry;
use mmq_core::{DelayDist, DelayedReward, Env, Observer, RunInfo, Start, StepTrace};
use mmq_log::messages::topics;
use mmq_log::{McapRecorder, RecorderConfig, read_log};
use mmq_robot::{RobotConfig, RobotEnv};

use crate::common;

#[test]
fn a_recorded_robot_run_reads_back_in_order() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("robot.mcap");
    let world = common::world("paper-3x3");
    let env = RobotEnv::new(&world, RobotConfig::from_world(&world).unwrap()).unwrap();
    let mut ch = DelayedReward::new(env, &DelayDist::parse("poisson:2").unwrap(), true);
    let mut rec = McapRecorder::create(RecorderConfig::new(&path)).unwrap();
    ch.env_mut().set_trace(rec.trace_period_s());
    let mut s = ch.reset(3, 4, Start::World).unwrap();
    let names = ch.env().action_names();
    let facts = mmq_robot::features();
    let info = RunInfo {
        world: &world,
        seed: 3,
        learner: "scripted",
        action_names: &names,
        config_toml: common::CONFIG_TOML,
        env_kind: "robot",
        facts: &facts,
        start_pose: Some(ch.env().pose()),
    };
    rec.on_start(&info, s, ch.env().sim_time_s());
    let mut trace = StepTrace::default();
    let mut want = Vec::new();
    // Sweep towards the goal (N, W) and bump walls on the way, for 40 steps.
    for t in 0..40u64 {
        let a = [0, 3, 0, 3, 1, 2][t as usize % 6] % ch.env().num_actions();
        let st = ch.step(a).unwrap();
        ch.env_mut().take_trace(&mut trace);
        rec.on_step(&ch.record(s, a, None, false, &st, &trace));
        want.push((t, s as u64, a as u64, st.step.state as u64));
        s = st.step.state;
    }
    rec.on_finish(40, true);
    assert!(rec.take_error().is_none());
    let log = read_log(&path).unwrap();
    assert!(log.complete, "{:?}", log.stop);
    let got: Vec<_> =
        log.decisions.iter().map(|d| (d.msg.t, d.msg.state, d.msg.action, d.msg.next_state)).collect();
    assert_eq!(got, want);
    assert!(log.poses.len() > 40, "{} poses", log.poses.len());
    let (w, h) = (world.width as f64 * world.cell_size, world.height as f64 * world.cell_size);
    for p in &log.poses {
        assert!(p.x > 0.0 && p.x < w && p.y > 0.0 && p.y < h, "{p:?}");
    }
    // A teleport takes no simulated time: the next decision shares its time.
    for w in log.decisions.windows(2) {
        assert!(w[1].log_time >= w[0].log_time);
        if w[0].msg.event != "goal" {
            assert!(w[1].log_time > w[0].log_time);
        }
    }
    // Every step ends with its end pose, teleports included.
    let teleports: Vec<_> = log.decisions.iter().filter(|d| d.msg.event == "goal").collect();
    assert!(!teleports.is_empty(), "the scripted sweep should reach the goal");
    let (rx, ry) = world.cell_center(world.respawn);
    for d in teleports {
        let p = log.poses.iter().rev().find(|p| p.log_time <= d.log_time).unwrap();
        assert!(
            (p.x - rx).abs() < 0.3 * world.cell_size && (p.y - ry).abs() < 0.3 * world.cell_size,
            "{p:?}"
        );
    }
    for w in log.poses.windows(2) {
        assert!(w[1].log_time >= w[0].log_time, "{w:?}");
    }
    assert_eq!(log.run_fact("rapier2d.enhanced-determinism"), Some("on"));
    assert!(log.topics[topics::TF].count == log.poses.len() as u64);
    crate::schemas::validate_all(&path);
    match crate::schemas::python_with_mcap() {
        Some(py) => {
            let script =
                std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tools/validate_mcap.py");
            let out = std::process::Command::new(py).arg(script).arg("-q").arg(&path).output().unwrap();
            assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        }
        None => println!("note: Python validation skipped (no Python with mcap and jsonschema)"),
    }
}

/// The first pose of a robot recording carries the robot's true start pose: the paper's
/// moves start it facing north (yaw π/2), not the recorder's default heading 0.
#[test]
fn the_first_pose_carries_the_start_heading() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("start.mcap");
    let world = common::world("paper-3x3");
    let env = RobotEnv::new(&world, RobotConfig::from_world(&world).unwrap()).unwrap();
    let mut ch = DelayedReward::new(env, &DelayDist::parse("poisson:2").unwrap(), true);
    let mut rec = McapRecorder::create(RecorderConfig::new(&path)).unwrap();
    ch.env_mut().set_trace(rec.trace_period_s());
    let s = ch.reset(5, 6, Start::World).unwrap();
    let start = ch.env().pose();
    // (rapier keeps angles in f32.)
    assert!((start.theta - std::f64::consts::FRAC_PI_2).abs() < 1e-6, "the paper's moves start facing north");
    let names = ch.env().action_names();
    let info = RunInfo {
        world: &world,
        seed: 5,
        learner: "scripted",
        action_names: &names,
        config_toml: common::CONFIG_TOML,
        env_kind: "robot",
        facts: &[],
        start_pose: Some(start),
    };
    rec.on_start(&info, s, ch.env().sim_time_s());
    rec.on_finish(0, true);
    assert!(rec.take_error().is_none());
    let log = read_log(&path).unwrap();
    let first = log.poses.first().expect("the start pose is recorded");
    assert_eq!(first.log_time, 0);
    assert!((first.theta - start.theta).abs() < 1e-12, "{first:?} vs {start:?}");
    assert!((first.x - start.x).abs() < 1e-12 && (first.y - start.y).abs() < 1e-12, "{first:?}");
}
