//! The colour scale of grid heat maps: its domain and ticks (linear, or log with minor
//! ticks), and the vertical colour bar drawn beside the map.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use crate::grid::{LABEL_FONT, TICK_FONT};
use crate::render::{
    DrawResult, INK, Ink, fmt_log_tick, fmt_tick, log_ticks, nice_ticks, text_size, viridis,
};

/// Width of the colour bar itself, logical pixels.
pub(crate) const BAR_W: f64 = 24.0;

/// A colour scale: domain, log or linear, and its ticks.
pub(crate) struct Scale {
    pub(crate) lo: f64,
    pub(crate) hi: f64,
    pub(crate) log: bool,
    pub(crate) ticks: Vec<(f64, String)>,
    /// Unlabelled minor ticks (log scale: 2…9 × 10^k), in scale units.
    pub(crate) minor: Vec<f64>,
}

impl Scale {
    pub(crate) fn fit(values: &[f64], log: bool) -> Scale {
        let pos: Vec<f64> = values.iter().copied().filter(|&v| v > 0.0).collect();
        if log && !pos.is_empty() {
            let lo = pos.iter().copied().fold(f64::INFINITY, f64::min).log10();
            let hi = pos.iter().copied().fold(f64::NEG_INFINITY, f64::max).log10();
            let (lo, hi) = if hi - lo < 1e-9 { (lo - 0.5, hi + 0.5) } else { (lo, hi) };
            let (major, minor) = log_ticks(lo, hi);
            let ticks = major.into_iter().map(|l| (l, fmt_log_tick(l))).collect();
            return Scale { lo, hi, log: true, ticks, minor };
        }
        let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let (lo, hi) = if lo > hi {
            (0.0, 1.0)
        } else if hi - lo <= 1e-12 * lo.abs().max(1.0) {
            let d = (lo.abs() * 0.1).max(0.5);
            (lo - d, hi + d)
        } else {
            (lo, hi)
        };
        let (t, step) = nice_ticks(lo, hi, 5);
        Scale {
            lo,
            hi,
            log: false,
            ticks: t.into_iter().map(|v| (v, fmt_tick(v, step))).collect(),
            minor: vec![],
        }
    }

    pub(crate) fn probability() -> Scale {
        let (t, step) = nice_ticks(0.0, 1.0, 5);
        let ticks = t.into_iter().map(|v| (v, fmt_tick(v, step))).collect();
        Scale { lo: 0.0, hi: 1.0, log: false, ticks, minor: vec![] }
    }

    /// Position of a value in [0, 1] along the scale (ticks are given in scale units:
    /// log10 for a log scale).
    pub(crate) fn t_of_tick(&self, v: f64) -> f64 {
        (v - self.lo) / (self.hi - self.lo)
    }

    pub(crate) fn t(&self, v: f64) -> f64 {
        let u = if self.log { if v > 0.0 { v.log10() } else { self.lo } } else { v };
        ((u - self.lo) / (self.hi - self.lo)).clamp(0.0, 1.0)
    }
}

/// Width of a colour bar with its tick labels and rotated label.
pub(crate) fn colorbar_width(s: &Scale, label: &str) -> f64 {
    let tick_w = s.ticks.iter().map(|(_, l)| text_size(l, TICK_FONT).0).fold(0.0, f64::max);
    let label_h = if label.is_empty() { 0.0 } else { text_size(label, LABEL_FONT).1 + 10.0 };
    BAR_W + 12.0 + tick_w + 10.0 + label_h
}

/// A vertical colour bar from `y0` to `y1` (logical) at the panel's left edge.
pub(crate) fn draw_colorbar<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    x: f64,
    (y0, y1): (f64, f64),
    s: &Scale,
    label: &str,
    ink: Ink,
) -> DrawResult<DB> {
    let (bx0, bx1) = (ink.p(x), ink.p(x + BAR_W));
    let (by0, by1) = (ink.p(y0), ink.p(y1));
    let n = (by1 - by0).max(1);
    for i in 0..n {
        // Row i from the top: t = 1 at the top.
        let t = 1.0 - (f64::from(i) + 0.5) / f64::from(n);
        root.draw(&Rectangle::new([(bx0, by0 + i), (bx1, by0 + i + 1)], viridis(t).filled()))?;
    }
    root.draw(&Rectangle::new([(bx0, by0), (bx1, by1)], INK.stroke_width(ink.pu(1.0))))?;
    for &v in &s.minor {
        let y = ink.p(y1 - s.t_of_tick(v) * (y1 - y0));
        root.draw(&PathElement::new(vec![(bx1, y), (bx1 + ink.p(3.0), y)], INK.stroke_width(ink.pu(1.0))))?;
    }
    let mut tick_w: f64 = 0.0;
    for (v, text) in &s.ticks {
        let t = s.t_of_tick(*v);
        if !(-1e-9..=1.0 + 1e-9).contains(&t) {
            continue;
        }
        let y = ink.p(y1 - t * (y1 - y0));
        root.draw(&PathElement::new(vec![(bx1, y), (bx1 + ink.p(6.0), y)], INK.stroke_width(ink.pu(1.0))))?;
        ink.label(root, text, TICK_FONT, INK, (HPos::Left, VPos::Center), false, (bx1 + ink.p(10.0), y))?;
        tick_w = tick_w.max(text_size(text, TICK_FONT).0);
    }
    if !label.is_empty() {
        let lh = text_size(label, LABEL_FONT).1;
        let lx = x + BAR_W + 12.0 + tick_w + 10.0 + lh / 2.0;
        let pos = (ink.p(lx), ink.p((y0 + y1) / 2.0));
        ink.label(root, label, LABEL_FONT, INK, (HPos::Center, VPos::Center), true, pos)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_scale_maps_decades_evenly() {
        let s = Scale::fit(&[1.0, 10.0, 100.0, 0.0], true);
        assert!(s.log);
        assert_eq!(s.t(1.0), 0.0);
        assert!((s.t(10.0) - 0.5).abs() < 1e-12);
        assert_eq!(s.t(0.0), 0.0);
        assert_eq!(s.t(1000.0), 1.0);
        let s = Scale::fit(&[0.0, 0.0], true);
        assert!(!s.log);
        assert!(s.lo < s.hi);
    }
}
