//! Recording cost.
//!
//! - `record/grid`, `record/robot-like`: the recorder alone, per step: a grid run (paper
//!   9×9, Poisson(5) delays, with the ledger) and a robot-like run (60 pose samples per
//!   step thinned to 10 Hz), recorded to a temporary file; the steps are precomputed.
//! - `robot/bare`, `robot/recorded`, `robot/recorded-inline`: a real robot run (rapier2d,
//!   paper 9×9, Poisson(13) delays, seeded pseudo-random primitives) without and with
//!   recording at the default pose rate, per primitive: the overhead as the runner sees
//!   it, in wall time; `recorded` is the default (JSON of the poses, compression and
//!   writing on the recorder's writer thread), `recorded-inline` does it all on the
//!   run's thread (`RecorderConfig::writer_thread = false`; the same file).
//!
//! The recording overhead (the target: ≤ 15 %) is printed first, measured
//! paired: rounds that run bare, recorded and recorded-inline back to back, the median
//! over rounds of recorded / bare. Criterion's own groups time each way for a minute in
//! turn; on this machine the speed drifts more than the overhead between them (the same
//! bare run measured 491, 560 and 627 ms in three runs of this bench), so their ratios
//! are not the overhead.
//!
//! Bytes per step (per primitive) and the robot overhead are printed before the timings.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group};
use mmq_core::Telemetry;
use mmq_core::seed::splitmix64;
use mmq_core::{
    ContactSample, DelayDist, DelayedReward, Env, Event, Ledger, Move, Observer, PoseSample, RunInfo, Start,
    StepRecord, StepTrace, World,
};
use mmq_grid::GridEnv;
use mmq_log::{McapRecorder, RecorderConfig};
use mmq_robot::{RobotConfig, RobotEnv};

const STEPS: u64 = 10_000;

struct Step {
    t: u64,
    state: usize,
    action: usize,
    next_state: usize,
    emitted: f64,
    event: Event,
    delay: Option<u32>,
    delivered: f64,
    ids: Vec<u64>,
    sim_time_s: f64,
    trace: StepTrace,
}

struct Run {
    world: World,
    kind: &'static str,
    s0: usize,
    steps: Vec<Step>,
    ledger: Option<Ledger>,
}

fn action(t: u64) -> usize {
    let r = splitmix64(t);
    if r % 10 < 4 { [0, 3][(r >> 8) as usize % 2] } else { ((r >> 16) % 4) as usize }
}

fn world(name: &str) -> World {
    World::load(format!("{}/../../worlds/{name}.toml", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

fn grid_run() -> Run {
    let world = world("paper-9x9");
    let mut ch = DelayedReward::new(GridEnv::new(&world), &DelayDist::Poisson(5.0), true);
    let s0 = ch.reset(1, 2, Start::World).unwrap();
    let mut s = s0;
    let mut steps = Vec::new();
    for t in 0..STEPS {
        let a = action(t);
        let st = ch.step(a).unwrap();
        steps.push(Step {
            t,
            state: s,
            action: a,
            next_state: st.step.state,
            emitted: st.step.reward,
            event: st.step.event,
            delay: st.delay,
            delivered: st.delivered,
            ids: ch.delivered_ids().to_vec(),
            sim_time_s: ch.env().sim_time_s(),
            trace: StepTrace::default(),
        });
        s = st.step.state;
    }
    Run { ledger: ch.ledger().cloned(), world, kind: "grid", s0, steps }
}

fn robot_run() -> Run {
    let world = world("room-12x6");
    let mut s = world.respawn;
    let mut steps = Vec::new();
    for t in 0..STEPS {
        let a = action(t);
        let (n, r, ev) = world.transition(s, Move::ALL[a]);
        let ((x0, y0), (x1, y1)) = (world.cell_center(s), world.cell_center(n));
        let mut trace = StepTrace::default();
        for k in 1..=60 {
            let f = k as f64 / 60.0;
            let time_s = t as f64 + f;
            trace.poses.push(PoseSample { time_s, x: x0 + (x1 - x0) * f, y: y0 + (y1 - y0) * f, theta: 0.0 });
        }
        if ev == Event::WallBump {
            trace.contacts.push(ContactSample {
                time_s: t as f64 + 0.5,
                started: true,
                wall: "boundary-north".into(),
            });
            trace.contacts.push(ContactSample {
                time_s: t as f64 + 0.6,
                started: false,
                wall: "boundary-north".into(),
            });
        }
        steps.push(Step {
            t,
            state: s,
            action: a,
            next_state: n,
            emitted: r,
            event: ev,
            delay: (r != 0.0).then_some(0),
            delivered: r,
            ids: Vec::new(),
            sim_time_s: t as f64 + 1.0,
            trace,
        });
        s = n;
    }
    Run { world: world.clone(), kind: "robot", s0: world.respawn, steps, ledger: None }
}

/// Records the run; returns the file size.
fn record(run: &Run, path: &std::path::Path) -> u64 {
    let mut rec = McapRecorder::create(RecorderConfig::new(path)).unwrap();
    let names: Vec<String> = Move::ALL.iter().map(|m| m.name().to_string()).collect();
    let info = RunInfo {
        world: &run.world,
        seed: 1,
        learner: "bench",
        action_names: &names,
        config_toml: "",
        env_kind: run.kind,
        facts: &[],
        start_pose: None,
    };
    rec.on_start(&info, run.s0, 0.0);
    for s in &run.steps {
        rec.on_step(&StepRecord {
            t: s.t,
            state: s.state,
            action: s.action,
            model: Some(3),
            explored: false,
            next_state: s.next_state,
            emitted: s.emitted,
            event: s.event,
            delay: s.delay,
            delivered: s.delivered,
            delivered_ids: &s.ids,
            ledger: run.ledger.as_ref(),
            sim_time_s: s.sim_time_s,
            trace: &s.trace,
        });
    }
    rec.finish(STEPS, true).unwrap().bytes
}

fn bench(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let mut g = c.benchmark_group("record");
    g.throughput(Throughput::Elements(STEPS));
    g.sample_size(10);
    for run in [grid_run(), robot_run()] {
        let path = dir.path().join(format!("{}.mcap", run.kind));
        let bytes = record(&run, &path);
        println!(
            "record/{}: {:.1} bytes per step ({bytes} bytes for {STEPS} steps)",
            run.kind,
            bytes as f64 / STEPS as f64
        );
        let name = if run.kind == "robot" { "robot-like" } else { run.kind };
        g.bench_function(name, |b| b.iter(|| black_box(record(&run, &path))));
    }
    g.finish();
}

/// Primitives of one real robot run: long enough that the file's fixed costs (creating
/// it and the writer thread, attachments, the summary section) weigh about as little as
/// in a real run of 150,000 primitives (at 1000 they added ~15 points to the overhead).
const PRIMITIVES: u64 = 10_000;

/// Paired rounds of the overhead measurement (odd: the median is one round's).
const ROUNDS: usize = 9;

/// How a robot run is recorded: not, or to a file with or without the writer thread.
#[derive(Clone, Copy)]
enum Rec<'a> {
    Bare,
    To(&'a std::path::Path, bool),
}

/// Runs `PRIMITIVES` robot primitives, recorded as `how` says (as the runner does: the
/// ledger on, the trace at the recorder's period). Returns the file size.
fn robot(world: &World, how: Rec<'_>) -> u64 {
    let env = RobotEnv::new(world, RobotConfig::from_world(world).unwrap()).unwrap();
    let mut ch = DelayedReward::new(env, &DelayDist::Poisson(13.0), true);
    let mut rec = match how {
        Rec::Bare => None,
        Rec::To(p, thread) => {
            let mut cfg = RecorderConfig::new(p);
            cfg.writer_thread = thread;
            Some(McapRecorder::create(cfg).unwrap())
        }
    };
    if let Some(r) = &rec {
        ch.env_mut().set_trace(r.trace_period_s());
    }
    let mut s = ch.reset(1, 2, Start::World).unwrap();
    let names = ch.env().action_names();
    let facts = mmq_robot::features();
    let info = RunInfo {
        world,
        seed: 1,
        learner: "bench",
        action_names: &names,
        config_toml: "",
        env_kind: "robot",
        facts: &facts,
        start_pose: Some(ch.env().pose()),
    };
    if let Some(r) = rec.as_mut() {
        r.on_start(&info, s, ch.env().sim_time_s());
    }
    let mut trace = StepTrace::default();
    for t in 0..PRIMITIVES {
        let a = action(t) % ch.env().num_actions();
        let st = ch.step(a).unwrap();
        if let Some(r) = rec.as_mut() {
            ch.env_mut().take_trace(&mut trace);
            r.on_step(&ch.record(s, a, Some(3), false, &st, &trace));
        }
        s = st.step.state;
    }
    black_box(s);
    rec.map_or(0, |mut r| r.finish(PRIMITIVES, true).unwrap().bytes)
}

fn bench_robot(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("robot.mcap");
    let world = world("paper-9x9");
    // The overhead, paired: ROUNDS rounds, each running the three ways back to back, so
    // that a slow spell of the machine (its speed drifts by ±10–15 % over minutes, more
    // than the overhead) hits all of them alike. Reported: the median over rounds of each
    // way's time over the same round's bare time, and best against best. Criterion's
    // groups below time the ways one after the other, minutes apart, so their ratios
    // carry that drift.
    let ways =
        [("bare", Rec::Bare), ("recorded", Rec::To(&path, true)), ("recorded-inline", Rec::To(&path, false))];
    let mut times = vec![Vec::new(); ways.len()];
    let mut bytes = vec![0; ways.len()];
    for _ in 0..ROUNDS {
        for ((ts, b), (_, how)) in times.iter_mut().zip(&mut bytes).zip(ways) {
            let start = std::time::Instant::now();
            *b = robot(&world, how);
            ts.push(start.elapsed().as_secs_f64() / PRIMITIVES as f64 * 1e6);
        }
    }
    let best = |ts: &[f64]| ts.iter().copied().fold(f64::INFINITY, f64::min);
    for (((name, _), ts), bytes) in ways.iter().zip(&times).zip(&bytes).skip(1) {
        let mut ratios: Vec<f64> = ts.iter().zip(&times[0]).map(|(t, b)| t / b - 1.0).collect();
        ratios.sort_by(f64::total_cmp);
        println!(
            "robot/{name}: overhead {:+.1} % (median of {ROUNDS} paired rounds; range {:+.1} to {:+.1} %), \
             best {:.1} against bare {:.1} µs per primitive ({:+.1} %); {:.0} bytes per primitive",
            100.0 * ratios[ROUNDS / 2],
            100.0 * ratios[0],
            100.0 * ratios[ROUNDS - 1],
            best(ts),
            best(&times[0]),
            100.0 * (best(ts) / best(&times[0]) - 1.0),
            *bytes as f64 / PRIMITIVES as f64
        );
    }
    let mut g = c.benchmark_group("robot");
    g.throughput(Throughput::Elements(PRIMITIVES));
    g.sample_size(10);
    g.bench_function("bare", |b| b.iter(|| black_box(robot(&world, Rec::Bare))));
    for (name, how) in ways.into_iter().skip(1) {
        g.bench_function(name, |b| b.iter(|| black_box(robot(&world, how))));
    }
    g.finish();
}

criterion_group!(benches, bench, bench_robot);

fn main() {
    benches();
    Criterion::default().configure_from_args().final_summary();
}
