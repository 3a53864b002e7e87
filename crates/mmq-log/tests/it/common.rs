//! Runs fed to a recorder: the real grid world through the real delay channel, and a
//! scripted robot-like run with continuous poses and contacts.

use std::path::Path;

use mmq_core::Telemetry;
use mmq_core::seed::splitmix64;
use mmq_core::{
    ContactSample, DelayDist, DelayedReward, Env, Event, Move, Observer, PoseSample, RunInfo, Start,
    StepRecord, StepTrace, World,
};
use mmq_grid::GridEnv;
use mmq_log::{McapRecorder, RecordStats, RecorderConfig};

/// What the run told the observer at one step (the test's own copy).
#[derive(Clone, Debug, PartialEq)]
pub struct StepLog {
    pub t: u64,
    pub state: usize,
    pub action: usize,
    pub model: Option<usize>,
    pub explored: bool,
    pub next_state: usize,
    pub emitted: f64,
    pub event: Event,
    pub delay: Option<u32>,
    pub delivered: f64,
    pub ids: Vec<u64>,
    pub sim_time_s: f64,
    pub poses: Vec<PoseSample>,
    pub contacts: Vec<ContactSample>,
}

pub fn world(name: &str) -> World {
    World::load(format!("{}/../../worlds/{name}.toml", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

pub const CONFIG_TOML: &str = "[run]\nsteps = 1\nseed = 7\n";

/// Pseudo-random actions drifting north-west, where the paper's worlds keep their goal.
fn action_of(seed: u64, t: u64) -> usize {
    let r = splitmix64(seed ^ t.wrapping_mul(0x9E37_79B9));
    if r % 10 < 4 { [0, 3][(r >> 8) as usize % 2] } else { ((r >> 16) % 4) as usize }
}

/// A grid run of `steps` steps with seeded pseudo-random actions and a Poisson(5) delay.
/// Tables are offered every `tables_every` steps (0: never).
pub fn run_grid(
    world: &World,
    obs: &mut dyn Observer,
    steps: u64,
    seed: u64,
    tables_every: u64,
) -> Vec<StepLog> {
    let dist = DelayDist::parse("poisson:5").unwrap();
    let mut ch = DelayedReward::new(GridEnv::new(world), &dist, true);
    // As the runner: only what the observer reads of the ledger.
    ch.trim_ledger(!obs.ledger_history());
    let mut s = ch.reset(seed, seed + 1, Start::World).unwrap();
    let names = ch.env().action_names();
    let facts = vec![("grid_step_period_s".to_string(), mmq_grid::STEP_PERIOD_S.to_string())];
    let info = RunInfo {
        world,
        seed,
        learner: "test-learner",
        action_names: &names,
        config_toml: CONFIG_TOML,
        env_kind: "grid",
        facts: &facts,
        start_pose: None,
    };
    obs.on_start(&info, s, ch.env().sim_time_s());
    // The runner's gate: no step is told while it is closed, the resume point when it
    // opens again.
    let gate = obs.step_gate();
    let mut was_open = true;
    let trace = StepTrace::default();
    let mut out = Vec::new();
    let mut visits = vec![0.0; world.num_cells()];
    for t in 0..steps {
        let open = gate.as_ref().is_none_or(|g| g.is_open());
        if open && !was_open {
            obs.on_resume(&ch.resume_point());
        }
        was_open = open;
        let a = action_of(seed, t);
        let st = ch.step(a).unwrap();
        visits[s] += 1.0;
        let rec = ch.record(s, a, (t % 7 != 0).then_some((t % 3) as usize), t % 5 == 0, &st, &trace);
        if open {
            obs.on_step(&rec);
        }
        out.push(StepLog {
            t,
            state: s,
            action: a,
            model: rec.model,
            explored: rec.explored,
            next_state: rec.next_state,
            emitted: rec.emitted,
            event: rec.event,
            delay: rec.delay,
            delivered: rec.delivered,
            ids: rec.delivered_ids.to_vec(),
            sim_time_s: rec.sim_time_s,
            poses: Vec::new(),
            contacts: Vec::new(),
        });
        if tables_every > 0 && (t + 1) % tables_every == 0 {
            let values: Vec<f64> = (0..world.num_cells()).map(|c| c as f64 * 0.5 - t as f64 * 1e-3).collect();
            obs.on_tables(t + 1, ch.env().sim_time_s(), &visits, &values);
        }
        s = st.step.state;
    }
    obs.on_finish(steps, true);
    out
}

/// Records a grid run to `path` and returns the stats and the steps.
pub fn record_grid(
    path: &Path,
    config: impl FnOnce(&mut RecorderConfig),
    steps: u64,
    seed: u64,
) -> (RecordStats, Vec<StepLog>) {
    let mut cfg = RecorderConfig::new(path);
    config(&mut cfg);
    let mut rec = McapRecorder::create(cfg).unwrap();
    let log = run_grid(&world("paper-9x9"), &mut rec, steps, seed, 250);
    assert!(rec.take_error().is_none());
    (rec.stats().clone(), log)
}

/// A scripted robot-like run: one second of simulated time per step, poses every 1/60 s
/// moving between cell centres, a contact (start, stop) at every wall bump.
pub fn run_robot(world: &World, obs: &mut dyn Observer, steps: u64, seed: u64) -> Vec<StepLog> {
    run_robot_with(world, obs, steps, seed, false)
}

/// The estimate's offset from the true pose in [`run_robot_with`]: x, y (m), θ (rad).
pub const ESTIMATE_OFFSET: (f64, f64, f64) = (0.05, -0.03, 0.02);

/// [`run_robot`], and with `estimating` a robot that controls on an estimate: the
/// estimate at every pose sample (offset by [`ESTIMATE_OFFSET`]) and one localisation
/// fix per step, half-way through it, 1 cm east of the true pose.
pub fn run_robot_with(
    world: &World,
    obs: &mut dyn Observer,
    steps: u64,
    seed: u64,
    estimating: bool,
) -> Vec<StepLog> {
    let names: Vec<String> = Move::ALL.iter().map(|m| m.name().to_string()).collect();
    let facts =
        vec![("robot.radius_m".to_string(), "0.2".to_string()), ("physics.dt_s".into(), "0.0166".into())];
    let info = RunInfo {
        world,
        seed,
        learner: "test-learner",
        action_names: &names,
        config_toml: CONFIG_TOML,
        env_kind: "robot",
        facts: &facts,
        start_pose: None,
    };
    let mut s = world.respawn;
    obs.on_start(&info, s, 0.0);
    let mut out = Vec::new();
    let mut trace = StepTrace::default();
    for t in 0..steps {
        let a = action_of(seed, t);
        let (n, r, ev) = world.transition(s, Move::ALL[a]);
        let (x0, y0) = world.cell_center(s);
        let (x1, y1) = world.cell_center(n);
        trace.poses.clear();
        trace.contacts.clear();
        trace.estimates.clear();
        trace.fixes.clear();
        let t0 = t as f64;
        for k in 1..=60 {
            let f = k as f64 / 60.0;
            let (x, y) = match ev {
                Event::Teleport if k == 60 => (x1, y1),
                Event::Teleport => (x0, y0),
                Event::WallBump => {
                    let (dr, dc) = Move::ALL[a].delta();
                    let g = 0.3 * world.cell_size * (1.0 - (2.0 * f - 1.0).abs());
                    (x0 + dc as f64 * g, y0 - dr as f64 * g)
                }
                _ => (x0 + (x1 - x0) * f, y0 + (y1 - y0) * f),
            };
            trace.poses.push(PoseSample { time_s: t0 + f, x, y, theta: 0.1 * a as f64 });
            if estimating {
                let (dx, dy, dth) = ESTIMATE_OFFSET;
                trace.estimates.push(PoseSample {
                    time_s: t0 + f,
                    x: x + dx,
                    y: y + dy,
                    theta: 0.1 * a as f64 + dth,
                });
                if k == 30 {
                    trace.fixes.push(PoseSample { time_s: t0 + f, x: x + 0.01, y, theta: 0.1 * a as f64 });
                }
            }
        }
        if ev == Event::WallBump {
            let wall = format!("wall-{n}-{a}");
            trace.contacts.push(ContactSample { time_s: t0 + 0.5, started: true, wall: wall.clone() });
            trace.contacts.push(ContactSample { time_s: t0 + 0.6, started: false, wall });
        }
        let rec = StepRecord {
            t,
            state: s,
            action: a,
            model: None,
            explored: false,
            next_state: n,
            emitted: r,
            event: ev,
            delay: (r != 0.0).then_some(0),
            delivered: r,
            delivered_ids: &[],
            ledger: None,
            sim_time_s: t0 + 1.0,
            trace: &trace,
        };
        obs.on_step(&rec);
        out.push(StepLog {
            t,
            state: s,
            action: a,
            model: None,
            explored: false,
            next_state: n,
            emitted: r,
            event: ev,
            delay: rec.delay,
            delivered: r,
            ids: Vec::new(),
            sim_time_s: rec.sim_time_s,
            poses: trace.poses.clone(),
            contacts: trace.contacts.clone(),
        });
        s = n;
    }
    obs.on_finish(steps, true);
    out
}
