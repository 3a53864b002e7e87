//! The picture as a list of shapes in pixel coordinates (y down): the title, the arena,
//! the trajectory, a scale bar in metres and a legend.

use crate::error::LogError;
use crate::reader::{LogContents, PoseStamp};

/// An sRGB colour.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Rgb(pub u8, pub u8, pub u8);

impl Rgb {
    pub(crate) fn hex(self) -> String {
        format!("#{:02x}{:02x}{:02x}", self.0, self.1, self.2)
    }
}

pub(crate) const WHITE: Rgb = Rgb(0xff, 0xff, 0xff);
pub(crate) const INK: Rgb = Rgb(0x22, 0x22, 0x22);
pub(crate) const FLOOR: Rgb = Rgb(0xf4, 0xf4, 0xef);
pub(crate) const GRID_LINE: Rgb = Rgb(0xdd, 0xdd, 0xdd);
pub(crate) const BLOCKED: Rgb = Rgb(0x5a, 0x5a, 0x66);
pub(crate) const GOAL: Rgb = Rgb(0x4c, 0xbf, 0x5a);
pub(crate) const RESPAWN: Rgb = Rgb(0x4f, 0x7f, 0xe0);
pub(crate) const PATH: Rgb = Rgb(0xd9, 0x48, 0x0f);
/// Opacity of the trajectory (overlapping passes darken it).
pub(crate) const PATH_OPACITY: f64 = 0.55;

/// Where a text's `x` is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Anchor {
    Start,
    Middle,
}

/// One shape, in pixels.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Shape {
    /// A filled rectangle, optionally outlined (colour, width).
    Rect { x: f64, y: f64, w: f64, h: f64, fill: Option<Rgb>, stroke: Option<(Rgb, f64)> },
    /// Thin straight lines (the cell grid): (x1, y1, x2, y2) each.
    Lines { lines: Vec<(f64, f64, f64, f64)>, color: Rgb, width: f64 },
    /// A polyline.
    Polyline { points: Vec<(f64, f64)>, color: Rgb, opacity: f64, width: f64 },
    /// A circle, filled or outlined.
    Circle { cx: f64, cy: f64, r: f64, fill: Option<Rgb>, stroke: Option<(Rgb, f64)> },
    /// Text with its baseline at `y` (or centred on `y` when `middle_v`).
    Text { x: f64, y: f64, size: f64, text: String, color: Rgb, anchor: Anchor, bold: bool, middle_v: bool },
}

/// A picture: its size in pixels and its shapes, drawn in order on white.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Picture {
    pub width: f64,
    pub height: f64,
    pub shapes: Vec<Shape>,
}

/// The poses of steps `window` (by the decisions' times; all poses without a window).
pub fn window_poses(log: &LogContents, window: Option<(u64, u64)>) -> &[PoseStamp] {
    let Some((from, to)) = window else { return &log.poses };
    let d = &log.decisions;
    let lo = d.iter().find(|x| x.msg.t >= from).map_or(u64::MAX, |x| x.log_time);
    let hi = d.iter().find(|x| x.msg.t > to).map_or(u64::MAX, |x| x.log_time);
    let a = log.poses.partition_point(|p| p.log_time < lo);
    let b = log.poses.partition_point(|p| p.log_time <= hi);
    &log.poses[a..b.max(a)]
}

/// The longest "nice" length (1, 2 or 5 × 10^k metres) not above `max_m`.
pub(crate) fn nice_length(max_m: f64) -> f64 {
    if !(max_m.is_finite() && max_m > 0.0) {
        return 1.0;
    }
    let k = max_m.log10().floor();
    let base = 10f64.powf(k);
    [5.0, 2.0, 1.0].into_iter().map(|m| m * base).find(|&l| l <= max_m * (1.0 + 1e-9)).unwrap_or(base)
}

/// A length in metres as the scale bar's label (`1 m`, `0.5 m`, `20 m`).
fn metres(l: f64) -> String {
    let s = format!("{l:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    format!("{s} m")
}

/// Builds the picture of [`super::render`].
pub(crate) fn build(log: &LogContents, window: Option<(u64, u64)>) -> Result<Picture, LogError> {
    let world = log.world()?;
    let cs = world.cell_size;
    let (w, h) = (world.width as f64, world.height as f64);
    let px = (1000.0 / w.max(h)).clamp(6.0, 48.0);
    let (margin, header, footer) = (16.0, 28.0, 44.0);
    let width = (2.0 * margin + w * px).max(420.0);
    let height = 2.0 * margin + header + h * px + footer;
    // World metres → pixels (y down).
    let sx = |x: f64| margin + x / cs * px;
    let sy = |y: f64| margin + header + (h - y / cs) * px;
    let mut shapes = Vec::new();
    let fact = |k: &str| log.run_fact(k).unwrap_or("?").to_string();
    let steps = match window {
        Some((a, b)) => format!("steps {a}–{b}"),
        None => "all recorded steps".to_string(),
    };
    let title = format!("{} · {} · seed {} · {steps}", world.name, fact("learner"), fact("seed"));
    shapes.push(Shape::Text {
        x: margin,
        y: margin + 14.0,
        size: 14.0,
        text: title,
        color: INK,
        anchor: Anchor::Start,
        bold: false,
        middle_v: false,
    });
    // Floor and cell lines.
    let (x0, y0) = (sx(0.0), sy(h * cs));
    shapes.push(Shape::Rect { x: x0, y: y0, w: w * px, h: h * px, fill: Some(FLOOR), stroke: None });
    let mut lines = Vec::new();
    for i in 1..world.width {
        let x = x0 + i as f64 * px;
        lines.push((x, y0, x, y0 + h * px));
    }
    for j in 1..world.height {
        let y = y0 + j as f64 * px;
        lines.push((x0, y, x0 + w * px, y));
    }
    shapes.push(Shape::Lines { lines, color: GRID_LINE, width: 0.5 });
    // Cells: blocked, goal, respawn.
    for c in 0..world.num_cells() {
        let (r, col) = world.row_col(c);
        let (x, y) = (x0 + col as f64 * px, y0 + r as f64 * px);
        let fill = if !world.is_free(c) {
            BLOCKED
        } else if c == world.goal {
            GOAL
        } else if c == world.respawn {
            RESPAWN
        } else {
            continue;
        };
        shapes.push(Shape::Rect { x, y, w: px, h: px, fill: Some(fill), stroke: None });
        if world.is_free(c) {
            let label = if c == world.goal { "G" } else { "S" };
            shapes.push(Shape::Text {
                x: x + px / 2.0,
                y: y + px / 2.0,
                size: 0.6 * px,
                text: label.into(),
                color: WHITE,
                anchor: Anchor::Middle,
                bold: true,
                middle_v: true,
            });
        }
    }
    // Boundary wall.
    let wall = (0.12 * px).max(2.0);
    shapes.push(Shape::Rect {
        x: x0,
        y: y0,
        w: w * px,
        h: h * px,
        fill: None,
        stroke: Some((BLOCKED, wall)),
    });
    // Trajectory.
    let poses = window_poses(log, window);
    let stroke = (0.08 * px).clamp(1.0, 4.0);
    for seg in super::segments(log, poses, cs) {
        let points = seg.iter().map(|p| (sx(p.x), sy(p.y))).collect();
        shapes.push(Shape::Polyline { points, color: PATH, opacity: PATH_OPACITY, width: stroke });
    }
    let r = (0.18 * px).max(3.0);
    if let (Some(a), Some(b)) = (poses.first(), poses.last()) {
        shapes.push(Shape::Circle { cx: sx(a.x), cy: sy(a.y), r, fill: None, stroke: Some((INK, 1.5)) });
        shapes.push(Shape::Circle { cx: sx(b.x), cy: sy(b.y), r, fill: Some(INK), stroke: None });
        let (hx, hy) = (sx(b.x) + 2.0 * r * b.theta.cos(), sy(b.y) - 2.0 * r * b.theta.sin());
        shapes.push(Shape::Lines { lines: vec![(sx(b.x), sy(b.y), hx, hy)], color: INK, width: 1.5 });
    }
    footer_shapes(&mut shapes, margin, y0 + h * px + 14.0, px, cs, w * cs, r);
    Ok(Picture { width, height, shapes })
}

/// The scale bar (left) and the legend (right of it), in a row whose top is `top`.
fn footer_shapes(shapes: &mut Vec<Shape>, left: f64, top: f64, px: f64, cs: f64, arena_m: f64, r: f64) {
    let text = |x: f64, y: f64, s: &str| Shape::Text {
        x,
        y,
        size: 11.0,
        text: s.to_string(),
        color: INK,
        anchor: Anchor::Start,
        bold: false,
        middle_v: true,
    };
    // Scale bar: a nice length of at most a quarter of the arena (and 160 px).
    let per_m = px / cs;
    let len_m = nice_length((arena_m / 4.0).min(160.0 / per_m));
    let len = len_m * per_m;
    let (y, tick) = (top + 8.0, 4.0);
    shapes.push(Shape::Lines {
        lines: vec![
            (left, y, left + len, y),
            (left, y - tick, left, y + tick),
            (left + len, y - tick, left + len, y + tick),
        ],
        color: INK,
        width: 1.5,
    });
    shapes.push(text(left + len + 6.0, y, &metres(len_m)));
    // Legend: swatches and their names.
    let mut x = left + len + 60.0;
    let sw = 12.0;
    shapes.push(Shape::Lines { lines: vec![(x, y, x + 22.0, y)], color: PATH, width: 3.0 });
    shapes.push(text(x + 27.0, y, "trajectory"));
    x += 92.0;
    let rr = r.min(6.0);
    shapes.push(Shape::Circle { cx: x + rr, cy: y, r: rr, fill: None, stroke: Some((INK, 1.5)) });
    shapes.push(text(x + 2.0 * rr + 5.0, y, "start"));
    x += 2.0 * rr + 42.0;
    shapes.push(Shape::Circle { cx: x + rr, cy: y, r: rr, fill: Some(INK), stroke: None });
    shapes.push(text(x + 2.0 * rr + 5.0, y, "end"));
    x += 2.0 * rr + 36.0;
    let row2 = y + 18.0;
    let mut x2 = left;
    for (fill, name) in [(GOAL, "goal (G)"), (RESPAWN, "respawn (S)"), (BLOCKED, "blocked cell, wall")] {
        // Outlined in white, so a swatch is told apart from the arena's cells.
        shapes.push(Shape::Rect {
            x: x2,
            y: row2 - sw / 2.0,
            w: sw,
            h: sw,
            fill: Some(fill),
            stroke: Some((WHITE, 0.5)),
        });
        shapes.push(text(x2 + sw + 5.0, row2, name));
        x2 += sw + 12.0 + 6.5 * name.chars().count() as f64;
    }
    let _ = x;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scale_bars_have_nice_lengths() {
        assert_eq!(nice_length(1.125), 1.0);
        assert_eq!(nice_length(0.75), 0.5);
        assert_eq!(nice_length(3.0), 2.0);
        assert_eq!(nice_length(49.0), 20.0);
        assert_eq!(nice_length(50.0), 50.0);
        assert_eq!(nice_length(0.0), 1.0);
        assert_eq!(metres(0.5), "0.5 m");
        assert_eq!(metres(20.0), "20 m");
    }
}
