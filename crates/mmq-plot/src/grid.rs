//! Figures drawn on the map of a grid world: a per-cell heat map with a colour bar
//! ([`GridHeatmap`], e.g. visit counts), a deterministic policy as arrows
//! ([`PolicyArrows`]) and a probabilistic policy as four coloured wedges per cell
//! ([`ActionProbabilities`]).
//!
//! Row 0 of the map is drawn at the top, so `N` points up. Rows and columns are numbered
//! from 1 along the edges, as the paper names states "(row, column)".

use std::path::{Path, PathBuf};

use mmq_core::{Cell, World};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use crate::PlotError;
use crate::colorbar::{Scale, colorbar_width, draw_colorbar};
use crate::render::{
    BLOCKED, DrawResult, Figure, INK, Ink, NO_DATA, PALETTE, contrast, text_size, tint, viridis, write_figure,
};
use crate::title::{TITLE_MARGIN, Title};

/// Bit of action N (up) in a [`PolicyArrows`] cell.
pub const ARROW_N: u8 = 1 << 0;
/// Bit of action E (right).
pub const ARROW_E: u8 = 1 << 1;
/// Bit of action S (down).
pub const ARROW_S: u8 = 1 << 2;
/// Bit of action W (left).
pub const ARROW_W: u8 = 1 << 3;

/// The arrow bitset of a set of action indices (0 = N, 1 = E, 2 = S, 3 = W, the order of
/// `mmq_core::Move::ALL`); indices above 3 are ignored.
pub fn arrow_bits(actions: impl IntoIterator<Item = usize>) -> u8 {
    actions.into_iter().filter(|&a| a < 4).fold(0, |b, a| b | (1 << a))
}

/// Longest side of the map in logical pixels.
const MAP_SIDE: f64 = 560.0;
const TITLE_FONT: f64 = 24.0;
/// A long title widens a grid figure up to this width (that of a line chart), then wraps.
const TITLE_MAX_W: f64 = 800.0;
pub(crate) const LABEL_FONT: f64 = 18.0;
pub(crate) const TICK_FONT: f64 = 16.0;
const LEGEND_FONT: f64 = 16.0;
/// Colour-bar width.
/// Arrow colours per action N, E, S, W (Okabe–Ito): direction is also shown by colour so
/// regions of one action stand out.
const ARROW_COLORS: [RGBColor; 4] = [PALETTE[0], PALETTE[1], PALETTE[2], PALETTE[3]];
/// Tint of highlighted path cells.
const PATH_TINT: RGBColor = RGBColor(250, 222, 160);

/// The geometry of a grid world, as the figures need it: build it from a [`World`] with
/// `GridLayout::from(&world)`, or by hand.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GridLayout {
    /// Width in cells.
    pub width: usize,
    /// Height in cells.
    pub height: usize,
    /// Row-major, row 0 at the top: `true` for a blocked cell.
    pub blocked: Vec<bool>,
    /// The goal cell `G`, labelled on the map.
    pub goal: Option<usize>,
    /// The respawn cell `S`, labelled on the map.
    pub respawn: Option<usize>,
}

impl GridLayout {
    /// An all-free `width` × `height` grid without `G` or `S`.
    pub fn open(width: usize, height: usize) -> Self {
        Self { width, height, blocked: vec![false; width * height], goal: None, respawn: None }
    }

    fn cells(&self) -> usize {
        self.width * self.height
    }

    fn check(&self, per_cell: usize, what: &str) -> Result<(), String> {
        if self.width == 0 || self.height == 0 {
            return Err(format!(
                "the grid is {}×{} cells; it needs at least one cell",
                self.width, self.height
            ));
        }
        if self.blocked.len() != self.cells() {
            return Err(format!(
                "the blocked mask has {} entries but the {}×{} grid has {} cells",
                self.blocked.len(),
                self.width,
                self.height,
                self.cells()
            ));
        }
        for (name, c) in [("goal", self.goal), ("respawn", self.respawn)] {
            if let Some(c) = c
                && c >= self.cells()
            {
                return Err(format!("the {name} cell {c} is outside the grid of {} cells", self.cells()));
            }
        }
        if per_cell != self.cells() {
            return Err(format!(
                "{what} has {per_cell} entries but the {}×{} grid has {} cells (one per cell, row-major, row 0 at the top)",
                self.width,
                self.height,
                self.cells()
            ));
        }
        Ok(())
    }
}

impl From<&World> for GridLayout {
    fn from(w: &World) -> Self {
        Self {
            width: w.width,
            height: w.height,
            blocked: w.cells.iter().map(|c| *c == Cell::Blocked).collect(),
            goal: Some(w.goal),
            respawn: Some(w.respawn),
        }
    }
}

/// Per-cell values (e.g. how often each state was visited) as colours on the map, with a
/// colour bar. Blocked cells are dark grey, cells whose value is not finite light grey
/// ("no data"); `G` and `S` are labelled.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GridHeatmap {
    /// Title above the map (may be empty).
    pub title: String,
    /// The map.
    pub grid: GridLayout,
    /// One value per cell, row-major, row 0 at the top (values of blocked cells are
    /// ignored).
    pub values: Vec<f64>,
    /// Colour-bar label with unit, e.g. `"visits"`.
    pub colorbar_label: String,
    /// Logarithmic colour scale (for counts spanning decades). Cells ≤ 0 are drawn white
    /// (legend: "≤ 0"), e.g. states never visited; with no positive value the scale
    /// falls back to linear.
    pub log_scale: bool,
}

impl GridHeatmap {
    /// A heat map of `values` on the map of `world`.
    pub fn new(
        title: impl Into<String>,
        world: &World,
        values: Vec<f64>,
        colorbar_label: impl Into<String>,
    ) -> Self {
        Self {
            title: title.into(),
            grid: world.into(),
            values,
            colorbar_label: colorbar_label.into(),
            log_scale: false,
        }
    }

    /// The same heat map with a logarithmic colour scale.
    pub fn log(mut self) -> Self {
        self.log_scale = true;
        self
    }

    /// Writes `<base>.svg` and `<base>.png` (the directory must exist; `.svg`/`.png` are
    /// appended to the file name) and returns both paths.
    pub fn write(&self, base: &Path) -> Result<Vec<PathBuf>, PlotError> {
        write_figure(self, base)
    }

    fn scale(&self) -> Scale {
        let free: Vec<f64> = self
            .values
            .iter()
            .zip(&self.grid.blocked)
            .filter(|&(v, &b)| !b && v.is_finite())
            .map(|(&v, _)| v)
            .collect();
        Scale::fit(&free, self.log_scale)
    }

    fn layout(&self) -> Layout {
        let s = self.scale();
        let legend = !self.legend().is_empty();
        Layout::new(&self.grid, &self.title, colorbar_width(&s, &self.colorbar_label), 0.0, legend)
    }

    fn has_no_data(&self) -> bool {
        self.values.iter().zip(&self.grid.blocked).any(|(v, &b)| !b && !v.is_finite())
    }

    /// Whether some free cell is ≤ 0 on a log scale (drawn white).
    fn has_off_scale(&self, s: &Scale) -> bool {
        s.log && self.values.iter().zip(&self.grid.blocked).any(|(&v, &b)| !b && v <= 0.0)
    }

    fn legend(&self) -> Vec<Item> {
        let mut items = legend_items(&self.grid, self.has_no_data(), false);
        if self.has_off_scale(&self.scale()) {
            items.push(Item::NonPositive);
        }
        items
    }
}

/// A deterministic policy: in every free cell, an arrow from the centre per chosen
/// action (several on ties), optionally over a highlighted path of cells.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PolicyArrows {
    /// Title above the map (may be empty).
    pub title: String,
    /// The map.
    pub grid: GridLayout,
    /// One bitset per cell over the actions: bit 0 = N (up) … bit 3 = W, see
    /// [`ARROW_N`] … [`ARROW_W`] and [`arrow_bits`]. 0 draws no arrow.
    pub arrows: Vec<u8>,
    /// Cells to shade, e.g. the greedy path from `S` to `G` (may be empty).
    pub highlight_path: Vec<usize>,
}

impl PolicyArrows {
    /// The policy `arrows` on the map of `world`, no path.
    pub fn new(title: impl Into<String>, world: &World, arrows: Vec<u8>) -> Self {
        Self { title: title.into(), grid: world.into(), arrows, highlight_path: Vec::new() }
    }

    /// The same figure with `path` shaded.
    pub fn with_path(mut self, path: Vec<usize>) -> Self {
        self.highlight_path = path;
        self
    }

    /// Writes `<base>.svg` and `<base>.png` (the directory must exist; `.svg`/`.png` are
    /// appended to the file name) and returns both paths.
    pub fn write(&self, base: &Path) -> Result<Vec<PathBuf>, PlotError> {
        write_figure(self, base)
    }

    fn layout(&self) -> Layout {
        let legend = legend_items(&self.grid, false, !self.highlight_path.is_empty());
        Layout::new(&self.grid, &self.title, 0.0, 0.0, !legend.is_empty())
    }
}

/// A probabilistic policy: every free cell is cut along its diagonals into four wedges,
/// the wedge towards N (top), E, S, W coloured by the probability of that action, with a
/// shared 0–1 colour bar and a key.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ActionProbabilities {
    /// Title above the map (may be empty).
    pub title: String,
    /// The map.
    pub grid: GridLayout,
    /// One `[P(N), P(E), P(S), P(W)]` per cell (`mmq_core::Move::ALL` order). Values are
    /// clamped to [0, 1]; non-finite ones are drawn as "no data".
    pub probs: Vec<[f64; 4]>,
}

impl ActionProbabilities {
    /// The policy `probs` on the map of `world`.
    pub fn new(title: impl Into<String>, world: &World, probs: Vec<[f64; 4]>) -> Self {
        Self { title: title.into(), grid: world.into(), probs }
    }

    /// Writes `<base>.svg` and `<base>.png` (the directory must exist; `.svg`/`.png` are
    /// appended to the file name) and returns both paths.
    pub fn write(&self, base: &Path) -> Result<Vec<PathBuf>, PlotError> {
        write_figure(self, base)
    }

    fn has_no_data(&self) -> bool {
        self.probs.iter().zip(&self.grid.blocked).any(|(p, &b)| !b && p.iter().any(|v| !v.is_finite()))
    }

    fn layout(&self) -> Layout {
        let legend = legend_items(&self.grid, self.has_no_data(), false);
        let s = Scale::probability();
        Layout::new(
            &self.grid,
            &self.title,
            colorbar_width(&s, PROB_LABEL),
            KEY_H + 160.0,
            !legend.is_empty(),
        )
    }
}

const PROB_LABEL: &str = "probability of the action";
/// Height of the wedge key above the colour bar.
const KEY_H: f64 = 118.0;

/// Where everything goes, in logical pixels.
struct Layout {
    w: usize,
    h: usize,
    cell: f64,
    /// Top-left corner of the map.
    left: f64,
    top: f64,
    /// Left edge of the right-hand panel.
    panel_x: f64,
    fig_w: f64,
    fig_h: f64,
    title: Title,
}

impl Layout {
    fn new(g: &GridLayout, title: &str, panel_w: f64, panel_min_h: f64, bottom_legend: bool) -> Layout {
        let (w, h) = (g.width.max(1), g.height.max(1));
        let cell = MAP_SIDE / w.max(h) as f64;
        let head = 24.0;
        let left = 16.0 + text_size(&g.height.to_string(), TICK_FONT * 0.9).0 + 8.0;
        let (gw, gh) = (cell * w as f64, cell * h as f64);
        let panel_x = left + gw + 28.0;
        let natural_w = if panel_w > 0.0 { panel_x + panel_w + 14.0 } else { left + gw + 24.0 };
        // The map decides the width; a long title widens the figure up to the width of a
        // line chart, then wraps.
        let title_w = text_size(title, TITLE_FONT).0 + 2.0 * TITLE_MARGIN;
        let fig_w = natural_w.max(title_w.min(natural_w.max(TITLE_MAX_W))).ceil();
        let title = Title::fit(title, fig_w, TITLE_FONT);
        let title_h = if title.lines.is_empty() { 10.0 } else { title.height() + 26.0 };
        let top = title_h + head;
        let body_h = gh.max(panel_min_h);
        let fig_h = top + body_h + if bottom_legend { 50.0 } else { 20.0 };
        Layout { w, h, cell, left, top, panel_x, fig_w, fig_h: fig_h.ceil(), title }
    }

    fn size(&self) -> (u32, u32) {
        (self.fig_w as u32, self.fig_h as u32)
    }

    /// Backend-pixel rectangle of a cell.
    fn cell_rect(&self, ink: Ink, idx: usize) -> ((i32, i32), (i32, i32)) {
        let (r, c) = (idx / self.w, idx % self.w);
        let x0 = ink.p(self.left + c as f64 * self.cell);
        let x1 = ink.p(self.left + (c + 1) as f64 * self.cell);
        let y0 = ink.p(self.top + r as f64 * self.cell);
        let y1 = ink.p(self.top + (r + 1) as f64 * self.cell);
        ((x0, y0), (x1, y1))
    }

    fn map_rect(&self, ink: Ink) -> ((i32, i32), (i32, i32)) {
        (
            (ink.p(self.left), ink.p(self.top)),
            (ink.p(self.left + self.w as f64 * self.cell), ink.p(self.top + self.h as f64 * self.cell)),
        )
    }
}

/// Title, row and column numbers.
fn draw_frame<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, l: &Layout, ink: Ink) -> DrawResult<DB> {
    root.fill(&WHITE)?;
    l.title.draw(root, l.fig_w / 2.0, 12.0, ink)?;
    let font = TICK_FONT * 0.9;
    let grey = RGBColor(90, 90, 90);
    let step = [1usize, 2, 5, 10, 20, 50, 100, 200, 500, 1000]
        .into_iter()
        .find(|&s| s as f64 * l.cell >= 22.0)
        .unwrap_or(1000);
    for c in 0..l.w {
        if c == 0 || (c + 1) % step == 0 {
            let x = ink.p(l.left + (c as f64 + 0.5) * l.cell);
            let pos = (x, ink.p(l.top - 6.0));
            ink.label(root, &(c + 1).to_string(), font, grey, (HPos::Center, VPos::Bottom), false, pos)?;
        }
    }
    for r in 0..l.h {
        if r == 0 || (r + 1) % step == 0 {
            let y = ink.p(l.top + (r as f64 + 0.5) * l.cell);
            let pos = (ink.p(l.left - 7.0), y);
            ink.label(root, &(r + 1).to_string(), font, grey, (HPos::Right, VPos::Center), false, pos)?;
        }
    }
    Ok(())
}

/// Thin lines between cells and a frame around the map.
fn draw_cell_lines<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    l: &Layout,
    color: RGBColor,
    ink: Ink,
) -> DrawResult<DB> {
    let ((x0, y0), (x1, y1)) = l.map_rect(ink);
    if l.cell >= 6.0 {
        let style = color.stroke_width(ink.pu(1.0));
        for c in 1..l.w {
            let x = ink.p(l.left + c as f64 * l.cell);
            root.draw(&PathElement::new(vec![(x, y0), (x, y1)], style))?;
        }
        for r in 1..l.h {
            let y = ink.p(l.top + r as f64 * l.cell);
            root.draw(&PathElement::new(vec![(x0, y), (x1, y)], style))?;
        }
    }
    root.draw(&Rectangle::new([(x0, y0), (x1, y1)], INK.stroke_width(ink.pu(1.5))))
}

/// A bold-ish cell letter (G or S): drawn twice, offset by a hair, since only one font
/// weight is embedded.
fn draw_letter<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    text: &str,
    (x, y): (i32, i32),
    size: f64,
    color: RGBColor,
    h: HPos,
    v: VPos,
    ink: Ink,
) -> DrawResult<DB> {
    let d = ink.p((size / 28.0).max(0.5)).max(1);
    ink.label(root, text, size, color, (h, v), false, (x, y))?;
    ink.label(root, text, size, color, (h, v), false, (x + d, y))
}

/// Legend entries under the map.
#[derive(Clone, Copy, PartialEq)]
enum Item {
    Goal,
    Respawn,
    Blocked,
    NoData,
    NonPositive,
    Path,
}

fn legend_items(g: &GridLayout, no_data: bool, path: bool) -> Vec<Item> {
    let mut v = Vec::new();
    if g.goal.is_some() {
        v.push(Item::Goal);
    }
    if g.respawn.is_some() {
        v.push(Item::Respawn);
    }
    if g.blocked.iter().any(|&b| b) {
        v.push(Item::Blocked);
    }
    if no_data {
        v.push(Item::NoData);
    }
    if path {
        v.push(Item::Path);
    }
    v
}

fn draw_bottom_legend<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    l: &Layout,
    items: &[Item],
    ink: Ink,
) -> DrawResult<DB> {
    let y = l.top + l.h as f64 * l.cell + 28.0;
    let mut x = l.left;
    let sw = 18.0;
    for &it in items {
        let (swatch, text): (Option<RGBColor>, &str) = match it {
            Item::Goal => (None, "goal"),
            Item::Respawn => (None, "respawn"),
            Item::Blocked => (Some(BLOCKED), "blocked"),
            Item::NoData => (Some(NO_DATA), "no data"),
            Item::NonPositive => (Some(WHITE), "≤ 0 (off the log scale)"),
            Item::Path => (Some(PATH_TINT), "path"),
        };
        match swatch {
            Some(c) => {
                let r = [(ink.p(x), ink.p(y - sw / 2.0)), (ink.p(x + sw), ink.p(y + sw / 2.0))];
                root.draw(&Rectangle::new(r, c.filled()))?;
                root.draw(&Rectangle::new(r, RGBColor(120, 120, 120).stroke_width(ink.pu(1.0))))?;
            }
            None => {
                let letter = if it == Item::Goal { "G" } else { "S" };
                draw_letter(
                    root,
                    letter,
                    (ink.p(x + sw / 2.0), ink.p(y)),
                    LEGEND_FONT + 2.0,
                    INK,
                    HPos::Center,
                    VPos::Center,
                    ink,
                )?;
            }
        }
        x += sw + 7.0;
        ink.label(root, text, LEGEND_FONT, INK, (HPos::Left, VPos::Center), false, (ink.p(x), ink.p(y)))?;
        x += text_size(text, LEGEND_FONT).0 + 26.0;
    }
    Ok(())
}

impl Figure for GridHeatmap {
    fn validate(&self) -> Result<(), String> {
        self.grid.check(self.values.len(), "values")
    }

    fn size(&self) -> (u32, u32) {
        self.layout().size()
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, ink: Ink) -> DrawResult<DB> {
        let l = self.layout();
        let s = self.scale();
        draw_frame(root, &l, ink)?;
        let fill_of = |i: usize| {
            if self.grid.blocked[i] {
                BLOCKED
            } else if !self.values[i].is_finite() {
                NO_DATA
            } else if s.log && self.values[i] <= 0.0 {
                WHITE
            } else {
                viridis(s.t(self.values[i]))
            }
        };
        for i in 0..self.grid.cells() {
            root.draw(&Rectangle::new(<[_; 2]>::from(l.cell_rect(ink, i)), fill_of(i).filled()))?;
        }
        draw_cell_lines(root, &l, WHITE, ink)?;
        let size = (l.cell * 0.5).min(30.0);
        for (cell, letter) in [(self.grid.goal, "G"), (self.grid.respawn, "S")] {
            if let Some(c) = cell {
                let ((x0, y0), (x1, y1)) = l.cell_rect(ink, c);
                let center = ((x0 + x1) / 2, (y0 + y1) / 2);
                draw_letter(
                    root,
                    letter,
                    center,
                    size,
                    contrast(fill_of(c)),
                    HPos::Center,
                    VPos::Center,
                    ink,
                )?;
            }
        }
        let (y0, y1) = (l.top, l.top + l.h as f64 * l.cell);
        draw_colorbar(root, l.panel_x, (y0, y1), &s, &self.colorbar_label, ink)?;
        draw_bottom_legend(root, &l, &self.legend(), ink)
    }
}

/// Draws one arrow in direction `a` (0 = N, 1 = E, 2 = S, 3 = W) in the cell centred at
/// `c` (backend pixels): through the centre if it is the cell's only arrow, else from the
/// centre outwards (ties form a cross).
fn draw_arrow<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    (cx, cy): (f64, f64),
    a: usize,
    cell_px: f64,
    color: RGBColor,
    alone: bool,
) -> DrawResult<DB> {
    let (start, len) = if alone { (-0.34 * cell_px, 0.34 * cell_px) } else { (0.0, 0.42 * cell_px) };
    let head_l = 0.2 * cell_px;
    let head_w = 0.13 * cell_px;
    let half = (0.045 * cell_px).max(0.8);
    // Unit vector of the direction, screen y down: N is up.
    let (ux, uy) = [(0.0, -1.0), (1.0, 0.0), (0.0, 1.0), (-1.0, 0.0)][a];
    let (px, py) = (-uy, ux);
    let p = |along: f64, across: f64| {
        ((cx + ux * along + px * across).round() as i32, (cy + uy * along + py * across).round() as i32)
    };
    let shaft_end = len - head_l * 0.9;
    let start = if alone { start } else { start - half };
    let shaft = vec![p(start, -half), p(shaft_end, -half), p(shaft_end, half), p(start, half)];
    root.draw(&Polygon::new(shaft, color.filled()))?;
    let head = vec![p(len, 0.0), p(len - head_l, head_w), p(len - head_l, -head_w)];
    root.draw(&Polygon::new(head, color.filled()))
}

impl Figure for PolicyArrows {
    fn validate(&self) -> Result<(), String> {
        self.grid.check(self.arrows.len(), "arrows")?;
        if let Some(&c) = self.highlight_path.iter().find(|&&c| c >= self.grid.cells()) {
            return Err(format!(
                "highlight_path cell {c} is outside the grid of {} cells",
                self.grid.cells()
            ));
        }
        Ok(())
    }

    fn size(&self) -> (u32, u32) {
        self.layout().size()
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, ink: Ink) -> DrawResult<DB> {
        let l = self.layout();
        draw_frame(root, &l, ink)?;
        let mut on_path = vec![false; self.grid.cells()];
        for &c in &self.highlight_path {
            on_path[c] = true;
        }
        for i in 0..self.grid.cells() {
            let fill = if self.grid.blocked[i] {
                BLOCKED
            } else if on_path[i] {
                PATH_TINT
            } else {
                WHITE
            };
            root.draw(&Rectangle::new(<[_; 2]>::from(l.cell_rect(ink, i)), fill.filled()))?;
        }
        draw_cell_lines(root, &l, RGBColor(190, 190, 190), ink)?;
        let cell_px = l.cell * ink.k;
        for i in 0..self.grid.cells() {
            if self.grid.blocked[i] {
                continue;
            }
            let ((x0, y0), (x1, y1)) = l.cell_rect(ink, i);
            let c = (f64::from(x0 + x1) / 2.0, f64::from(y0 + y1) / 2.0);
            let bits = self.arrows[i] & 0b1111;
            for a in 0..4 {
                if bits & (1 << a) != 0 {
                    draw_arrow(root, c, a, cell_px, ARROW_COLORS[a], bits.count_ones() == 1)?;
                }
            }
        }
        let size = (l.cell * 0.36).clamp(11.0, 24.0);
        for (cell, letter) in [(self.grid.goal, "G"), (self.grid.respawn, "S")] {
            if let Some(c) = cell {
                let ((x0, y0), _) = l.cell_rect(ink, c);
                let inset = ink.p(l.cell * 0.05 + 1.0);
                draw_letter(root, letter, (x0 + inset, y0 + inset), size, INK, HPos::Left, VPos::Top, ink)?;
            }
        }
        draw_bottom_legend(root, &l, &legend_items(&self.grid, false, !self.highlight_path.is_empty()), ink)
    }
}

/// The four wedges of a cell as backend-pixel triangles, in N, E, S, W order.
fn wedges(((x0, y0), (x1, y1)): ((i32, i32), (i32, i32))) -> [Vec<(i32, i32)>; 4] {
    let c = ((x0 + x1) / 2, (y0 + y1) / 2);
    [
        vec![(x0, y0), (x1, y0), c],
        vec![(x1, y0), (x1, y1), c],
        vec![(x1, y1), (x0, y1), c],
        vec![(x0, y1), (x0, y0), c],
    ]
}

impl Figure for ActionProbabilities {
    fn validate(&self) -> Result<(), String> {
        self.grid.check(self.probs.len(), "probs")
    }

    fn size(&self) -> (u32, u32) {
        self.layout().size()
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, ink: Ink) -> DrawResult<DB> {
        let l = self.layout();
        draw_frame(root, &l, ink)?;
        let sep = WHITE.stroke_width(ink.pu(if l.cell >= 30.0 { 1.0 } else { 0.5 }));
        for i in 0..self.grid.cells() {
            let rect = l.cell_rect(ink, i);
            if self.grid.blocked[i] {
                root.draw(&Rectangle::new(<[_; 2]>::from(rect), BLOCKED.filled()))?;
                continue;
            }
            for (a, tri) in wedges(rect).into_iter().enumerate() {
                let p = self.probs[i][a];
                let fill = if p.is_finite() { viridis(p.clamp(0.0, 1.0)) } else { NO_DATA };
                root.draw(&Polygon::new(tri, fill.filled()))?;
            }
            if l.cell >= 12.0 {
                let ((x0, y0), (x1, y1)) = rect;
                root.draw(&PathElement::new(vec![(x0, y0), (x1, y1)], sep))?;
                root.draw(&PathElement::new(vec![(x1, y0), (x0, y1)], sep))?;
            }
        }
        draw_cell_lines(root, &l, WHITE, ink)?;
        for (cell, letter) in [(self.grid.goal, "G"), (self.grid.respawn, "S")] {
            if let Some(c) = cell {
                let ((x0, y0), (x1, y1)) = l.cell_rect(ink, c);
                let center = ((x0 + x1) / 2, (y0 + y1) / 2);
                let r = ink.p((l.cell * 0.2).clamp(7.0, 17.0));
                root.draw(&Circle::new(center, r, WHITE.filled()))?;
                root.draw(&Circle::new(center, r, INK.stroke_width(ink.pu(1.0))))?;
                let size = (l.cell * 0.27).clamp(9.0, 22.0);
                draw_letter(root, letter, center, size, INK, HPos::Center, VPos::Center, ink)?;
            }
        }

        // Key: which wedge is which action.
        let kx = l.panel_x;
        let ks = 64.0;
        ink.label(root, "action", TICK_FONT, INK, (HPos::Left, VPos::Top), false, (ink.p(kx), ink.p(l.top)))?;
        let ky = l.top + 28.0;
        let krect = ((ink.p(kx), ink.p(ky)), (ink.p(kx + ks), ink.p(ky + ks)));
        let shades = [tint(RGBColor(0, 0, 0), 0.12), tint(RGBColor(0, 0, 0), 0.25)];
        for (a, tri) in wedges(krect).into_iter().enumerate() {
            root.draw(&Polygon::new(tri, shades[a % 2].filled()))?;
        }
        root.draw(&Rectangle::new([krect.0, krect.1], INK.stroke_width(ink.pu(1.0))))?;
        let c = (kx + ks / 2.0, ky + ks / 2.0);
        for (a, name) in ["N", "E", "S", "W"].into_iter().enumerate() {
            let (dx, dy) = [(0.0, -1.0), (1.0, 0.0), (0.0, 1.0), (-1.0, 0.0)][a];
            let pos = (ink.p(c.0 + dx * ks * 0.32), ink.p(c.1 + dy * ks * 0.32));
            ink.label(root, name, TICK_FONT, INK, (HPos::Center, VPos::Center), false, pos)?;
        }
        let bar_top = l.top + KEY_H;
        let bar_bottom = (l.top + l.h as f64 * l.cell).max(bar_top + 160.0);
        draw_colorbar(root, l.panel_x, (bar_top, bar_bottom), &Scale::probability(), PROB_LABEL, ink)?;
        draw_bottom_legend(root, &l, &legend_items(&self.grid, self.has_no_data(), false), ink)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arrow_bits_follow_move_order() {
        assert_eq!(arrow_bits([0]), ARROW_N);
        assert_eq!(arrow_bits([0, 3]), ARROW_N | ARROW_W);
        assert_eq!(arrow_bits([1, 2, 7]), ARROW_E | ARROW_S);
    }
}
