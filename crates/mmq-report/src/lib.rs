//! Reports of mmq's studies: results from the lab (`mmq-lab`) in, markdown, CSV and
//! figures (`mmq-plot`) out.
//!
//! - [`paper`]: the paper's figures (2, 3, 4, 6–12 and the ε/q0 sensitivity) and the
//!   learner comparison, run and written as one `report.md` with every picture inlined;
//! - [`sweep`]: the report of one finished sweep, or of several side by side;
//! - [`text`]: a run's summary table and a world's map and optimal policy, for a terminal;
//! - [`run`], [`sweep_run`], [`suite_run`], [`live`], [`replay`] and [`worlds`]: a run, a
//!   sweep, a suite tier, the live view, a recording's drawing and check, and world files'
//!   checks, carried out for a front end that shows progress and output through
//!   [`Progress`].
//! - [`format`](mod@format): numbers as every report and terminal table shows them.
//!
//! The library prints nothing: long work reports through a [`Progress`] the caller
//! supplies (the command line shows a bar), and each entry point returns what it wrote.

mod axes;
mod comparison;
pub mod format;
pub mod leaderboard;
pub mod live;
pub mod paper;
mod reference;
pub mod replay;
pub mod run;
pub mod suite_run;
mod swarm;
pub mod sweep;
pub mod sweep_run;
pub mod terminal;
pub mod text;
pub mod worlds;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use mmq_lab::LabError;
use mmq_plot::PlotError;

/// Why a report could not be made.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// Running the study or reading or writing its files failed.
    #[error(transparent)]
    Lab(#[from] LabError),
    /// A figure could not be drawn or written.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// A figure name that is not one of the paper's (the field `fig` of the request).
    #[error(
        "`fig` `{0}` is not a figure; use 2, 3, 4, 6, 7, 8, 9, 10, 11, 12, sens, comparison or all (comma-separated)"
    )]
    UnknownFigure(String),
    /// A figure spec that cannot make its figure: the file, the field and what to change.
    #[error("{file}: `{field}`: {message}")]
    FigureSpec {
        /// The spec file (an edited copy, or the built-in one).
        file: String,
        /// The spec's field.
        field: String,
        /// What is wrong and the fix.
        message: String,
    },
    /// A report was asked of no sweep directory.
    #[error("give a sweep output directory")]
    NoSweep,
    /// An option of a command that is not accepted; the message names it as a field
    /// (`live_speed`), which a front end shows as its own name for it.
    #[error("{0}")]
    InvalidOption(String),
    /// The live view or a served recording failed while serving (a port in use), or a
    /// recording could not be drawn.
    #[error(transparent)]
    Log(#[from] mmq_log::LogError),
    /// A recording's re-run differs from it: the verdict.
    #[error("{0}")]
    Differs(String),
    /// The command's output could not be written (a full disk; a reader that went away
    /// is not an error).
    #[error(transparent)]
    Output(std::io::Error),
    /// Some of the world files checked are invalid (each said why).
    #[error("{bad} of {total} world files are invalid")]
    InvalidWorlds {
        /// How many are invalid.
        bad: usize,
        /// How many were checked.
        total: usize,
    },
}

impl ReportError {
    /// Whether the error is bad input (a world file, a config, a figure name) rather
    /// than a failure while running or writing.
    pub fn is_input_error(&self) -> bool {
        match self {
            ReportError::Lab(e) => e.is_input_error(),
            ReportError::Plot(_) | ReportError::Log(_) | ReportError::Differs(_) | ReportError::Output(_) => {
                false
            }
            ReportError::UnknownFigure(_)
            | ReportError::NoSweep
            | ReportError::FigureSpec { .. }
            | ReportError::InvalidOption(_)
            | ReportError::InvalidWorlds { .. } => true,
        }
    }

    /// Whether the message names run-configuration fields (see [`LabError::names_fields`]).
    pub fn names_fields(&self) -> bool {
        match self {
            ReportError::Lab(e) => e.names_fields(),
            ReportError::UnknownFigure(_) | ReportError::InvalidOption(_) => true,
            ReportError::Plot(_)
            | ReportError::NoSweep
            | ReportError::FigureSpec { .. }
            | ReportError::Log(_)
            | ReportError::Differs(_)
            | ReportError::Output(_)
            | ReportError::InvalidWorlds { .. } => false,
        }
    }
}

/// Where long work reports its progress, and notices for the user. Every method has a
/// silent default.
pub trait Progress: Sync {
    /// Work of `total` decision steps, called `label`, begins.
    fn begin(&self, total: u64, label: &str) {
        let _ = (total, label);
    }
    /// `n` more steps of the current work are done.
    fn advance(&self, n: u64) {
        let _ = n;
    }
    /// The current work ended.
    fn end(&self) {}
    /// A notice worth showing (e.g. files of an earlier report being replaced).
    fn notice(&self, text: &str) {
        let _ = text;
    }
    /// A line of detail about the work (a finished job), which a quiet front end leaves out.
    fn line(&self, text: &str) {
        let _ = text;
    }
    /// The command's output, as is (the command line writes it to stdout).
    fn say(&self, text: &str) {
        let _ = text;
    }
}

/// Progress that shows nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;

impl Progress for Silent {}

/// A report under construction: its folder, its markdown and the files written so far.
#[derive(Debug)]
pub(crate) struct Doc {
    out: PathBuf,
    md: String,
    files: Vec<PathBuf>,
}

impl Doc {
    fn new(out: &Path) -> Self {
        Doc { out: out.to_path_buf(), md: String::new(), files: Vec::new() }
    }

    /// The base path (no extension) of the figure `name`.
    fn path(&self, name: &str) -> PathBuf {
        self.out.join(name)
    }

    /// A figure's written files: the PNG inlined with its caption.
    fn figure(&mut self, written: Vec<PathBuf>, caption: &str) {
        if let Some(png) = written.iter().find(|p| p.extension().is_some_and(|e| e == "png")) {
            let name = png.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            let _ = writeln!(self.md, "\n![{caption}]({name})\n\n*{caption}*\n");
        }
        self.files.extend(written);
    }

    /// A table's data as `name` (CSV), linked from the markdown.
    fn csv(&mut self, name: &str, text: &str) -> Result<(), ReportError> {
        let p = self.out.join(name);
        mmq_lab::output::write_atomic(&p, text.as_bytes())?;
        let _ = writeln!(self.md, "Data: [`{name}`]({name})\n");
        self.files.push(p);
        Ok(())
    }
}
