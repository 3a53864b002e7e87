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
