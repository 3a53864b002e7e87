//! Records a short grid run (random actions drifting toward the goal, Poisson(5) reward
//! delays) to an MCAP file, then prints its summary and draws it:
//!
//! ```text
//! cargo run -p mmq-log --example demo -- [OUT.mcap] [WORLD.toml] [STEPS]
//! ```
//!
//! Handy for trying Foxglove or `tools/validate_mcap.py` without the full CLI.

use std::path::PathBuf;

use mmq_core::Telemetry;
use mmq_core::seed::splitmix64;
use mmq_core::{DelayDist, DelayedReward, Env, Observer, RunInfo, Start, StepTrace, World};
use mmq_grid::GridEnv;
use mmq_log::{McapRecorder, RecorderConfig, read_log, render, summary};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let out = PathBuf::from(args.next().unwrap_or_else(|| "out/demo.mcap".into()));
    let world_path = args
        .next()
        .unwrap_or_else(|| concat!(env!("CARGO_MANIFEST_DIR"), "/../../worlds/paper-9x9.toml").into());
    let steps: u64 = args.next().map_or(Ok(5000), |s| s.parse())?;
    let world = World::load(&world_path)?;
    let dist = DelayDist::parse("poisson:5")?;
    let mut ch = DelayedReward::new(GridEnv::new(&world), &dist, true);
    let seed = 7;
    let mut s = ch.reset(seed, seed + 1, Start::World)?;
    let mut rec = McapRecorder::create(RecorderConfig::new(&out))?;
    let names = ch.env().action_names();
    let facts = vec![("grid_step_period_s".to_string(), mmq_grid::STEP_PERIOD_S.to_string())];
    let config =
        format!("[run]\nworld = {world_path:?}\nsteps = {steps}\ndelay = \"poisson:5\"\nseed = {seed}\n");
    let info = RunInfo {
        world: &world,
        seed,
        learner: "random-walk",
        action_names: &names,
        config_toml: &config,
        env_kind: "grid",
        facts: &facts,
        start_pose: None,
    };
    rec.on_start(&info, s, 0.0);
    let trace = StepTrace::default();
    let mut visits = vec![0.0; world.num_cells()];
    for t in 0..steps {
        let r = splitmix64(seed ^ t);
        let a = if r % 10 < 4 { [0, 3][(r >> 8) as usize % 2] } else { ((r >> 16) % 4) as usize };
        let st = ch.step(a)?;
        visits[s] += 1.0;
        rec.on_step(&ch.record(s, a, None, true, &st, &trace));
        if (t + 1) % 500 == 0 {
            let values: Vec<f64> = visits.iter().map(|v| v / (t + 1) as f64).collect();
            rec.on_tables(t + 1, ch.env().sim_time_s(), &visits, &values);
        }
        s = st.step.state;
    }
    let stats = rec.finish(steps, true)?;
    println!(
        "wrote {} ({} bytes, {:.1} bytes/step)",
        out.display(),
        stats.bytes,
        stats.bytes as f64 / steps as f64
    );
    let log = read_log(&out)?;
    print!("{}", summary(&log));
    let svg = out.with_extension("svg");
    render(&log, &svg, None)?;
    println!("drew {}", svg.display());
    Ok(())
}
