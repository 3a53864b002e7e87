//! Typed errors of the lab; the CLI maps them to messages and exit codes.

use std::path::PathBuf;

/// What can go wrong in a run.
#[derive(Debug, thiserror::Error)]
pub enum LabError {
    /// A world file that cannot be used.
    #[error(transparent)]
    World(#[from] mmq_core::WorldError),
    /// An impossible delay spec (its message names the spec and what is accepted).
    #[error(transparent)]
    Delay(#[from] mmq_core::DelayError),
    /// An impossible learner parameter or tables too large.
    #[error(transparent)]
    Learner(#[from] mmq_learn::LearnError),
    /// An impossible run parameter.
    #[error("`{field}` = {value} is not accepted; {accepted}")]
    InvalidParam {
        /// The run-configuration field (`mmq_lab::fields` maps it to a flag).
        field: String,
        /// The value given.
        value: String,
        /// What is accepted.
        accepted: String,
    },
    /// A learner setting the chosen learner does not have, or of the wrong type.
    #[error("`{field}`: {message}")]
    Setting {
        /// The setting, as the configuration names it.
        field: String,
        /// What is wrong and the fix.
        message: String,
    },
    /// A learner setting given twice (as its own option and as `KEY=VALUE`, or twice so).
    #[error("`{0}` is given twice; give it once")]
    GivenTwice(String),
    /// A configuration file that cannot be read.
    #[error("{file}: {message}")]
    Config {
        /// The file.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// A sweep spec that cannot be used, with where the problem is.
    #[error("{file}:{line}:{column}: {field}: {message}")]
    Spec {
        /// The spec file.
        file: String,
        /// Line, from 1.
        line: usize,
        /// Column (characters), from 1.
        column: usize,
        /// The field (`delay`, or `delay[2]` for an item of a list).
        field: String,
        /// What is wrong.
        message: String,
    },
    /// The environment failed during the run.
    #[error("seed {seed}: {source}")]
    Env {
        /// Which seed.
        seed: u64,
        /// The failure.
        source: mmq_core::EnvError,
    },
    /// The environment could not be built.
    #[error("{0}")]
    EnvBuild(String),
    /// An output folder that holds files this program did not write.
    #[error(
        "{path}: the output folder holds {example}, which mmq did not write; choose an empty or new folder for `out`"
    )]
    OutDirInUse {
        /// The folder.
        path: PathBuf,
        /// One of the foreign files.
        example: String,
    },
    /// An output folder another process is writing into (its lock, `mmq_lab::lock`).
    #[error(
        "{path}: another mmq process{} is writing into this folder; wait for it to end (or stop it), or choose another folder for `out`",
        pid.map_or(String::new(), |p| format!(" (PID {p})"))
    )]
    OutDirLocked {
        /// The folder.
        path: PathBuf,
        /// The holder's process id, when its lock file says it.
        pid: Option<u32>,
    },
    /// Every seed's results were written, but some seeds lost output they should have
    /// written (a recording); the summary marks the run incomplete.
    #[error("{}; the summary in {} marks the run incomplete", lost.join("; "), dir.display())]
    LostOutput {
        /// The run's folder.
        dir: PathBuf,
        /// One message per seed that lost output.
        lost: Vec<String>,
    },
    /// A number of worker threads out of range.
    #[error("`threads` {n}: use a number of worker threads from 1 to {max} (default: one per core)")]
    Threads {
        /// The number given.
        n: usize,
        /// The most accepted.
        max: usize,
    },
    /// The worker pool could not start (a memory or process limit).
    #[error("cannot start {n} worker threads ({reason}); give fewer with `threads`")]
    Pool {
        /// The number asked for.
        n: usize,
        /// Why it could not start.
        reason: String,
    },
    /// A recording that cannot be read, or an MCAP file that is not one.
    #[error("{0}")]
    Recording(mmq_log::LogError),
    /// The temporary folder a verification re-runs in does not exist.
    #[error(
        "verify: the temporary folder {} does not exist; the re-run writes its log there: set TMPDIR to a writable folder",
        .0.display()
    )]
    NoTempDir(PathBuf),
    /// Writing an output failed.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The failure.
        source: std::io::Error,
    },
}

impl LabError {
    /// Whether the message names run-configuration fields in backticks (`` `max_delay` ``),
    /// which a front end shows as its own names for them (`mmq_lab::fields`).
    pub fn names_fields(&self) -> bool {
        use mmq_learn::LearnError;
        matches!(
            self,
            LabError::InvalidParam { .. }
                | LabError::Setting { .. }
                | LabError::EnvBuild(_)
                | LabError::OutDirInUse { .. }
                | LabError::OutDirLocked { .. }
                | LabError::Threads { .. }
                | LabError::Pool { .. }
                | LabError::Learner(LearnError::InvalidParam { .. } | LearnError::TooLarge { .. })
        )
    }

    /// Whether the error is bad input rather than a failure while running or writing.
    pub fn is_input_error(&self) -> bool {
        matches!(
            self,
            LabError::World(_)
                | LabError::Delay(_)
                | LabError::Learner(_)
                | LabError::InvalidParam { .. }
                | LabError::Setting { .. }
                | LabError::GivenTwice(_)
                | LabError::Config { .. }
                | LabError::Spec { .. }
                | LabError::OutDirInUse { .. }
                | LabError::OutDirLocked { .. }
                | LabError::EnvBuild(_)
                | LabError::Threads { .. }
                | LabError::Recording(_)
        )
    }

    /// An invalid parameter error.
    pub fn param(field: &str, value: impl ToString, accepted: &str) -> Self {
        let value = value.to_string();
        // A float of 300 digits says no more than its scientific form (integers, at most
        // 20 digits, stay as they are).
        let value = match value.parse::<f64>() {
            Ok(x) if value.len() > 24 => mmq_core::stats::compact(x),
            _ => value,
        };
        LabError::InvalidParam { field: field.into(), value, accepted: accepted.into() }
    }
}
