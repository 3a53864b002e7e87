//! Primitives per second of the robot on the paper's 9×9 world with uniformly random
//! actions (noise off, default TurtleBot3 Burger, 60 Hz physics).
//!
//! Run: `cargo bench -p mmq-robot --bench primitives`. Criterion reports the time per
//! batch of 100 primitives; primitives/s = 100 / that time (also printed as throughput).

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mmq_core::seed::rng_from_seed;
use mmq_core::{Env, Start, World};
use mmq_robot::{RobotConfig, RobotEnv};
use rand::RngExt;

const BATCH: u64 = 100;

fn primitives(c: &mut Criterion) {
    let world = World::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../worlds/paper-9x9.toml")).unwrap();
    let cfg = RobotConfig::from_world(&world).unwrap();
    let mut env = RobotEnv::new(&world, cfg).unwrap();
    env.reset(1, Start::World).unwrap();
    let mut rng = rng_from_seed(2);
    let mut g = c.benchmark_group("robot");
    g.throughput(Throughput::Elements(BATCH));
    g.bench_function("paper-9x9 random primitives", |b| {
        b.iter(|| {
            for _ in 0..BATCH {
                let a = rng.random_range(0..4);
                black_box(env.step(a).unwrap());
            }
        })
    });
    g.finish();
    let stats = env.stats();
    let get = |k: &str| stats.iter().find(|(n, _)| n == k).map_or(0.0, |(_, v)| *v);
    println!(
        "physics steps per primitive: {:.1}; sim time per primitive: {:.2} s",
        get("robot/physics_steps") / get("robot/primitives"),
        get("robot/sim_time_s") / get("robot/primitives")
    );
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = primitives
}
criterion_main!(benches);
