//! A [`Picture`] drawn into pixels and encoded as PNG: shapes anti-aliased by their
//! exact pixel coverage (distance to an edge), text from the glyph outlines of DejaVu
//! Sans (the font file `mmq-plot` embeds; Bitstream Vera licence,
//! `crates/mmq-plot/assets/DejaVuSans-LICENSE.txt`).

use ab_glyph::{Font, FontRef, PxScale, ScaleFont, point};

use super::scene::{Anchor, Picture, Rgb, Shape};

static FONT: &[u8] = include_bytes!("../../../mmq-plot/assets/DejaVuSans.ttf");

/// Pixels per SVG unit in the PNG (crisper text and lines than 1:1).
pub(crate) const PNG_SCALE: f64 = 2.0;

/// A segment between two points, pixels.
type Segment = ((f64, f64), (f64, f64));

/// An RGB image being drawn.
struct Canvas {
    w: usize,
    h: usize,
    px: Vec<[f32; 3]>,
    /// Coverage of the polyline being drawn (composited once, so that its segments do
    /// not darken where they meet).
    mask: Vec<f32>,
}

impl Canvas {
    fn new(w: usize, h: usize) -> Self {
        Self { w, h, px: vec![[1.0; 3]; w * h], mask: vec![0.0; w * h] }
    }

    fn blend(&mut self, x: usize, y: usize, c: Rgb, a: f32) {
        if x >= self.w || y >= self.h || a <= 0.0 {
            return;
        }
        let a = a.min(1.0);
        let p = &mut self.px[y * self.w + x];
        for (v, c) in p.iter_mut().zip([c.0, c.1, c.2]) {
            *v += (f32::from(c) / 255.0 - *v) * a;
        }
    }

    /// Pixel range covering [lo, hi] (clamped to `n`).
    fn span(lo: f64, hi: f64, n: usize) -> std::ops::Range<usize> {
        let a = lo.floor().max(0.0) as usize;
        let b = (hi.ceil().max(0.0) as usize).min(n);
        a.min(b)..b
    }

    /// A filled axis-aligned rectangle, edges covered in proportion.
    fn fill_rect(&mut self, x0: f64, y0: f64, x1: f64, y1: f64, c: Rgb) {
        for y in Self::span(y0, y1, self.h) {
            let cy = ((y as f64 + 1.0).min(y1) - (y as f64).max(y0)).max(0.0);
            for x in Self::span(x0, x1, self.w) {
                let cx = ((x as f64 + 1.0).min(x1) - (x as f64).max(x0)).max(0.0);
                self.blend(x, y, c, (cx * cy) as f32);
            }
        }
    }

    /// Adds the coverage of a segment of `width` to the mask; returns its pixel box.
    fn mask_segment(&mut self, (x1, y1): (f64, f64), (x2, y2): (f64, f64), width: f64) -> [usize; 4] {
        let hw = width / 2.0;
        let xs = Self::span(x1.min(x2) - hw - 1.0, x1.max(x2) + hw + 1.0, self.w);
        let ys = Self::span(y1.min(y2) - hw - 1.0, y1.max(y2) + hw + 1.0, self.h);
        let (dx, dy) = (x2 - x1, y2 - y1);
        let len2 = dx * dx + dy * dy;
        for y in ys.clone() {
            for x in xs.clone() {
                let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                let t =
                    if len2 > 0.0 { (((px - x1) * dx + (py - y1) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
                let d = (px - x1 - t * dx).hypot(py - y1 - t * dy);
                let cov = (hw - d + 0.5).clamp(0.0, 1.0) as f32;
                let m = &mut self.mask[y * self.w + x];
                *m = m.max(cov);
            }
        }
        [xs.start, ys.start, xs.end, ys.end]
    }

    /// Composites the mask over its box with colour `c` and opacity `a`, and clears it.
    fn flush_mask(&mut self, b: [usize; 4], c: Rgb, a: f32) {
        for y in b[1]..b[3] {
            for x in b[0]..b[2] {
                let i = y * self.w + x;
                let m = std::mem::take(&mut self.mask[i]);
                self.blend(x, y, c, m * a);
            }
        }
    }

    /// Lines (or a polyline when `joined`) of `width`, composited once.
    fn stroke(&mut self, pts: &[Segment], width: f64, c: Rgb, a: f32) {
        let mut b = [usize::MAX, usize::MAX, 0, 0];
        for &(p, q) in pts {
            let s = self.mask_segment(p, q, width);
            b = [b[0].min(s[0]), b[1].min(s[1]), b[2].max(s[2]), b[3].max(s[3])];
        }
        if b[0] < b[2] && b[1] < b[3] {
            self.flush_mask(b, c, a);
        }
    }

    /// A disc (`ring` = None) or a ring of that width.
    fn circle(&mut self, cx: f64, cy: f64, r: f64, ring: Option<f64>, c: Rgb) {
        let reach = r + ring.unwrap_or(0.0) + 1.0;
        for y in Self::span(cy - reach, cy + reach, self.h) {
            for x in Self::span(cx - reach, cx + reach, self.w) {
                let d = (x as f64 + 0.5 - cx).hypot(y as f64 + 0.5 - cy);
                let cov = match ring {
                    None => r - d + 0.5,
                    Some(w) => w / 2.0 - (d - r).abs() + 0.5,
                };
                self.blend(x, y, c, cov.clamp(0.0, 1.0) as f32);
            }
        }
    }

    /// Text of `size` px; `y` is the baseline (or the middle of the capitals and
    /// x-height box when `middle_v`).
    #[allow(clippy::too_many_arguments)]
    fn text(
        &mut self,
        font: &FontRef<'_>,
        x: f64,
        y: f64,
        size: f64,
        s: &str,
        c: Rgb,
        mid_x: bool,
        mid_y: bool,
    ) {
        let f = font.as_scaled(PxScale::from(size as f32));
        let ids: Vec<_> = s.chars().map(|ch| f.glyph_id(ch)).collect();
        let mut width = 0.0f32;
        for (i, id) in ids.iter().enumerate() {
            if i > 0 {
                width += f.kern(ids[i - 1], *id);
            }
            width += f.h_advance(*id);
        }
        let mut pen = if mid_x { x as f32 - width / 2.0 } else { x as f32 };
        let base = if mid_y { y as f32 + (f.ascent() + f.descent()) / 2.0 } else { y as f32 };
        for (i, id) in ids.iter().enumerate() {
            if i > 0 {
                pen += f.kern(ids[i - 1], *id);
            }
            let glyph = id.with_scale_and_position(f.scale(), point(pen, base));
            pen += f.h_advance(*id);
            if let Some(outline) = font.outline_glyph(glyph) {
                let b = outline.px_bounds();
                outline.draw(|gx, gy, cov| {
                    let (px, py) = (b.min.x as i64 + i64::from(gx), b.min.y as i64 + i64::from(gy));
                    if px >= 0 && py >= 0 {
                        self.blend(px as usize, py as usize, c, cov);
                    }
                });
            }
        }
    }

    fn encode(&self) -> Result<Vec<u8>, String> {
        let mut out = Vec::new();
        {
            let mut enc = ::png::Encoder::new(&mut out, self.w as u32, self.h as u32);
            enc.set_color(::png::ColorType::Rgb);
            enc.set_depth(::png::BitDepth::Eight);
            let mut wr = enc.write_header().map_err(|e| e.to_string())?;
            let data: Vec<u8> =
                self.px.iter().flat_map(|p| p.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)).collect();
            wr.write_image_data(&data).map_err(|e| e.to_string())?;
        }
        Ok(out)
    }
}

/// The PNG of `pic`, [`PNG_SCALE`] pixels per unit.
pub(crate) fn png(pic: &Picture) -> Result<Vec<u8>, String> {
    let font = FontRef::try_from_slice(FONT).map_err(|_| "the embedded font cannot be read".to_string())?;
    let k = PNG_SCALE;
    let (w, h) = ((pic.width * k).ceil() as usize, (pic.height * k).ceil() as usize);
    if w == 0 || h == 0 || w > 16_384 || h > 16_384 {
        return Err(format!("a picture of {w}×{h} pixels cannot be drawn"));
    }
    let mut cv = Canvas::new(w, h);
    for shape in &pic.shapes {
        match shape {
            Shape::Rect { x, y, w, h, fill, stroke } => {
                let (x0, y0, x1, y1) = (x * k, y * k, (x + w) * k, (y + h) * k);
                if let Some(c) = fill {
                    cv.fill_rect(x0, y0, x1, y1, *c);
                }
                if let Some((c, sw)) = stroke {
                    let e = [
                        ((x0, y0), (x1, y0)),
                        ((x1, y0), (x1, y1)),
                        ((x1, y1), (x0, y1)),
                        ((x0, y1), (x0, y0)),
                    ];
                    cv.stroke(&e, sw * k, *c, 1.0);
                }
            }
            Shape::Lines { lines, color, width } => {
                let segs: Vec<_> =
                    lines.iter().map(|&(a, b, c, d)| ((a * k, b * k), (c * k, d * k))).collect();
                cv.stroke(&segs, width * k, *color, 1.0);
            }
            Shape::Polyline { points, color, opacity, width } => {
                let p: Vec<(f64, f64)> = points.iter().map(|&(x, y)| (x * k, y * k)).collect();
                let segs: Vec<Segment> = if p.len() == 1 {
                    vec![(p[0], p[0])]
                } else {
                    p.windows(2).map(|s| (s[0], s[1])).collect()
                };
                cv.stroke(&segs, width * k, *color, *opacity as f32);
            }
            Shape::Circle { cx, cy, r, fill, stroke } => {
                if let Some(c) = fill {
                    cv.circle(cx * k, cy * k, r * k, None, *c);
                }
                if let Some((c, sw)) = stroke {
                    cv.circle(cx * k, cy * k, r * k, Some(sw * k), *c);
                }
            }
            Shape::Text { x, y, size, text, color, anchor, bold: _, middle_v } => {
                let mid = *anchor == Anchor::Middle;
                cv.text(&font, x * k, y * k, size * k, text, *color, mid, *middle_v);
            }
        }
    }
    cv.encode()
}
