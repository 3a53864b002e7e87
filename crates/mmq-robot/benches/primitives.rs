//! Primitives per second of the robot on the paper's 9×9 world with uniformly random
//! actions (default TurtleBot3 Burger, 60 Hz physics): the ideal profile without noise
//! (the default), with rapier on every step, with actuation noise, and the realistic
//! profile (odometry, localisation fixes and the filter, noise on as its default).
//!
//! Run: `cargo bench -p mmq-robot --bench primitives`. Group `robot`: criterion reports
//! the time per batch of 100 primitives; primitives/s = 100 / that time (also printed as
//! throughput).

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group};
use mmq_core::Telemetry;
use mmq_core::seed::rng_from_seed;
use mmq_core::{Env, Start, World};
use mmq_robot::{NoiseConfig, Profile, RobotConfig, RobotEnv};
use rand::RngExt;

const BATCH: u64 = 100;

fn primitives(c: &mut Criterion) {
    let world = World::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../worlds/paper-9x9.toml")).unwrap();
    let mut g = c.benchmark_group("robot");
    g.throughput(Throughput::Elements(BATCH));
    // The default, and rapier stepped on every physics step (free flight off) for
    // comparison: both give bit-identical trajectories.
    let ideal = RobotConfig::from_world(&world).unwrap();
    let realistic =
        RobotConfig { profile: Profile::Realistic, noise: Some(NoiseConfig::default()), ..ideal.clone() };
    let ideal_noise = RobotConfig { noise: Some(NoiseConfig::default()), ..ideal.clone() };
    for (name, cfg) in [
        ("paper-9x9 random primitives", ideal.clone()),
        ("paper-9x9 random primitives, rapier every step", RobotConfig { free_flight: false, ..ideal }),
        ("paper-9x9 random primitives, ideal with noise", ideal_noise),
        ("paper-9x9 random primitives, realistic", realistic),
    ] {
        let mut env = RobotEnv::new(&world, cfg).unwrap();
        env.reset(1, Start::World).unwrap();
        let mut rng = rng_from_seed(2);
        g.bench_function(name, |b| {
            b.iter(|| {
                for _ in 0..BATCH {
                    let a = rng.random_range(0..4);
                    black_box(env.step(a).unwrap());
                }
            })
        });
        let stats = env.stats();
        let get = |k: &str| stats.iter().find(|(n, _)| n == k).map_or(0.0, |(_, v)| *v);
        if get("robot/primitives") == 0.0 {
            continue; // filtered out
        }
        println!(
            "{name}: {:.1} physics steps ({:.1} rapier steps) and {:.2} s simulated per primitive",
            get("robot/physics_steps") / get("robot/primitives"),
            get("robot/rapier_steps") / get("robot/primitives"),
            get("robot/sim_time_s") / get("robot/primitives")
        );
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = primitives
}

/// `PRIMITIVES_RUN="env P"`: instead of criterion, runs P random primitives on one
/// RobotEnv and exits; a last word `rapier` turns free flight off (for `perf stat -e task-clock` and callgrind, which measure CPU time and
/// instructions whatever the load; the difference of two lengths removes start-up).
fn fixed_run(spec: &str) {
    let world = World::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../worlds/paper-9x9.toml")).unwrap();
    let mut words: Vec<&str> = spec.split_whitespace().collect();
    // A last word `rapier`: free flight off (rapier on every physics step).
    let free_flight = words.last() != Some(&"rapier");
    if !free_flight {
        words.pop();
    }
    let cfg = RobotConfig { free_flight, ..RobotConfig::from_world(&world).unwrap() };
    let mut rng = rng_from_seed(2);
    match words.as_slice() {
        ["env", p] => {
            let mut env = RobotEnv::new(&world, cfg).unwrap();
            env.reset(1, Start::World).unwrap();
            for _ in 0..p.parse::<u64>().unwrap() {
                black_box(env.step(rng.random_range(0..4)).unwrap());
            }
        }
        _ => panic!("PRIMITIVES_RUN: \"env P [rapier]\""),
    }
}

fn main() {
    if let Ok(spec) = std::env::var("PRIMITIVES_RUN") {
        fixed_run(&spec);
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
