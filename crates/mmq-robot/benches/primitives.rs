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
    let mut g = c.benchmark_group("robot");
    g.throughput(Throughput::Elements(BATCH));
    // The default, and rapier stepped on every physics step (free flight off) for
    // comparison: both give bit-identical trajectories.
    for (name, free_flight) in
        [("paper-9x9 random primitives", true), ("paper-9x9 random primitives, rapier every step", false)]
    {
        let cfg = RobotConfig { free_flight, ..RobotConfig::from_world(&world).unwrap() };
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
criterion_main!(benches);
