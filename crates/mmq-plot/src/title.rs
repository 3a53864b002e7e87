//! Titles that fit their figure: a title wider than the space it has is first shrunk a
//! little, then wrapped onto two lines at the most balanced word break (preferring a
//! break after `:` or `,`, or before `(` or `·`), and shrunk further only if a line is
//! still too wide. The measured height tells the figure where its content starts.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use crate::render::{DrawResult, INK, Ink, text_size};

/// Free space left and right of the widest title line, logical pixels.
pub(crate) const TITLE_MARGIN: f64 = 24.0;
/// A one-line title is shrunk to at most this fraction of its size before it is wrapped.
const MIN_SHRINK: f64 = 0.85;
/// Extra space between two title lines, as a fraction of the font size.
const LINE_GAP: f64 = 0.25;

/// A title laid out for a width: its lines and font size (logical pixels).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Title {
    /// One or two lines; none for an empty title.
    pub lines: Vec<String>,
    /// Font size of every line.
    pub font: f64,
}

impl Title {
    /// Lays out `text` at `font` (or smaller) to fit `width` (the figure's width; the
    /// margins are taken off here).
    pub fn fit(text: &str, width: f64, font: f64) -> Title {
        let text = text.trim();
        if text.is_empty() {
            return Title { lines: Vec::new(), font };
        }
        let avail = (width - 2.0 * TITLE_MARGIN).max(40.0);
        let w = text_size(text, font).0;
        if w <= avail {
            return Title { lines: vec![text.to_string()], font };
        }
        if avail / w >= MIN_SHRINK {
            return Title { lines: vec![text.to_string()], font: font * avail / w };
        }
        let Some((a, b)) = best_break(text, font) else {
            // One long word: shrink it to fit.
            return Title { lines: vec![text.to_string()], font: font * avail / w };
        };
        let widest = text_size(&a, font).0.max(text_size(&b, font).0);
        let font = if widest <= avail { font } else { font * avail / widest };
        Title { lines: vec![a, b], font }
    }

    /// Vertical distance between the tops of two lines.
    fn pitch(&self) -> f64 {
        text_size("Ág", self.font).1.max(self.font) + LINE_GAP * self.font
    }

    /// Height of the drawn title (0 for an empty one), logical pixels.
    pub fn height(&self) -> f64 {
        match self.lines.as_slice() {
            [] => 0.0,
            [one] => text_size(one, self.font).1,
            [.., last] => self.pitch() * (self.lines.len() - 1) as f64 + text_size(last, self.font).1,
        }
    }

    /// Width of the widest line, logical pixels.
    #[cfg(test)]
    pub fn width(&self) -> f64 {
        self.lines.iter().map(|l| text_size(l, self.font).0).fold(0.0, f64::max)
    }

    /// Draws the lines centred on `centre_x`, the first with its top at `top` (logical).
    pub fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        centre_x: f64,
        top: f64,
        ink: Ink,
    ) -> DrawResult<DB> {
        for (i, line) in self.lines.iter().enumerate() {
            let pos = (ink.p(centre_x), ink.p(top + self.pitch() * i as f64));
            ink.label(root, line, self.font, INK, (HPos::Center, VPos::Top), false, pos)?;
        }
        Ok(())
    }
}

/// The two lines of `text` split at the space that balances them best, a break at
/// punctuation counting as slightly better; `None` without a space.
fn best_break(text: &str, font: f64) -> Option<(String, String)> {
    let mut best: Option<(f64, String, String)> = None;
    for (i, c) in text.char_indices() {
        if c != ' ' {
            continue;
        }
        let (a, b) = (text[..i].trim_end(), text[i + 1..].trim_start());
        if a.is_empty() || b.is_empty() {
            continue;
        }
        let widest = text_size(a, font).0.max(text_size(b, font).0);
        let natural = a.ends_with([':', ',', ';']) || b.starts_with(['(', '·', '—', '–']);
        let score = if natural { widest * 0.9 } else { widest };
        if best.as_ref().is_none_or(|x| score < x.0) {
            best = Some((score, a.to_string(), b.to_string()));
        }
    }
    best.map(|(_, a, b)| (a, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    const LONG: &str =
        "Fig. 6-robot: 9×9 robot, λ = 13: MMQ vs Q-learning (points: 6 below −60 cut) and a little more";

    #[test]
    fn short_titles_are_left_alone() {
        let t = Title::fit("Effect of the delay", 800.0, 24.0);
        assert_eq!(t.lines, vec!["Effect of the delay".to_string()]);
        assert_eq!(t.font, 24.0);
        assert_eq!(t.height(), text_size("Effect of the delay", 24.0).1);
    }

    #[test]
    fn long_titles_wrap_and_fit() {
        let t = Title::fit(LONG, 800.0, 24.0);
        assert_eq!(t.lines.len(), 2, "{t:?}");
        assert!(t.width() <= 800.0 - 2.0 * TITLE_MARGIN, "{}", t.width());
        assert_eq!(t.lines.join(" "), LONG);
        assert!(t.height() > 1.8 * text_size("A", t.font).1);
        // A break at punctuation wins over a slightly more balanced one.
        assert!(t.lines[0].ends_with(':') || t.lines[1].starts_with('('), "{t:?}");
        // A narrow figure shrinks the lines as well.
        let t = Title::fit(LONG, 400.0, 24.0);
        assert!(t.width() <= 400.0 - 2.0 * TITLE_MARGIN && t.font < 24.0, "{t:?}");
        let t = Title::fit(&"x".repeat(200), 400.0, 24.0);
        assert_eq!(t.lines.len(), 1);
        assert!(t.width() <= 400.0 - 2.0 * TITLE_MARGIN + 1.0, "{}", t.width());
    }

    /// First and last inked column and last inked row of the title band of a line chart
    /// (from the top down to just above the plot frame), and the image width.
    fn title_ink(chart: &crate::LineChart) -> ((usize, usize, usize), usize) {
        use crate::render::{Figure, render_rgb};
        let (w, h) = chart.size();
        let rgb = render_rgb(chart, (w, h)).unwrap();
        let band = (12.0 + Title::fit(&chart.title, f64::from(w), 24.0).height() + 6.0) as usize;
        let inked = |x: usize, y: usize| rgb[(y * w as usize + x) * 3..][..3].iter().any(|&v| v < 200);
        let cols: Vec<usize> = (0..w as usize).filter(|&x| (0..band).any(|y| inked(x, y))).collect();
        let last_row = (0..band).rev().find(|&y| (0..w as usize).any(|x| inked(x, y))).unwrap();
        ((cols[0], *cols.last().unwrap(), last_row), w as usize)
    }

    #[test]
    fn a_long_title_is_drawn_inside_the_image() {
        let chart = crate::LineChart::new(LONG, "step", "reward");
        let ((first, last, bottom), w) = title_ink(&chart);
        assert!(first >= 12 && last + 12 <= w, "title ink spans columns {first}..={last} of {w}");
        // On two lines: the ink reaches well below one line.
        let ((_, _, one_line), _) = title_ink(&crate::LineChart::new("Short", "step", "reward"));
        assert!(bottom > one_line + 20, "{bottom} vs {one_line}");
    }

    #[test]
    fn slightly_long_titles_shrink_on_one_line() {
        let base = text_size("A title", 24.0).0;
        let text = "A title ".repeat(((800.0 - 2.0 * TITLE_MARGIN) / base) as usize);
        let t = Title::fit(&text, 800.0, 24.0);
        assert_eq!(t.lines.len(), 1, "{t:?}");
        assert!(t.font < 24.0 && t.font >= 24.0 * MIN_SHRINK);
    }
}
