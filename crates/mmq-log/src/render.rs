//! [`render`]: an SVG of the arena (walls, blocked cells, G, S) with the trajectory read
//! from `/robot/pose`. Plain SVG text, no plotting library.

use std::fmt::Write as _;
use std::path::Path;

use crate::error::LogError;
use crate::reader::{LogContents, PoseStamp};

/// Draws the arena and the trajectory of steps `window` = (from, to), inclusive (`None`:
/// everything recorded), to the SVG file `out` (its folder is created if needed).
///
/// The trajectory is broken at teleports, at jumps longer than 1.5 cells and at gaps in
/// time (between recording windows); it starts with a hollow circle and ends with a
/// filled one.
pub fn render(log: &LogContents, out: &Path, window: Option<(u64, u64)>) -> Result<(), LogError> {
    let svg = render_svg(log, window)?;
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| LogError::Io {
            path: out.to_path_buf(),
            action: "create the picture's folder",
            source,
        })?;
    }
    std::fs::write(out, svg).map_err(|source| LogError::Io {
        path: out.to_path_buf(),
        action: "write the picture",
        source,
    })
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

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// The SVG text of [`render`].
pub fn render_svg(log: &LogContents, window: Option<(u64, u64)>) -> Result<String, LogError> {
    let world = log.world()?;
    let cs = world.cell_size;
    let (w, h) = (world.width as f64, world.height as f64);
    let px = (1000.0 / w.max(h)).clamp(6.0, 48.0);
    let (margin, header) = (16.0, 28.0);
    let width = 2.0 * margin + w * px;
    let height = 2.0 * margin + header + h * px;
    // World metres → SVG pixels (y down).
    let sx = |x: f64| margin + x / cs * px;
    let sy = |y: f64| margin + header + (h - y / cs) * px;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0}" height="{height:.0}" viewBox="0 0 {width:.1} {height:.1}" font-family="sans-serif">"#
    );
    let _ = writeln!(s, r##"<rect width="100%" height="100%" fill="#ffffff"/>"##);
    let fact = |k: &str| log.run_fact(k).unwrap_or("?").to_string();
    let steps = match window {
        Some((a, b)) => format!("steps {a}–{b}"),
        None => "all recorded steps".to_string(),
    };
    let title = format!("{} · {} · seed {} · {steps}", world.name, fact("learner"), fact("seed"));
    let _ = writeln!(
        s,
        r##"<text x="{margin}" y="{}" font-size="14" fill="#222">{}</text>"##,
        margin + 14.0,
        esc(&title)
    );
    // Floor and cell lines.
    let (x0, y0) = (sx(0.0), sy(h * cs));
    let _ = writeln!(
        s,
        r##"<rect x="{x0:.1}" y="{y0:.1}" width="{:.1}" height="{:.1}" fill="#f4f4ef"/>"##,
        w * px,
        h * px
    );
    let _ = write!(s, r##"<path stroke="#dddddd" stroke-width="0.5" d=""##);
    for i in 1..world.width {
        let _ = write!(s, "M{:.1} {y0:.1}V{:.1}", x0 + i as f64 * px, y0 + h * px);
    }
    for j in 1..world.height {
        let _ = write!(s, "M{x0:.1} {:.1}H{:.1}", y0 + j as f64 * px, x0 + w * px);
    }
    let _ = writeln!(s, r#""/>"#);
    // Cells: blocked, goal, respawn.
    for c in 0..world.num_cells() {
        let (r, col) = world.row_col(c);
        let (x, y) = (x0 + col as f64 * px, y0 + r as f64 * px);
        let fill = if !world.is_free(c) {
            "#5a5a66"
        } else if c == world.goal {
            "#4cbf5a"
        } else if c == world.respawn {
            "#4f7fe0"
        } else {
            continue;
        };
        let _ =
            writeln!(s, r#"<rect x="{x:.1}" y="{y:.1}" width="{px:.1}" height="{px:.1}" fill="{fill}"/>"#);
        if world.is_free(c) {
            let label = if c == world.goal { "G" } else { "S" };
            let _ = writeln!(
                s,
                r##"<text x="{:.1}" y="{:.1}" font-size="{:.1}" fill="#ffffff" text-anchor="middle" dominant-baseline="central" font-weight="bold">{label}</text>"##,
                x + px / 2.0,
                y + px / 2.0,
                0.6 * px
            );
        }
    }
    // Boundary wall.
    let _ = writeln!(
        s,
        r##"<rect x="{x0:.1}" y="{y0:.1}" width="{:.1}" height="{:.1}" fill="none" stroke="#5a5a66" stroke-width="{:.1}"/>"##,
        w * px,
        h * px,
        (0.12 * px).max(2.0)
    );
    // Trajectory.
    let poses = window_poses(log, window);
    let stroke = (0.08 * px).clamp(1.0, 4.0);
    for seg in segments(log, poses, cs) {
        let _ = write!(
            s,
            r##"<polyline fill="none" stroke="#d9480f" stroke-opacity="0.55" stroke-width="{stroke:.1}" stroke-linejoin="round" points=""##
        );
        for p in &seg {
            let _ = write!(s, "{:.1},{:.1} ", sx(p.x), sy(p.y));
        }
        let _ = writeln!(s, r#""/>"#);
    }
    if let (Some(a), Some(b)) = (poses.first(), poses.last()) {
        let r = (0.18 * px).max(3.0);
        let _ = writeln!(
            s,
            r##"<circle cx="{:.1}" cy="{:.1}" r="{r:.1}" fill="none" stroke="#222" stroke-width="1.5"/>"##,
            sx(a.x),
            sy(a.y)
        );
        let _ = writeln!(s, r##"<circle cx="{:.1}" cy="{:.1}" r="{r:.1}" fill="#222"/>"##, sx(b.x), sy(b.y));
        let (hx, hy) = (sx(b.x) + 2.0 * r * b.theta.cos(), sy(b.y) - 2.0 * r * b.theta.sin());
        let _ = writeln!(
            s,
            r##"<line x1="{:.1}" y1="{:.1}" x2="{hx:.1}" y2="{hy:.1}" stroke="#222" stroke-width="1.5"/>"##,
            sx(b.x),
            sy(b.y)
        );
    }
    let _ = writeln!(s, "</svg>");
    Ok(s)
}
