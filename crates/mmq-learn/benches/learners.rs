//! Steps per second of each learner on the paper's 9×9 world with the Poisson(13)
//! channel (environment, channel and learner together, as in a run), and of the
//! channel alone. Figures and history: docs/performance.md.
//!
//! `cargo bench -p mmq-learn --bench learners`
//!
//! - `learner-steps-9x9-poisson13/{q,fixed,mmq}`: the learner as the runner holds it,
//!   a `Box<dyn Learner>` built from the default [`LearnerSpec`] (MMQ: N = 51 models).
//! - `learner-steps-9x9-poisson13/channel-only`: environment and channel, no learner.
//! - `learner-steps-static-9x9-poisson13/{q,mmq}`: the same loop with the concrete
//!   learner type (no virtual calls), to show what dynamic dispatch costs.
//! - `mmq-reference-9x9/mmq-reference`: the plain transcription of Algorithm 1.
//!
//! With `LEARNERS_STEPS="NAME STEPS"` set (e.g. `"mmq 60000"`; NAME a learner, or
//! `static-q` / `static-mmq`) the binary instead runs that loop once for that many
//! steps and exits: for instruction counts under `valgrind --tool=callgrind` and CPU
//! time under `perf stat` (see docs/performance.md).

use criterion::{Criterion, Throughput, criterion_group};
use mmq_core::{DelayDist, DelayedReward, Rng, SeedTree, Start, Stream, World};
use mmq_grid::GridEnv;
use mmq_learn::mmq::MultipleModelQ;
use mmq_learn::qlearning::QLearning;
use mmq_learn::{Experience, Learner, LearnerKind, LearnerSpec};

const STEPS: u64 = 100_000;

fn world() -> World {
    World::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../worlds/paper-9x9.toml")).unwrap()
}

/// `steps` steps of learning from scratch; returns the reward earned.
fn learn<L: Learner + ?Sized>(learner: &mut L, w: &World, steps: u64) -> f64 {
    let seeds = SeedTree::new(1);
    let mut ch = DelayedReward::new(GridEnv::new(w), &DelayDist::Poisson(13.0), false);
    let mut s = ch.reset(seeds.seed(Stream::Env), seeds.seed(Stream::Delay), Start::World).unwrap();
    let mut rng: Rng = seeds.rng(Stream::Explore);
    let mut total = 0.0;
    for t in 0..steps {
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

/// A fresh learner of `kind` as the runner builds it, then `steps` steps.
fn run(kind: LearnerKind, w: &World, steps: u64) -> f64 {
    let spec = LearnerSpec::new(kind);
    let mut learner = spec.build(w.num_cells(), 4, 1 << 30).unwrap();
    learn(&mut *learner, w, steps)
}

fn bench(c: &mut Criterion) {
    // The world is parsed once; each iteration builds the learner, environment and
    // channel afresh (as a run does) and takes STEPS steps.
    let w = world();
    let mut g = c.benchmark_group("learner-steps-9x9-poisson13");
    g.throughput(Throughput::Elements(STEPS));
    g.sample_size(10);
    for kind in [LearnerKind::Q, LearnerKind::Fixed, LearnerKind::Mmq] {
        g.bench_function(kind.name(), |b| b.iter(|| run(kind, &w, STEPS)));
    }
    g.bench_function("channel-only", |b| {
        b.iter(|| {
            let mut ch = DelayedReward::new(GridEnv::new(&w), &DelayDist::Poisson(13.0), false);
            ch.reset(1, 2, Start::World).unwrap();
            let mut acc = 0.0;
            for t in 0..STEPS {
                acc += ch.step((t % 4) as usize).unwrap().delivered;
            }
            acc
        })
    });
    g.finish();

    let mut g = c.benchmark_group("learner-steps-static-9x9-poisson13");
    g.throughput(Throughput::Elements(STEPS));
    g.sample_size(10);
    let p = LearnerSpec::default().params;
    g.bench_function("q", |b| b.iter(|| learn(&mut QLearning::new(p, w.num_cells(), 4), &w, STEPS)));
    g.bench_function("mmq", |b| {
        b.iter(|| {
            learn(
                &mut MultipleModelQ::new(
                    p,
                    mmq_learn::settings::MmqSettings::default().max_delay,
                    w.num_cells(),
                    4,
                ),
                &w,
                STEPS,
            )
        })
    });
    g.finish();

    let mut g = c.benchmark_group("mmq-reference-9x9");
    g.throughput(Throughput::Elements(10_000));
    g.sample_size(10);
    g.bench_function("mmq-reference", |b| b.iter(|| run(LearnerKind::MmqReference, &w, 10_000)));
    g.finish();
}

criterion_group!(benches, bench);

fn main() {
    if let Ok(v) = std::env::var("LEARNERS_STEPS") {
        let mut it = v.split_whitespace();
        let name = it.next().unwrap_or("mmq");
        let steps: u64 = it.next().and_then(|x| x.parse().ok()).unwrap_or(STEPS);
        let (w, p) = (world(), LearnerSpec::default().params);
        let earned = match name {
            "static-q" => learn(&mut QLearning::new(p, w.num_cells(), 4), &w, steps),
            "static-mmq" => learn(
                &mut MultipleModelQ::new(
                    p,
                    mmq_learn::settings::MmqSettings::default().max_delay,
                    w.num_cells(),
                    4,
                ),
                &w,
                steps,
            ),
            _ => run(LearnerKind::parse(name).unwrap(), &w, steps),
        };
        println!("{name} {steps} steps: earned {earned}");
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
