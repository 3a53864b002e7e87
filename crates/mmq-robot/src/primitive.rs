//! The motion primitives and their controller state: what a step asks the robot to do
//! (turn, drive to the neighbouring cell, back off after a bump), resumable one physics
//! step at a time.

use std::f64::consts::{FRAC_PI_2, PI};

use mmq_core::{Event, Move};
use rapier2d::prelude::RigidBody;

use crate::controller::{self, wrap};
use crate::robot::Core;

/// After a contact starts, the robot keeps driving until it presses on the wall, or for
/// at most this long, before it backs off, seconds.
pub const BUMP_DWELL_S: f64 = 0.5;

/// One motion primitive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Primitive {
    /// Turn to the move's heading, then drive to the neighbouring cell's centre.
    Go(Move),
    /// Turn in place by this many quarter turns (+1 left, −1 right) from the nearest
    /// cardinal heading.
    Turn(i8),
}

/// The phase of the running primitive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Phase {
    /// Turn in place to `heading`; then drive to `then` if any.
    Turn { heading: f64, then: Option<(f64, f64)> },
    /// Drive to a point.
    Drive { tx: f64, ty: f64 },
    /// After a wall contact: back to the centre of the primitive's start cell.
    BackOff,
}

/// Cardinal heading of a move, radians.
pub(crate) fn heading_of(m: Move) -> f64 {
    match m {
        Move::N => FRAC_PI_2,
        Move::E => 0.0,
        Move::S => -FRAC_PI_2,
        Move::W => PI,
    }
}

/// The cardinal move nearest to heading `theta`.
pub(crate) fn nearest_move(theta: f64) -> Move {
    let k = libm::round(wrap(theta) / FRAC_PI_2) as i64;
    match k.rem_euclid(4) {
        0 => Move::E,
        1 => Move::N,
        2 => Move::W,
        _ => Move::S,
    }
}

pub(crate) fn move_index(m: Move) -> usize {
    Move::ALL.iter().position(|&x| x == m).unwrap_or(0)
}

/// The robot's pose as f64: x, y, heading.
pub(crate) fn raw_pose(rb: &RigidBody) -> (f64, f64, f64) {
    let t = rb.translation();
    (t.x as f64, t.y as f64, rb.rotation().angle() as f64)
}

/// How a step begins.
pub(crate) enum Begin {
    /// It ended without physics (the goal's teleport): finish it with this event.
    Done(Event),
    /// A primitive runs.
    Run(PrimRun),
}

/// What a running primitive asks for next.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Next {
    /// One physics step under this commanded twist (v, ω).
    Command(f64, f64),
    /// The primitive has ended.
    End(Event),
}

/// The controller state of a running primitive, resumable one physics step at a time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct PrimRun {
    pub ox: f64,
    pub oy: f64,
    pub t0: f64,
    pub phase: Phase,
    pub contact_at: Option<f64>,
}

impl PrimRun {
    /// The command for the next physics step, or the primitive's end.
    pub fn next(&mut self, core: &Core, rb: &RigidBody) -> Next {
        loop {
            if core.time_s - self.t0 >= core.timeout_s {
                return Next::End(if self.contact_at.is_some() { Event::WallBump } else { Event::TimedOut });
            }
            let (x, y, th) = core.control_pose(rb);
            let (v, w) = match self.phase {
                Phase::Turn { heading, then } => {
                    let err = wrap(heading - th);
                    if err.abs() < core.cfg.heading_tolerance_rad {
                        self.phase = match (then, self.contact_at) {
                            (_, Some(_)) => Phase::BackOff,
                            (Some((tx, ty)), None) => Phase::Drive { tx, ty },
                            (None, None) => return Next::End(Event::Moved),
                        };
                        continue;
                    }
                    controller::turn(err, &core.limits)
                }
                Phase::Drive { tx, ty } => {
                    let (v, w, d) = controller::drive_to(x, y, th, tx, ty, &core.limits);
                    if d < core.cfg.position_tolerance_m {
                        if self.contact_at.is_some() {
                            self.phase = Phase::BackOff;
                            continue;
                        }
                        return Next::End(Event::Moved);
                    }
                    (v, w)
                }
                Phase::BackOff => {
                    let (v, w, d) = controller::drive_to(x, y, th, self.ox, self.oy, &core.limits);
                    if d < core.cfg.position_tolerance_m {
                        return Next::End(Event::WallBump);
                    }
                    (v, w)
                }
            };
            return Next::Command(v, w);
        }
    }

    /// After a physics step: bump bookkeeping from the core's contact flags.
    pub fn after_physics(&mut self, core: &Core) {
        if (core.started_now || core.pressing_now) && self.contact_at.is_none() {
            self.contact_at = Some(core.time_s);
        }
        if let (Phase::Drive { .. }, Some(t)) = (self.phase, self.contact_at)
            && (core.pressing_now || core.time_s - t >= BUMP_DWELL_S)
        {
            self.phase = Phase::BackOff;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_moves() {
        assert_eq!(nearest_move(0.1), Move::E);
        assert_eq!(nearest_move(FRAC_PI_2 - 0.1), Move::N);
        assert_eq!(nearest_move(-PI + 0.05), Move::W);
        assert_eq!(nearest_move(PI), Move::W);
        assert_eq!(nearest_move(-FRAC_PI_2), Move::S);
        for m in Move::ALL {
            assert_eq!(nearest_move(heading_of(m)), m);
        }
    }
}
