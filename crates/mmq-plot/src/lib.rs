//! mmq-plot: publication-quality figures from plain data — line charts with confidence
//! bands and reference lines, grid-world heat maps, deterministic policies as arrows and
//! probabilistic policies as coloured wedges.
//!
//! Every figure is a plain struct with a `write(base)` method that writes
//! `<base>.svg` (vector, for papers) and `<base>.png` (raster, for reports) and returns
//! both paths. PNG text is drawn with an embedded DejaVu Sans font, so figures render the
//! same on a machine without any font installed; PNGs are supersampled for smooth lines.
//!
//! ```
//! use mmq_plot::{GridHeatmap, LineChart, RefLine, Series};
//!
//! let dir = std::env::temp_dir().join("mmq-plot-doc");
//! std::fs::create_dir_all(&dir).unwrap();
//! let lambda = vec![0.0, 5.0, 10.0];
//! let mut chart = LineChart::new("Effect of the delay", "mean delay λ (steps)", "relative performance");
//! chart.series.push(
//!     Series::new("Q-learning", lambda.clone(), vec![1.0, 0.4, 0.1])
//!         .with_band(vec![0.95, 0.3, 0.0], vec![1.05, 0.5, 0.2]) // 95 % CI
//!         .with_markers(),
//! );
//! chart.ref_lines.push(RefLine::new("undelayed Q-learning", 1.0));
//! let files = chart.write(&dir.join("fig2")).unwrap(); // fig2.svg, fig2.png
//! assert!(files[1].ends_with("fig2.png"));
//!
//! let world = mmq_core::World::parse("map = \"G.S\"", "doc.toml").unwrap();
//! GridHeatmap::new("Visits", &world, vec![5.0, 2.0, 9.0], "visits").write(&dir.join("visits")).unwrap();
//! ```
//!
//! Conventions: series colours follow the Okabe–Ito colour-blind-safe palette (a seventh
//! series and later are dashed), markers change shape per series, bands are the series
//! colour at 22 % opacity, reference lines are dashed black then grey; a legend sits
//! inside the plot where it hides no data, otherwise below the chart; titles too wide for
//! the figure are shrunk a little, then wrapped onto two lines; colour scales are
//! viridis (perceptually uniform, readable in grey scale). Grid figures draw row 0 at the
//! top, so action N points up, and number rows and columns from 1 as the paper does.
//! Text goes to the SVG as text (the viewer's sans-serif font); in the PNG it is drawn
//! with the embedded font, with plotters' bitmap baseline and combining-accent
//! placement corrected (so `λ̂` renders as in the SVG).
//!
//! Architecture invariant: this is the only crate that knows plotters; it knows no
//! learner, environment or run format — callers hand it numbers.

mod categories;
mod clip;
mod colorbar;
mod geometry;
mod grid;
mod legend;
mod line;
mod render;
mod stroke;
mod title;

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
