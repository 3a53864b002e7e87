//! Every figure type writes a decodable PNG of the promised size and a well-formed SVG,
//! names the file in its errors, and survives degenerate input (empty, constant, NaN).

use std::path::{Path, PathBuf};

use mmq_core::World;
use mmq_plot::{
    ARROW_E, ARROW_N, ARROW_W, ActionProbabilities, GridHeatmap, GridLayout, LineChart, PlotError,
    PolicyArrows, RefLine, Series,
};

const MAP: &str = "map = \"\"\"\nG..#\n.#..\n...S\n\"\"\"\n";

fn world() -> World {
    World::parse(MAP, "test.toml").unwrap()
}

/// Decoded PNG: (width, height, RGB bytes).
fn decode(path: &Path) -> (u32, u32, Vec<u8>) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{} is not a PNG", path.display());
    let dec = png::Decoder::new(std::io::Cursor::new(bytes));
    let mut reader = dec.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

/// Checks the two files and returns the PNG's size.
fn check_files(paths: &[PathBuf], base: &Path) -> (u32, u32) {
    assert_eq!(paths.len(), 2);
    assert_eq!(paths[0], PathBuf::from(format!("{}.svg", base.display())));
    assert_eq!(paths[1], PathBuf::from(format!("{}.png", base.display())));
    let svg = std::fs::read_to_string(&paths[0]).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"), "malformed SVG");
    let (w, h, px) = decode(&paths[1]);
    assert_eq!(px.len(), (w * h * 3) as usize);
    assert!(svg.contains(&format!("width=\"{w}\"")) && svg.contains(&format!("height=\"{h}\"")));
    (w, h)
}

/// Dark pixels in a band of rows: text and lines were drawn there.
fn dark_pixels(path: &Path, rows: std::ops::Range<u32>) -> usize {
    let (w, _, px) = decode(path);
    rows.flat_map(|y| (0..w).map(move |x| ((y * w + x) * 3) as usize))
        .filter(|&i| px[i] < 100 && px[i + 1] < 100 && px[i + 2] < 100)
        .count()
}

fn chart() -> LineChart {
    let x: Vec<f64> = (0..20).map(f64::from).collect();
    let y: Vec<f64> = x.iter().map(|v| (v / 5.0).sin()).collect();
    let mut c = LineChart::new("Relative performance", "mean delay λ̂ (steps)", "relative performance");
    c.series.push(
        Series::new("MMQ", x.clone(), y.clone())
            .with_band(y.iter().map(|v| v - 0.1).collect(), y.iter().map(|v| v + 0.1).collect())
            .with_markers(),
    );
    c.series.push(Series::new("Q", x, vec![0.0; 20]));
    c.ref_lines.push(RefLine::new("undelayed", 1.0));
    c
}

#[test]
fn line_chart_writes_svg_and_png() {
    let dir = tempfile::tempdir().unwrap();
    let base = dir.path().join("chart");
    let paths = chart().write(&base).unwrap();
    assert_eq!(check_files(&paths, &base), (800, 560));
    let svg = std::fs::read_to_string(&paths[0]).unwrap();
    for text in ["Relative performance", "mean delay λ̂ (steps)", "MMQ", "undelayed"] {
        assert!(svg.contains(text), "SVG lacks {text:?}");
    }
    // The title is rendered in the PNG with the embedded font.
    assert!(dark_pixels(&paths[1], 10..40) > 200);
}

#[test]
fn log_x_chart_renders() {
    let dir = tempfile::tempdir().unwrap();
    let mut c = chart();
    c.x_log = true;
    c.series[1].x[0] = -1.0; // non-positive x is left out on a log axis
    let base = dir.path().join("log");
    assert_eq!(check_files(&c.write(&base).unwrap(), &base), (800, 560));
}

#[test]
fn grid_figures_write_svg_and_png() {
    let dir = tempfile::tempdir().unwrap();
    let w = world();
    let n = w.num_cells();

    let base = dir.path().join("visits");
    let values: Vec<f64> = (0..n).map(|c| (c * c) as f64).collect();
    let (wd, ht) =
        check_files(&GridHeatmap::new("Visits", &w, values, "visits").log().write(&base).unwrap(), &base);
    assert!(wd > 400 && ht > 300, "{wd}×{ht}");
    assert!(dark_pixels(&base.with_extension("png"), 10..40) > 50);

    let base = dir.path().join("policy");
    let arrows =
        vec![0b1111, ARROW_W, ARROW_W, 0, ARROW_N, 0, ARROW_N | ARROW_W, ARROW_E, ARROW_N, ARROW_W, 3, 5];
    let fig = PolicyArrows::new("Policy", &w, arrows).with_path(vec![11, 7, 3]);
    check_files(&fig.write(&base).unwrap(), &base);

    let base = dir.path().join("probs");
    let probs = vec![[0.25, 0.25, 0.25, 0.25]; n];
    check_files(&ActionProbabilities::new("Probabilities", &w, probs).write(&base).unwrap(), &base);
}

/// N points up: in a one-column world, an N arrow in the middle cell puts ink above the
/// cell centre and none below it.
#[test]
fn north_arrow_points_up() {
    let dir = tempfile::tempdir().unwrap();
    let mut grid = GridLayout::open(1, 3);
    grid.goal = None;
    let fig =
        PolicyArrows { title: String::new(), grid, arrows: vec![0, ARROW_N, 0], highlight_path: vec![] };
    let base = dir.path().join("north");
    let paths = fig.write(&base).unwrap();
    let (w, h, px) = decode(&paths[1]);
    // Blue arrow pixels (Okabe–Ito blue 0,114,178), by row.
    let blue_rows: Vec<u32> = (0..h)
        .filter(|&y| {
            (0..w).any(|x| {
                let i = ((y * w + x) * 3) as usize;
                px[i] < 60 && px[i + 1] > 80 && px[i + 1] < 150 && px[i + 2] > 140
            })
        })
        .collect();
    assert!(!blue_rows.is_empty());
    let (top, bottom) = (blue_rows[0], *blue_rows.last().unwrap());
    // The arrow head (the widest row) is in the upper half of the arrow.
    let width = |y: u32| {
        (0..w)
            .filter(|&x| {
                let i = ((y * w + x) * 3) as usize;
                px[i] < 60 && px[i + 1] > 80 && px[i + 1] < 150 && px[i + 2] > 140
            })
            .count()
    };
    let widest = (top..=bottom).max_by_key(|&y| width(y)).unwrap();
    assert!(widest < (top + bottom) / 2, "head at row {widest}, arrow rows {top}..{bottom}");
    // And the arrow is centred on the middle cell, vertically.
    assert!(((top + bottom) as i64 - h as i64).abs() < h as i64 / 5, "{top}..{bottom} of {h}");
}

#[test]
fn unwritable_path_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let base = dir.path().join("no-such-dir").join("fig");
    let err = chart().write(&base).unwrap_err();
    assert!(matches!(err, PlotError::Write { .. }), "{err:?}");
    let msg = err.to_string();
    assert!(msg.contains(&format!("{}.svg", base.display())), "{msg}");
    assert_eq!(err.path(), Path::new(&format!("{}.svg", base.display())));
}

#[test]
fn inconsistent_input_is_an_error_naming_the_figure() {
    let dir = tempfile::tempdir().unwrap();
    let base = dir.path().join("bad");
    let mut c = chart();
    c.series[0].y.pop();
    let msg = c.write(&base).unwrap_err().to_string();
    assert!(msg.contains(&base.display().to_string()) && msg.contains("`MMQ`"), "{msg}");

    let mut c = chart();
    c.y_range = Some((1.0, 1.0));
    assert!(matches!(c.write(&base), Err(PlotError::Input { .. })));

    let w = world();
    let err = GridHeatmap::new("t", &w, vec![1.0; 3], "v").write(&base).unwrap_err();
    assert!(err.to_string().contains("3 entries"), "{err}");
    let err = PolicyArrows::new("t", &w, vec![0; 12]).with_path(vec![99]).write(&base).unwrap_err();
    assert!(err.to_string().contains("99"), "{err}");
    let fig = GridHeatmap { grid: GridLayout::open(0, 0), ..GridHeatmap::default() };
    assert!(matches!(fig.write(&base), Err(PlotError::Input { .. })));
    // Nothing was written.
    assert!(!dir.path().join("bad.svg").exists());
}

#[test]
fn degenerate_input_does_not_panic() {
    let dir = tempfile::tempdir().unwrap();
    let out = |name: &str| dir.path().join(name);
    let nan = f64::NAN;

    // Charts: nothing at all, empty series, one point, constant, NaN and infinities, huge.
    LineChart::default().write(&out("default")).unwrap();
    let mut c = LineChart::new("", "", "");
    c.series.push(Series::new("empty", vec![], vec![]));
    c.series.push(Series::new("one", vec![3.0], vec![2.0]));
    c.write(&out("one")).unwrap();
    let mut c = LineChart::new("const", "x", "y");
    c.series.push(Series::new("flat", vec![1.0, 1.0, 1.0], vec![5.0, 5.0, 5.0]).with_markers());
    c.x_log = true;
    c.write(&out("const")).unwrap();
    let mut c = LineChart::new("nan", "x", "y");
    c.series.push(
        Series::new("gaps", vec![0.0, 1.0, nan, 3.0, 4.0, f64::INFINITY], vec![nan, 1.0, 2.0, nan, 4.0, 5.0])
            .with_band(vec![nan; 6], vec![f64::INFINITY; 6]),
    );
    c.series.push(Series::new("all nan", vec![nan; 3], vec![nan; 3]));
    c.ref_lines.push(RefLine::new("nan ref", nan));
    c.write(&out("nan")).unwrap();
    let mut c = LineChart::new("huge", "x", "y");
    c.series.push(Series::new("big", vec![0.0, 1e300], vec![-1e300, 1e300]));
    c.series.push(Series::new("tiny", vec![0.0, 1e-300], vec![0.0, 1e-300]));
    c.write(&out("huge")).unwrap();
    let mut c = chart();
    c.y_range = Some((0.2, 0.3)); // most data clipped away
    for _ in 0..8 {
        c.series.push(Series::new("many", vec![0.0, 19.0], vec![0.25, 0.26]));
    }
    c.write(&out("clipped")).unwrap();

    // Grids: all equal, all NaN, NaN probabilities, out-of-range probabilities, no G/S.
    let w = world();
    let n = w.num_cells();
    GridHeatmap::new("equal", &w, vec![7.0; n], "v").write(&out("equal")).unwrap();
    GridHeatmap::new("zeros", &w, vec![0.0; n], "v").log().write(&out("zeros")).unwrap();
    GridHeatmap::new("nan", &w, vec![nan; n], "").log().write(&out("allnan")).unwrap();
    let mut probs = vec![[nan, 2.0, -1.0, 0.5]; n];
    probs[0] = [f64::INFINITY; 4];
    ActionProbabilities::new("", &w, probs).write(&out("badprobs")).unwrap();
    let fig =
        PolicyArrows { grid: GridLayout::open(40, 1), arrows: vec![0xff; 40], ..PolicyArrows::default() };
    fig.write(&out("strip")).unwrap();
}

#[test]
fn output_is_deterministic() {
    let dir = tempfile::tempdir().unwrap();
    let a = chart().write(&dir.path().join("a")).unwrap();
    let b = chart().write(&dir.path().join("b")).unwrap();
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(std::fs::read(x).unwrap(), std::fs::read(y).unwrap(), "{}", x.display());
    }
}

/// A noisy per-step curve (sharp turns everywhere) stays inside the plot: plotters'
/// mitred thick lines would shoot spikes over the title and below the axis.
#[test]
fn noisy_curves_stay_inside_the_plot() {
    let dir = tempfile::tempdir().unwrap();
    let x: Vec<f64> = (0..50_000).map(f64::from).collect();
    let y: Vec<f64> = x.iter().map(|t| ((t * 12.9898).sin() * 43_758.545).fract()).collect();
    let mut c = LineChart::new("Noise", "t", "y");
    // Unnamed: no legend (it would go below the chart), so the bottom band holds only the
    // x axis.
    c.series.push(Series::new("", x, y));
    let base = dir.path().join("noise");
    let paths = c.write(&base).unwrap();
    let (w, h, px) = decode(&paths[1]);
    let blue = |y: u32| {
        (0..w).any(|x| {
            let i = ((y * w + x) * 3) as usize;
            px[i] < 60 && px[i + 1] > 80 && px[i + 1] < 150 && px[i + 2] > 140
        })
    };
    assert!((0..40).all(|y| !blue(y)), "line pixels in the title band");
    assert!((h - 60..h).all(|y| !blue(y)), "line pixels in the x-axis label band");
    assert!((100..400).any(blue));
    // Long input is decimated: the SVG stays small.
    assert!(std::fs::metadata(&paths[0]).unwrap().len() < 400_000);
}
