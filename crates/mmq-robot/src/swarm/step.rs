//! One physics step of the swarm: every robot's drive, then either free flight (no
//! robot can reach a wall or another robot during the step) or one rapier step for all,
//! with contact bookkeeping per robot and the runaway checks. With one robot this is the
//! single robot's physics step, operation for operation.

use mmq_core::EnvError;
use rapier2d::prelude::{ColliderHandle, CollisionEvent};

use super::{Member, SwarmEnv};
use crate::arena::wall_of;
use crate::physics::{FREE_FLIGHT_MARGIN_M, pressing};
use crate::robot::Core;

impl SwarmEnv {
    /// One physics step under every robot's command.
    pub(super) fn physics_step(&mut self) -> Result<(), EnvError> {
        let quarantined = !self.phys.quarantine().bodies().is_empty();
        for m in &mut self.members {
            let rb = &mut self.phys.bodies[m.body];
            m.core.drive_body(rb, m.cmd.0, m.cmd.1);
        }
        if self.all_free() {
            for m in &self.members {
                let rb = &mut self.phys.bodies[m.body];
                Core::free_flight(rb, &self.phys.integration_parameters);
                m.core.check_runaway(rb, quarantined)?;
            }
            return Ok(());
        }
        self.phys.step_with_events(&(), &self.collector);
        for m in &mut self.members {
            m.core.counts.rapier_steps += 1;
        }
        if let Ok(mut events) = self.collector.events.lock() {
            for e in events.drain(..) {
                let started = matches!(e, CollisionEvent::Started(..));
                let (a, b) = (e.collider1(), e.collider2());
                for (me, other) in [(a, b), (b, a)] {
                    let Some(i) = robot_of(&self.members, me) else { continue };
                    if robot_of(&self.members, other).is_some() {
                        robot_contact(&mut self.members[i], started);
                    } else if let Some(wall) = wall_of(&self.phys, other) {
                        let m = &mut self.members[i];
                        if started && m.first_contact_robot.is_none() && running(m) {
                            m.first_contact_robot = Some(false);
                        }
                        m.core.contact_event(started, wall);
                    }
                }
            }
        }
        let quarantined = !self.phys.quarantine().bodies().is_empty();
        for m in &mut self.members {
            m.core.pressing_now = pressing(&self.phys, m.collider);
            m.core.check_runaway(&self.phys.bodies[m.body], quarantined)?;
        }
        Ok(())
    }

    /// Whether free flight is exact for every robot this step: free flight is on, no
    /// robot can reach a wall, and no two robots can reach each other.
    fn all_free(&self) -> bool {
        let params = &self.phys.integration_parameters;
        if !self.members.iter().all(|m| m.core.is_free(&self.phys.bodies[m.body], params)) {
            return false;
        }
        if self.members.len() < 2 {
            return true;
        }
        let pred = params.prediction_distance() as f64;
        let dt = self.cfg.dt_s;
        let r2 = 2.0 * self.cfg.radius_m;
        // Position and travel this step of robot `m` (no allocation: this runs every step).
        let at = |m: &Member| {
            let rb = &self.phys.bodies[m.body];
            let t = rb.translation();
            (t.x as f64, t.y as f64, rb.linvel().length() as f64 * dt)
        };
        for (i, a) in self.members.iter().enumerate() {
            let (xi, yi, ti) = at(a);
            for b in &self.members[i + 1..] {
                let (xj, yj, tj) = at(b);
                let gap = libm::hypot(xi - xj, yi - yj) - r2;
                if gap <= pred + 2.0 * (ti + tj) + FREE_FLIGHT_MARGIN_M {
                    return false;
                }
            }
        }
        true
    }
}

fn running(m: &Member) -> bool {
    matches!(m.doing, super::Doing::Running(_))
}

/// The robot whose collider is `h`.
fn robot_of(members: &[Member], h: ColliderHandle) -> Option<usize> {
    members.iter().position(|m| m.collider == h)
}

/// A contact start or stop between robot `m` and another robot.
fn robot_contact(m: &mut Member, started: bool) {
    if started {
        if m.first_contact_robot.is_none() && running(m) {
            m.first_contact_robot = Some(true);
        }
        m.core.started_now = true;
        m.core.counts.contacts += 1;
    }
}
