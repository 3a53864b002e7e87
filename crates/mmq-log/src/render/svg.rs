//! A [`Picture`] as SVG text.

use std::fmt::Write as _;

use super::scene::{Anchor, Picture, Shape};

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// The SVG text of `pic`.
pub(crate) fn write(pic: &Picture) -> String {
    let (width, height) = (pic.width, pic.height);
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0}" height="{height:.0}" viewBox="0 0 {width:.1} {height:.1}" font-family="sans-serif">"#
    );
    let _ = writeln!(s, r##"<rect width="100%" height="100%" fill="#ffffff"/>"##);
    for shape in &pic.shapes {
        match shape {
            Shape::Rect { x, y, w, h, fill, stroke } => {
                let _ = write!(s, r#"<rect x="{x:.1}" y="{y:.1}" width="{w:.1}" height="{h:.1}""#);
                let _ = write!(s, r#" fill="{}""#, fill.map_or("none".to_string(), |c| c.hex()));
                if let Some((c, sw)) = stroke {
                    let _ = write!(s, r#" stroke="{}" stroke-width="{sw:.1}""#, c.hex());
                }
                let _ = writeln!(s, "/>");
            }
            Shape::Lines { lines, color, width } => {
                let _ = write!(s, r#"<path stroke="{}" stroke-width="{width:.1}" d=""#, color.hex());
                for (x1, y1, x2, y2) in lines {
                    let _ = write!(s, "M{x1:.1} {y1:.1}L{x2:.1} {y2:.1}");
                }
                let _ = writeln!(s, r#""/>"#);
            }
            Shape::Polyline { points, color, opacity, width } => {
                let _ = write!(
                    s,
                    r#"<polyline fill="none" stroke="{}" stroke-opacity="{opacity}" stroke-width="{width:.1}" stroke-linejoin="round" points=""#,
                    color.hex()
                );
                for (x, y) in points {
                    let _ = write!(s, "{x:.1},{y:.1} ");
                }
                let _ = writeln!(s, r#""/>"#);
            }
            Shape::Circle { cx, cy, r, fill, stroke } => {
                let _ = write!(s, r#"<circle cx="{cx:.1}" cy="{cy:.1}" r="{r:.1}""#);
                let _ = write!(s, r#" fill="{}""#, fill.map_or("none".to_string(), |c| c.hex()));
                if let Some((c, sw)) = stroke {
                    let _ = write!(s, r#" stroke="{}" stroke-width="{sw:.1}""#, c.hex());
                }
                let _ = writeln!(s, "/>");
            }
            Shape::Text { x, y, size, text, color, anchor, bold, middle_v } => {
                let _ =
                    write!(s, r#"<text x="{x:.1}" y="{y:.1}" font-size="{size:.1}" fill="{}""#, color.hex());
                if *anchor == Anchor::Middle {
                    let _ = write!(s, r#" text-anchor="middle""#);
                }
                if *middle_v {
                    let _ = write!(s, r#" dominant-baseline="central""#);
                }
                if *bold {
                    let _ = write!(s, r#" font-weight="bold""#);
                }
                let _ = writeln!(s, ">{}</text>", esc(text));
            }
        }
    }
    let _ = writeln!(s, "</svg>");
    s
}
