//! [`render`]: a picture of the arena (walls, blocked cells, G, S) with the trajectory read
//! from `/robot/pose`, a scale bar in metres and a legend, as SVG and PNG.
//!
//! The picture is built once as a list of shapes (`scene.rs`); `svg.rs` writes it as SVG
//! text and `raster.rs` draws it into pixels (anti-aliased) for the PNG, so both files show
//! the same thing. No plotting library: the PNG is drawn here and encoded with `png`, its
//! text with the DejaVu Sans font that `mmq-plot` also embeds (`ab_glyph` outlines).

use std::path::{Path, PathBuf};

use crate::error::LogError;
use crate::reader::{LogContents, PoseStamp};

mod raster;
mod scene;
mod svg;

pub use scene::window_poses;

/// Draws the arena and the trajectory of steps `window` = (from, to), inclusive (`None`:
/// everything recorded), to the SVG file `out` and a PNG next to it (`out` with the
/// extension `png`); their folder is created if needed. Returns both paths.
///
/// The trajectory is broken at teleports, at jumps longer than 1.5 cells and at gaps in
/// time (between recording windows); it starts with a hollow circle and ends with a
/// filled one. Each file is written atomically: to a temporary file in the same folder,
/// then renamed; on an error the temporary file is removed and the error names the file.
pub fn render(log: &LogContents, out: &Path, window: Option<(u64, u64)>) -> Result<[PathBuf; 2], LogError> {
    let pic = scene::build(log, window)?;
    let svg = svg::write(&pic);
    let png = raster::png(&pic).map_err(|message| LogError::Io {
        path: out.with_extension("png"),
        action: "draw the picture",
        source: std::io::Error::other(message),
    })?;
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| LogError::Io {
            path: out.to_path_buf(),
            action: "create the picture's folder",
            source,
        })?;
    }
    let png_path = out.with_extension("png");
    write_atomic(out, svg.as_bytes())?;
    write_atomic(&png_path, &png)?;
    Ok([out.to_path_buf(), png_path])
}

/// Writes `bytes` to a temporary file next to `path`, then renames it to `path`; on an
/// error the temporary file is removed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), LogError> {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
    let err = |source| LogError::Io { path: path.to_path_buf(), action: "write the picture", source };
    let written = std::fs::write(&tmp, bytes).and_then(|()| std::fs::rename(&tmp, path));
    written.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        err(e)
    })
}

/// The SVG text of [`render`].
pub fn render_svg(log: &LogContents, window: Option<(u64, u64)>) -> Result<String, LogError> {
    Ok(svg::write(&scene::build(log, window)?))
}

/// The PNG bytes of [`render`].
pub fn render_png(log: &LogContents, window: Option<(u64, u64)>) -> Result<Vec<u8>, LogError> {
    let pic = scene::build(log, window)?;
    raster::png(&pic).map_err(|message| LogError::Io {
        path: log.path.clone(),
        action: "draw the picture",
        source: std::io::Error::other(message),
    })
}

/// Splits poses into polylines at teleports, long jumps and time gaps.
fn segments(log: &LogContents, poses: &[PoseStamp], cell: f64) -> Vec<Vec<PoseStamp>> {
    let mut dts: Vec<u64> = poses.windows(2).map(|w| w[1].log_time.saturating_sub(w[0].log_time)).collect();
    dts.sort_unstable();
    let typical = dts.get(dts.len() / 2).copied().unwrap_or(0).max(1);
    let tele: Vec<u64> = log.teleports.iter().map(|t| t.log_time).collect();
    let mut out: Vec<Vec<PoseStamp>> = Vec::new();
    let mut cur: Vec<PoseStamp> = Vec::new();
    for &p in poses {
        if let Some(q) = cur.last() {
            let jump = (p.x - q.x).hypot(p.y - q.y) > 1.5 * cell;
            let teleported =
                tele.partition_point(|&t| t <= q.log_time) < tele.partition_point(|&t| t <= p.log_time);
            let gap = p.log_time.saturating_sub(q.log_time) > 5 * typical;
            if jump || teleported || gap {
                out.push(std::mem::take(&mut cur));
            }
        }
        cur.push(p);
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}
