//! The swarm: one robot without consultation is the single robot bit for bit; robots
//! decide asynchronously; robot–robot bumps; consultation delays and lost rewards;
//! determinism.

use mmq_core::seed::rng_from_seed;
use mmq_core::{Env, Event, Start, Telemetry, World};
use mmq_robot::swarm::{SwarmConfig, SwarmEnv, SwarmStep};
use mmq_robot::{RobotConfig, RobotEnv, apply_overrides};
use rand::RngExt;

fn robot_cfg(world: &World, profile: &str) -> RobotConfig {
    let t = apply_overrides(world.robot.as_ref(), &[format!("profile={profile}")]).unwrap();
    RobotConfig::from_table(&t).unwrap()
}

fn swarm(world: &World, profile: &str, ov: &[&str]) -> SwarmEnv {
    let ov: Vec<String> = ov.iter().map(|s| s.to_string()).collect();
    let sc = SwarmConfig::from_world(world, &ov).unwrap();
    SwarmEnv::new(world, robot_cfg(world, profile), sc).unwrap()
}

/// Runs every robot for `n` decisions with seeded random actions; returns every step
/// that ended, in the order reported.
fn drive(env: &mut SwarmEnv, seed: u64, n: u64) -> Vec<SwarmStep> {
    env.reset(seed, seed ^ 1).unwrap();
    let mut rng = rng_from_seed(seed ^ 0x5eed);
    let mut done = vec![0u64; env.robots()];
    let mut out = Vec::new();
    let mut batch = Vec::new();
    for r in 0..env.robots() {
        env.act(r, rng.random_range(0..env.num_actions())).unwrap();
    }
    loop {
        batch.clear();
        env.advance(&mut batch).unwrap();
        if batch.is_empty() {
            return out;
        }
        for st in &batch {
            done[st.robot] += 1;
            if done[st.robot] < n {
                env.act(st.robot, rng.random_range(0..env.num_actions())).unwrap();
            } else {
                env.park(st.robot);
            }
        }
        out.extend(batch.iter().cloned());
    }
}

#[test]
fn one_robot_without_consultation_is_the_single_robot_bit_for_bit() {
    for (name, profile) in [("paper-9x9", "ideal"), ("paper-9x9", "realistic"), ("room-12x6", "ideal")] {
        let world = crate::world(name);
        let mut single = RobotEnv::new(&world, robot_cfg(&world, profile)).unwrap();
        let mut sw = swarm(&world, profile, &[]);
        for seed in [3u64, 11] {
            let s0 = single.reset(seed, Start::World).unwrap();
            assert_eq!(sw.reset(seed, 99).unwrap(), vec![s0], "{name} {profile}");
            let mut rng = rng_from_seed(seed);
            let mut out = Vec::new();
            for t in 0..1500u64 {
                let a = rng.random_range(0..single.num_actions());
                let st = single.step(a).unwrap();
                sw.act(0, a).unwrap();
                out.clear();
                sw.advance(&mut out).unwrap();
                assert_eq!(out.len(), 1);
                let s = &out[0];
                assert_eq!((s.decision, &s.step), (t, &st), "{name} {profile} seed {seed} step {t}");
                assert_eq!(s.delivered.to_bits(), st.reward.to_bits());
                assert_eq!(s.time_s.to_bits(), single.sim_time_s().to_bits());
                let (p, q) = (single.pose(), sw.poses()[0]);
                assert_eq!(
                    (p.x.to_bits(), p.y.to_bits(), p.theta.to_bits()),
                    (q.x.to_bits(), q.y.to_bits(), q.theta.to_bits())
                );
                assert_eq!(single.pose_estimate(), sw.estimates()[0]);
            }
            assert_eq!(single.stats(), sw.stats(0), "{name} {profile}");
        }
    }
}

#[test]
fn robots_decide_asynchronously_and_deterministically() {
    let world = crate::world("paper-9x9");
    let mut a = swarm(&world, "realistic", &["robots=4"]);
    let steps = drive(&mut a, 5, 200);
    assert_eq!(steps.len(), 800);
    // Each robot's decisions are consecutive, and reported in time order.
    for r in 0..4 {
        let mine: Vec<&SwarmStep> = steps.iter().filter(|s| s.robot == r).collect();
        assert!(mine.iter().enumerate().all(|(i, s)| s.decision == i as u64));
        assert!(mine.windows(2).all(|w| w[0].time_s <= w[1].time_s));
    }
    assert!(steps.windows(2).all(|w| w[0].time_s <= w[1].time_s));
    // Primitives end at different times: most reports carry a single robot.
    let mut times: Vec<u64> = steps.iter().map(|s| s.time_s.to_bits()).collect();
    times.dedup();
    assert!(times.len() > 600, "{} distinct end times", times.len());
    let mut b = swarm(&world, "realistic", &["robots=4"]);
    assert_eq!(drive(&mut b, 5, 200), steps);
    assert_ne!(drive(&mut b, 6, 200), steps);
}

#[test]
fn bumping_into_another_robot_costs_the_swarms_penalty() {
    // Two robots in a corridor facing each other: both drive into the middle cell.
    let world = World::parse("map = \"\"\"\n#####\nS...G\n#####\n\"\"\"", "corridor").unwrap();
    let mut env = swarm(&world, "ideal", &["robots=2", "starts=[[2, 2], [2, 4]]", "bump_penalty=-3"]);
    env.reset(1, 2).unwrap();
    let (east, west) = (1, 3); // Move::ALL is N, E, S, W
    env.act(0, east).unwrap();
    env.act(1, west).unwrap();
    let mut out = Vec::new();
    while out.len() < 2 {
        env.advance(&mut out).unwrap();
    }
    for s in &out {
        assert_eq!((s.step.event, s.step.reward), (Event::WallBump, -3.0), "{s:?}");
    }
    assert_eq!((env.robot_bumps(0), env.robot_bumps(1)), (1, 1));
    // Both backed off to where they started.
    let w = &world;
    assert_eq!(out.iter().map(|s| s.step.state).collect::<Vec<_>>(), vec![w.index(1, 1), w.index(1, 3)]);
}

#[test]
fn consultation_delays_rewards_by_the_round_trip_and_delivers_them_in_time() {
    let world = crate::world("paper-9x9");
    let hop = 0.75;
    let mut env = swarm(
        &world,
        "ideal",
        &["robots=4", "consult=peers", "k=1", "radio_range_m=20", &format!("hop_delay=const:{hop}s")],
    );
    let steps = drive(&mut env, 7, 400);
    let mut delivered = 0;
    for s in &steps {
        if let Some((d, hops)) = s.consultation {
            // Everyone is in range: one hop there, one back.
            assert_eq!((d, hops), (2.0 * hop, 1));
        } else {
            assert_eq!(s.step.reward, 0.0);
        }
        for d in &s.deliveries {
            // Delivered at the robot's first decision ending at or after the reply.
            assert!(s.time_s >= d.emitted_s + d.delay_s);
            let earlier = steps.iter().rfind(|e| e.robot == s.robot && e.decision + 1 == s.decision);
            if let Some(e) = earlier {
                assert!(e.time_s < d.emitted_s + d.delay_s);
            }
            delivered += 1;
        }
    }
    let stats = env.delays();
    let emitted: u64 = stats.iter().map(|d| d.emitted).sum();
    let in_flight: u64 = env.in_flight().iter().map(|f| f.0).sum();
    assert!(emitted > 50, "{emitted}");
    assert_eq!(delivered as u64 + in_flight, emitted);
    assert!(stats.iter().all(|d| d.lost == 0));
}

#[test]
fn a_robot_out_of_range_never_gets_its_rewards() {
    let world = crate::world("paper-9x9");
    let mut env = swarm(&world, "ideal", &["robots=2", "consult=peers", "k=1", "radio_range_m=0.01"]);
    let steps = drive(&mut env, 2, 300);
    assert!(steps.iter().all(|s| s.deliveries.is_empty() && s.consultation.is_none()));
    let d = env.delays();
    assert!(d.iter().all(|d| d.delivered == 0 && d.lost == d.emitted));
    assert!(d.iter().map(|d| d.emitted).sum::<u64>() > 10);
}

#[test]
fn frames_sample_every_robot_at_the_trace_rate_and_consultations_name_their_links() {
    let world = crate::world("paper-9x9");
    let mut env = swarm(&world, "realistic", &["robots=3", "consult=server", "radio_range_m=20"]);
    env.set_trace(Some(0.5));
    let steps = drive(&mut env, 4, 60);
    let mut frames = Vec::new();
    env.take_frames(&mut frames);
    assert_eq!(frames[0].time_s, 0.0);
    let dt = env.config().dt_s;
    // Frame k is the first physics step at or after k × 0.5 s.
    for (k, f) in frames.iter().enumerate() {
        let tick = k as f64 * 0.5;
        assert!(f.time_s >= tick - 1e-9 && f.time_s < tick + dt + 1e-9, "frame {k} at {}", f.time_s);
    }
    assert!(frames.iter().all(|f| f.poses.len() == 3 && f.estimates.iter().all(Option::is_some)));
    let last = steps.last().unwrap().time_s;
    assert!(frames.last().unwrap().time_s > last - 0.5 - dt);
    // Taken frames are gone; tracing off records none.
    env.take_frames(&mut frames);
    assert!(frames.is_empty());
    // A consultation with the server (node 3) in reach of everyone: one hop there, one back.
    let consulted: Vec<&SwarmStep> = steps.iter().filter(|s| s.consultation.is_some()).collect();
    assert!(!consulted.is_empty());
    for s in consulted {
        let r = s.robot as u32;
        assert_eq!(
            s.links,
            vec![(r, 3), (3, r)]
                .into_iter()
                .collect::<std::collections::BTreeSet<_>>()
                .into_iter()
                .collect::<Vec<_>>()
        );
    }
    assert!(steps.iter().filter(|s| s.consultation.is_none()).all(|s| s.links.is_empty()));
    // Links come with where their nodes were: the three robots, then the station.
    let station = world.cell_center(world.respawn);
    for s in &steps {
        if s.links.is_empty() {
            assert!(s.nodes.is_empty());
        } else {
            assert_eq!((s.nodes.len(), s.nodes[3]), (4, station));
        }
    }
}
