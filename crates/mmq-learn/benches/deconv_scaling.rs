//! Speed of `deconv-model` as the world grows: the paper's 9×9 room, the 15×15 maze and
//! the open 30×30 and 50×50 rooms, Poisson(13) delays, ε 0.05, q0 10, the default
//! learner otherwise (λ̂max 50). Environment, channel and learner together over a whole
//! run of 150,000 steps (the refits grow sparser with t, so the cost per step depends on
//! the horizon); throughput in steps per second. Results: docs/performance.md.
//!
//! Two groups: `deconv-model-scaling` on one core, as a seed runs when every core has a
//! seed of its own, and `deconv-model-scaling-spare-core` with a second core the learner
//! may borrow (`mmq_learn::spare`: a refit's cold start runs beside its warm start), as
//! one seed of `mmq run` runs on a 2-core machine. The fits are the same in both.
//!
//! `cargo bench --workspace --bench deconv_scaling` (one world: append its name, e.g.
//! `-- open-30x30`).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mmq_core::{DelayDist, DelayedReward, Rng, SeedTree, Start, Stream, World};
use mmq_grid::GridEnv;
use mmq_learn::{Experience, LearnerKind, LearnerSpec};

const STEPS: u64 = 150_000;

fn world(name: &str) -> World {
    World::load(format!("{}/../../worlds/{name}.toml", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

/// A fresh learner from `spec`, then `STEPS` steps of learning; returns the reward earned.
fn run(spec: &LearnerSpec, w: &World) -> f64 {
    let mut learner = spec.build(w.num_cells(), 4, 1 << 33).unwrap();
    let seeds = SeedTree::new(1);
    let mut ch = DelayedReward::new(GridEnv::new(w), &DelayDist::Poisson(13.0), false);
    let mut s = ch.reset(seeds.seed(Stream::Env), seeds.seed(Stream::Delay), Start::World).unwrap();
    let mut rng: Rng = seeds.rng(Stream::Explore);
    let mut total = 0.0;
    for t in 0..STEPS {
        let d = learner.act(s, &mut rng);
        let st = ch.step(d.action).unwrap();
        learner.observe(&Experience {
            t,
            state: s,
            action: d.action,
            next_state: st.step.state,
            reward: st.delivered,
            time_s: st.time_s,
            truth: None,
        });
        total += st.step.reward;
        s = st.step.state;
    }
    total
}

fn bench(c: &mut Criterion) {
    let spec = LearnerSpec {
        params: mmq_learn::spec::Params { epsilon: 0.05, q0: 10.0, ..Default::default() },
        ..LearnerSpec::new(LearnerKind::DeconvModel)
    };
    for (group, spare_core) in [("deconv-model-scaling", false), ("deconv-model-scaling-spare-core", true)] {
        // This thread runs a learner; with two threads, the other is free to lend.
        mmq_learn::spare::set_threads(if spare_core { 2 } else { 1 });
        let _job = mmq_learn::spare::Job::start();
        let mut g = c.benchmark_group(group);
        g.throughput(Throughput::Elements(STEPS));
        g.sample_size(10);
        for name in ["paper-9x9", "maze-15x15", "open-30x30", "open-50x50"] {
            let w = world(name);
            g.bench_function(name, |b| b.iter(|| run(&spec, &w)));
        }
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
