//! The swarm's recording: a realistic swarm of three robots with consultation, recorded
//! and read back (one step message per decision of every robot, messages in log-time
//! order, a transform per robot and estimate per frame, the consultations' links), its
//! schemas checked here and by the official Python reader.

use std::path::Path;

use mmq_core::seed::splitmix64;
use mmq_core::{Env, RunInfo, World};
use mmq_log::live::{LiveConfig, LiveServer};
use mmq_log::swarm::{SWARM_CHANNELS, SWARM_LIVE, topics};
use mmq_log::{RecorderConfig, SwarmDelivery, SwarmRecorder, SwarmSetup, SwarmStepIn, read_log};
use mmq_robot::swarm::{SwarmConfig, SwarmEnv, SwarmFrame};
use mmq_robot::{RobotConfig, RobotEnv, apply_overrides};

use crate::common;

const ROBOTS: usize = 3;
const DECISIONS: u64 = 200;

/// Records `DECISIONS` seeded pseudo-random decisions of every robot of a realistic
/// swarm consulting a base station; returns the frames fed to the recorder.
fn record_swarm(world: &World, path: &Path) -> usize {
    let mut rec = SwarmRecorder::create(RecorderConfig::new(path)).unwrap();
    let fed = drive(world, &mut rec);
    let stats = rec.finish(true).unwrap();
    assert!(stats.finished);
    assert_eq!(stats.topics[topics::STEP].count, ROBOTS as u64 * DECISIONS);
    fed
}

/// Feeds `rec` the swarm of [`record_swarm`]; returns the frames fed.
fn drive(world: &World, rec: &mut SwarmRecorder) -> usize {
    let t = apply_overrides(world.robot.as_ref(), &["profile=realistic".to_string()]).unwrap();
    let cfg = RobotConfig::from_table(&t).unwrap();
    let ov: Vec<String> = ["robots=3", "consult=server", "radio_range_m=20"].map(String::from).to_vec();
    let sc = SwarmConfig::from_world(world, &ov).unwrap();
    let station = match sc.consult {
        mmq_robot::swarm::Consult::Server { cell } => Some(world.cell_center(cell)),
        _ => None,
    };
    let mut env = SwarmEnv::new(world, cfg.clone(), sc).unwrap();
    let names = RobotEnv::new(world, cfg).unwrap().action_names();
    env.set_trace(Some(rec.frame_period_s()));
    let states = env.reset(5, 6).unwrap();
    let info = RunInfo {
        world,
        seed: 5,
        learner: "random",
        action_names: &names,
        config_toml: common::CONFIG_TOML,
        env_kind: "swarm",
        facts: &[("robot.radius_m".into(), "0.2".into())],
        start_pose: None,
    };
    rec.start(&info, SwarmSetup { robots: ROBOTS, station, estimates: true }, env.time_s());
    let (mut s, mut a, mut done) = (states, vec![0usize; ROBOTS], vec![0u64; ROBOTS]);
    let pick = |r: usize, t: u64| (splitmix64((r as u64) << 32 ^ t) % 4) as usize;
    for r in 0..ROBOTS {
        a[r] = pick(r, 0);
        env.act(r, a[r]).unwrap();
    }
    let (mut out, mut frames, mut fed) = (Vec::new(), Vec::<SwarmFrame>::new(), 0);
    loop {
        out.clear();
        env.advance(&mut out).unwrap();
        env.take_frames(&mut frames);
        for f in &frames {
            rec.frame(f.time_s, &f.poses, &f.estimates);
        }
        fed += frames.len();
        if out.is_empty() {
            break;
        }
        for st in &out {
            let r = st.robot;
            let deliveries: Vec<SwarmDelivery> = st
                .deliveries
                .iter()
                .map(|d| SwarmDelivery {
                    t_emit: d.decision,
                    value: d.value,
                    t_emit_s: d.emitted_s,
                    delay_s: d.delay_s,
                    hops: d.hops,
                })
                .collect();
            rec.step(&SwarmStepIn {
                robot: r,
                t: st.decision,
                time_s: st.time_s,
                state: s[r],
                action: a[r],
                model: None,
                explored: true,
                next_state: st.step.state,
                event: st.step.event,
                earned: st.step.reward,
                delivered: st.delivered,
                deliveries: &deliveries,
                consultation: st.consultation,
                links: &st.links,
                nodes: &st.nodes,
            });
            s[r] = st.step.state;
            done[r] += 1;
            if done[r] < DECISIONS {
                a[r] = pick(r, done[r]);
                env.act(r, a[r]).unwrap();
            } else {
                env.park(r);
            }
        }
    }
    fed
}

/// The live view of a swarm: a client sees the arena and the bodies (latched), every
/// robot's frame and its estimate's on `/tf`, and robots' steps, each message valid
/// against the schema the server advertised.
#[test]
fn a_live_swarm_shows_every_robot_to_a_client() {
    let world = common::world("paper-9x9");
    let config = LiveConfig { channels: SWARM_LIVE, ..crate::live::local(0.0) };
    let server = LiveServer::start(&config).unwrap();
    let mut client = crate::live::Client::connect(server.addr());
    let all: Vec<&str> = SWARM_CHANNELS.iter().map(|c| c.0).collect();
    assert!(all.iter().all(|t| client.channels.contains_key(*t)), "{:?}", client.channels.keys());
    client.subscribe(&all);
    // The subscriptions reach the server before the run starts.
    let _ = client.until(0.5, |_, _| false);
    let mut rec = SwarmRecorder::live_only(RecorderConfig::new(""), server.tap());
    drive(&world, &mut rec);
    rec.finish(true).unwrap();
    let (_, got) = client.until(3.0, |_, _| false);
    let on = |t: &str| got.iter().filter(|g| g.0 == t).count();
    assert!(on(topics::ARENA) >= 1 && on(topics::BODIES) >= 1, "no scenes");
    assert!(on(topics::STEP) >= 1, "no steps");
    let frames: std::collections::BTreeSet<&str> =
        got.iter().filter(|g| g.0 == topics::TF).filter_map(|g| g.2["child_frame_id"].as_str()).collect();
    for i in 0..ROBOTS {
        assert!(frames.contains(format!("robot{i}").as_str()), "{frames:?}");
        assert!(frames.contains(format!("robot{i}_estimate").as_str()), "{frames:?}");
    }
    server.stop();
}

#[test]
fn a_swarm_recording_holds_every_robots_steps_frames_and_links_in_time_order() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("swarm.mcap");
    let world = common::world("paper-9x9");
    let frames = record_swarm(&world, &path);
    let log = read_log(&path).unwrap();
    assert!(log.complete, "{:?} {:?}", log.problems, log.stop);
    assert_eq!(log.out_of_order, 0, "messages out of log-time order");
    // One step message per decision of every robot, each robot's decisions in order.
    assert_eq!(log.swarm_steps.len(), ROBOTS * DECISIONS as usize);
    for r in 0..ROBOTS as u64 {
        let ts: Vec<u64> = log.swarm_steps.iter().filter(|s| s.msg.robot == r).map(|s| s.msg.t).collect();
        assert_eq!(ts, (0..DECISIONS).collect::<Vec<_>>(), "robot {r}");
    }
    for s in &log.swarm_steps {
        assert_eq!(s.log_time, (s.msg.time_s * 1e9).round() as u64);
    }
    // Every frame moves every robot and its estimate.
    assert!(frames > 100);
    assert_eq!(log.topics[topics::TF].count, (frames * ROBOTS * 2) as u64);
    assert_eq!(log.topics[topics::BODIES].count, 1);
    assert_eq!(log.topics[topics::ARENA].count, 1);
    assert!(log.topics[topics::TRAILS].count > 10);
    // Consultations: a link message per consultation that sent anything, each
    // consultation's delay in its step; the totals add up.
    let consulted = log.swarm_steps.iter().filter(|s| s.msg.links > 0).count();
    assert!(consulted > 0, "no consultation in {} steps", log.swarm_steps.len());
    assert_eq!(log.topics[topics::LINKS].count, consulted as u64);
    assert!(log.swarm_steps.iter().any(|s| !s.msg.deliveries.is_empty()));
    for s in log.swarm_steps.iter().filter(|s| s.msg.consult == "done") {
        assert!(s.msg.delay_s.is_some_and(|d| d >= 0.0) && s.msg.hops.is_some());
    }
    let last = log.swarm_steps.iter().rfind(|s| s.msg.robot == 0).unwrap();
    let delivered: f64 = log.swarm_steps.iter().filter(|s| s.msg.robot == 0).map(|s| s.msg.delivered).sum();
    assert_eq!(last.msg.delivered_total, delivered);
    // Metadata and attachments.
    assert_eq!(log.run_fact("robots"), Some("3"));
    assert_eq!(log.run_fact("env_kind"), Some("swarm"));
    assert!(log.run_fact("station_m").is_some());
    assert!(log.attachment("config.toml").is_some() && log.attachment("world.toml").is_some());
    let end = &log.metadata["end"];
    assert_eq!(end["steps"], (ROBOTS as u64 * DECISIONS).to_string());
    assert_eq!(end["decisions"], "200,200,200");
    // Every message against its channel's schema, here and with the official reader.
    let per_schema = crate::schemas::validate_all(&path);
    assert_eq!(per_schema["mmq.SwarmStep"], ROBOTS * DECISIONS as usize);
    if let Some(py) = crate::schemas::python_with_mcap() {
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tools/validate_mcap.py");
        let out = std::process::Command::new(py).arg(script).arg(&path).output().unwrap();
        let text =
            format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
        assert!(out.status.success(), "validate_mcap.py failed:\n{text}");
        assert!(text.contains(topics::STEP) && text.contains(topics::LINKS) && text.contains("OK"), "{text}");
    } else {
        println!("note: Python validation skipped (no Python with mcap and jsonschema)");
    }
}

#[test]
fn the_swarms_schemas_are_ones_foxglove_reads() {
    for (topic, name, text) in SWARM_CHANNELS {
        let v: serde_json::Value = serde_json::from_str(text).unwrap();
        assert_eq!(crate::schemas::foxglove_subset_problems(&v), Vec::<String>::new(), "{name} ({topic})");
    }
}

#[test]
fn a_swarm_recorder_that_cannot_write_says_so() {
    let full = Path::new("/dev/full");
    if !full.exists() {
        println!("note: skipped: no /dev/full on this system");
        return;
    }
    let world = common::world("paper-9x9");
    let mut rec = SwarmRecorder::create(RecorderConfig::new(full)).unwrap();
    let info = RunInfo {
        world: &world,
        seed: 1,
        learner: "random",
        action_names: &[],
        config_toml: common::CONFIG_TOML,
        env_kind: "swarm",
        facts: &[],
        start_pose: None,
    };
    rec.start(&info, SwarmSetup { robots: 2, station: None, estimates: false }, 0.0);
    let err = rec.finish(true).unwrap_err().to_string();
    assert!(err.contains("/dev/full"), "{err}");
    assert!(mmq_core::Observer::error(&rec).is_some());
}
