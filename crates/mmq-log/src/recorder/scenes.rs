//! The scenes and grids of a log: the arena, the robot's body (and the ghost of its
//! pose estimate), and the per-cell heat maps, as Foxglove well-known messages.

use base64::Engine;
use mmq_core::{RunInfo, World};

use crate::messages as m;

pub(crate) fn robot_radius(info: &RunInfo<'_>) -> f64 {
    let from_facts = info
        .facts
        .iter()
        .find(|(k, _)| matches!(k.as_str(), "robot.radius_m" | "robot_radius_m" | "radius_m"))
        .and_then(|(_, v)| v.parse::<f64>().ok());
    let from_world = info
        .world
        .robot
        .as_ref()
        .and_then(|t| t.get("radius_m"))
        .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)));
    from_facts.or(from_world).filter(|r| r.is_finite() && *r > 0.0).unwrap_or(0.3 * info.world.cell_size)
}

/// `/viz/arena`: floor, boundary walls, blocked cells, goal and respawn, cell lines.
pub(crate) fn arena_scene(world: &World, timestamp: m::Time) -> m::SceneUpdate {
    let cs = world.cell_size;
    let (w, h) = (world.width as f64 * cs, world.height as f64 * cs);
    let wall_h = 0.5 * cs;
    let th = 0.1 * cs;
    let wall = m::Color::rgba(0.35, 0.35, 0.4, 1.0);
    let mut e = m::SceneEntity::new(timestamp, "world", "arena");
    let cube = |x: f64, y: f64, z: f64, sx: f64, sy: f64, sz: f64, color: m::Color| m::CubePrimitive {
        pose: m::Pose::planar(x, y, z, 0.0),
        size: m::Vector3 { x: sx, y: sy, z: sz },
        color,
    };
    e.cubes.push(cube(w / 2.0, h / 2.0, -0.005, w, h, 0.01, m::Color::rgba(0.93, 0.93, 0.9, 1.0)));
    e.cubes.push(cube(w / 2.0, h + th / 2.0, wall_h / 2.0, w + 2.0 * th, th, wall_h, wall));
    e.cubes.push(cube(w / 2.0, -th / 2.0, wall_h / 2.0, w + 2.0 * th, th, wall_h, wall));
    e.cubes.push(cube(-th / 2.0, h / 2.0, wall_h / 2.0, th, h, wall_h, wall));
    e.cubes.push(cube(w + th / 2.0, h / 2.0, wall_h / 2.0, th, h, wall_h, wall));
    for c in 0..world.num_cells() {
        if !world.is_free(c) {
            let (x, y) = world.cell_center(c);
            e.cubes.push(cube(x, y, wall_h / 2.0, cs, cs, wall_h, wall));
        }
    }
    for (cell, color, label) in [
        (world.goal, m::Color::rgba(0.2, 0.75, 0.3, 0.8), "G"),
        (world.respawn, m::Color::rgba(0.25, 0.45, 0.9, 0.8), "S"),
    ] {
        let (x, y) = world.cell_center(cell);
        e.cubes.push(cube(x, y, 0.002, cs, cs, 0.004, color));
        e.texts.push(m::TextPrimitive {
            pose: m::Pose::planar(x, y, wall_h, 0.0),
            billboard: true,
            font_size: 0.5 * cs,
            scale_invariant: false,
            color: m::Color::rgba(0.1, 0.1, 0.1, 1.0),
            text: label.into(),
        });
    }
    let mut points = Vec::with_capacity(2 * (world.width + world.height + 2));
    for i in 0..=world.width {
        let x = i as f64 * cs;
        points.push(m::Vector3 { x, y: 0.0, z: 0.003 });
        points.push(m::Vector3 { x, y: h, z: 0.003 });
    }
    for j in 0..=world.height {
        let y = j as f64 * cs;
        points.push(m::Vector3 { x: 0.0, y, z: 0.003 });
        points.push(m::Vector3 { x: w, y, z: 0.003 });
    }
    e.lines.push(m::LinePrimitive {
        kind: m::LINE_LIST,
        pose: m::Pose::default(),
        thickness: 1.0,
        scale_invariant: true,
        points,
        color: m::Color::rgba(0.6, 0.6, 0.6, 1.0),
        colors: Vec::new(),
        indices: Vec::new(),
    });
    e.metadata.push(m::KeyValuePair { key: "world".into(), value: world.name.clone() });
    m::SceneUpdate { deletions: Vec::new(), entities: vec![e] }
}

/// `/viz/robot`: a disc (short cylinder) and a heading arrow in the "robot" frame, which
/// `/tf` moves.
pub(crate) fn robot_scene(radius: f64, timestamp: m::Time) -> m::SceneUpdate {
    let height = 0.4 * radius;
    let mut e = m::SceneEntity::new(timestamp, "robot", "robot");
    e.frame_locked = true;
    e.cylinders.push(m::CylinderPrimitive {
        pose: m::Pose::planar(0.0, 0.0, height / 2.0, 0.0),
        size: m::Vector3 { x: 2.0 * radius, y: 2.0 * radius, z: height },
        bottom_scale: 1.0,
        top_scale: 1.0,
        color: m::Color::rgba(0.95, 0.55, 0.1, 0.9),
    });
    e.arrows.push(m::ArrowPrimitive {
        pose: m::Pose::planar(0.0, 0.0, height + 0.01, 0.0),
        shaft_length: 0.8 * radius,
        shaft_diameter: 0.15 * radius,
        head_length: 0.5 * radius,
        head_diameter: 0.4 * radius,
        color: m::Color::rgba(0.1, 0.1, 0.1, 1.0),
    });
    e.metadata.push(m::KeyValuePair { key: "radius_m".into(), value: radius.to_string() });
    m::SceneUpdate { deletions: Vec::new(), entities: vec![e] }
}

/// A `foxglove.Grid` of one FLOAT32 field per cell, rows from the bottom of the map
/// (y = 0) up, origin at the arena's bottom-left corner.
pub(crate) fn heatmap(world: &World, log_time: u64, field: &str, per_cell: &[f64]) -> m::Grid {
    let (w, h) = (world.width, world.height);
    let mut bytes = Vec::with_capacity(4 * w * h);
    for row_from_bottom in 0..h {
        let r = h - 1 - row_from_bottom;
        for c in 0..w {
            bytes.extend_from_slice(&(per_cell[world.index(r, c)] as f32).to_le_bytes());
        }
    }
    m::Grid {
        timestamp: m::Time::from_ns(log_time),
        frame_id: "world".into(),
        pose: m::Pose::default(),
        column_count: w as u32,
        cell_size: m::Vector2 { x: world.cell_size, y: world.cell_size },
        row_stride: 4 * w as u32,
        cell_stride: 4,
        fields: vec![m::PackedElementField { name: field.into(), offset: 0, kind: m::FLOAT32 }],
        data: base64::engine::general_purpose::STANDARD.encode(&bytes),
    }
}

/// The frame of the robot's pose estimate (child of "world" on `/tf`).
pub(crate) const ESTIMATE_FRAME: &str = "robot_estimate";

/// `/viz/robot_estimate`: the outline of the robot where it believes it is, a flat
/// translucent blue disc and heading arrow in the "robot_estimate" frame, drawn next to
/// the true body.
pub(crate) fn estimate_scene(radius: f64, timestamp: m::Time) -> m::SceneUpdate {
    let height = 0.1 * radius;
    let mut e = m::SceneEntity::new(timestamp, ESTIMATE_FRAME, "robot_estimate");
    e.frame_locked = true;
    e.cylinders.push(m::CylinderPrimitive {
        pose: m::Pose::planar(0.0, 0.0, height / 2.0, 0.0),
        size: m::Vector3 { x: 2.0 * radius, y: 2.0 * radius, z: height },
        bottom_scale: 1.0,
        top_scale: 1.0,
        color: m::Color::rgba(0.2, 0.45, 0.95, 0.45),
    });
    e.arrows.push(m::ArrowPrimitive {
        pose: m::Pose::planar(0.0, 0.0, height + 0.01, 0.0),
        shaft_length: 0.8 * radius,
        shaft_diameter: 0.1 * radius,
        head_length: 0.5 * radius,
        head_diameter: 0.3 * radius,
        color: m::Color::rgba(0.2, 0.45, 0.95, 0.9),
    });
    e.metadata.push(m::KeyValuePair { key: "radius_m".into(), value: radius.to_string() });
    m::SceneUpdate { deletions: Vec::new(), entities: vec![e] }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heatmap_rows_go_up_from_the_bottom() {
        let w = World::parse("map = \"\"\"\nG.\n.S\n\"\"\"", "t").unwrap();
        let g = heatmap(&w, 5, "v", &[1.0, 2.0, 3.0, 4.0]);
        let bytes = base64::engine::general_purpose::STANDARD.decode(&g.data).unwrap();
        let vals: Vec<f32> = bytes.chunks(4).map(|b| f32::from_le_bytes(b.try_into().unwrap())).collect();
        // Bottom row (cells 2, 3) first.
        assert_eq!(vals, vec![3.0, 4.0, 1.0, 2.0]);
        assert_eq!((g.column_count, g.row_stride, g.cell_stride), (2, 8, 4));
        assert_eq!(g.timestamp, m::Time { sec: 0, nsec: 5 });
    }
}
