//! Steps per second of Q-learning, fixed-delay Q and MMQ on the paper's 9×9 world with
//! the Poisson(13) channel, each as one seed of a run through the runner's own entry
//! point (`mmq_lab::run_seed`: the step loop of `Stepper`, the learner a
//! `Box<dyn Learner>` built from the default `LearnerSpec`, with the run's metrics, then
//! the policy maps; no baseline, no greedy evaluation, no tables; see `common/mod.rs`),
//! and of the channel alone. Figures: docs/performance.md.
//!
//! `cargo bench -p mmq-lab --bench learners`
//!
//! - `learner-steps-9x9-poisson13/{q,fixed,mmq}`: 100,000 steps of the learner (MMQ:
//!   N = 51 models).
//! - `learner-steps-9x9-poisson13/channel-only`: environment and channel, no learner and
//!   no runner.
//! - `mmq-reference-9x9/mmq-reference`: 10,000 steps of the plain transcription of
//!   Algorithm 1.
//!
//! With `LEARNERS_STEPS="NAME STEPS"` set (e.g. `"mmq 60000"`; NAME a learner) the binary
//! instead runs that seed once for that many steps and exits: for instruction counts
//! under `valgrind --tool=callgrind` and CPU time under `perf stat` (see
//! docs/performance.md).

mod common;

use criterion::{Criterion, Throughput, criterion_group};
use mmq_core::{DelayDist, DelayedReward, Start};
use mmq_grid::GridEnv;
use mmq_learn::{LearnerKind, LearnerSpec};

use common::{Seed, config};

const STEPS: u64 = 100_000;

/// One seed of the default learner of `kind` for `steps` steps, on one thread.
fn seed(kind: LearnerKind, steps: u64) -> Seed {
    Seed::new(config("paper-9x9", LearnerSpec::new(kind), steps), 1)
}

fn bench(c: &mut Criterion) {
    // Each iteration runs a seed as the runner does: it builds the learner, environment
    // and channel afresh and takes the steps; the world file is parsed once.
    let mut g = c.benchmark_group("learner-steps-9x9-poisson13");
    g.throughput(Throughput::Elements(STEPS));
    g.sample_size(10);
    for kind in [LearnerKind::Q, LearnerKind::Fixed, LearnerKind::Mmq] {
        let s = seed(kind, STEPS);
        g.bench_function(kind.name(), |b| b.iter(|| s.run()));
    }
    let w = seed(LearnerKind::Q, STEPS).run.world().clone();
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

    let mut g = c.benchmark_group("mmq-reference-9x9");
    g.throughput(Throughput::Elements(10_000));
    g.sample_size(10);
    let s = seed(LearnerKind::MmqReference, 10_000);
    g.bench_function("mmq-reference", |b| b.iter(|| s.run()));
    g.finish();
}

criterion_group!(benches, bench);

fn main() {
    if let Ok(v) = std::env::var("LEARNERS_STEPS") {
        let mut it = v.split_whitespace();
        let name = it.next().unwrap_or("mmq");
        let steps: u64 = it.next().and_then(|x| x.parse().ok()).unwrap_or(STEPS);
        let kind = LearnerKind::parse(name).unwrap_or_else(|e| panic!("LEARNERS_STEPS: {e}"));
        let earned = seed(kind, steps).run();
        println!("{name} {steps} steps: earned {earned}");
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
