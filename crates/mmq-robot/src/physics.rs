//! One physics step of a robot outside rapier's own step: the drive's impulses, contact
//! bookkeeping, free flight (the disc integrated exactly as rapier would while no wall
//! is within reach) and the runaway checks.

use mmq_core::{ContactSample, EnvError};
use rapier2d::prelude::{ColliderHandle, IntegrationParameters, PhysicsWorld, Real, RigidBody, Rotation};

use crate::drive::BodyState;
use crate::robot::Core;

/// A contact pair whose normal impulse in one step exceeds this is "pressing", N·s
/// (0.06 N over a 1/60 s step; the Burger pushing at its traction limit gives ~0.13).
pub const PRESS_IMPULSE_NS: f64 = 1e-3;

/// Free flight needs this much more gap than rapier's prediction distance and two
/// steps of travel, metres.
pub const FREE_FLIGHT_MARGIN_M: f64 = 0.01;

/// Runaway: a speed above this multiple of the limits is a physics failure.
const RUNAWAY_FACTOR: f64 = 10.0;

impl Core {
    /// Steps 1–5 of a physics step: the drive's impulses go to the body; the clock
    /// advances; the contact flags are cleared.
    pub fn drive_body(&mut self, rb: &mut RigidBody, v_cmd: f64, w_cmd: f64) {
        self.drive.command(v_cmd, w_cmd);
        {
            let lv = rb.linvel();
            let s = BodyState {
                theta: rb.rotation().angle() as f64,
                vx: lv.x as f64,
                vy: lv.y as f64,
                w: rb.angvel() as f64,
            };
            let (p, l) = self.drive.impulses(&s);
            rb.apply_impulse(p, true);
            rb.apply_torque_impulse(l, true);
        }
        self.time_s += self.cfg.dt_s;
        self.counts.physics_steps += 1;
        self.started_now = false;
        self.pressing_now = false;
    }

    /// A contact start or stop between the robot and wall `wall` reported by rapier.
    pub fn contact_event(&mut self, started: bool, wall: usize) {
        if started {
            self.started_now = true;
            self.counts.contacts += 1;
        }
        if self.trace_period.is_some() {
            self.trace.contacts.push(ContactSample {
                time_s: self.time_s,
                started,
                wall: self.walls[wall].name.clone(),
            });
        }
    }

    /// Distance from the robot's disc to the nearest wall, metres (negative when
    /// overlapping). Only the 8 neighbours of the cell holding the centre can be within
    /// a cell of it; a neighbour outside the arena is boundary wall.
    fn wall_gap(&self, x: f64, y: f64) -> f64 {
        let w = &self.world;
        let cs = w.cell_size;
        let col = libm::floor(x / cs) as i64;
        let row_up = libm::floor(y / cs) as i64; // row counted from the bottom
        let solid = |c: i64, ru: i64| {
            c < 0
                || ru < 0
                || c >= w.width as i64
                || ru >= w.height as i64
                || !w.is_free(w.index(w.height - 1 - ru as usize, c as usize))
        };
        if solid(col, row_up) {
            return -1.0;
        }
        let mut d2 = f64::INFINITY;
        for dr in -1..=1 {
            for dc in -1..=1 {
                if (dr, dc) != (0, 0) && solid(col + dc, row_up + dr) {
                    let (x0, y0) = ((col + dc) as f64 * cs, (row_up + dr) as f64 * cs);
                    let dx = (x0 - x).max(x - (x0 + cs)).max(0.0);
                    let dy = (y0 - y).max(y - (y0 + cs)).max(0.0);
                    d2 = d2.min(dx * dx + dy * dy);
                }
            }
        }
        libm::sqrt(d2) - self.cfg.radius_m
    }

    /// Whether free flight is on and the robot cannot reach any wall during this step.
    pub fn is_free(&self, rb: &RigidBody, params: &IntegrationParameters) -> bool {
        self.cfg.free_flight && self.is_clear(rb, params)
    }

    /// Whether the robot cannot reach any wall during this step (free flight is exact).
    pub fn is_clear(&self, rb: &RigidBody, params: &IntegrationParameters) -> bool {
        let pred = params.prediction_distance() as f64;
        let travel = rb.linvel().length() as f64 * self.cfg.dt_s;
        let pose = rb.position();
        let gap = self.wall_gap(pose.translation.x as f64, pose.translation.y as f64);
        // A non-finite state is not free: it goes to rapier, which quarantines it.
        gap > pred + 2.0 * travel + FREE_FLIGHT_MARGIN_M
    }

    /// Integrates the free disc as rapier's solver would (its substeps, each the
    /// linearised rotation update with renormalisation and `translation += linvel·h`);
    /// rapier is not stepped. Only exact when [`Core::is_free`] holds.
    pub fn free_flight(rb: &mut RigidBody, params: &IntegrationParameters) {
        let substeps = params.num_solver_iterations;
        let (lv, w) = (rb.linvel(), rb.angvel());
        let mut pose = *rb.position();
        let h = params.dt / substeps as Real;
        for _ in 0..substeps {
            let dang = w * h;
            let r = pose.rotation;
            pose.rotation = Rotation::from_cos_sin_unchecked(r.re - dang * r.im, r.im + dang * r.re);
            pose.rotation.normalize_mut();
            pose.translation += lv * h;
        }
        rb.set_position(pose, false);
    }

    /// Runaway checks after a physics step; `quarantined`: rapier quarantined the body.
    pub fn check_runaway(&self, rb: &RigidBody, quarantined: bool) -> Result<(), EnvError> {
        let (t, lv, w) = (rb.translation(), rb.linvel(), rb.angvel());
        let theta = rb.rotation().angle();
        if quarantined || !rb.is_enabled() {
            return Err(self.physics_error("rapier quarantined the robot (non-finite state)".into()));
        }
        let finite = [t.x, t.y, theta, lv.x, lv.y, w].iter().all(|v| v.is_finite());
        if !finite {
            return Err(self.physics_error(format!(
                "non-finite robot state: position ({}, {}), heading {theta}, velocity ({}, {}), turn rate {w}",
                t.x, t.y, lv.x, lv.y
            )));
        }
        let cs = self.world.cell_size;
        let (wm, hm) = (self.world.width as f64 * cs, self.world.height as f64 * cs);
        let (x, y) = (t.x as f64, t.y as f64);
        if x < -cs || y < -cs || x > wm + cs || y > hm + cs {
            return Err(self.physics_error(format!(
                "robot at ({x:.3}, {y:.3}) m is more than a cell outside the {wm} × {hm} m arena"
            )));
        }
        let speed = lv.length() as f64;
        if speed > RUNAWAY_FACTOR * self.cfg.max_speed_mps {
            return Err(self.physics_error(format!(
                "robot speed {speed:.3} m/s is far above the limit {} m/s",
                self.cfg.max_speed_mps
            )));
        }
        if (w as f64).abs() > RUNAWAY_FACTOR * self.cfg.max_turn_rate_radps {
            return Err(self.physics_error(format!(
                "robot turn rate {w:.3} rad/s is far above the limit {} rad/s",
                self.cfg.max_turn_rate_radps
            )));
        }
        Ok(())
    }
}

/// Whether the robot's collider `rc` presses on a wall: a contact pair with an active
/// contact whose normal impulse in the last step exceeds [`PRESS_IMPULSE_NS`].
pub(crate) fn pressing(phys: &PhysicsWorld, rc: ColliderHandle) -> bool {
    phys.narrow_phase
        .contact_pairs_with(rc)
        .any(|pair| pair.has_any_active_contact() && pair.total_impulse_magnitude() as f64 > PRESS_IMPULSE_NS)
}
