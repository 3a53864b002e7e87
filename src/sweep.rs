//! `mmq sweep`: run a spec's product of parameters over seeds (resumable, shardable),
//! merge shard outputs, and report them (the report itself is `mmq_report::sweep`).

use std::io::Write as _;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use mmq_lab::Control;
use mmq_lab::sweep::{Shard, SweepEvent, SweepSpec, merge, run_sweep};
use mmq_report::Progress as _;
use mmq_report::terminal as say;

use crate::Failure;
use crate::cli::{SweepAction, SweepArgs};
use crate::progress::Bars;

/// Runs `mmq sweep`.
pub fn sweep(a: SweepArgs, stop: &AtomicBool) -> Result<(), Failure> {
    match a.action {
        Some(SweepAction::Report { dirs, out }) => {
            println!("{}", say::sweep_reported(&mmq_report::sweep::report(&dirs, out.as_deref())?));
            return Ok(());
        }
        Some(SweepAction::Merge { dirs, out }) => {
            let (said, missing) = say::merged(dirs.len(), &merge(&dirs, &out)?);
            println!("{said}");
            if let Some(m) = missing {
                eprintln!("{m}");
            }
            return Ok(());
        }
        None => {}
    }
    let spec =
        a.spec.ok_or_else(|| crate::input_error("give a sweep spec: mmq sweep SPEC.toml --out DIR"))?;
    let out = a.out.ok_or_else(|| crate::input_error("give an output directory: --out DIR"))?;
    let shard = a.shard.as_deref().map(Shard::parse).transpose()?;
    let spec = SweepSpec::load(&spec)?;
    let plan = &spec.plan;
    if a.dry_run {
        // One write, errors ignored: `mmq sweep ... --dry-run | head` must not panic.
        let _ = std::io::stdout().lock().write_all(say::sweep_plan(plan, shard).as_bytes());
        return Ok(());
    }
    let clock = Instant::now();
    // The bar begins once the plan says how many steps are left to run.
    let pb = Bars::new(a.quiet);
    let progress = |n: u64| pb.advance(n);
    let ctl = Control { stop, progress: &progress };
    let events = |e: &SweepEvent<'_>| match e {
        SweepEvent::Planned { jobs_total, jobs_here, done, baselines, steps } => {
            pb.begin(*steps, "sweep");
            println!("{}", say::sweep_planned(plan, shard, *jobs_total, *jobs_here, *done, *baselines));
        }
        SweepEvent::JobDone { .. } if a.quiet => {}
        SweepEvent::JobDone { cell, cell_index, seed, finished, of, wall_s } => {
            let axes = say::cell_axes(plan, *cell_index);
            pb.line(&format!("[{finished}/{of}] cell {cell} ({axes}) seed {seed}: {wall_s:.2} s"));
        }
    };
    let outcome = run_sweep(&spec, &out, shard, ctl, &events)?;
    pb.end();
    let (ran, left) = say::sweep_ran(&outcome, shard.is_some(), clock.elapsed().as_secs_f64());
    println!("{ran}");
    if let Some(left) = left {
        eprintln!("{left}");
    }
    Ok(())
}
