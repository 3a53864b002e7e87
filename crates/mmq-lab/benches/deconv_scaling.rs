//! Speed of `deconv-model` as the world grows: the paper's 9×9 room, the 15×15 maze and
//! the open 30×30 and 50×50 rooms, Poisson(13) delays, ε 0.05, q0 10, the default
//! learner otherwise (λ̂max 50). One seed of a whole run of 150,000 steps through the
//! runner's own entry point (`mmq_lab::run_seed`: the step loop of `Stepper` with its
//! metrics, then the policy maps; no baseline, no greedy evaluation, no tables; see
//! `common/mod.rs`). The refits grow sparser with t, so the cost per step depends on the
//! horizon; throughput in steps per second. Results: docs/performance.md.
//!
//! Two groups: `deconv-model-scaling` on a pool of one thread, as a seed runs when every
//! core has a seed of its own, and `deconv-model-scaling-spare-core` on a pool of two,
//! whose second core the learner may borrow (`mmq_learn::spare`: a refit's cold start
//! runs beside its warm start), as one seed of `mmq run` runs on a 2-core machine. The
//! fits are the same in both.
//!
//! `cargo bench -p mmq-lab --bench deconv_scaling` (one world: append its name, e.g.
//! `-- open-30x30`).

mod common;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mmq_learn::{LearnerKind, LearnerSpec};

use common::{Seed, config};

const STEPS: u64 = 150_000;

fn bench(c: &mut Criterion) {
    let spec = LearnerSpec {
        params: mmq_learn::spec::Params { epsilon: 0.05, q0: 10.0, ..Default::default() },
        ..LearnerSpec::new(LearnerKind::DeconvModel)
    };
    for (group, threads) in [("deconv-model-scaling", 1), ("deconv-model-scaling-spare-core", 2)] {
        let mut g = c.benchmark_group(group);
        g.throughput(Throughput::Elements(STEPS));
        g.sample_size(10);
        for name in ["paper-9x9", "maze-15x15", "open-30x30", "open-50x50"] {
            let s = Seed::new(config(name, spec.clone(), STEPS), threads);
            g.bench_function(name, |b| b.iter(|| s.run()));
        }
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
