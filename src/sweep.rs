//! `mmq sweep`: run a spec's product of parameters over seeds (resumable, shardable),
//! merge shard outputs, and report them (the report itself is `mmq_report::sweep`).

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use mmq_lab::Control;
use mmq_lab::sweep::{Plan, Shard, SweepEvent, SweepSpec, merge, run_sweep};

use crate::cli::{SweepAction, SweepArgs};
use crate::{Failure, progress};

/// Runs `mmq sweep`.
pub fn sweep(a: SweepArgs, stop: &AtomicBool) -> Result<(), Failure> {
    match a.action {
        Some(SweepAction::Report { dirs, out }) => report(&dirs, out.as_deref()),
        Some(SweepAction::Merge { dirs, out }) => merge_cmd(&dirs, &out),
        None => {
            let spec = a
                .spec
                .ok_or_else(|| crate::input_error("give a sweep spec: mmq sweep SPEC.toml --out DIR"))?;
            let out = a.out.ok_or_else(|| crate::input_error("give an output directory: --out DIR"))?;
            let shard = a.shard.as_deref().map(Shard::parse).transpose()?;
            run(&spec, &out, shard, a.dry_run, a.quiet, stop)
        }
    }
}

fn run(
    spec: &Path,
    out: &Path,
    shard: Option<Shard>,
    dry_run: bool,
    quiet: bool,
    stop: &AtomicBool,
) -> Result<(), Failure> {
    let spec = SweepSpec::load(spec)?;
    let plan = &spec.plan;
    let shard_text = shard.map_or(String::new(), |s| format!(", shard {s}"));
    if dry_run {
        print_plan(plan, shard);
        return Ok(());
    }
    let clock = Instant::now();
    let pb = progress::bar(0, "sweep", quiet);
    let progress = |n: u64| pb.inc(n);
    let ctl = Control { stop, progress: &progress };
    let name = plan.name.clone();
    let events = |e: &SweepEvent<'_>| match e {
        SweepEvent::Planned { jobs_total, jobs_here, done, baselines, steps } => {
            pb.set_length(*steps);
            println!(
                "sweep {name}: {} cells × {} seeds = {jobs_total} jobs{shard_text}: {jobs_here} here, {done} already finished, {} to run ({baselines} shared baselines)",
                plan.cells.len(),
                plan.seeds.len(),
                jobs_here - done,
            );
        }
        SweepEvent::JobDone { cell, cell_index, seed, finished, of, wall_s } => {
            if !quiet {
                let axes: Vec<String> =
                    plan.axes.iter().map(|a| format!("{a}={}", plan.param(*cell_index, a))).collect();
                pb.suspend(|| {
                    eprintln!("[{finished}/{of}] cell {cell} ({}) seed {seed}: {wall_s:.2} s", axes.join(" "))
                });
            }
        }
    };
    let outcome = run_sweep(&spec, out, shard, ctl, &events)?;
    pb.finish_and_clear();
    println!(
        "ran {} job(s), skipped {} already finished, {} left; {} rows in {} ({:.1} s)",
        outcome.ran,
        outcome.skipped,
        outcome.left,
        outcome.rows,
        outcome.results_csv.display(),
        clock.elapsed().as_secs_f64()
    );
    if outcome.left > 0 {
        eprintln!(
            "interrupted: {} job(s) of this {} unfinished; run the same command again to resume",
            outcome.left,
            if shard.is_some() { "shard" } else { "sweep" }
        );
    }
    Ok(())
}

fn print_plan(plan: &Plan, shard: Option<Shard>) {
    // One write, errors ignored: `mmq sweep ... --dry-run | head` must not panic.
    let mut t = format!(
        "sweep {}: {} cells × {} seeds = {} jobs\n",
        plan.name,
        plan.cells.len(),
        plan.seeds.len(),
        plan.jobs()
    );
    if let Some(s) = shard {
        let n = (0..plan.jobs()).filter(|&j| s.contains(j)).count();
        let _ = writeln!(t, "shard {s}: {n} jobs");
    }
    for (k, v) in plan.fixed() {
        let _ = writeln!(t, "  {k:<11} = {v}");
    }
    for a in &plan.axes {
        let _ = writeln!(t, "  {a:<11} ∈ {{{}}}", plan.axis_values(a).join(", "));
    }
    let seeds: Vec<String> = plan.seeds.iter().map(u64::to_string).collect();
    let _ = writeln!(t, "  {:<11} ∈ {{{}}}", "seed", seeds.join(", "));
    t.push_str("cells:\n");
    for (i, c) in plan.cells.iter().enumerate() {
        let axes: Vec<String> = plan.axes.iter().map(|a| format!("{a}={}", plan.param(i, a))).collect();
        let _ = writeln!(t, "  {} {}", c.id, axes.join(" "));
    }
    let _ = std::io::stdout().lock().write_all(t.as_bytes());
}

fn merge_cmd(dirs: &[PathBuf], out: &Path) -> Result<(), Failure> {
    let m = merge(dirs, out)?;
    println!(
        "merged {} director{}: {} of {} jobs finished ({} copied); wrote {}",
        dirs.len(),
        if dirs.len() == 1 { "y" } else { "ies" },
        m.done,
        m.jobs_total,
        m.copied,
        m.results_csv.display()
    );
    if m.done < m.jobs_total {
        eprintln!("warning: {} job(s) missing from every input; rerun their shards", m.jobs_total - m.done);
    }
    Ok(())
}

fn report(dirs: &[PathBuf], out: Option<&Path>) -> Result<(), Failure> {
    let r = mmq_report::sweep::report(dirs, out)?;
    println!(
        "sweep {}: {} cells, {} of {} jobs finished; wrote {}, {} and {} figure(s)",
        r.name,
        r.cells,
        r.done,
        r.jobs,
        r.csv.display(),
        r.markdown.display(),
        r.figures,
    );
    Ok(())
}
