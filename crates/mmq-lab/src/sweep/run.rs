//! Running a sweep: the pending jobs of a shard in parallel, each written as it
//! finishes, with the undelayed baselines computed once and shared by the jobs that
//! need them.

use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use mmq_core::DelayDist;
use rayon::prelude::*;

use super::plan::Shard;
use super::spec::SweepSpec;
use super::store::{finish_dir, read_job, write_job};
use crate::config::RunConfig;
use crate::error::LabError;
use crate::output::write_atomic;
use crate::runner::{Control, SeedResult, Trajectory, check_tables_fit, memory_limit, run_seed};
use crate::summary::seed_metrics;

/// What a sweep reports while it runs (the CLI prints it).
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
        /// Decision steps to run (jobs and baselines), for a progress bar.
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

/// Key of an undelayed baseline: everything it depends on.
fn baseline_key(spec: &SweepSpec, c: usize, seed: u64) -> String {
    let cfg = spec.config(c);
    let p = cfg.learner.params;
    format!(
        "{}|{}|{}|{}|{}|{}|{}|{}|{}|{seed}",
        spec.world_of[c],
        cfg.env.name(),
        p.alpha,
        p.gamma,
        p.epsilon,
        p.q0,
        cfg.steps,
        cfg.window,
        cfg.eval_steps
    )
}

/// An undelayed baseline shared by the jobs that need it.
struct SharedBaseline {
    /// Jobs still to use it.
    users: AtomicUsize,
    /// Its state.
    slot: Mutex<Slot>,
}

/// The state of a shared baseline.
enum Slot {
    /// Not computed yet.
    Pending,
    /// The trajectory and its greedy evaluation.
    Ready(Arc<(Trajectory, f64)>),
    /// Unavailable: interrupted, failed, or no longer needed.
    Gone,
}

/// The undelayed Q-learning run of cell `c`'s baseline: what [`run_seed`] runs as its
/// baseline, as a run of its own.
fn baseline_config(cfg: &RunConfig) -> RunConfig {
    RunConfig { learner: cfg.baseline_learner(), delay: "none".into(), baseline: false, ..cfg.clone() }
}

/// The learning curve in `points` equal parts of `steps` (none for 0): reward earned
/// per step in each part, as `curve/<last step of the part>`. The spec checks that the
/// parts end on rows of the curve; a part without its row (an interrupted run) is left
/// out.
pub(super) fn curve_points(run: &Trajectory, steps: u64, points: u64) -> Vec<(String, f64)> {
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
            out.push((format!("curve/{t1}"), (b - a) / (t1 - t0) as f64));
        }
    }
    out
}

/// Runs the jobs of `shard` (all without) that `out` does not hold yet, writing each
/// result as it finishes, then `results.csv` and `sweep.json`. Stops early (leaving
/// every finished result) when `ctl.stop` is set.
pub fn run_sweep(
    spec: &SweepSpec,
    out: &Path,
    shard: Option<Shard>,
    ctl: Control<'_>,
    events: &EventSink<'_>,
) -> Result<SweepOutcome, LabError> {
    let plan = &spec.plan;
    let spec_file = spec.file.display().to_string();
    write_atomic(&out.join("spec.toml"), spec.text.as_bytes())?;
    // The manifest first, so that a directory killed at once is still recognisable.
    finish_dir(out, plan, &spec_file, shard)?;
    let here: Vec<usize> = (0..plan.jobs()).filter(|&j| shard.is_none_or(|s| s.contains(j))).collect();
    let have: Vec<bool> = here.par_iter().map(|&j| read_job(out, plan, j).is_some()).collect();
    let pending: Vec<usize> = here.iter().zip(&have).filter(|x| !*x.1).map(|x| *x.0).collect();
    let skipped = here.len() - pending.len();

    // Refuse tables that cannot fit before running anything.
    let parallel = rayon::current_num_threads().min(pending.len()).max(1);
    let limit = memory_limit(parallel);
    let mut checked = BTreeSet::new();
    for &j in &pending {
        let c = plan.job(j).0;
        if checked.insert(c) {
            check_tables_fit(spec.config(c), spec.world(c), limit)?;
        }
    }

    // Distinct baselines of the pending jobs, each with the number of jobs that use it.
    let mut shared: HashMap<String, SharedBaseline> = HashMap::new();
    let mut base_steps = 0;
    for &j in &pending {
        let (c, seed) = plan.job(j);
        if spec.config(c).baseline {
            let e = shared.entry(baseline_key(spec, c, seed)).or_insert_with(|| {
                base_steps += spec.config(c).steps;
                SharedBaseline { users: AtomicUsize::new(0), slot: Mutex::new(Slot::Pending) }
            });
            e.users.fetch_add(1, Ordering::Relaxed);
        }
    }
    let steps: u64 = pending.iter().map(|&j| spec.config(plan.job(j).0).steps).sum::<u64>() + base_steps;
    events(&SweepEvent::Planned {
        jobs_total: plan.jobs(),
        jobs_here: here.len(),
        done: skipped,
        baselines: shared.len(),
        steps,
    });

    let failed = AtomicBool::new(false);
    let first_error = Mutex::new(None::<LabError>);
    let fail = |e: LabError| {
        failed.store(true, Ordering::SeqCst);
        let mut g = first_error.lock().unwrap_or_else(|p| p.into_inner());
        if g.is_none() {
            *g = Some(e);
        }
    };
    let halted = || ctl.stop.load(Ordering::Relaxed) || failed.load(Ordering::Relaxed);
    let dists: Vec<DelayDist> = spec.configs.iter().map(RunConfig::validate).collect::<Result<_, _>>()?;
    let optimum: Vec<f64> = spec.worlds.iter().map(|w| mmq_core::optimum(w).gain).collect();
    let ceilings: Vec<Option<f64>> = (0..spec.configs.len())
        .map(|c| crate::summary::ceiling_per_step(spec.config(c), spec.world(c)))
        .collect();

    // The baseline of job (c, seed): computed by the first job that asks, awaited by
    // the others that ask meanwhile, dropped after its last user.
    let baseline_of = |c: usize, seed: u64| -> Option<Arc<(Trajectory, f64)>> {
        let s = &shared[&baseline_key(spec, c, seed)];
        let mut slot = s.slot.lock().unwrap_or_else(|p| p.into_inner());
        if matches!(*slot, Slot::Pending) {
            let cfg = baseline_config(spec.config(c));
            *slot = match run_seed(&cfg, spec.world(c), &DelayDist::None, seed, None, ctl, limit) {
                Ok(r) if r.complete => Slot::Ready(Arc::new((r.run, r.greedy_per_step))),
                Ok(_) => Slot::Gone,
                Err(e) => {
                    fail(e);
                    Slot::Gone
                }
            };
        }
        let b = match &*slot {
            Slot::Ready(b) => Some(b.clone()),
            _ => None,
        };
        if s.users.fetch_sub(1, Ordering::AcqRel) == 1 {
            *slot = Slot::Gone;
        }
        b
    };

    let finished = AtomicUsize::new(0);
    pending.par_iter().for_each(|&j| {
        if halted() {
            return;
        }
        let (c, seed) = plan.job(j);
        let cfg = spec.config(c);
        let base = if cfg.baseline {
            match baseline_of(c, seed) {
                Some(b) => Some(b),
                None => return, // interrupted or failed
            }
        } else {
            None
        };
        if halted() {
            return;
        }
        let run_cfg = RunConfig { baseline: false, ..cfg.clone() };
        let mut r: SeedResult = match run_seed(&run_cfg, spec.world(c), &dists[c], seed, None, ctl, limit) {
            Ok(r) => r,
            Err(e) => return fail(e),
        };
        if !r.complete {
            return;
        }
        if let Some(b) = base {
            r.baseline = Some(b.0.clone());
            r.baseline_greedy_per_step = Some(b.1);
        }
        let mut metrics = seed_metrics(&r, optimum[spec.world_of[c]], ceilings[c]);
        metrics.extend(curve_points(&r.run, cfg.steps, spec.curve));
        if let Err(e) = write_job(out, plan, j, &metrics) {
            return fail(e);
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
    });

    let (results_csv, rows, jobs_here, done) = finish_dir(out, plan, &spec_file, shard)?;
    if let Some(e) = first_error.into_inner().unwrap_or_else(|p| p.into_inner()) {
        return Err(e);
    }
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
    use super::*;
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
        let cfg = s.config(0);
        let dist = cfg.validate().unwrap();
        let whole = run_seed(cfg, s.world(0), &dist, 7, None, ctl, 1 << 30).unwrap();
        let mut part =
            run_seed(&RunConfig { baseline: false, ..cfg.clone() }, s.world(0), &dist, 7, None, ctl, 1 << 30)
                .unwrap();
        let base =
            run_seed(&baseline_config(cfg), s.world(0), &DelayDist::None, 7, None, ctl, 1 << 30).unwrap();
        part.baseline = Some(base.run);
        part.baseline_greedy_per_step = Some(base.greedy_per_step);
        let opt = mmq_core::optimum(s.world(0)).gain;
        let a = seed_metrics(&whole, opt, None);
        let b = seed_metrics(&part, opt, None);
        assert!(a.contains_key("perf/relative"));
        assert!(same_results(&a, &b), "{a:?}\n{b:?}");
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
        assert_eq!(p, [("curve/200".to_string(), 0.15), ("curve/400".to_string(), 0.2)]);
        // An interrupted run (no row at 400) has only its first point.
        let short = Trajectory { curve: run.curve[..3].to_vec(), ..Trajectory::default() };
        assert_eq!(curve_points(&short, 400, 2).len(), 1);
        assert!(curve_points(&run, 400, 0).is_empty());
    }
}
