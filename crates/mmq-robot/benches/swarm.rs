//! Primitives per second of the swarm on the paper's 9×9 world with uniformly random
//! actions, realistic profile (odometry, fixes, the filter, actuation noise): one robot
//! and 16 robots, with the `peers` consultation (k = 2, WiFi hops) for 16. The figure to
//! compare is primitives per second summed over the robots.
//!
//! Run: `cargo bench -p mmq-robot --bench swarm`. Group `swarm`: criterion reports the
//! time per batch of 160 primitives (whoever ends them); primitives/s = 160 / that time
//! (also printed as throughput).

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mmq_core::World;
use mmq_core::seed::rng_from_seed;
use mmq_robot::swarm::{SwarmConfig, SwarmEnv};
use mmq_robot::{NoiseConfig, Profile, RobotConfig};
use rand::RngExt;

const BATCH: usize = 160;

fn swarm(c: &mut Criterion) {
    let world = World::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../worlds/paper-9x9.toml")).unwrap();
    let realistic = RobotConfig {
        profile: Profile::Realistic,
        noise: Some(NoiseConfig::default()),
        ..RobotConfig::from_world(&world).unwrap()
    };
    let mut g = c.benchmark_group("swarm");
    g.throughput(Throughput::Elements(BATCH as u64));
    for (name, overrides) in [
        ("1 realistic robot", vec![]),
        ("16 realistic robots, peers k=2", vec!["robots=16", "consult=peers", "k=2"]),
    ] {
        let ov: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
        let sc = SwarmConfig::from_world(&world, &ov).unwrap();
        let mut env = SwarmEnv::new(&world, realistic.clone(), sc).unwrap();
        env.reset(1, 2).unwrap();
        let mut rng = rng_from_seed(3);
        for r in 0..env.robots() {
            env.act(r, rng.random_range(0..4)).unwrap();
        }
        let mut out = Vec::new();
        g.bench_function(name, |b| {
            b.iter(|| {
                let mut n = 0;
                while n < BATCH {
                    out.clear();
                    env.advance(&mut out).unwrap();
                    for st in &out {
                        env.act(st.robot, rng.random_range(0..4)).unwrap();
                    }
                    n += out.len();
                    black_box(&out);
                }
            })
        });
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = swarm
}
criterion_main!(benches);
