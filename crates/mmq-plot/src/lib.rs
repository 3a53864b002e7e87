//! mmq-plot: publication-quality figures from plain data — line charts with confidence
//! bands and reference lines, grid-world heat maps, deterministic policies as arrows and
//! probabilistic policies as coloured wedges.
//!
//! Every figure is a plain struct with a `write(base)` method that writes
//! `<base>.svg` (vector, for papers) and `<base>.png` (raster, for reports) and returns
//! both paths. PNG text is drawn with an embedded DejaVu Sans font, so figures render the
//! same on a machine without any font installed; PNGs are supersampled for smooth lines.
//!
//! Architecture invariant: this is the only crate that knows plotters; it knows no
//! learner, environment or run format — callers hand it numbers.

mod grid;
mod line;
mod render;

use std::path::PathBuf;

pub use grid::{
    ARROW_E, ARROW_N, ARROW_S, ARROW_W, ActionProbabilities, GridHeatmap, GridLayout, PolicyArrows,
    arrow_bits,
};
pub use line::{LineChart, RefLine, Series};

/// Why a figure could not be written. Every variant names the file concerned.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The figure's data is inconsistent (e.g. a series with more x than y values);
    /// `path` is the base path the figure was to be written to.
    #[error("{}: cannot draw the figure: {message}", path.display())]
    Input {
        /// Base path of the figure (without extension).
        path: PathBuf,
        /// What is inconsistent.
        message: String,
    },
    /// Rendering failed (font or backend error).
    #[error("{}: cannot render the figure: {message}", path.display())]
    Render {
        /// The SVG or PNG file being rendered.
        path: PathBuf,
        /// The backend's message.
        message: String,
    },
    /// The file could not be written.
    #[error("{}: cannot write the figure: {source}", path.display())]
    Write {
        /// The SVG or PNG file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
}

impl PlotError {
    /// The file (or base path) the error is about.
    pub fn path(&self) -> &std::path::Path {
        match self {
            PlotError::Input { path, .. }
            | PlotError::Render { path, .. }
            | PlotError::Write { path, .. } => path,
        }
    }
}
