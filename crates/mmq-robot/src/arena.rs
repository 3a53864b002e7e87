//! The rapier scene built from a [`World`]: fixed cuboid walls (the boundary and every
//! blocked cell), each with a name for contact reports, and the robot's disc body.
//!
//! Frame: x right, y up, metres, origin at the arena's bottom-left corner; map row 0 is
//! the top row. Wall names: `boundary-north`, `boundary-east`, `boundary-south`,
//! `boundary-west`, and `block-r{row}c{col}` with 1-based row and column counted from
//! the map's top-left corner, as in world-file error messages (`block-r1c8` is the
//! eighth cell of the top row).

use std::sync::Mutex;

use mmq_core::{Cell, World};
use rapier2d::prelude::*;

use crate::config::RobotConfig;

/// A fixed wall of the arena.
#[derive(Clone, Debug, PartialEq)]
pub struct Wall {
    /// Its name in contact reports.
    pub name: String,
    /// Centre x, metres.
    pub cx: f64,
    /// Centre y, metres.
    pub cy: f64,
    /// Half width, metres.
    pub hx: f64,
    /// Half height, metres.
    pub hy: f64,
}

/// The walls of a world, boundary first (north, east, south, west), then blocked cells
/// in index order. The boundary walls are one cell thick, outside the arena, and long
/// enough to close the corners.
pub fn walls(world: &World) -> Vec<Wall> {
    let cs = world.cell_size;
    let (w, h) = (world.width as f64 * cs, world.height as f64 * cs);
    let mut out = vec![
        Wall { name: "boundary-north".into(), cx: w / 2.0, cy: h + cs / 2.0, hx: w / 2.0 + cs, hy: cs / 2.0 },
        Wall { name: "boundary-east".into(), cx: w + cs / 2.0, cy: h / 2.0, hx: cs / 2.0, hy: h / 2.0 + cs },
        Wall { name: "boundary-south".into(), cx: w / 2.0, cy: -cs / 2.0, hx: w / 2.0 + cs, hy: cs / 2.0 },
        Wall { name: "boundary-west".into(), cx: -cs / 2.0, cy: h / 2.0, hx: cs / 2.0, hy: h / 2.0 + cs },
    ];
    for (i, cell) in world.cells.iter().enumerate() {
        if *cell == Cell::Blocked {
            let (r, c) = world.row_col(i);
            let (cx, cy) = world.cell_center(i);
            out.push(Wall {
                name: format!("block-r{}c{}", r + 1, c + 1),
                cx,
                cy,
                hx: cs / 2.0,
                hy: cs / 2.0,
            });
        }
    }
    out
}

/// Collects rapier's collision events into a reused buffer (no allocation per step once
/// the buffer has grown).
#[derive(Debug, Default)]
pub(crate) struct Collector {
    pub events: Mutex<Vec<CollisionEvent>>,
}

impl EventHandler for Collector {
    fn handle_collision_event(
        &self,
        _bodies: &RigidBodySet,
        _colliders: &ColliderSet,
        event: CollisionEvent,
        _contact_pair: Option<&ContactPair>,
    ) {
        if let Ok(mut v) = self.events.lock() {
            v.push(event);
        }
    }

    fn handle_contact_force_event(
        &self,
        _dt: Real,
        _bodies: &RigidBodySet,
        _colliders: &ColliderSet,
        _contact_pair: &ContactPair,
        _total_force_magnitude: Real,
    ) {
    }

    fn handle_soft_body_tear_event(&self, _soft_bodies: &SoftBodySet, _event: &SoftBodyTearEvent) {}
}

/// The rapier state of one episode: rebuilt from scratch on every reset, so that a run
/// depends on its seed only (no solver cache survives a reset).
pub(crate) struct Scene {
    pub phys: PhysicsWorld,
    pub robot: RigidBodyHandle,
    pub robot_collider: ColliderHandle,
}

/// `user_data` of the robot's collider; a wall's is its index in [`walls`] + 1.
pub(crate) const ROBOT_USER_DATA: u128 = 0;

impl Scene {
    /// Builds the arena's walls and the robot at `(x, y)` with heading `theta`, at rest.
    pub fn new(walls: &[Wall], cfg: &RobotConfig, x: f64, y: f64, theta: f64) -> Scene {
        let mut phys = new_world(walls, cfg, None);
        let (robot, robot_collider) = insert_robot(&mut phys, cfg, x, y, theta, None);
        Scene { phys, robot, robot_collider }
    }

    /// The wall index of a collider (None for the robot).
    pub fn wall_of(&self, h: ColliderHandle) -> Option<usize> {
        wall_of(&self.phys, h)
    }
}

/// The wall index of a collider of a world built by [`new_world`] (None for a robot).
pub(crate) fn wall_of(phys: &PhysicsWorld, h: ColliderHandle) -> Option<usize> {
    let ud = phys.colliders.get(h)?.user_data;
    (ud != ROBOT_USER_DATA).then(|| (ud - 1) as usize)
}

/// A rapier world (no gravity, the robot's physics step, no contact recycling) holding
/// the arena's fixed walls, in `walls` order; `groups`: their collision groups (rapier's
/// default when None).
pub(crate) fn new_world(
    walls: &[Wall],
    cfg: &RobotConfig,
    groups: Option<InteractionGroups>,
) -> PhysicsWorld {
    let mut phys = PhysicsWorld::new();
    phys.gravity = Vector::ZERO;
    phys.integration_parameters.dt = cfg.dt_s as Real;
    phys.integration_parameters.contact_recycling = false;
    for (i, w) in walls.iter().enumerate() {
        let mut c = ColliderBuilder::cuboid(w.hx as Real, w.hy as Real)
            .translation(Vector::new(w.cx as Real, w.cy as Real))
            .friction(cfg.wall_friction as Real)
            .restitution(0.0)
            .user_data(i as u128 + 1);
        if let Some(g) = groups {
            c = c.collision_groups(g);
        }
        phys.insert_collider(c, None);
    }
    phys
}

/// Inserts a robot at `(x, y)` with heading `theta`, at rest; `groups`: its collider's
/// collision groups (rapier's default when None).
pub(crate) fn insert_robot(
    phys: &mut PhysicsWorld,
    cfg: &RobotConfig,
    x: f64,
    y: f64,
    theta: f64,
    groups: Option<InteractionGroups>,
) -> (RigidBodyHandle, ColliderHandle) {
    let body = RigidBodyBuilder::dynamic()
        .translation(Vector::new(x as Real, y as Real))
        .rotation(theta as Real)
        .can_sleep(false);
    let mut coll = ColliderBuilder::ball(cfg.radius_m as Real)
        .mass(cfg.mass_kg as Real)
        .friction(cfg.wall_friction as Real)
        .restitution(0.0)
        .active_events(ActiveEvents::COLLISION_EVENTS)
        .user_data(ROBOT_USER_DATA);
    if let Some(g) = groups {
        coll = coll.collision_groups(g);
    }
    phys.insert(body, coll)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_sizes() {
        let w = World::parse("cell_size = 0.5\nmap = \"\"\"\nG.#\n...\n#.S\n\"\"\"", "t").unwrap();
        let ws = walls(&w);
        let names: Vec<&str> = ws.iter().map(|w| w.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "boundary-north",
                "boundary-east",
                "boundary-south",
                "boundary-west",
                "block-r1c3",
                "block-r3c1"
            ]
        );
        assert_eq!((ws[4].cx, ws[4].cy, ws[4].hx), (1.25, 1.25, 0.25));
        assert_eq!((ws[0].cy - ws[0].hy, ws[1].cx - ws[1].hx), (1.5, 1.5));
        assert_eq!((ws[2].cy + ws[2].hy, ws[3].cx + ws[3].hx), (0.0, 0.0));
    }
}
