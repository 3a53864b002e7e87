//! The legend of a line chart: its entries, its size in one or more columns, and its
//! drawing. Where it goes is the chart's choice: inside the plot where it hides no data,
//! otherwise below the chart, in as many columns as fit, so the plot keeps the width.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use crate::render::{DrawResult, INK, Ink, text_size};
use crate::stroke::{Marker, draw_marker, draw_open_marker};

/// Font size of the entries.
const LEGEND_FONT: f64 = 16.0;
/// Padding inside the box and width of an entry's symbol, logical pixels.
const LEGEND_PAD: f64 = 10.0;
const LEGEND_SYMBOL: f64 = 34.0;
/// Space between two columns of entries.
const COLUMN_GAP: f64 = 18.0;

/// One legend entry.
pub(crate) enum Entry {
    Series {
        name: String,
        color: RGBColor,
        band: bool,
        marker: Option<Marker>,
        dashed: bool,
        /// Drawn as stems (a vertical line with the marker on top), not as a line.
        stem: bool,
        /// The marker is an outline.
        open: bool,
    },
    Ref {
        label: String,
        color: RGBColor,
    },
}

impl Entry {
    fn text(&self) -> &str {
        match self {
            Entry::Series { name, .. } => name,
            Entry::Ref { label, .. } => label,
        }
    }
}

fn row_h() -> f64 {
    text_size("Ag", LEGEND_FONT).1.max(LEGEND_FONT) + 7.0
}

/// Width of one column (symbol and the longest text).
fn column_w(entries: &[Entry]) -> f64 {
    let text_w = entries.iter().map(|e| text_size(e.text(), LEGEND_FONT).0).fold(0.0, f64::max);
    LEGEND_SYMBOL + 8.0 + text_w
}

/// A legend's box and how many columns its entries fill (row by row).
#[derive(Clone, Copy, Debug)]
pub(crate) struct LegendBox {
    pub x: f64,
    pub y: f64,
    pub w: f64,
    pub h: f64,
    pub cols: usize,
}

impl LegendBox {
    /// The size of a legend of `entries` in `cols` columns.
    pub fn sized(entries: &[Entry], cols: usize) -> LegendBox {
        let cols = cols.clamp(1, entries.len().max(1));
        let rows = entries.len().div_ceil(cols);
        let w = 2.0 * LEGEND_PAD + column_w(entries) * cols as f64 + COLUMN_GAP * (cols - 1) as f64;
        let h = LEGEND_PAD * 0.7 * 2.0 + row_h() * rows as f64;
        LegendBox { x: 0.0, y: 0.0, w, h, cols }
    }

    /// The widest legend of `entries` (most columns) no wider than `max_w`.
    pub fn fitting(entries: &[Entry], max_w: f64) -> LegendBox {
        let n = entries.len().max(1);
        (1..=n)
            .rev()
            .map(|c| Self::sized(entries, c))
            .find(|b| b.w <= max_w)
            .unwrap_or(Self::sized(entries, 1))
    }
}

/// Draws the legend in its box.
pub(crate) fn draw_legend<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    entries: &[Entry],
    b: LegendBox,
    ink: Ink,
) -> DrawResult<DB> {
    let r = [(ink.p(b.x), ink.p(b.y)), (ink.p(b.x + b.w), ink.p(b.y + b.h))];
    root.draw(&Rectangle::new(r, WHITE.filled()))?;
    root.draw(&Rectangle::new(r, RGBColor(150, 150, 150).stroke_width(ink.pu(1.0))))?;
    let row_h = row_h();
    let col_w = column_w(entries) + COLUMN_GAP;
    for (i, e) in entries.iter().enumerate() {
        let (row, col) = (i / b.cols, i % b.cols);
        let cy = ink.p(b.y + LEGEND_PAD * 0.7 + row_h * (row as f64 + 0.5));
        let x = b.x + col_w * col as f64;
        let sx0 = ink.p(x + LEGEND_PAD);
        let sx1 = ink.p(x + LEGEND_PAD + LEGEND_SYMBOL);
        let dashes = |color: &RGBColor, width: f64, seg: f64, gap: f64| -> DrawResult<DB> {
            let style = color.stroke_width(ink.pu(width));
            let mut a = sx0;
            while a < sx1 {
                root.draw(&PathElement::new(vec![(a, cy), ((a + ink.p(seg)).min(sx1), cy)], style))?;
                a += ink.p(seg + gap);
            }
            Ok(())
        };
        match e {
            Entry::Series { color, band, marker, dashed, stem, open, .. } => {
                let mid = (sx0 + sx1) / 2;
                let half = ink.p(row_h * 0.4);
                let at = if *stem {
                    // A short stem standing on a baseline.
                    root.draw(&PathElement::new(
                        vec![(sx0, cy + half), (sx1, cy + half)],
                        INK.mix(0.5).stroke_width(ink.pu(1.0)),
                    ))?;
                    root.draw(&PathElement::new(
                        vec![(mid, cy + half), (mid, cy - half / 2)],
                        color.stroke_width(ink.pu(1.8)),
                    ))?;
                    (mid, cy - half / 2)
                } else {
                    if *band {
                        let half = ink.p(row_h * 0.33);
                        root.draw(&Rectangle::new(
                            [(sx0, cy - half), (sx1, cy + half)],
                            color.mix(0.22).filled(),
                        ))?;
                    }
                    if *dashed {
                        dashes(color, 2.5, 12.0, 5.0)?;
                    } else {
                        root.draw(&PathElement::new(
                            vec![(sx0, cy), (sx1, cy)],
                            color.stroke_width(ink.pu(2.5)),
                        ))?;
                    }
                    (mid, cy)
                };
                if let Some(m) = marker {
                    if *open {
                        draw_open_marker(root, *m, at, ink.p(6.0), *color, ink)?;
                    } else {
                        draw_marker(root, *m, at, ink.p(5.0), *color, ink)?;
                    }
                }
            }
            Entry::Ref { color, .. } => dashes(color, 1.8, 9.0, 6.0)?,
        }
        let pos = (sx1 + ink.p(8.0), cy);
        ink.label(root, e.text(), LEGEND_FONT, INK, (HPos::Left, VPos::Center), false, pos)?;
    }
    Ok(())
}
