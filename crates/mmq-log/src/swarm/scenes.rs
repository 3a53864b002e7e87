//! The swarm's scenes: every robot's body in its own frame, a colour per robot, the base
//! station, the trails and a consultation's radio links, as `foxglove.SceneUpdate`s.

use std::collections::VecDeque;

use super::SwarmStepIn;
use crate::messages as m;

/// Robot `i`'s frame (child of `world` on `/tf`).
pub(super) fn frame(i: usize) -> String {
    format!("robot{i}")
}

/// The frame of robot `i`'s pose estimate.
pub(super) fn estimate_frame(i: usize) -> String {
    format!("robot{i}_estimate")
}

/// Robot `i`'s colour: hues a golden angle apart, so neighbours in number differ.
pub(super) fn colour(i: usize, alpha: f64) -> m::Color {
    let h = (i as f64 * 0.618_033_988_749_895).fract() * 6.0;
    let (s, v) = (0.75, 0.9);
    let c = v * s;
    let x = c * (1.0 - ((h % 2.0) - 1.0).abs());
    let (r, g, b) = match h as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let base = v - c;
    m::Color::rgba(r + base, g + base, b + base, alpha)
}

/// `/swarm/bodies`: per robot a disc of its colour with a heading arrow and its number,
/// in its frame (which `/tf` moves); with estimates, a flat translucent disc of the same
/// colour in the estimate's frame.
pub(super) fn bodies(robots: usize, radius: f64, estimates: bool, ts: m::Time) -> m::SceneUpdate {
    let height = 0.4 * radius;
    let mut out = m::SceneUpdate::default();
    for i in 0..robots {
        let mut e = m::SceneEntity::new(ts, &frame(i), &frame(i));
        e.frame_locked = true;
        e.cylinders.push(m::CylinderPrimitive {
            pose: m::Pose::planar(0.0, 0.0, height / 2.0, 0.0),
            size: m::Vector3 { x: 2.0 * radius, y: 2.0 * radius, z: height },
            bottom_scale: 1.0,
            top_scale: 1.0,
            color: colour(i, 0.95),
        });
        e.arrows.push(m::ArrowPrimitive {
            pose: m::Pose::planar(0.0, 0.0, height + 0.01, 0.0),
            shaft_length: 0.8 * radius,
            shaft_diameter: 0.15 * radius,
            head_length: 0.5 * radius,
            head_diameter: 0.4 * radius,
            color: m::Color::rgba(0.1, 0.1, 0.1, 1.0),
        });
        e.texts.push(m::TextPrimitive {
            pose: m::Pose::planar(0.0, 0.0, 2.0 * height + 0.05, 0.0),
            billboard: true,
            font_size: 0.8 * radius,
            scale_invariant: false,
            color: m::Color::rgba(0.05, 0.05, 0.05, 1.0),
            text: i.to_string(),
        });
        e.metadata.push(m::KeyValuePair { key: "radius_m".into(), value: radius.to_string() });
        out.entities.push(e);
        if estimates {
            let flat = 0.1 * radius;
            let mut g = m::SceneEntity::new(ts, &estimate_frame(i), &estimate_frame(i));
            g.frame_locked = true;
            g.cylinders.push(m::CylinderPrimitive {
                pose: m::Pose::planar(0.0, 0.0, flat / 2.0, 0.0),
                size: m::Vector3 { x: 2.0 * radius, y: 2.0 * radius, z: flat },
                bottom_scale: 1.0,
                top_scale: 1.0,
                color: colour(i, 0.35),
            });
            g.arrows.push(m::ArrowPrimitive {
                pose: m::Pose::planar(0.0, 0.0, flat + 0.01, 0.0),
                shaft_length: 0.8 * radius,
                shaft_diameter: 0.1 * radius,
                head_length: 0.5 * radius,
                head_diameter: 0.3 * radius,
                color: colour(i, 0.8),
            });
            out.entities.push(g);
        }
    }
    out
}

/// The base station: a grey post with an `R` (radio) label, in `/viz/arena`.
pub(super) fn station((x, y): (f64, f64), cell: f64, ts: m::Time) -> m::SceneEntity {
    let mut e = m::SceneEntity::new(ts, "world", "station");
    let h = 0.8 * cell;
    e.cylinders.push(m::CylinderPrimitive {
        pose: m::Pose::planar(x, y, h / 2.0, 0.0),
        size: m::Vector3 { x: 0.15 * cell, y: 0.15 * cell, z: h },
        bottom_scale: 1.0,
        top_scale: 0.4,
        color: m::Color::rgba(0.3, 0.3, 0.3, 1.0),
    });
    e.texts.push(m::TextPrimitive {
        pose: m::Pose::planar(x, y, h + 0.1 * cell, 0.0),
        billboard: true,
        font_size: 0.4 * cell,
        scale_invariant: false,
        color: m::Color::rgba(0.1, 0.1, 0.1, 1.0),
        text: "R".into(),
    });
    e
}

/// `/swarm/trails`: each robot's recent positions as a line strip of its colour, 2 px
/// wide at any zoom.
pub(super) fn trails(trails: &[VecDeque<(f64, f64)>], ts: m::Time) -> m::SceneUpdate {
    let mut out = m::SceneUpdate::default();
    for (i, t) in trails.iter().enumerate() {
        let mut e = m::SceneEntity::new(ts, "world", &format!("trail{i}"));
        e.lines.push(m::LinePrimitive {
            kind: m::LINE_STRIP,
            pose: m::Pose::default(),
            thickness: 2.0,
            scale_invariant: true,
            points: t.iter().map(|&(x, y)| m::Vector3 { x, y, z: 0.01 }).collect(),
            color: colour(i, 0.7),
            colors: Vec::new(),
            indices: Vec::new(),
        });
        out.entities.push(e);
    }
    out
}

/// `/swarm/links`: the radio hops of step `s`'s consultation as line segments between
/// the nodes where they were, in the robot's colour (red when the reward is lost), shown
/// for `shown_s` seconds. Hops naming a node outside `s.nodes` are left out.
pub(super) fn links(s: &SwarmStepIn<'_>, radius: f64, shown_s: f64, ts: m::Time) -> m::SceneUpdate {
    let z = 0.6 * radius;
    let mut points = Vec::with_capacity(2 * s.links.len());
    for &(a, b) in s.links {
        if let (Some(&(ax, ay)), Some(&(bx, by))) = (s.nodes.get(a as usize), s.nodes.get(b as usize)) {
            points.push(m::Vector3 { x: ax, y: ay, z });
            points.push(m::Vector3 { x: bx, y: by, z });
        }
    }
    let lost = s.earned != 0.0 && s.consultation.is_none();
    let mut e = m::SceneEntity::new(ts, "world", &format!("consult/robot{}/t{}", s.robot, s.t));
    e.lifetime = m::Time::from_ns((shown_s * 1e9).round() as u64);
    e.lines.push(m::LinePrimitive {
        kind: m::LINE_LIST,
        pose: m::Pose::default(),
        thickness: 3.0,
        scale_invariant: true,
        points,
        color: if lost { m::Color::rgba(0.9, 0.1, 0.1, 0.9) } else { colour(s.robot, 0.9) },
        colors: Vec::new(),
        indices: Vec::new(),
    });
    e.metadata.push(m::KeyValuePair { key: "robot".into(), value: s.robot.to_string() });
    e.metadata.push(m::KeyValuePair { key: "t".into(), value: s.t.to_string() });
    m::SceneUpdate { deletions: Vec::new(), entities: vec![e] }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colours_are_valid_and_distinct() {
        let cs: Vec<m::Color> = (0..16).map(|i| colour(i, 1.0)).collect();
        for c in &cs {
            assert!([c.r, c.g, c.b].iter().all(|x| (0.0..=1.0).contains(x)), "{c:?}");
        }
        for i in 0..16 {
            for j in 0..i {
                let d = (cs[i].r - cs[j].r).abs() + (cs[i].g - cs[j].g).abs() + (cs[i].b - cs[j].b).abs();
                assert!(d > 0.02, "robots {i} and {j}");
            }
        }
    }
}
