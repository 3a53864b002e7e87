//! Running a sweep: the pending jobs of a shard in parallel, each written as it
//! finishes, with the undelayed baselines computed once and shared by the jobs that
//! need them.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;

use super::plan::Shard;
use super::spec::SweepSpec;
use super::store::{finish_dir, is_finished, write_failed_job, write_job};
use crate::batch::{BatchLearner, run_batch};
use crate::error::LabError;
use crate::exec::{Job, baselines_needed, run_jobs};
use crate::metric::MetricId;
use crate::output::write_atomic;
use crate::runner::{Control, LearnerFactory, SeedResult, Trajectory, memory_limit};
use crate::summary::seed_metrics;

/// What a sweep reports while it runs (`mmq_report::sweep_run` says it).
#[derive(Debug)]
pub enum SweepEvent<'a> {
    /// After reading the output directory, before any work.
    Planned {
        /// Jobs of the whole sweep.
        jobs_total: usize,
        /// Jobs of this shard (all without `--shard`).
        jobs_here: usize,
        /// Of those, already finished (skipped).
        done: usize,
        /// Distinct undelayed baselines to compute first.
        baselines: usize,
        /// Decision steps to run (jobs, their references and baselines), for a progress bar.
        steps: u64,
    },
    /// A job finished and its result was written.
    JobDone {
        /// Cell id.
        cell: &'a str,
        /// Cell index in the plan.
        cell_index: usize,
        /// Master seed.
        seed: u64,
        /// Jobs finished so far in this process.
        finished: usize,
        /// Jobs this process set out to run.
        of: usize,
        /// Wall-clock seconds of the job.
        wall_s: f64,
    },
}

/// Callback for [`SweepEvent`]s.
pub type EventSink<'a> = dyn Fn(&SweepEvent<'_>) + Sync + 'a;

/// Builds the learner of a job of cell `cell` in place of the spec's: called with the
/// cell's index, the numbers of states and actions, and the master seed (see
/// [`LearnerFactory`]).
pub type CellLearners<'a> =
    dyn Fn(usize, usize, usize, u64) -> Result<Box<dyn mmq_learn::Learner>, LabError> + Sync + 'a;

/// Builds the batched learner of the seeds of cell `cell` in place of the spec's: called
/// with the cell's index, the numbers of states and actions, and the seeds (see
/// [`crate::batch::BatchFactory`]).
pub type CellBatches<'a> =
    dyn Fn(usize, usize, usize, &[u64]) -> Result<Box<dyn BatchLearner>, LabError> + 'a;

/// What [`run_sweep`] did.
#[derive(Clone, Debug)]
pub struct SweepOutcome {
    /// Jobs of the whole sweep.
    pub jobs_total: usize,
    /// Jobs of this shard.
    pub jobs_here: usize,
    /// Jobs found finished and skipped.
    pub skipped: usize,
    /// Jobs run and written by this call.
    pub ran: usize,
    /// Jobs of this shard still unfinished (after an interruption).
    pub left: usize,
    /// `DIR/results.csv`.
    pub results_csv: PathBuf,
    /// Its number of rows.
    pub rows: usize,
}

/// The learning curve in `points` equal parts of `steps` (none for 0): reward earned
/// per step in each part, as `curve/<last step of the part>`. The spec checks that the
/// parts end on rows of the curve; a part without its row (an interrupted run) is left
/// out.
pub(super) fn curve_points(run: &Trajectory, steps: u64, points: u64) -> Vec<(MetricId, f64)> {
    let cum_at = |t: u64| -> Option<f64> {
        if t == 0 {
            return Some(0.0);
        }
        run.curve.iter().find(|row| row.step == t).map(|row| row.earned_cum)
    };
    let mut out = Vec::new();
    for k in 1..=points {
        let (t0, t1) = ((k - 1) * steps / points, k * steps / points);
        if let (Some(a), Some(b)) = (cum_at(t0), cum_at(t1)) {
            out.push((MetricId::curve(t1), (b - a) / (t1 - t0) as f64));
        }
    }
    out
}

/// Runs `jobs` (of the plan's jobs `pending`) a cell at a time, the seeds of a cell in
/// one batch, handing each seed's result to `done`; stops before the next batch on the
/// stop flag, and at the first error.
fn run_batches(
    jobs: &[Job<'_>],
    pending: &[usize],
    plan: &super::plan::Plan,
    batches: &CellBatches<'_>,
    ctl: Control<'_>,
    done: &dyn Fn(usize, SeedResult) -> Result<(), LabError>,
) -> Result<(), LabError> {
    let limit = memory_limit(1);
    let mut start = 0;
    while start < jobs.len() && !ctl.stop.load(Ordering::Relaxed) {
        let c = plan.job(pending[start]).0;
        let end = start + pending[start..].iter().take_while(|&&j| plan.job(j).0 == c).count();
        let j = &jobs[start];
        let seeds: Vec<u64> = jobs[start..end].iter().map(|j| j.seed).collect();
        let factory =
            |n_states: usize, n_actions: usize, seeds: &[u64]| batches(c, n_states, n_actions, seeds);
        let results = run_batch(j.run, &seeds, &factory, ctl, limit)?;
        for (k, r) in results.into_iter().enumerate() {
            done(start + k, r)?;
        }
        start = end;
    }
    Ok(())
}

/// Runs the jobs of `shard` (all without) that `out` does not hold yet, writing each
/// result as it finishes, then `results.csv` and `sweep.json`. Stops early (leaving
/// every finished result) when `ctl.stop` is set. Holds `out`'s lock ([`crate::lock`])
/// throughout: a folder another process writes into is refused.
pub fn run_sweep(
    spec: &SweepSpec,
    out: &Path,
    shard: Option<Shard>,
    ctl: Control<'_>,
    events: &EventSink<'_>,
) -> Result<SweepOutcome, LabError> {
    run_sweep_with(spec, out, shard, ctl, events, None)
}

/// [`run_sweep`] with each job's learner built by `learners` (when given) in place of the
/// spec's. A seed whose learner failed is finished: it is written as failed, with the
/// learner's error, and not run again.
pub fn run_sweep_with(
    spec: &SweepSpec,
    out: &Path,
    shard: Option<Shard>,
    ctl: Control<'_>,
    events: &EventSink<'_>,
    learners: Option<&CellLearners<'_>>,
) -> Result<SweepOutcome, LabError> {
    run_sweep_how(spec, out, shard, ctl, events, How::Each(learners))
}

/// [`run_sweep`] with the pending seeds of each cell run together in lockstep
/// ([`crate::batch::run_batch`]) by the batched learner `batches` builds for them
/// (called with the cell's index, the numbers of states and actions, and the seeds),
/// one cell after another on the calling thread. Results are written as
/// [`run_sweep_with`] writes them: each seed of a batch as failed (its learner failed
/// it), finished, or not at all (cut short by the stop flag).
pub fn run_sweep_batched(
    spec: &SweepSpec,
    out: &Path,
    shard: Option<Shard>,
    ctl: Control<'_>,
    events: &EventSink<'_>,
    batches: &CellBatches<'_>,
) -> Result<SweepOutcome, LabError> {
    run_sweep_how(spec, out, shard, ctl, events, How::Batched(batches))
}

/// The jobs of pending seeds in `out` of `shard` of `spec`: (cell, seed) pairs in plan
/// order. (Read without the output folder's lock: a look before a run.)
pub fn pending_jobs(spec: &SweepSpec, out: &Path, shard: Option<Shard>) -> Vec<(usize, u64)> {
    let plan = &spec.plan;
    (0..plan.jobs())
        .filter(|&j| shard.is_none_or(|s| s.contains(j)) && !is_finished(out, spec, j))
        .map(|j| plan.job(j))
        .collect()
}

/// How the learners of a sweep's jobs are made.
#[derive(Clone, Copy)]
enum How<'a> {
    /// Each job's own: the spec's, or the factory's.
    Each(Option<&'a CellLearners<'a>>),
    /// One batched learner for the pending seeds of each cell.
    Batched(&'a CellBatches<'a>),
}

fn run_sweep_how(
    spec: &SweepSpec,
    out: &Path,
    shard: Option<Shard>,
    ctl: Control<'_>,
    events: &EventSink<'_>,
    how: How<'_>,
) -> Result<SweepOutcome, LabError> {
    let plan = &spec.plan;
    let spec_file = spec.file.display().to_string();
    let _lock = crate::lock::lock_out_dir(out)?;
    write_atomic(&out.join("spec.toml"), spec.text.as_bytes())?;
    // The manifest first, so that a directory killed at once is still recognisable.
    finish_dir(out, plan, &spec_file, shard)?;
    let here: Vec<usize> = (0..plan.jobs()).filter(|&j| shard.is_none_or(|s| s.contains(j))).collect();
    let have: Vec<bool> = here.par_iter().map(|&j| is_finished(out, spec, j)).collect();
    let pending: Vec<usize> = here.iter().zip(&have).filter(|x| !*x.1).map(|x| *x.0).collect();
    let skipped = here.len() - pending.len();

    let per_cell: Vec<Box<LearnerFactory<'_>>> = match how {
        How::Each(Some(f)) => (0..plan.cells.len())
            .map(|c| Box::new(move |s, a, seed| f(c, s, a, seed)) as Box<LearnerFactory<'_>>)
            .collect(),
        How::Each(None) | How::Batched(_) => Vec::new(),
    };
    let jobs: Vec<Job<'_>> = pending
        .iter()
        .map(|&j| {
            let (c, seed) = plan.job(j);
            let learner = per_cell.get(c).map(|f| &**f);
            Job { run: spec.run(c), seed, learner }
        })
        .collect();
    let baselines = baselines_needed(&jobs);
    // A job with the grid-optimal reference runs its steps twice.
    let steps: u64 =
        jobs.iter().map(|j| j.run.cfg().steps * (1 + u64::from(j.run.cfg().reference))).sum::<u64>()
            + baselines.iter().map(|(_, steps)| steps).sum::<u64>();
    events(&SweepEvent::Planned {
        jobs_total: plan.jobs(),
        jobs_here: here.len(),
        done: skipped,
        baselines: baselines.len(),
        steps,
    });

    let optimum: Vec<f64> = spec.worlds.iter().map(|w| mmq_core::optimum(w).gain).collect();
    let ceilings: Vec<Option<f64>> = (0..spec.runs.len())
        .map(|c| crate::summary::ceiling_per_step(spec.config(c), spec.world(c)))
        .collect();
    let finished = AtomicUsize::new(0);
    let done = |i: usize, r: SeedResult| -> Result<(), LabError> {
        let j = pending[i];
        let (c, seed) = plan.job(j);
        if let Some(e) = &r.failure {
            write_failed_job(out, plan, j, e)?;
        } else if r.complete {
            let mut metrics = seed_metrics(&r, optimum[spec.world_of[c]], ceilings[c]);
            metrics.extend(curve_points(&r.run, spec.config(c).steps, spec.curve));
            // Figs. 7–12 map a cell's first seed: only it keeps its maps.
            let maps = plan.seeds_of(c).first() == Some(&seed);
            let record = spec.keeps_records().then(|| super::record::SeedRecord::of(&r, maps));
            write_job(out, plan, j, &metrics, record)?;
        } else {
            return Ok(());
        }
        let n = finished.fetch_add(1, Ordering::SeqCst) + 1;
        events(&SweepEvent::JobDone {
            cell: &plan.cells[c].id,
            cell_index: c,
            seed,
            finished: n,
            of: pending.len(),
            wall_s: r.wall_time_s,
        });
        Ok(())
    };
    let ran = match how {
        How::Each(_) => run_jobs(&jobs, ctl, &done),
        How::Batched(f) => run_batches(&jobs, &pending, plan, f, ctl, &done),
    };

    let (results_csv, rows, jobs_here, done) = finish_dir(out, plan, &spec_file, shard)?;
    ran?;
    Ok(SweepOutcome {
        jobs_total: plan.jobs(),
        jobs_here,
        skipped,
        ran: finished.into_inner(),
        left: jobs_here - done,
        results_csv,
        rows,
    })
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::AtomicBool;

    use super::*;
    use crate::resolved::run_seed;
    use crate::sweep::merge::same_results;

    fn spec(text: &str) -> Result<SweepSpec, LabError> {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../worlds/sweeps");
        SweepSpec::parse(text, &dir.join("t.toml"))
    }

    /// The shared baseline gives the same metrics as `run_seed`'s own baseline.
    #[test]
    fn shared_baseline_is_run_seeds_baseline() {
        let s = spec("world = \"../paper-3x3.toml\"\nlearner = \"mmq\"\ndelay = \"poisson:2\"\nmax_delay = 4\nsteps = 3000\n").unwrap();
        let stop = AtomicBool::new(false);
        let ctl = Control { stop: &stop, progress: &|_| {} };
        let run = s.run(0);
        let whole = run_seed(run, 7, None, ctl, 1 << 30).unwrap();
        let alone = run.with_cfg(crate::config::RunConfig { baseline: false, ..run.cfg().clone() });
        let mut part = run_seed(&alone, 7, None, ctl, 1 << 30).unwrap();
        let base = run_seed(&run.baseline(), 7, None, ctl, 1 << 30).unwrap();
        part.baseline = Some(base.run);
        part.baseline_greedy_per_step = Some(base.greedy_per_step);
        let opt = mmq_core::optimum(s.world(0)).gain;
        let a = seed_metrics(&whole, opt, None);
        let b = seed_metrics(&part, opt, None);
        assert!(a.contains_key("perf/relative"));
        assert!(same_results(&a, &b), "{a:?}\n{b:?}");
    }

    /// Acts 0; with `at`, gives up after `at` steps.
    #[derive(Debug)]
    struct GivesUp {
        t: u64,
        at: Option<u64>,
    }

    impl mmq_learn::Learner for GivesUp {
        fn name(&self) -> &'static str {
            "gives-up"
        }
        fn act(&mut self, _: usize, _: &mut mmq_core::Rng) -> mmq_learn::Decision {
            mmq_learn::Decision { action: 0, model: None, explored: false }
        }
        fn observe(&mut self, _: &mmq_learn::Experience<'_>) {
            self.t += 1;
        }
        fn greedy(&self, _: usize, _: &mut mmq_core::Rng) -> usize {
            0
        }
        fn action_values(&self, _: usize, out: &mut [f64]) {
            out.fill(0.0);
        }
        fn tables(&self) -> Vec<mmq_learn::Table> {
            Vec::new()
        }
        fn failure(&self) -> Option<String> {
            self.at.filter(|&a| self.t >= a).map(|a| format!("gave up after {a} steps"))
        }
    }

    /// A factory builds every job's learner; a seed whose learner gives up is stored as
    /// failed with its error, counts as finished and is not run again.
    #[test]
    fn a_factory_builds_the_learners_and_a_failed_seed_is_kept() {
        let s = spec("world = \"../paper-3x3.toml\"\nlearner = \"q\"\ndelay = \"poisson:2\"\nsteps = 500\nseeds = 3\nbaseline = false\n").unwrap();
        let dir = tempfile::tempdir().unwrap();
        let stop = AtomicBool::new(false);
        let ctl = Control { stop: &stop, progress: &|_| {} };
        let made = AtomicUsize::new(0);
        let f = |cell: usize, _: usize, n_actions: usize, seed: u64| {
            assert_eq!((cell, n_actions), (0, 4));
            made.fetch_add(1, Ordering::SeqCst);
            Ok(Box::new(GivesUp { t: 0, at: (seed == 1).then_some(100) }) as Box<dyn mmq_learn::Learner>)
        };
        let o = run_sweep_with(&s, dir.path(), None, ctl, &|_| {}, Some(&f)).unwrap();
        assert_eq!((o.ran, o.left, o.rows), (3, 0, 3));
        let failures = crate::sweep::load_failures(dir.path(), &s.plan);
        assert_eq!(failures, [None, Some("gave up after 100 steps".to_string()), None]);
        let again = run_sweep_with(&s, dir.path(), None, ctl, &|_| {}, Some(&f)).unwrap();
        assert_eq!((again.ran, again.skipped, made.load(Ordering::SeqCst)), (0, 3, 3));
    }

    /// The progress counts a job's grid-optimal reference: the steps reported done come
    /// to the steps planned, twice a job's own with the reference.
    #[test]
    fn the_planned_steps_include_the_reference() {
        use std::sync::atomic::AtomicU64;
        let text = "world = \"../paper-3x3.toml\"\nlearner = \"q\"\ndelay = \"poisson:2\"\nsteps = 500\nseeds = 2\nbaseline = false\nreference = true\n";
        let s = spec(text).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let stop = AtomicBool::new(false);
        let done = AtomicU64::new(0);
        let add = |n: u64| {
            done.fetch_add(n, Ordering::SeqCst);
        };
        let ctl = Control { stop: &stop, progress: &add };
        let planned = AtomicU64::new(0);
        let events = |e: &SweepEvent<'_>| {
            if let SweepEvent::Planned { steps, .. } = e {
                planned.store(*steps, Ordering::SeqCst);
            }
        };
        run_sweep_with(&s, dir.path(), None, ctl, &events, None).unwrap();
        assert_eq!(planned.load(Ordering::SeqCst), 2 * 500 * 2);
        assert_eq!(done.load(Ordering::SeqCst), 2 * 500 * 2);
    }

    /// Curve points by hand: earned reward per step in equal parts of the run.
    #[test]
    fn curve_points_by_hand() {
        use crate::runner::CurveRow;
        let row =
            |step, earned_cum| CurveRow { step, earned: 0.0, received: 0.0, earned_cum, received_cum: 0.0 };
        let run = Trajectory {
            curve: vec![row(100, 10.0), row(200, 30.0), row(300, 30.0), row(400, 70.0)],
            ..Trajectory::default()
        };
        let p = curve_points(&run, 400, 2);
        assert_eq!(p, [(MetricId::curve(200), 0.15), (MetricId::curve(400), 0.2)]);
        assert_eq!(p.iter().map(|x| x.0.curve_step()).collect::<Vec<_>>(), [Some(200), Some(400)]);
        // An interrupted run (no row at 400) has only its first point.
        let short = Trajectory { curve: run.curve[..3].to_vec(), ..Trajectory::default() };
        assert_eq!(curve_points(&short, 400, 2).len(), 1);
        assert!(curve_points(&run, 400, 0).is_empty());
    }
}
