//! Speed of the learners besides Q-learning and MMQ on the paper's 9×9 world with the
//! Poisson(13) channel: environment, channel and learner together, as in a run, over a
//! whole run of 150,000 steps (the deconvolving learners refit on a schedule that grows
//! with t, so their cost per step depends on the horizon). Results:
//! docs/algorithms/deconvolution.md.
//!
//! `cargo bench -p mmq-learn --bench whole_run`
//!
//! - `whole-run-9x9-poisson13/{q,mmq-kernel,q-lambda,sarsa-lambda,oracle,deconv-q,deconv-model}`:
//!   each learner as the runner builds it from the default [`LearnerSpec`]; `q` is the
//!   reference. The oracle's channel keeps the ground-truth ledger it reads.
//! - `.../deconv-q-told`, `.../deconv-model-told`: told the true pmf (no pmf estimate).
//! - `.../deconv-q-summed`, `.../deconv-model-summed`: `decode_values` off (one
//!   deconvolver of the summed deliveries instead of one per reward value).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mmq_core::{DelayDist, DelayedReward, Rng, SeedTree, Start, Stream, World};
use mmq_grid::GridEnv;
use mmq_learn::{Experience, LearnerKind, LearnerSpec, Truth};

const STEPS: u64 = 150_000;

fn world() -> World {
    World::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../worlds/paper-9x9.toml")).unwrap()
}

/// A fresh learner from `spec`, then `STEPS` steps of learning; returns the reward earned.
fn run(spec: &LearnerSpec, w: &World) -> f64 {
    let mut learner = spec.build(w.num_cells(), 4, 1 << 31).unwrap();
    let needs_truth = learner.needs_truth();
    let seeds = SeedTree::new(1);
    let mut ch = DelayedReward::new(GridEnv::new(w), &DelayDist::Poisson(13.0), needs_truth);
    let mut s = ch.reset(seeds.seed(Stream::Env), seeds.seed(Stream::Delay), Start::World).unwrap();
    let mut rng: Rng = seeds.rng(Stream::Explore);
    let mut truth = Truth::default();
    let mut total = 0.0;
    for t in 0..STEPS {
        let d = learner.act(s, &mut rng);
        let st = ch.step(d.action).unwrap();
        if needs_truth {
            truth.emitted_now = st.delay.map(|_| st.step.reward);
            truth.delivered.clear();
            truth.delivered.extend(ch.delivered_emissions());
        }
        learner.observe(&Experience {
            t,
            state: s,
            action: d.action,
            next_state: st.step.state,
            reward: st.delivered,
            time_s: st.time_s,
            truth: needs_truth.then_some(&truth),
        });
        total += st.step.reward;
        s = st.step.state;
    }
    total
}

fn bench(c: &mut Criterion) {
    let w = world();
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
        let spec = base(kind);
        g.bench_function(kind.name(), |b| b.iter(|| run(&spec, &w)));
    }
    for kind in [LearnerKind::DeconvQ, LearnerKind::DeconvModel] {
        let mut spec = base(kind);
        if let Some(d) = spec.settings.deconv_mut() {
            d.told_delay = Some("poisson:13".into());
        }
        g.bench_function(format!("{}-told", kind.name()), |b| b.iter(|| run(&spec, &w)));
        let mut spec = base(kind);
        if let Some(d) = spec.settings.deconv_mut() {
            d.decode_values = false;
        }
        g.bench_function(format!("{}-summed", kind.name()), |b| b.iter(|| run(&spec, &w)));
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
