//! Rendering plumbing shared by every figure: the embedded font, the scale-aware drawing
//! helpers, the colour palettes, tick placement and number formatting, and the one
//! function that renders a figure to SVG and (supersampled) PNG and writes both files.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{FontFamily, FontStyle, FontTransform, register_font};

use crate::PlotError;

/// DejaVu Sans (Bitstream Vera licence, see `assets/DejaVuSans-LICENSE.txt`), embedded so
/// PNG text renders on a machine without any system font.
static DEJAVU_SANS: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// PNGs are drawn at this many times their size and box-filtered down: plotters' bitmap
/// backend does not anti-alias lines and polygons, supersampling does.
const PNG_SUPERSAMPLE: u32 = 2;

/// Registers the embedded font as plotters' `sans-serif` family (once per process).
fn ensure_font() -> Result<(), String> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            register_font("sans-serif", FontStyle::Normal, DEJAVU_SANS)
                .map_err(|_| "the embedded DejaVu Sans font could not be parsed".to_string())
        })
        .clone()
}

/// Drawing error of a backend, as text.
pub(crate) type DrawResult<DB> = Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// A figure that can be drawn at any scale on any plotters backend.
pub(crate) trait Figure {
    /// Checks the input; the message says what is inconsistent.
    fn validate(&self) -> Result<(), String>;
    /// Size in logical pixels (the SVG size and the PNG size).
    fn size(&self) -> (u32, u32);
    /// Draws the whole figure on `root`, every length multiplied by `ink.k`.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, ink: Ink) -> DrawResult<DB>;
}

/// `base` with `.ext` appended to its file name (`fig.v2` → `fig.v2.svg`).
fn with_suffix(base: &Path, ext: &str) -> PathBuf {
    let mut s = base.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// Renders `fig` and writes `<base>.svg` and `<base>.png`; returns both paths.
pub(crate) fn write_figure<F: Figure>(fig: &F, base: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let svg_path = with_suffix(base, "svg");
    let png_path = with_suffix(base, "png");
    fig.validate().map_err(|message| PlotError::Input { path: base.to_path_buf(), message })?;
    ensure_font().map_err(|message| PlotError::Render { path: svg_path.clone(), message })?;
    let size = fig.size();
    let svg =
        render_svg(fig, size).map_err(|message| PlotError::Render { path: svg_path.clone(), message })?;
    let png =
        render_png(fig, size).map_err(|message| PlotError::Render { path: png_path.clone(), message })?;
    // Each file whole or not at all: a full disk never leaves a cut figure behind.
    let write = |path: &PathBuf, bytes: &[u8]| {
        mmq_core::files::write_atomic(path, bytes)
            .map_err(|source| PlotError::Write { path: path.clone(), source })
    };
    write(&svg_path, svg.as_bytes())?;
    write(&png_path, &png)?;
    Ok(vec![svg_path, png_path])
}

fn render_svg<F: Figure>(fig: &F, (w, h): (u32, u32)) -> Result<String, String> {
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (w, h)).into_drawing_area();
        fig.draw(&root, Ink { k: 1.0, bitmap: false }).map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(text)
}

/// The figure as 8-bit RGB rows of `w` × `h` pixels (supersampled, then box-filtered).
pub(crate) fn render_rgb<F: Figure>(fig: &F, (w, h): (u32, u32)) -> Result<Vec<u8>, String> {
    let s = PNG_SUPERSAMPLE;
    let (big_w, big_h) = (w * s, h * s);
    let mut big = vec![255u8; (big_w * big_h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut big, (big_w, big_h)).into_drawing_area();
        fig.draw(&root, Ink { k: f64::from(s), bitmap: true }).map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())?;
    }
    // Box filter s×s → 1.
    let (w, h, s) = (w as usize, h as usize, s as usize);
    let mut small = vec![0u8; w * h * 3];
    for y in 0..h {
        for x in 0..w {
            for ch in 0..3 {
                let mut sum = 0u32;
                for dy in 0..s {
                    for dx in 0..s {
                        sum += u32::from(big[((y * s + dy) * w * s + x * s + dx) * 3 + ch]);
                    }
                }
                small[(y * w + x) * 3 + ch] = ((sum + (s * s / 2) as u32) / (s * s) as u32) as u8;
            }
        }
    }
    Ok(small)
}

fn render_png<F: Figure>(fig: &F, (w, h): (u32, u32)) -> Result<Vec<u8>, String> {
    let small = render_rgb(fig, (w, h))?;
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut writer = enc.write_header().map_err(|e| e.to_string())?;
        writer.write_image_data(&small).map_err(|e| e.to_string())?;
        writer.finish().map_err(|e| e.to_string())?;
    }
    Ok(out)
}

/// Scale of one rendering: logical pixels × `k` = backend pixels; `bitmap` for the PNG
/// backend, whose text placement [`Ink::label`] corrects.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Ink {
    pub k: f64,
    pub bitmap: bool,
}

impl Ink {
    /// A logical length in backend pixels.
    pub fn p(self, v: f64) -> i32 {
        (v * self.k).round() as i32
    }

    /// A logical length in backend pixels, at least 1.
    pub fn pu(self, v: f64) -> u32 {
        (v * self.k).round().max(1.0) as u32
    }

    /// The embedded sans-serif font at a logical size.
    pub fn font(self, size: f64) -> FontDesc<'static> {
        FontDesc::new(FontFamily::SansSerif, size * self.k, FontStyle::Normal)
    }

    /// Draws `text` at logical font `size`, anchored at `pos` (backend pixels) by `(h, v)`,
    /// reading bottom to top if `up`.
    ///
    /// The SVG backend leaves text to the viewer. On the bitmap backend, plotters' ab_glyph
    /// path puts the baseline about 0.11 × size higher than the SVG does and ignores glyph
    /// side bearings, which strands combining accents (λ̂ = λ + U+0302) after their letter;
    /// this corrects the baseline and draws each accent as its spacing form centred over
    /// its letter.
    #[allow(clippy::too_many_arguments)]
    pub fn label<DB: DrawingBackend>(
        self,
        root: &DrawingArea<DB, Shift>,
        text: &str,
        size: f64,
        color: RGBColor,
        (h, v): (HPos, VPos),
        up: bool,
        pos: (i32, i32),
    ) -> DrawResult<DB> {
        if text.is_empty() {
            return Ok(());
        }
        let font = if up { self.font(size).transform(FontTransform::Rotate270) } else { self.font(size) };
        let style = font.color(&color).pos(Pos::new(h, v));
        if !self.bitmap {
            return root.draw_text(text, &style, pos);
        }
        // Offsets (along the text, across it towards its bottom) in backend pixels → screen.
        let at = |along: f64, across: f64| -> (i32, i32) {
            let (dx, dy) = if up { (across, -along) } else { (along, across) };
            (pos.0 + dx.round() as i32, pos.1 + dy.round() as i32)
        };
        let px = size * self.k;
        let drop = 0.11 * px;
        let mut base = String::new();
        let mut marks: Vec<(usize, char)> = Vec::new();
        for c in text.chars() {
            if ('\u{300}'..='\u{36f}').contains(&c) {
                marks.push((base.chars().count(), c));
            } else {
                base.push(c);
            }
        }
        root.draw_text(&base, &style, at(0.0, drop))?;
        if marks.is_empty() {
            return Ok(());
        }
        let plain = FontDesc::new(FontFamily::SansSerif, px, FontStyle::Normal);
        let width = |s: &str| plain.box_size(s).map(|(w, _)| f64::from(w)).unwrap_or(0.0);
        let total = width(&base);
        let left = match h {
            HPos::Left => 0.0,
            HPos::Center => -total / 2.0,
            HPos::Right => -total,
        };
        let mark_style = font.color(&color).pos(Pos::new(HPos::Center, v));
        for (n, mark) in marks {
            let Some(spacing) = spacing_accent(mark) else { continue };
            if n == 0 {
                continue;
            }
            let prefix: String = base.chars().take(n).collect();
            let last: String = base.chars().nth(n - 1).into_iter().collect();
            let centre = left + width(&prefix) - width(&last) / 2.0 + 0.04 * px;
            root.draw_text(&spacing.to_string(), &mark_style, at(centre, drop - 0.16 * px))?;
        }
        Ok(())
    }
}

/// The spacing form of a combining accent, drawn over the letter by hand.
fn spacing_accent(c: char) -> Option<char> {
    Some(match c {
        '\u{300}' => '`',
        '\u{301}' => '\u{b4}',
        '\u{302}' => '\u{2c6}',
        '\u{303}' => '\u{2dc}',
        '\u{304}' | '\u{305}' => '\u{2c9}',
        '\u{306}' => '\u{2d8}',
        '\u{307}' => '\u{2d9}',
        '\u{308}' => '\u{a8}',
        '\u{30c}' => '\u{2c7}',
        _ => return None,
    })
}

/// Width and height of `text` at a logical font size, in logical pixels.
pub(crate) fn text_size(text: &str, size: f64) -> (f64, f64) {
    if ensure_font().is_err() || text.is_empty() {
        return (0.0, 0.0);
    }
    let font = FontDesc::new(FontFamily::SansSerif, size, FontStyle::Normal);
    font.box_size(text)
        .map(|(w, h)| (f64::from(w), f64::from(h)))
        .unwrap_or((0.6 * size * text.len() as f64, size))
}

/// Text colour for the figure's text.
pub(crate) const INK: RGBColor = RGBColor(20, 20, 20);
/// Blocked cells.
pub(crate) const BLOCKED: RGBColor = RGBColor(64, 64, 64);
/// Cells with no data (NaN).
pub(crate) const NO_DATA: RGBColor = RGBColor(235, 235, 235);

/// The Okabe–Ito colour-blind-safe palette, without black (kept for reference lines)
/// and yellow (too light on white).
pub(crate) const PALETTE: [RGBColor; 6] = [
    RGBColor(0, 114, 178),   // blue
    RGBColor(213, 94, 0),    // vermillion
    RGBColor(0, 158, 115),   // bluish green
    RGBColor(204, 121, 167), // reddish purple
    RGBColor(230, 159, 0),   // orange
    RGBColor(86, 180, 233),  // sky blue
];

/// Colours of reference lines, in order.
pub(crate) const REF_COLORS: [RGBColor; 3] =
    [RGBColor(0, 0, 0), RGBColor(110, 110, 110), RGBColor(170, 120, 0)];

/// Viridis at nine evenly spaced stops (perceptually uniform, colour-blind safe, prints
/// in grey scale).
const VIRIDIS: [(u8, u8, u8); 9] = [
    (68, 1, 84),
    (72, 40, 120),
    (62, 73, 137),
    (49, 104, 142),
    (38, 130, 142),
    (31, 158, 137),
    (53, 183, 121),
    (109, 205, 89),
    (253, 231, 37),
];

/// Viridis colour of `t` in [0, 1] (clamped).
pub(crate) fn viridis(t: f64) -> RGBColor {
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 };
    let x = t * (VIRIDIS.len() - 1) as f64;
    let i = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let f = x - i as f64;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    let lerp = |p: u8, q: u8| (f64::from(p) + (f64::from(q) - f64::from(p)) * f).round() as u8;
    RGBColor(lerp(a.0, b.0), lerp(a.1, b.1), lerp(a.2, b.2))
}

/// `c` blended over white with opacity `a`, as an opaque colour (identical in SVG and PNG).
pub(crate) fn tint(c: RGBColor, a: f64) -> RGBColor {
    let m = |v: u8| (255.0 - (255.0 - f64::from(v)) * a).round() as u8;
    RGBColor(m(c.0), m(c.1), m(c.2))
}

/// Black or white, whichever reads better on `c`.
pub(crate) fn contrast(c: RGBColor) -> RGBColor {
    let lum = 0.2126 * f64::from(c.0) + 0.7152 * f64::from(c.1) + 0.0722 * f64::from(c.2);
    if lum > 140.0 { RGBColor(0, 0, 0) } else { RGBColor(255, 255, 255) }
}

/// A 1-2-5 step giving about `target` intervals over `span`.
pub(crate) fn nice_step(span: f64, target: usize) -> f64 {
    let raw = span / target.max(1) as f64;
    if !(raw.is_finite() && raw > 0.0) {
        return 1.0;
    }
    let mag = 10f64.powf(raw.log10().floor());
    let f = raw / mag;
    let nf = if f < 1.5 {
        1.0
    } else if f < 3.0 {
        2.0
    } else if f < 7.0 {
        5.0
    } else {
        10.0
    };
    nf * mag
}

/// Tick values at multiples of a nice step inside [lo, hi], and the step.
pub(crate) fn nice_ticks(lo: f64, hi: f64, target: usize) -> (Vec<f64>, f64) {
    let step = nice_step(hi - lo, target);
    let first = (lo / step - 1e-9).ceil() as i64;
    let last = (hi / step + 1e-9).floor() as i64;
    let ticks =
        if last - first > 1000 { Vec::new() } else { (first..=last).map(|i| i as f64 * step).collect() };
    (ticks, step)
}

/// Ticks of a log10 axis over [lo, hi] (both log10 values): (labelled, minor), in log10.
pub(crate) fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    let (d0, d1) = (lo.floor() as i64, hi.ceil() as i64);
    if d1 - d0 > 400 {
        return (Vec::new(), Vec::new());
    }
    let inside = |v: f64| v >= lo - 1e-9 && v <= hi + 1e-9;
    let mut decades: Vec<f64> = (d0..=d1).map(|d| d as f64).filter(|&v| inside(v)).collect();
    let mut minor = Vec::new();
    let mut with_125 = Vec::new();
    for d in d0..=d1 {
        for m in 2..=9 {
            let v = d as f64 + f64::from(m).log10();
            if inside(v) {
                minor.push(v);
                if m == 2 || m == 5 {
                    with_125.push(v);
                }
            }
        }
    }
    if decades.len() > 8 {
        // Too many decades for labels: label every other (or every n-th).
        let every = decades.len().div_ceil(7);
        decades.retain(|&v| (v as i64).rem_euclid(every as i64) == 0);
    }
    if decades.len() < 2 {
        decades.extend(with_125);
        decades.sort_by(f64::total_cmp);
        minor.retain(|m| !decades.iter().any(|d| (d - m).abs() < 1e-9));
    }
    if decades.len() < 2 {
        // Less than a factor of ~2.5 between the ends: linear ticks on the values.
        let (t, _) = nice_ticks(10f64.powf(lo), 10f64.powf(hi), 4);
        decades = t.into_iter().filter(|&v| v > 0.0).map(f64::log10).collect();
        minor.clear();
    }
    (decades, minor)
}

/// Unicode minus for negative numbers.
fn minus(s: String) -> String {
    match s.strip_prefix('-') {
        Some(rest) => format!("\u{2212}{rest}"),
        None => s,
    }
}

/// A tick label for `v` on an axis whose ticks are `step` apart: as many decimals as the
/// step needs, thousands as `k` and millions as `M` once the step is that large.
pub(crate) fn fmt_tick(v: f64, step: f64) -> String {
    if v.abs() < step.abs() * 1e-6 {
        return "0".into();
    }
    let dec = |st: f64| (-(st.abs().log10() + 1e-9).floor()).max(0.0) as usize;
    if v.abs() >= 1e6 && step >= 1e5 {
        return minus(format!("{:.*}M", dec(step / 1e6), v / 1e6));
    }
    if v.abs() >= 1e4 && step >= 1e3 {
        return minus(format!("{:.*}k", dec(step / 1e3), v / 1e3));
    }
    minus(format!("{:.*}", dec(step), v))
}

/// A label for a tick at log10 value `l` of a log axis.
pub(crate) fn fmt_log_tick(l: f64) -> String {
    let v = 10f64.powf(l);
    let e = l.round();
    if (l - e).abs() < 1e-9 && !(-3.0..=6.0).contains(&e) {
        return format!("10{}", superscript(e as i64));
    }
    // Significant digits only.
    let s = format!("{:.*}", ((-l).ceil().max(0.0) as usize) + 1, v);
    let s = if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s };
    let n: f64 = s.parse().unwrap_or(v);
    if n >= 1e4 {
        let step = 10f64.powf(n.log10().floor());
        return fmt_tick(n, step);
    }
    s
}

fn superscript(n: i64) -> String {
    const D: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    let mut s: String = n.unsigned_abs().to_string().chars().map(|c| D[c as usize - '0' as usize]).collect();
    if n < 0 {
        s.insert(0, '⁻');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_numbers() {
        let (t, s) = nice_ticks(0.0, 1.0, 5);
        assert_eq!(s, 0.2);
        assert_eq!(t.len(), 6);
        assert_eq!(fmt_tick(t[3], s), "0.6");
        let (t, s) = nice_ticks(0.0, 150_000.0, 6);
        assert_eq!(s, 20_000.0);
        assert_eq!(fmt_tick(t[1], s), "20k");
        assert_eq!(fmt_tick(-3.0, 1.0), "\u{2212}3");
        assert_eq!(fmt_tick(2_500_000.0, 500_000.0), "2.5M");
    }

    #[test]
    fn log_ticks_label_decades() {
        let (b, m) = log_ticks(0.0, 3.0);
        assert_eq!(b, vec![0.0, 1.0, 2.0, 3.0]);
        assert_eq!(m.len(), 24);
        assert_eq!(fmt_log_tick(2.0), "100");
        assert_eq!(fmt_log_tick(-2.0), "0.01");
        assert_eq!(fmt_log_tick(4.0), "10k");
        assert_eq!(fmt_log_tick(9.0), "10⁹");
        assert_eq!(fmt_log_tick(2f64.log10()), "2");
        let (b, _) = log_ticks(0.1, 0.6);
        assert!(b.len() >= 2, "{b:?}");
    }

    #[test]
    fn viridis_ends() {
        assert_eq!(viridis(0.0), RGBColor(68, 1, 84));
        assert_eq!(viridis(1.0), RGBColor(253, 231, 37));
        assert_eq!(viridis(f64::NAN), RGBColor(68, 1, 84));
        assert_eq!(contrast(viridis(1.0)), RGBColor(0, 0, 0));
        assert_eq!(contrast(viridis(0.0)), RGBColor(255, 255, 255));
    }
}
