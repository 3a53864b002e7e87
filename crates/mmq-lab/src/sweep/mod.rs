//! Parameter sweeps: a TOML spec whose fields are run parameters, each one value or a
//! list (an axis); the product of the axes gives the cells, each run for every seed.
//! A (cell, seed) pair is a job. Jobs are run in parallel, each result is written
//! atomically as it finishes (`cells/<cell-id>/seed-<n>.json`) so that an interrupted
//! sweep resumes where it stopped, `--shard K/N` picks a deterministic disjoint part of
//! the jobs, [`merge`] joins shard outputs, and [`results_csv`] is one tidy table whose
//! bytes depend on neither the thread count nor the sharding.
//!
//! Layout of an output directory:
//!
//! ```text
//! DIR/spec.toml                    copy of the spec, as given
//! DIR/sweep.json                   the plan (cells, seeds) and this directory's status
//! DIR/cells/<cell-id>/seed-<n>.json  one finished job: cell parameters and metrics
//! DIR/results.csv                  a row per finished job
//! ```
//!
//! A cell's id is a hash of its parameters as written and of its world file's bytes, so
//! results survive reordering or extending the spec, and a changed world is recomputed.
//! The undelayed baseline of relative performance depends on neither the learner nor
//! the delay, so each distinct baseline is computed once per process and shared by the
//! cells that need it (bit-identical to [`crate::run_seed`]'s own baseline).

mod cell;
mod merge;
mod plan;
mod product;
mod record;
mod run;
mod spec;
mod stats;
mod store;
mod syntax;

use std::collections::BTreeMap;

pub use merge::{MergeOutcome, merge, merge_jobs};
pub use plan::{Plan, PlanCell, Shard};
pub use record::{RunRecord, SeedRecord};
pub use run::{
    CellBatches, CellLearners, EventSink, SweepEvent, SweepOutcome, pending_jobs, run_sweep,
    run_sweep_batched, run_sweep_with,
};
pub use spec::SweepSpec;
pub use stats::{CellStats, cell_stats, combine};
pub use store::{Manifest, load_failures, load_records, load_results, read_manifest, results_csv};

/// Format tag of `sweep.json` and of the per-job files.
pub const FORMAT: &str = "mmq-sweep/1";

/// The run parameters a spec may set or sweep, in the canonical order: the order of
/// the product (first = outermost) and of the parameter columns in CSV files.
pub const FIELDS: [&str; 14] = [
    "world",
    "env",
    "learner",
    "delay",
    "max_delay",
    "lambda_hat",
    "alpha",
    "gamma",
    "epsilon",
    "q0",
    "steps",
    "window",
    "eval_steps",
    "baseline",
];

/// Per-seed metrics under their stable names (see [`crate::summary::seed_metrics`]).
pub type Metrics = BTreeMap<crate::metric::MetricId, f64>;

/// Largest number of jobs a spec may describe. Every cell is built in memory (about
/// 1.3 KB each), so this also bounds what a short spec can make `mmq sweep` allocate:
/// at most ~1.3 GB, and a million jobs is far beyond a cluster's week of paper-sized runs.
pub const MAX_JOBS: usize = 1_000_000;
/// Largest sweep spec file read, bytes: a spec is a small text file.
pub const MAX_SPEC_BYTES: u64 = 1 << 20;
/// Largest job file read or written, bytes: one job's metrics are a few KiB, and a
/// study's seed record (`record.rs`) tens of KiB on the paper's worlds (the maps of a
/// 9×9 world's first seed about 15 KiB).
pub const MAX_JOB_BYTES: u64 = 16 << 20;
/// Largest `sweep.json` read, bytes: the plan of the largest accepted sweep.
pub const MAX_MANIFEST_BYTES: u64 = 512 << 20;
