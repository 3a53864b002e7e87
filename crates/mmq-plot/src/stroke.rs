//! Drawing primitives of line charts, in backend pixels: thick (optionally dashed)
//! polylines with round joints on bitmaps, and the series' marker shapes.

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::render::{DrawResult, Ink};

/// Draws a polyline (backend pixels) `width` logical pixels wide, optionally dashed
/// (`(dash, gap)` in logical pixels).
///
/// On the bitmap backend plotters joins thick segments with unlimited mitres, which
/// shoot spikes far out of the plot at sharp turns (any noisy curve); there every
/// segment is drawn on its own and the joints are rounded with discs.
pub(crate) fn stroke<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    pts: &[(i32, i32)],
    color: RGBColor,
    width: f64,
    dash: Option<(f64, f64)>,
    ink: Ink,
) -> DrawResult<DB> {
    let mut pieces: Vec<Vec<(i32, i32)>> = Vec::new();
    match dash {
        None => pieces.push(pts.to_vec()),
        Some((on, off)) => {
            // Walk the polyline, emitting the "on" stretches.
            let (on, off) = (on * ink.k, off * ink.k);
            let mut drawing = true;
            let mut left = on;
            let mut cur: Vec<(f64, f64)> = Vec::new();
            let f = |p: (i32, i32)| (f64::from(p.0), f64::from(p.1));
            let r = |p: (f64, f64)| (p.0.round() as i32, p.1.round() as i32);
            if let Some(&first) = pts.first() {
                cur.push(f(first));
            }
            for w in pts.windows(2) {
                let (mut a, b) = (f(w[0]), f(w[1]));
                let mut len = (b.0 - a.0).hypot(b.1 - a.1);
                while len > left {
                    let t = left / len;
                    let m = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
                    if drawing {
                        cur.push(m);
                        pieces.push(cur.drain(..).map(r).collect());
                    } else {
                        cur.push(m);
                    }
                    len -= left;
                    a = m;
                    drawing = !drawing;
                    left = if drawing { on } else { off };
                }
                left -= len;
                if drawing {
                    cur.push(b);
                } else {
                    cur.clear();
                }
            }
            if drawing && cur.len() >= 2 {
                pieces.push(cur.into_iter().map(r).collect());
            }
        }
    }
    let style = color.stroke_width(ink.pu(width));
    for piece in pieces {
        if !ink.bitmap {
            root.draw(&PathElement::new(piece, style))?;
            continue;
        }
        let radius = (width * ink.k / 2.0).floor() as i32;
        let mut prev_dir: Option<(f64, f64)> = None;
        for w in piece.windows(2) {
            if w[0] == w[1] {
                continue;
            }
            root.draw(&PathElement::new(vec![w[0], w[1]], style))?;
            let (dx, dy) = (f64::from(w[1].0 - w[0].0), f64::from(w[1].1 - w[0].1));
            let len = dx.hypot(dy);
            let dir = (dx / len, dy / len);
            // Round the joint where the line turns by more than ~20°.
            if let Some(d) = prev_dir
                && d.0 * dir.0 + d.1 * dir.1 < 0.94
                && radius >= 2
            {
                root.draw(&Circle::new(w[0], radius, color.filled()))?;
            }
            prev_dir = Some(dir);
        }
    }
    Ok(())
}

/// Marker shapes, one per series (cycled).
#[derive(Clone, Copy)]
pub(crate) enum Marker {
    Circle,
    Square,
    Triangle,
    Diamond,
    TriangleDown,
}

pub(crate) const MARKERS: [Marker; 5] =
    [Marker::Circle, Marker::Square, Marker::Triangle, Marker::Diamond, Marker::TriangleDown];

pub(crate) fn draw_marker<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    m: Marker,
    (x, y): (i32, i32),
    r: i32,
    color: RGBColor,
    ink: Ink,
) -> DrawResult<DB> {
    let fill = color.filled();
    let edge = WHITE.stroke_width(ink.pu(1.0));
    let poly = |pts: Vec<(i32, i32)>| -> DrawResult<DB> {
        area.draw(&Polygon::new(pts.clone(), fill))?;
        let mut closed = pts;
        closed.push(closed[0]);
        area.draw(&PathElement::new(closed, edge))
    };
    match m {
        Marker::Circle => {
            area.draw(&Circle::new((x, y), r, fill))?;
            area.draw(&Circle::new((x, y), r, edge))
        }
        Marker::Square => {
            let s = (f64::from(r) * 0.85) as i32;
            poly(vec![(x - s, y - s), (x + s, y - s), (x + s, y + s), (x - s, y + s)])
        }
        Marker::Triangle => {
            let s = f64::from(r) * 1.2;
            let (h, w) = ((s * 0.9) as i32, (s * 1.05) as i32);
            poly(vec![(x, y - h), (x + w, y + h * 3 / 4), (x - w, y + h * 3 / 4)])
        }
        Marker::TriangleDown => {
            let s = f64::from(r) * 1.2;
            let (h, w) = ((s * 0.9) as i32, (s * 1.05) as i32);
            poly(vec![(x, y + h), (x + w, y - h * 3 / 4), (x - w, y - h * 3 / 4)])
        }
        Marker::Diamond => {
            let s = (f64::from(r) * 1.25) as i32;
            poly(vec![(x, y - s), (x + s, y), (x, y + s), (x - s, y)])
        }
    }
}

/// A marker drawn as an outline in `color`, nothing inside, so a filled marker at the
/// same place stays visible within it (`r`: half its width).
pub(crate) fn draw_open_marker<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    m: Marker,
    (x, y): (i32, i32),
    r: i32,
    color: RGBColor,
    ink: Ink,
) -> DrawResult<DB> {
    let edge = color.stroke_width(ink.pu(2.0));
    if let Marker::Circle = m {
        return area.draw(&Circle::new((x, y), r, edge));
    }
    let s = r;
    let mut pts = match m {
        Marker::Diamond => vec![(x, y - s), (x + s, y), (x, y + s), (x - s, y)],
        Marker::Triangle => vec![(x, y - s), (x + s, y + s * 3 / 4), (x - s, y + s * 3 / 4)],
        Marker::TriangleDown => vec![(x, y + s), (x + s, y - s * 3 / 4), (x - s, y - s * 3 / 4)],
        _ => vec![(x - s, y - s), (x + s, y - s), (x + s, y + s), (x - s, y + s)],
    };
    pts.push(pts[0]);
    area.draw(&PathElement::new(pts, edge))
}
