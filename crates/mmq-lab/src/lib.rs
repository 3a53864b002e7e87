//! mmq-lab: run configurations, the runner (one seed: learning, metrics, greedy
//! evaluation, the undelayed baseline), multi-seed execution in parallel with results
//! independent of the thread count, outputs (config, summary, metrics, Q-tables), sweeps
//! with their stored results and per-cell statistics, and the paper's experiments as
//! data. Reports of them (markdown, study CSVs, figures) are mmq-report's.
//!
//! Architecture invariant: the lab reports progress through a callback and stops on a
//! flag; it never prints, never owns a progress bar and knows no command-line parser.

pub mod batch;
pub mod comparison;
pub mod config;
pub mod error;
pub mod exec;
pub mod fields;
pub mod grid_optimal;
pub mod lock;
pub mod metric;
pub mod output;
pub mod record;
mod resolved;
pub mod runner;
pub mod settings;
pub mod stepper;
pub mod study;
pub mod suite;
pub mod summary;
pub mod swarm;
mod swarm_record;
pub mod sweep;
pub mod trajectory;

pub use config::{EnvKind, RunConfig};
pub use error::LabError;
pub use exec::run_all;
pub use resolved::{Resolved, run_seed};
pub use runner::{Control, SeedResult};
pub use summary::Summary;
