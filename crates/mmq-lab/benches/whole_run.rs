//! Speed of whole runs of the learners on the paper's 9×9 world with the Poisson(13)
//! channel: one seed of 150,000 steps through the runner's own entry point
//! (`mmq_lab::run_seed`: the step loop of `Stepper` with its metrics and curves, then the
//! policy maps; no baseline, no greedy evaluation, no tables; see `common/mod.rs`), on
//! one thread with no spare core. The deconvolving learners refit on a schedule that
//! grows with t, so their cost per step depends on the horizon. Throughput in steps per
//! second. Results: docs/algorithms/deconvolution.md.
//!
//! `cargo bench -p mmq-lab --bench whole_run` (some of them: append a filter, e.g.
//! `-- 'whole-run-9x9-poisson13/q$'` or `-- deconv`)
//!
//! - `whole-run-9x9-poisson13/{q,mmq-kernel,q-lambda,sarsa-lambda,oracle,deconv-q,deconv-model}`:
//!   each learner built from the default `LearnerSpec` with ε 0.05 and q0 10; `q` is the
//!   reference. The runner keeps the channel's ground-truth ledger the oracle reads.
//! - `.../deconv-q-told`, `.../deconv-model-told`: told the true pmf (no pmf estimate).
//! - `.../deconv-q-summed`, `.../deconv-model-summed`: `decode_values` off (one
//!   deconvolver of the summed deliveries instead of one per reward value).

mod common;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mmq_learn::{LearnerKind, LearnerSpec};

use common::{Seed, config};

const STEPS: u64 = 150_000;

/// One seed of `spec` on the paper's world, on one thread.
fn seed(spec: LearnerSpec) -> Seed {
    Seed::new(config("paper-9x9", spec, STEPS), 1)
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("whole-run-9x9-poisson13");
    g.throughput(Throughput::Elements(STEPS));
    g.sample_size(10);
    let base = |kind| LearnerSpec {
        params: mmq_learn::spec::Params { epsilon: 0.05, q0: 10.0, ..Default::default() },
        ..LearnerSpec::new(kind)
    };
    for kind in [
        LearnerKind::Q,
        LearnerKind::MmqKernel,
        LearnerKind::QLambda,
        LearnerKind::SarsaLambda,
        LearnerKind::Oracle,
        LearnerKind::DeconvQ,
        LearnerKind::DeconvModel,
    ] {
        let s = seed(base(kind));
        g.bench_function(kind.name(), |b| b.iter(|| s.run()));
    }
    for kind in [LearnerKind::DeconvQ, LearnerKind::DeconvModel] {
        let mut spec = base(kind);
        if let Some(d) = spec.settings.deconv_mut() {
            d.told_delay = Some("poisson:13".into());
        }
        let s = seed(spec);
        g.bench_function(format!("{}-told", kind.name()), |b| b.iter(|| s.run()));
        let mut spec = base(kind);
        if let Some(d) = spec.settings.deconv_mut() {
            d.decode_values = false;
        }
        let s = seed(spec);
        g.bench_function(format!("{}-summed", kind.name()), |b| b.iter(|| s.run()));
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
