//! render: an SVG with the arena and the trajectory, whole or for a window of steps.

use mmq_log::{read_log, render, render_svg};

use crate::common::record_grid;

#[test]
fn draws_arena_and_trajectory() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("r.mcap");
    record_grid(&path, |_| {}, 400, 6);
    let log = read_log(&path).unwrap();
    let out = dir.path().join("pics/r.svg");
    render(&log, &out, None).unwrap();
    let svg = std::fs::read_to_string(&out).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    assert!(svg.contains(">G</text>") && svg.contains(">S</text>"));
    assert!(svg.contains("<polyline"));
    assert!(svg.contains("seed 6"));
    // Blocked cells of the 9×9 world are drawn.
    let world = log.world().unwrap();
    let blocked = (0..world.num_cells()).filter(|&c| !world.is_free(c)).count();
    assert_eq!(svg.matches("#5a5a66\"/>").count(), blocked);
    // A window draws fewer points.
    let part = render_svg(&log, Some((100, 120))).unwrap();
    let points = |s: &str| s.matches(',').count();
    assert!(points(&part) < points(&svg));
    assert!(part.contains("steps 100–120"));
    // 21 decisions → the poses after each, plus the one before the first.
    let poses = mmq_log::render::window_poses(&log, Some((100, 120)));
    assert_eq!(poses.len(), 22);
}

#[test]
fn without_a_world_attachment_says_so() {
    let log = mmq_log::LogContents { path: "x.mcap".into(), ..Default::default() };
    let e = render_svg(&log, None).unwrap_err().to_string();
    assert!(e.contains("x.mcap") && e.contains("world.toml"), "{e}");
}

#[test]
fn draws_blocked_cells_of_a_maze() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("maze.mcap");
    let world = crate::common::world("maze-15x15");
    let mut rec = mmq_log::McapRecorder::create(mmq_log::RecorderConfig::new(&path)).unwrap();
    crate::common::run_grid(&world, &mut rec, 300, 1, 0);
    drop(rec);
    let svg = render_svg(&read_log(&path).unwrap(), None).unwrap();
    let blocked = (0..world.num_cells()).filter(|&c| !world.is_free(c)).count();
    assert!(blocked > 20);
    assert_eq!(svg.matches("#5a5a66\"/>").count(), blocked);
}

/// The picture has a scale bar in metres and a legend, and a PNG of it is written next to
/// the SVG: a real PNG of the picture's size, with the arena's colours in it.
#[test]
fn writes_a_png_with_a_scale_bar_and_a_legend() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("r.mcap");
    record_grid(&path, |_| {}, 400, 6);
    let log = read_log(&path).unwrap();
    let out = dir.path().join("r.svg");
    let [svg_path, png_path] = render(&log, &out, None).unwrap();
    assert_eq!((svg_path, png_path.clone()), (out.clone(), dir.path().join("r.png")));
    let svg = std::fs::read_to_string(&out).unwrap();
    // paper-9x9: 0.5 m cells drawn 48 px wide, a quarter of the 4.5 m arena → a 1 m bar.
    assert!(svg.contains(">1 m</text>"), "no scale bar");
    for name in ["trajectory", "start", "end", "goal (G)", "respawn (S)", "blocked cell, wall"] {
        assert!(svg.contains(&format!(">{name}</text>")), "legend lacks {name}");
    }
    let bytes = std::fs::read(&png_path).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    let (w, h) = (
        u32::from_be_bytes(bytes[16..20].try_into().unwrap()),
        u32::from_be_bytes(bytes[20..24].try_into().unwrap()),
    );
    let size = |k: &str| -> f64 {
        let i = svg.find(&format!("{k}=\"")).unwrap() + k.len() + 2;
        svg[i..].split('"').next().unwrap().parse().unwrap()
    };
    assert_eq!((w, h), ((2.0 * size("width")) as u32, (2.0 * size("height")) as u32));
    assert_eq!(mmq_log::render_png(&log, None).unwrap(), bytes, "the PNG is the picture's");
    // No temporary file is left next to them.
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names.len(), 3, "{names:?}");
}

/// A picture that cannot be written (its folder is a file) is an error naming the file,
/// and leaves no temporary file behind.
#[test]
fn a_failed_write_names_the_file_and_cleans_up() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("r.mcap");
    record_grid(&path, |_| {}, 50, 2);
    let log = read_log(&path).unwrap();
    // A folder where the SVG should go: the rename fails.
    let out = dir.path().join("taken.svg");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("x"), b"x").unwrap();
    let e = render(&log, &out, None).unwrap_err().to_string();
    assert!(e.contains("taken.svg"), "{e}");
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(names.iter().all(|n| !n.contains(".tmp-")), "{names:?}");
}
