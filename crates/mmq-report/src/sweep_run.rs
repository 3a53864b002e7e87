//! Running a sweep spec for a front end: its plan checked and said (`--dry-run`), its jobs
//! run with their progress, a line per finished job and the closing lines; merging shard
//! outputs and reporting them. A suite tier runs on the same engine ([`crate::suite_run`]).

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use mmq_lab::Control;
use mmq_lab::sweep::{CellLearners, Shard, SweepEvent, SweepOutcome, SweepSpec, merge as merge_dirs};

use crate::terminal as say;
use crate::{Progress, ReportError};

/// The shard `K/N` given as the field `shard`, if any.
pub(crate) fn shard(text: Option<&str>) -> Result<Option<Shard>, ReportError> {
    Ok(text.map(Shard::parse).transpose()?)
}

/// A finished job's name in its progress line, from its cell's id and index.
pub(crate) type JobName<'a> = dyn Fn(&str, usize) -> String + Sync + 'a;

/// The jobs of `shard` of `spec` that `out` does not hold yet, run under the progress
/// label `label`: the plan's line said before they run, and a line per finished job
/// named by `job`. The progress is begun, not ended.
pub(crate) fn run_jobs(
    spec: &SweepSpec,
    out: &Path,
    shard: Option<Shard>,
    learners: Option<&CellLearners<'_>>,
    (label, job): (&str, &JobName<'_>),
    stop: &AtomicBool,
    progress: &dyn Progress,
) -> Result<SweepOutcome, ReportError> {
    let advance = |n: u64| progress.advance(n);
    let ctl = Control { stop, progress: &advance };
    let events = |e: &SweepEvent<'_>| match e {
        SweepEvent::Planned { jobs_total, jobs_here, done, baselines, steps } => {
            progress.begin(*steps, label);
            let planned = say::sweep_planned(&spec.plan, shard, *jobs_total, *jobs_here, *done, *baselines);
            progress.say(&format!("{planned}\n"));
        }
        SweepEvent::JobDone { cell, cell_index, seed, finished, of, wall_s } => {
            progress
                .line(&format!("[{finished}/{of}] {} seed {seed}: {wall_s:.2} s", job(cell, *cell_index)));
        }
    };
    Ok(mmq_lab::sweep::run_sweep_with(spec, out, shard, ctl, &events, learners)?)
}

/// The cells and jobs of the spec `spec` (of the part `shard`, `K/N`) without running
/// anything: the text of `mmq sweep --dry-run`.
pub fn dry_run(spec: &Path, shard: Option<&str>) -> Result<String, ReportError> {
    let shard = self::shard(shard)?;
    Ok(say::sweep_plan(&SweepSpec::load(spec)?.plan, shard))
}

/// Runs the spec `spec` into `out` (the part `shard`, `K/N`, of its jobs when given;
/// finished jobs there are skipped), saying the plan, each finished job and what ran.
pub fn sweep(
    spec: &Path,
    out: &Path,
    shard: Option<&str>,
    stop: &AtomicBool,
    progress: &dyn Progress,
) -> Result<(), ReportError> {
    let shard = self::shard(shard)?;
    let spec = SweepSpec::load(spec)?;
    let clock = Instant::now();
    let job = |cell: &str, index: usize| format!("cell {cell} ({})", say::cell_axes(&spec.plan, index));
    let outcome = run_jobs(&spec, out, shard, None, ("sweep", &job), stop, progress)?;
    progress.end();
    let (ran, left) = say::sweep_ran(&outcome, shard.is_some(), clock.elapsed().as_secs_f64());
    progress.say(&format!("{ran}\n"));
    if let Some(left) = left {
        progress.notice(&left);
    }
    Ok(())
}

/// Reports the sweep output directories `dirs` together ([`crate::sweep::report`]) into
/// `out` (default: `DIR/report` of the first) and says what it wrote.
pub fn report(dirs: &[PathBuf], out: Option<&Path>, progress: &dyn Progress) -> Result<(), ReportError> {
    progress.say(&format!("{}\n", say::sweep_reported(&crate::sweep::report(dirs, out)?)));
    Ok(())
}

/// Says what a merge of `inputs` directories did, with a warning when jobs are missing.
pub(crate) fn say_merged(inputs: usize, m: &mmq_lab::sweep::MergeOutcome, progress: &dyn Progress) {
    let (said, missing) = say::merged(inputs, m);
    progress.say(&format!("{said}\n"));
    if let Some(m) = missing {
        progress.notice(&m);
    }
}

/// Merges the sweep output directories `dirs` (shards, or any runs of one spec) into
/// `out` and says what it did.
pub fn merge(dirs: &[PathBuf], out: &Path, progress: &dyn Progress) -> Result<(), ReportError> {
    say_merged(dirs.len(), &merge_dirs(dirs, out)?, progress);
    Ok(())
}
