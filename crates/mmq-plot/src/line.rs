//! Line charts: several series (optionally with a 95 % confidence band and markers, or
//! drawn as stems) and dashed horizontal reference lines, on a numeric, logarithmic or
//! categorical x axis, with a legend inside the plot where it hides no data and below
//! the chart otherwise (the plot keeps the figure's width).

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use crate::PlotError;
use crate::categories::CategoryLabels;
use crate::geometry::{clip_segment, decimate_band, decimate_line, min_max};
use crate::legend::{Entry, LegendBox, draw_legend};
use crate::render::{
    DrawResult, Figure, INK, Ink, PALETTE, REF_COLORS, fmt_log_tick, fmt_tick, log_ticks, nice_ticks,
    text_size, write_figure,
};
use crate::stroke::{MARKERS, draw_marker, draw_open_marker, stroke};
use crate::title::Title;

/// Figure size in pixels.
const SIZE: (u32, u32) = (800, 560);
/// Font sizes (plotters size units, logical pixels).
const TITLE_FONT: f64 = 24.0;
const DESC_FONT: f64 = 20.0;
const TICK_FONT: f64 = 17.0;

/// One curve of a [`LineChart`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Series {
    /// Legend entry (an empty name gives no entry).
    pub name: String,
    /// x values, in the unit of the chart's `x_label`.
    pub x: Vec<f64>,
    /// y values, one per x. Non-finite values leave a gap in the line.
    pub y: Vec<f64>,
    /// Lower and upper edge of a band drawn translucently behind the line (e.g. a 95 %
    /// confidence interval), one value each per x.
    pub band: Option<(Vec<f64>, Vec<f64>)>,
    /// Draw a marker at every point (for sparse x such as a sweep over λ).
    pub markers: bool,
    /// Draw each nonzero point as a stem from 0 with its marker on top, and no line (for
    /// sparse events such as rewards per step); zeros are left out.
    pub stems: bool,
    /// Draw the markers as outlines, so a filled marker of another series at the same
    /// place stays visible inside.
    pub open_markers: bool,
}

impl Series {
    /// A plain line.
    pub fn new(name: impl Into<String>, x: Vec<f64>, y: Vec<f64>) -> Self {
        Self { name: name.into(), x, y, ..Self::default() }
    }

    /// The same series with a band from `lower` to `upper`.
    pub fn with_band(mut self, lower: Vec<f64>, upper: Vec<f64>) -> Self {
        self.band = Some((lower, upper));
        self
    }

    /// The same series with markers.
    pub fn with_markers(mut self) -> Self {
        self.markers = true;
        self
    }

    /// The same series drawn as stems (see [`Series::stems`]).
    pub fn as_stems(mut self) -> Self {
        self.stems = true;
        self
    }

    /// The same series with outlined markers.
    pub fn with_open_markers(mut self) -> Self {
        self.open_markers = true;
        self
    }
}

/// A dashed horizontal line at `y` with a legend entry (e.g. "undelayed Q-learning = 1").
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RefLine {
    /// Legend entry.
    pub label: String,
    /// Height, in the unit of the chart's `y_label`.
    pub y: f64,
}

impl RefLine {
    /// A reference line.
    pub fn new(label: impl Into<String>, y: f64) -> Self {
        Self { label: label.into(), y }
    }
}

/// A line chart (800 × 560 px): series, bands, markers, reference lines, legend.
///
/// Labels should carry their units, e.g. `"mean delay λ (steps)"`. Colours follow the
/// Okabe–Ito colour-blind-safe palette in series order; markers also change shape per
/// series so the chart survives grey-scale printing.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LineChart {
    /// Title above the chart (may be empty).
    pub title: String,
    /// x-axis label with unit.
    pub x_label: String,
    /// y-axis label with unit.
    pub y_label: String,
    /// The curves, drawn in order (first at the bottom).
    pub series: Vec<Series>,
    /// Dashed horizontal reference lines.
    pub ref_lines: Vec<RefLine>,
    /// Fixed y range (lower, upper); `None` fits the data, bands and reference lines.
    /// Data outside a fixed range is clipped.
    pub y_range: Option<(f64, f64)>,
    /// Logarithmic x axis (non-positive x values are left out).
    pub x_log: bool,
    /// Names of categories at x = 1, 2, …: the x axis then has one tick per name,
    /// labelled by it (wrapped to its share of the width), instead of numbers.
    pub x_categories: Vec<String>,
}

impl LineChart {
    /// An empty chart with a title and axis labels.
    pub fn new(title: impl Into<String>, x_label: impl Into<String>, y_label: impl Into<String>) -> Self {
        Self { title: title.into(), x_label: x_label.into(), y_label: y_label.into(), ..Self::default() }
    }

    /// Writes `<base>.svg` and `<base>.png` (the directory must exist; `.svg`/`.png` are
    /// appended to the file name) and returns both paths. Points that a fixed y range
    /// cuts are named in the title ([`LineChart::title_marking_clipping`]).
    pub fn write(&self, base: &Path) -> Result<Vec<PathBuf>, PlotError> {
        let marked = self.title_marking_clipping();
        if marked != self.title {
            return write_figure(&LineChart { title: marked, ..self.clone() }, base);
        }
        write_figure(self, base)
    }

    /// x in plot space (log10 for a log axis), if drawable.
    fn px(&self, x: f64) -> Option<f64> {
        if !x.is_finite() {
            None
        } else if self.x_log {
            (x > 0.0).then(|| x.log10())
        } else {
            Some(x)
        }
    }

    fn prepare(&self) -> Prepared {
        let mut xs = Vec::new();
        let mut ys = Vec::new();
        let mut markers = false;
        for s in &self.series {
            markers |= s.markers || s.stems;
            if s.stems {
                ys.push(0.0);
            }
            for (i, (&x, &y)) in s.x.iter().zip(&s.y).enumerate() {
                let Some(x) = self.px(x) else { continue };
                let mut any = false;
                if y.is_finite() {
                    ys.push(y);
                    any = true;
                }
                if let Some((lo, hi)) = &s.band {
                    for v in [lo.get(i), hi.get(i)].into_iter().flatten() {
                        if v.is_finite() {
                            ys.push(*v);
                            any = true;
                        }
                    }
                }
                if any {
                    xs.push(x);
                }
            }
        }
        ys.extend(self.ref_lines.iter().map(|r| r.y).filter(|y| y.is_finite()));

        let n_cat = self.x_categories.len() as f64;
        let (x0, x1) = match min_max(&xs) {
            _ if n_cat > 0.0 => (0.5, n_cat + 0.5),
            None => (0.0, 1.0),
            Some((a, b)) if b - a <= 1e-12 * a.abs().max(1.0) => {
                if self.x_log {
                    (a - 0.5, a + 0.5)
                } else {
                    (a - a.abs().max(1.0) * 0.1, a + a.abs().max(1.0) * 0.1)
                }
            }
            Some((a, b)) => {
                let pad = if markers { 0.03 * (b - a) } else { 0.0 };
                (a - pad, b + pad)
            }
        };
        let (y0, y1) = match (self.y_range, min_max(&ys)) {
            (Some(r), _) => r,
            (None, None) => (0.0, 1.0),
            (None, Some((a, b))) if b - a <= 1e-12 * a.abs().max(1.0) => {
                let d = if a == 0.0 { 1.0 } else { a.abs() * 0.1 };
                (a - d, b + d)
            }
            (None, Some((a, b))) => (a - 0.05 * (b - a), b + 0.05 * (b - a)),
        };
        let (x_ticks, x_minor, x_step) = if n_cat > 0.0 {
            ((1..=self.x_categories.len()).map(|i| i as f64).collect(), Vec::new(), 1.0)
        } else if self.x_log {
            let (b, m) = log_ticks(x0, x1);
            (b, m, f64::NAN)
        } else {
            let (t, s) = nice_ticks(x0, x1, 7);
            (t, Vec::new(), s)
        };
        let (y_ticks, y_step) = nice_ticks(y0, y1, 6);
        Prepared { x: (x0, x1), y: (y0, y1), x_ticks, x_minor, x_step, y_ticks, y_step, empty: xs.is_empty() }
    }

    fn x_tick_label(&self, p: &Prepared, v: f64) -> String {
        if self.x_log { fmt_log_tick(v) } else { fmt_tick(v, p.x_step) }
    }

    /// Polylines of a series in plot space, split at missing values and clipped to the
    /// plot rectangle.
    fn lines(&self, s: &Series, p: &Prepared) -> Vec<Vec<(f64, f64)>> {
        if s.stems {
            return Vec::new();
        }
        let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
        let mut prev: Option<(f64, f64)> = None;
        for (&x, &y) in s.x.iter().zip(&s.y) {
            let pt = match self.px(x) {
                Some(x) if y.is_finite() => Some((x, y)),
                _ => None,
            };
            match (prev, pt) {
                (Some(a), Some(b)) => {
                    if let Some((c, d)) = clip_segment(a, b, p.x, p.y) {
                        match out.last_mut() {
                            Some(line) if line.last() == Some(&c) => line.push(d),
                            _ => out.push(vec![c, d]),
                        }
                    }
                }
                (None, Some(b)) if inside(b, p) => out.push(vec![b]),
                _ => {}
            }
            prev = pt;
        }
        out.into_iter().map(|l| decimate_line(l, p.x)).collect()
    }

    /// Band polygons in plot space, split at missing values, clamped to the y range.
    fn bands(&self, s: &Series, p: &Prepared) -> Vec<Vec<(f64, f64)>> {
        let Some((lo, hi)) = &s.band else { return Vec::new() };
        let mut runs: Vec<Vec<(f64, f64, f64)>> = vec![Vec::new()];
        for ((&x, &l), &h) in s.x.iter().zip(lo).zip(hi) {
            match self.px(x) {
                Some(x) if l.is_finite() && h.is_finite() && x >= p.x.0 && x <= p.x.1 => {
                    let c = |v: f64| v.clamp(p.y.0, p.y.1);
                    runs.last_mut().expect("non-empty").push((x, c(l.min(h)), c(l.max(h))));
                }
                _ => runs.push(Vec::new()),
            }
        }
        runs.into_iter()
            .map(|r| decimate_band(r, p.x))
            .filter(|r| r.len() >= 2)
            .map(|r| {
                r.iter().map(|&(x, _, h)| (x, h)).chain(r.iter().rev().map(|&(x, l, _)| (x, l))).collect()
            })
            .collect()
    }
}

impl LineChart {
    /// Stems of a series in plot space: (x, foot, top), the foot at 0 and both clamped to
    /// the y range; the top is the point itself unless the range cuts it.
    fn stems(&self, s: &Series, p: &Prepared) -> Vec<(f64, f64, f64)> {
        if !s.stems {
            return Vec::new();
        }
        let c = |v: f64| v.clamp(p.y.0, p.y.1);
        s.x.iter()
            .zip(&s.y)
            .filter_map(|(&x, &y)| Some((self.px(x)?, y)))
            .filter(|&(x, y)| y.is_finite() && y != 0.0 && x >= p.x.0 && x <= p.x.1)
            .map(|(x, y)| (x, c(0.0), c(y)))
            .collect()
    }
}

/// A linear axis in plot space with the ticks chosen here (plotters' own f64 axis picks
/// its ticks and cannot be labelled by a formatter once they are given).
struct Axis {
    range: (f64, f64),
    bold: Vec<f64>,
    light: Vec<f64>,
}

impl Ranged for Axis {
    type FormatOption = plotters::coord::ranged1d::DefaultFormatting;
    type ValueType = f64;

    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        let f = (v - self.range.0) / (self.range.1 - self.range.0);
        limit.0 + (f64::from(limit.1 - limit.0) * f).round() as i32
    }

    fn key_points<H: plotters::coord::ranged1d::KeyPointHint>(&self, hint: H) -> Vec<f64> {
        if hint.weight().allow_light_points() { self.light.clone() } else { self.bold.clone() }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.range.0..self.range.1
    }
}

/// Ranges, ticks and whether there is anything to draw.
struct Prepared {
    x: (f64, f64),
    y: (f64, f64),
    x_ticks: Vec<f64>,
    x_minor: Vec<f64>,
    x_step: f64,
    y_ticks: Vec<f64>,
    y_step: f64,
    empty: bool,
}

fn inside((x, y): (f64, f64), p: &Prepared) -> bool {
    x >= p.x.0 && x <= p.x.1 && y >= p.y.0 && y <= p.y.1
}

/// Where everything of a line chart goes, in logical pixels.
struct Plan {
    title: Title,
    title_h: f64,
    margin_left: f64,
    margin_right: f64,
    /// Plot rectangle.
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    y_area: f64,
    x_area: f64,
    tick_w: f64,
    /// Height of the x tick labels.
    tick_h: f64,
    categories: CategoryLabels,
    entries: Vec<Entry>,
    legend: Option<LegendBox>,
    /// Height added below the chart for a legend that found no room inside.
    extra_h: f64,
}

/// Gap between a tick mark's end and its label; tick length.
const TICK_LEN: f64 = 6.0;
const TICK_GAP: f64 = 4.0;
const MARGIN_TOP: f64 = 8.0;
const MARGIN_BOTTOM: f64 = 8.0;
/// Space between the x-axis title and a legend below it.
const LEGEND_GAP: f64 = 6.0;

impl LineChart {
    fn color(i: usize) -> RGBColor {
        PALETTE[i % PALETTE.len()]
    }

    fn entries(&self) -> Vec<Entry> {
        let mut entries = Vec::new();
        for (i, s) in self.series.iter().enumerate() {
            if !s.name.is_empty() {
                entries.push(Entry::Series {
                    name: s.name.clone(),
                    color: Self::color(i),
                    band: s.band.is_some(),
                    marker: (s.markers || s.stems).then_some(MARKERS[i % MARKERS.len()]),
                    dashed: i >= PALETTE.len(),
                    stem: s.stems,
                    open: s.open_markers,
                });
            }
        }
        for (i, r) in self.ref_lines.iter().enumerate() {
            if !r.label.is_empty() {
                entries.push(Entry::Ref { label: r.label.clone(), color: REF_COLORS[i % REF_COLORS.len()] });
            }
        }
        entries
    }

    fn plan(&self, p: &Prepared) -> Plan {
        let (w, h) = (f64::from(SIZE.0), f64::from(SIZE.1));
        let title = Title::fit(&self.title, w, TITLE_FONT);
        let title_h = if title.lines.is_empty() { 6.0 } else { title.height() + 22.0 };
        let tick_w =
            p.y_ticks.iter().map(|&v| text_size(&fmt_tick(v, p.y_step), TICK_FONT).0).fold(0.0, f64::max);
        let y_desc = if self.y_label.is_empty() { 0.0 } else { text_size(&self.y_label, DESC_FONT).1 + 10.0 };
        let x_desc = if self.x_label.is_empty() { 0.0 } else { text_size(&self.x_label, DESC_FONT).1 + 10.0 };
        let y_area = TICK_LEN + TICK_GAP + tick_w + y_desc + 4.0;
        let margin_left = 10.0;
        let margin_right = 30.0;
        let slot_w = (w - margin_right - margin_left - y_area) / self.x_categories.len().max(1) as f64 - 10.0;
        let categories = CategoryLabels::fit(&self.x_categories, slot_w, TICK_FONT);
        let tick_h =
            if self.x_categories.is_empty() { text_size("0", TICK_FONT).1 } else { categories.height() };
        let x_area = TICK_LEN + TICK_GAP + tick_h + x_desc + 4.0;
        let entries = self.entries();
        let mut plan = Plan {
            title,
            title_h,
            margin_left,
            margin_right,
            x0: margin_left + y_area,
            x1: w - margin_right,
            y0: title_h + MARGIN_TOP,
            y1: h - MARGIN_BOTTOM - x_area,
            y_area,
            x_area,
            tick_w,
            tick_h,
            categories,
            entries,
            legend: None,
            extra_h: 0.0,
        };
        if plan.entries.is_empty() {
            return plan;
        }
        let one_column = LegendBox::sized(&plan.entries, 1);
        let (lw, lh) = (one_column.w, one_column.h);

        // Data samples in logical pixels of the plot rectangle.
        let to_px = |(x, y): (f64, f64)| {
            (
                plan.x0 + (x - p.x.0) / (p.x.1 - p.x.0) * (plan.x1 - plan.x0),
                plan.y1 - (y - p.y.0) / (p.y.1 - p.y.0) * (plan.y1 - plan.y0),
            )
        };
        let mut samples = Vec::new();
        for s in &self.series {
            for line in self.lines(s, p) {
                samples.push(to_px(line[0]));
                for seg in line.windows(2) {
                    let (a, b) = (to_px(seg[0]), to_px(seg[1]));
                    let n = ((b.0 - a.0).hypot(b.1 - a.1) / 3.0).ceil().clamp(1.0, 400.0) as usize;
                    for k in 1..=n {
                        let t = k as f64 / n as f64;
                        samples.push((a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1)));
                    }
                }
            }
            for poly in self.bands(s, p) {
                samples.extend(poly.iter().map(|&q| to_px(q)));
            }
            if s.markers {
                for (&x, &y) in s.x.iter().zip(&s.y) {
                    if let Some(x) = self.px(x)
                        && inside((x, y), p)
                    {
                        samples.push(to_px((x, y)));
                    }
                }
            }
            for (x, foot, top) in self.stems(s, p) {
                let (a, b) = (to_px((x, foot)), to_px((x, top)));
                let n = ((b.1 - a.1).abs() / 3.0).ceil().clamp(1.0, 400.0) as usize;
                samples.extend((0..=n).map(|k| (a.0, a.1 + (b.1 - a.1) * k as f64 / n as f64)));
            }
        }
        for r in &self.ref_lines {
            if r.y.is_finite() && r.y >= p.y.0 && r.y <= p.y.1 {
                for k in 0..=200 {
                    samples.push(to_px((p.x.0 + (p.x.1 - p.x.0) * f64::from(k) / 200.0, r.y)));
                }
            }
        }
        let inset = 10.0;
        let xs = [plan.x1 - inset - lw, plan.x0 + inset, (plan.x0 + plan.x1 - lw) / 2.0];
        let ys = [plan.y0 + inset, plan.y1 - inset - lh, (plan.y0 + plan.y1 - lh) / 2.0];
        // Corners first, then edge middles; never the centre.
        let order = [(0, 0), (1, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 0), (2, 1)];
        let score = |(x, y): (f64, f64)| {
            let m = 4.0;
            samples
                .iter()
                .filter(|s| s.0 >= x - m && s.0 <= x + lw + m && s.1 >= y - m && s.1 <= y + lh + m)
                .count()
        };
        let fits = lw < (plan.x1 - plan.x0) * 0.6 && lh < (plan.y1 - plan.y0) * 0.8;
        let best = order.iter().map(|&(i, j)| (xs[i], ys[j])).map(|c| (score(c), c)).min_by_key(|&(s, _)| s);
        match best {
            Some((0, (x, y))) if fits => plan.legend = Some(LegendBox { x, y, ..one_column }),
            _ => {
                // No empty spot inside: below the chart, in as many columns as fit, so the
                // plot keeps the figure's width.
                let b = LegendBox::fitting(&plan.entries, w - 2.0 * margin_left);
                let y = h - MARGIN_BOTTOM + LEGEND_GAP;
                plan.legend = Some(LegendBox { x: (w - b.w) / 2.0, y, ..b });
                plan.extra_h = (LEGEND_GAP + b.h).ceil();
            }
        }
        plan
    }
}

impl Figure for LineChart {
    fn validate(&self) -> Result<(), String> {
        for (i, s) in self.series.iter().enumerate() {
            let name =
                if s.name.is_empty() { format!("series {}", i + 1) } else { format!("series `{}`", s.name) };
            if s.x.len() != s.y.len() {
                return Err(format!("{name}: x has {} values but y has {}", s.x.len(), s.y.len()));
            }
            if let Some((lo, hi)) = &s.band
                && (lo.len() != s.x.len() || hi.len() != s.x.len())
            {
                return Err(format!(
                    "{name}: the band has {} lower and {} upper values but x has {}",
                    lo.len(),
                    hi.len(),
                    s.x.len()
                ));
            }
        }
        if let Some((lo, hi)) = self.y_range
            && !(lo.is_finite() && hi.is_finite() && lo < hi)
        {
            return Err(format!("y_range ({lo}, {hi}) must be two finite numbers, lower < upper"));
        }
        Ok(())
    }

    fn size(&self) -> (u32, u32) {
        let extra = self.plan(&self.prepare()).extra_h;
        (SIZE.0, SIZE.1 + extra.ceil() as u32)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, ink: Ink) -> DrawResult<DB> {
        root.fill(&WHITE)?;
        let p = self.prepare();
        let plan = self.plan(&p);

        plan.title.draw(root, f64::from(SIZE.0) / 2.0, 12.0, ink)?;

        let x_spec = Axis { range: p.x, bold: p.x_ticks.clone(), light: p.x_minor.clone() };
        let y_spec = Axis { range: p.y, bold: p.y_ticks.clone(), light: Vec::new() };
        let mut chart = ChartBuilder::on(root)
            .margin_top(ink.p(plan.title_h + MARGIN_TOP))
            .margin_left(ink.p(plan.margin_left))
            .margin_right(ink.p(plan.margin_right))
            .margin_bottom(ink.p(MARGIN_BOTTOM + plan.extra_h))
            .x_label_area_size(ink.p(plan.x_area))
            .y_label_area_size(ink.p(plan.y_area))
            .build_cartesian_2d(x_spec, y_spec)?;
        // Grid lines only: ticks, labels and axis titles are drawn below, by `Ink::label`.
        chart
            .configure_mesh()
            .disable_axes()
            .label_style(ink.font(TICK_FONT).color(&TRANSPARENT))
            .bold_line_style(RGBColor(0, 0, 0).mix(0.12).stroke_width(ink.pu(1.0)))
            .light_line_style(RGBColor(0, 0, 0).mix(0.05).stroke_width(ink.pu(1.0)))
            .draw()?;

        // Bands first, then reference lines, then lines, then markers on top.
        for (i, s) in self.series.iter().enumerate() {
            for poly in self.bands(s, &p) {
                chart.draw_series(std::iter::once(Polygon::new(poly, Self::color(i).mix(0.22).filled())))?;
            }
        }
        for (i, r) in self.ref_lines.iter().enumerate() {
            if r.y.is_finite() && r.y >= p.y.0 && r.y <= p.y.1 {
                let c = REF_COLORS[i % REF_COLORS.len()];
                chart.draw_series(DashedLineSeries::new(
                    vec![(p.x.0, r.y), (p.x.1, r.y)],
                    ink.p(9.0),
                    ink.p(6.0),
                    c.stroke_width(ink.pu(1.8)),
                ))?;
            }
        }
        for (i, s) in self.series.iter().enumerate() {
            let dash = (i >= PALETTE.len()).then_some((12.0, 5.0));
            for line in self.lines(s, &p) {
                if line.len() >= 2 {
                    let px: Vec<(i32, i32)> = line.iter().map(|q| chart.backend_coord(q)).collect();
                    stroke(root, &px, Self::color(i), 2.5, dash, ink)?;
                }
            }
        }
        if self.series.iter().any(|s| s.stems) && p.y.0 < 0.0 && p.y.1 > 0.0 {
            let zero = [chart.backend_coord(&(p.x.0, 0.0)), chart.backend_coord(&(p.x.1, 0.0))];
            root.draw(&PathElement::new(zero.to_vec(), INK.mix(0.5).stroke_width(ink.pu(1.0))))?;
        }
        for (i, s) in self.series.iter().enumerate() {
            for (x, foot, top) in self.stems(s, &p) {
                let px = [chart.backend_coord(&(x, foot)), chart.backend_coord(&(x, top))];
                root.draw(&PathElement::new(px.to_vec(), Self::color(i).stroke_width(ink.pu(1.8))))?;
            }
        }
        for (i, s) in self.series.iter().enumerate() {
            let lines = self.lines(s, &p);
            // A lone point between gaps is invisible as a line: give it a marker.
            // Stems: a marker on every drawn stem whose top the y range does not cut.
            let pts: Vec<(f64, f64)> = if s.markers || s.stems {
                s.x.iter()
                    .zip(&s.y)
                    .filter_map(|(&x, &y)| Some((self.px(x)?, y)))
                    .filter(|&q| q.1.is_finite() && inside(q, &p) && !(s.stems && q.1 == 0.0))
                    .collect()
            } else {
                lines.into_iter().filter(|l| l.len() == 1).map(|l| l[0]).collect()
            };
            let (m, color) = (MARKERS[i % MARKERS.len()], Self::color(i));
            for q in pts {
                let at = chart.backend_coord(&q);
                if s.open_markers {
                    draw_open_marker(root, m, at, ink.p(6.0), color, ink)?;
                } else {
                    draw_marker(root, m, at, ink.p(if s.stems { 4.5 } else { 5.0 }), color, ink)?;
                }
            }
        }

        // Frame, ticks, tick labels, axis titles.
        let (xr, yr) = chart.plotting_area().get_pixel_range();
        let (fx0, fx1, fy0, fy1) = (xr.start, xr.end - 1, yr.start, yr.end - 1);
        root.draw(&Rectangle::new([(fx0, fy0), (fx1, fy1)], INK.stroke_width(ink.pu(1.2))))?;
        let tick = INK.stroke_width(ink.pu(1.2));
        let tl = ink.p(TICK_LEN);
        for (i, &v) in p.x_ticks.iter().enumerate() {
            let x = chart.backend_coord(&(v, p.y.0)).0;
            root.draw(&PathElement::new(vec![(x, fy1), (x, fy1 + tl)], tick))?;
            let pos = (x, fy1 + tl + ink.p(TICK_GAP));
            if let Some(lines) = plan.categories.lines.get(i) {
                let c = &plan.categories;
                for (k, line) in lines.iter().enumerate() {
                    let pos = (x, pos.1 + ink.p(c.pitch() * k as f64));
                    ink.label(root, line, c.font, INK, (HPos::Center, VPos::Top), false, pos)?;
                }
                continue;
            }
            ink.label(
                root,
                &self.x_tick_label(&p, v),
                TICK_FONT,
                INK,
                (HPos::Center, VPos::Top),
                false,
                pos,
            )?;
        }
        for &v in &p.x_minor {
            let x = chart.backend_coord(&(v, p.y.0)).0;
            root.draw(&PathElement::new(vec![(x, fy1), (x, fy1 + tl / 2)], tick))?;
        }
        for &v in &p.y_ticks {
            let y = chart.backend_coord(&(p.x.0, v)).1;
            root.draw(&PathElement::new(vec![(fx0 - tl, y), (fx0, y)], tick))?;
            let pos = (fx0 - tl - ink.p(TICK_GAP), y);
            ink.label(root, &fmt_tick(v, p.y_step), TICK_FONT, INK, (HPos::Right, VPos::Center), false, pos)?;
        }
        let xy = fy1 + tl + ink.p(TICK_GAP + plan.tick_h + 10.0);
        ink.label(
            root,
            &self.x_label,
            DESC_FONT,
            INK,
            (HPos::Center, VPos::Top),
            false,
            ((fx0 + fx1) / 2, xy),
        )?;
        let desc_h = text_size(&self.y_label, DESC_FONT).1;
        let yx = fx0 - tl - ink.p(TICK_GAP + plan.tick_w + 10.0 + desc_h / 2.0);
        ink.label(
            root,
            &self.y_label,
            DESC_FONT,
            INK,
            (HPos::Center, VPos::Center),
            true,
            (yx, (fy0 + fy1) / 2),
        )?;

        if p.empty && self.ref_lines.is_empty() {
            let c = ((fx0 + fx1) / 2, (fy0 + fy1) / 2);
            ink.label(
                root,
                "no data",
                DESC_FONT,
                RGBColor(120, 120, 120),
                (HPos::Center, VPos::Center),
                false,
                c,
            )?;
        }
        if let Some(b) = plan.legend {
            draw_legend(root, &plan.entries, b, ink)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::COLUMNS;

    #[test]
    fn long_lines_keep_their_envelope() {
        let n = 100_000;
        let x: Vec<f64> = (0..n).map(f64::from).collect();
        let y: Vec<f64> = (0..n).map(|i| if i == 4321 { 9.0 } else { f64::from(i % 7) }).collect();
        let c = LineChart { series: vec![Series::new("a", x, y)], ..LineChart::default() };
        let p = c.prepare();
        let l = c.lines(&c.series[0], &p);
        assert_eq!(l.len(), 1);
        assert!(l[0].len() < 4 * COLUMNS as usize + 4, "{}", l[0].len());
        assert!(l[0].contains(&(4321.0, 9.0)));
        assert_eq!(l[0][0], (0.0, 0.0));
        assert_eq!(*l[0].last().unwrap(), (f64::from(n - 1), f64::from((n - 1) % 7)));
        assert!(l[0].windows(2).all(|w| w[0].0 <= w[1].0));
    }

    #[test]
    fn lines_split_at_gaps_and_range() {
        let c = LineChart {
            series: vec![Series::new("a", vec![0.0, 1.0, 2.0, 3.0, 4.0], vec![0.0, 1.0, f64::NAN, 1.0, 5.0])],
            y_range: Some((0.0, 2.0)),
            ..LineChart::default()
        };
        let p = c.prepare();
        let l = c.lines(&c.series[0], &p);
        assert_eq!(l.len(), 2);
        assert_eq!(l[0], vec![(0.0, 0.0), (1.0, 1.0)]);
        assert_eq!(l[1], vec![(3.0, 1.0), (3.25, 2.0)]);
    }

    #[test]
    fn stems_leave_zeros_out_and_stand_on_zero() {
        let c = LineChart {
            series: vec![Series::new("r", vec![1.0, 2.0, 3.0, 4.0], vec![0.0, 10.0, 0.0, -1.0]).as_stems()],
            ..LineChart::default()
        };
        let p = c.prepare();
        assert!(c.lines(&c.series[0], &p).is_empty());
        assert_eq!(c.stems(&c.series[0], &p), vec![(2.0, 0.0, 10.0), (4.0, 0.0, -1.0)]);
    }

    #[test]
    fn a_legend_without_room_inside_goes_below_and_keeps_the_width() {
        let x: Vec<f64> = (0..50).map(f64::from).collect();
        let mut c = LineChart::new("t", "x", "y");
        for k in 0..6 {
            let y = x.iter().map(|v| (v * 0.3 + f64::from(k)).sin()).collect();
            c.series.push(Series::new(format!("a rather long series name number {k}"), x.clone(), y));
        }
        let p = c.prepare();
        let plan = c.plan(&p);
        let b = plan.legend.unwrap();
        assert!(plan.extra_h > 0.0 && b.y > plan.y1, "{b:?}");
        assert_eq!(plan.x1, f64::from(SIZE.0) - 30.0);
        assert!(b.x >= 0.0 && b.x + b.w <= f64::from(SIZE.0));
        assert_eq!(c.size().1, SIZE.1 + plan.extra_h as u32);
    }

    #[test]
    fn categories_get_one_tick_each() {
        let mut c = LineChart::new("t", "setting", "y");
        c.x_categories =
            vec!["grid · poisson:13".into(), "robot · exponential:48s · profile=realistic".into()];
        c.series.push(Series::new("a", vec![1.0, 2.0], vec![3.0, 4.0]).with_markers());
        let p = c.prepare();
        assert_eq!(p.x_ticks, vec![1.0, 2.0]);
        assert_eq!(p.x, (0.5, 2.5));
        let plan = c.plan(&p);
        assert_eq!(plan.categories.lines[0], vec!["grid · poisson:13"]);
    }
}
