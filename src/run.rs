//! `mmq run`: flags → a resolved run (`mmq_lab::Resolved`) → the run (`mmq_report::run`: config.toml,
//! seeds in parallel, summary.json, metrics.csv, policy.csv, Q-tables; a short table on
//! stdout).

use std::sync::atomic::AtomicBool;

use mmq_lab::config::{EnvKind, RecordSettings};
use mmq_lab::{Resolved, RunConfig};
use mmq_learn::spec::Params;
use mmq_report::live::LiveOptions;

use crate::Failure;
use crate::cli::RunArgs;
use crate::progress::Bars;

/// Stage two of the flags: the configuration resolved (world loaded, delay parsed,
/// everything a run refuses checked).
pub fn resolve(a: &RunArgs) -> Result<Resolved, Failure> {
    // Only the settings given are set; one the learner does not have, or one given twice,
    // is an error.
    let int = |x: usize| toml::Value::Integer(x.min(i64::MAX as usize) as i64);
    let mut given = vec![
        ("max_delay", a.max_delay.map(int)),
        ("lambda_hat", a.lambda_hat.map(int)),
        ("time_bin_s", a.time_bin.map(toml::Value::Float)),
    ];
    given.extend(settings(&a.set)?.into_iter().map(|(k, v)| (k, Some(v))));
    let params = Params { alpha: a.alpha, gamma: a.gamma, epsilon: a.epsilon, q0: a.q0 };
    let learner = mmq_lab::settings::learner(&a.learner, params, &given)?;
    // `EnvArg` lists the fidelities in `EnvKind`'s order.
    let env = [EnvKind::Grid, EnvKind::Robot, EnvKind::Swarm][a.env as usize];
    let cfg = RunConfig {
        world: a.world.clone(),
        env,
        learner,
        delay: a.delay.clone().unwrap_or_else(|| env.default_delay().to_string()),
        steps: a.steps,
        seed: a.seed,
        seeds: a.seeds,
        window: a.window,
        eval_steps: a.eval_steps,
        baseline: !a.no_baseline,
        reference: a.reference,
        save_tables: !a.no_tables,
        ledger: false,
        record: a.record.then(|| RecordSettings::new(a.record_rate, a.record_first, a.record_last)),
        robot: a.robot.clone(),
        swarm: a.swarm.clone(),
    };
    Ok(Resolved::new(cfg)?)
}

/// The `--set KEY=VALUE` flags: each value as TOML (a number, a boolean, a quoted
/// string), else as text (`poisson:13`).
pub(crate) fn settings(set: &[String]) -> Result<Vec<(&str, toml::Value)>, Failure> {
    let example = "write e.g. --set optimism_confidence=2";
    let bad = |kv: &str| crate::input_error(format!("--set `{kv}`: not KEY=VALUE; {example}"));
    set.iter().map(|kv| mmq_core::text_value::key_value(kv).ok_or_else(|| bad(kv))).collect()
}

/// Runs `mmq run`.
pub fn run(a: RunArgs, stop: &AtomicBool) -> Result<(), Failure> {
    let cfg = resolve(&a)?;
    let live = a.live.map(|addr| LiveOptions { addr, speed: a.live_speed, wait: a.live_wait });
    // A stop that came while the finished run's outputs were written changed nothing: the
    // summary says complete, so the exit code says success, not 130.
    if !mmq_report::run::run(&cfg, &a.out, live.as_ref(), stop, &Bars::new(a.quiet))? {
        stop.store(false, std::sync::atomic::Ordering::SeqCst);
    }
    Ok(())
}
