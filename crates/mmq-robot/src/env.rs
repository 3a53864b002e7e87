//! [`RobotEnv`]: the robot as an [`Env`]. A step runs one motion primitive to its end
//! (target reached, bump handled, or time-out) with fixed physics steps, then reports the
//! cell holding the robot's centre.

use std::f64::consts::{FRAC_PI_2, PI};
use std::fmt;

use mmq_core::seed::rng_from_seed;
use mmq_core::{
    Action, ContactSample, Env, EnvError, Event, Move, PoseSample, Rng, Start, StartRule, State, Step,
    StepTrace, World,
};
use rand::RngExt;
use rand_distr::{Distribution, Normal};
use rapier2d::prelude::{
    ColliderHandle, CollisionEvent, IntegrationParameters, PhysicsWorld, Real, RigidBody, Rotation, Vector,
};

use crate::arena::{Collector, Scene, Wall, walls};
use crate::config::{ActionSet, RobotConfig, RobotError};
use crate::controller::{self, Limits, wrap};
use crate::drive::{BodyState, Drive};

/// A contact pair whose normal impulse in one step exceeds this is "pressing", N·s
/// (0.06 N over a 1/60 s step; the Burger pushing at its traction limit gives ~0.13).
pub const PRESS_IMPULSE_NS: f64 = 1e-3;
/// After a contact starts, the robot keeps driving until it presses on the wall, or for
/// at most this long, before it backs off, seconds.
pub const BUMP_DWELL_S: f64 = 0.5;

/// Free flight needs this much more gap than rapier's prediction distance and two
/// steps of travel, metres.
pub const FREE_FLIGHT_MARGIN_M: f64 = 0.01;

/// Runaway: a speed above this multiple of the limits is a physics failure.
const RUNAWAY_FACTOR: f64 = 10.0;

/// Counters since the last reset.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Counts {
    pub physics_steps: u64,
    pub rapier_steps: u64,
    pub primitives: u64,
    pub contacts: u64,
    pub reached: u64,
    pub bumped: u64,
    pub timed_out: u64,
    pub goal: u64,
}

/// One motion primitive.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Primitive {
    /// Turn to the move's heading, then drive to the neighbouring cell's centre.
    Go(Move),
    /// Turn in place by this many quarter turns (+1 left, −1 right) from the nearest
    /// cardinal heading.
    Turn(i8),
}

/// The phase of the running primitive.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    /// Turn in place to `heading`; then drive to `then` if any.
    Turn { heading: f64, then: Option<(f64, f64)> },
    /// Drive to a point.
    Drive { tx: f64, ty: f64 },
    /// After a wall contact: back to the centre of the primitive's start cell.
    BackOff,
}

/// Everything of one robot but its rapier body: configuration, drive, controller
/// state, noise stream, clock, counters and trace. [`RobotEnv`] owns one with its own
/// rapier world; [`crate::MultiArena`] owns many whose bodies share one world. Methods
/// that need the body take it as an argument.
pub(crate) struct Core {
    pub world: World,
    pub cfg: RobotConfig,
    pub walls: Vec<Wall>,
    pub drive: Drive,
    limits: Limits,
    rng: Rng,
    free_non_goal: Vec<usize>,
    pub timeout_s: f64,
    pub time_s: f64,
    pub decision_step: u64,
    pub counts: Counts,
    pub trace_period: Option<f64>,
    pub trace: StepTrace,
    next_sample_s: f64,
    /// Set by a physics step: a robot–wall contact started during it.
    pub started_now: bool,
    /// Set by a physics step: the robot pressed on a wall during it.
    pub pressing_now: bool,
}

/// The robot environment.
pub struct RobotEnv {
    core: Core,
    scene: Scene,
    collector: Collector,
}

impl fmt::Debug for RobotEnv {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("RobotEnv")
            .field("world", &self.core.world.name)
            .field("cfg", &self.core.cfg)
            .field("time_s", &self.core.time_s)
            .field("decision_step", &self.core.decision_step)
            .field("counts", &self.core.counts)
            .finish_non_exhaustive()
    }
}

/// Cardinal heading of a move, radians.
fn heading_of(m: Move) -> f64 {
    match m {
        Move::N => FRAC_PI_2,
        Move::E => 0.0,
        Move::S => -FRAC_PI_2,
        Move::W => PI,
    }
}

/// The cardinal move nearest to heading `theta`.
fn nearest_move(theta: f64) -> Move {
    let k = libm::round(wrap(theta) / FRAC_PI_2) as i64;
    match k.rem_euclid(4) {
        0 => Move::E,
        1 => Move::N,
        2 => Move::W,
        _ => Move::S,
    }
}

fn move_index(m: Move) -> usize {
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
    ox: f64,
    oy: f64,
    t0: f64,
    phase: Phase,
    contact_at: Option<f64>,
}

impl PrimRun {
    /// The command for the next physics step, or the primitive's end.
    pub fn next(&mut self, core: &Core, rb: &RigidBody) -> Next {
        loop {
            if core.time_s - self.t0 >= core.timeout_s {
                return Next::End(if self.contact_at.is_some() { Event::WallBump } else { Event::TimedOut });
            }
            let (x, y, th) = raw_pose(rb);
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

impl Core {
    pub fn new(world: &World, cfg: RobotConfig) -> Result<Core, RobotError> {
        cfg.validate_for_world(world)?;
        let walls = walls(world);
        let free_non_goal = world.free_cells().filter(|&c| c != world.goal).collect();
        Ok(Core {
            world: world.clone(),
            limits: Limits {
                v_max: cfg.max_speed_mps,
                w_max: cfg.max_turn_rate_radps,
                a_max: cfg.max_accel_mps2,
                alpha_max: cfg.max_angular_accel_radps2,
            },
            drive: Drive::new(&cfg),
            timeout_s: cfg.timeout_s(world.cell_size),
            cfg,
            walls,
            rng: rng_from_seed(0),
            free_non_goal,
            time_s: 0.0,
            decision_step: 0,
            counts: Counts::default(),
            trace_period: None,
            trace: StepTrace::default(),
            next_sample_s: 0.0,
            started_now: false,
            pressing_now: false,
        })
    }

    pub fn num_states(&self) -> usize {
        match self.cfg.actions {
            ActionSet::Moves => self.world.num_cells(),
            ActionSet::Heading => self.world.num_cells() * 4,
        }
    }

    pub fn num_actions(&self) -> usize {
        match self.cfg.actions {
            ActionSet::Moves => 4,
            ActionSet::Heading => 3,
        }
    }

    pub fn state_cell(&self, state: State) -> usize {
        match self.cfg.actions {
            ActionSet::Moves => state,
            ActionSet::Heading => state / 4,
        }
    }

    pub fn physics_error(&self, message: String) -> EnvError {
        EnvError::Physics { step: self.decision_step, message }
    }

    /// The free cell holding the robot's centre.
    pub fn current_cell(&self, rb: &RigidBody) -> Result<usize, EnvError> {
        let (x, y, _) = raw_pose(rb);
        let cs = self.world.cell_size;
        let (w, h) = (self.world.width as f64 * cs, self.world.height as f64 * cs);
        // A centre a hair outside the arena (possible only while pressing on the
        // boundary) counts in the nearest cell; farther out is caught by the runaway check.
        let cx = x.clamp(0.0, w * (1.0 - 1e-12));
        let cy = y.clamp(0.0, h * (1.0 - 1e-12));
        let cell = self
            .world
            .cell_at(cx, cy)
            .ok_or_else(|| self.physics_error(format!("robot at ({x}, {y}) is not in the arena")))?;
        if !self.world.is_free(cell) {
            let (r, c) = self.world.row_col(cell);
            return Err(self.physics_error(format!(
                "robot centre ({x:.4}, {y:.4}) is inside blocked cell row {}, column {}",
                r + 1,
                c + 1
            )));
        }
        Ok(cell)
    }

    pub fn current_state(&self, rb: &RigidBody) -> Result<State, EnvError> {
        let cell = self.current_cell(rb)?;
        Ok(match self.cfg.actions {
            ActionSet::Moves => cell,
            ActionSet::Heading => cell * 4 + move_index(nearest_move(raw_pose(rb).2)),
        })
    }

    pub fn pose(&self, rb: &RigidBody) -> PoseSample {
        let (x, y, theta) = raw_pose(rb);
        PoseSample { time_s: self.time_s, x, y, theta }
    }

    fn sample_pose(&mut self, rb: &RigidBody) {
        let p = self.pose(rb);
        if self.trace.poses.last().is_none_or(|l| l.time_s != p.time_s) {
            self.trace.poses.push(p);
        }
    }

    /// The start of an episode: draws the start cell (and heading) from the seed and
    /// resets the clock, counters and drive. Returns the robot's start pose (x, y, θ);
    /// the caller puts the body there, at rest.
    pub fn reset(&mut self, seed: u64, start: Start) -> Result<(f64, f64, f64), EnvError> {
        self.rng = rng_from_seed(seed);
        let heading_states = self.cfg.actions == ActionSet::Heading;
        let (cell, heading) = match start {
            Start::World => {
                let cell = match self.world.start {
                    StartRule::Random => {
                        if self.free_non_goal.is_empty() {
                            self.world.respawn
                        } else {
                            self.free_non_goal[self.rng.random_range(0..self.free_non_goal.len())]
                        }
                    }
                    StartRule::Respawn => self.world.respawn,
                };
                let h = if heading_states { Move::ALL[self.rng.random_range(0..4)] } else { Move::N };
                (cell, h)
            }
            Start::Respawn => (self.world.respawn, Move::N),
            Start::State(s) => {
                if s >= self.num_states() {
                    return Err(EnvError::InvalidStart(s));
                }
                let cell = self.state_cell(s);
                if !self.world.is_free(cell) {
                    return Err(EnvError::InvalidStart(s));
                }
                (cell, if heading_states { Move::ALL[s % 4] } else { Move::N })
            }
        };
        let (x, y) = self.world.cell_center(cell);
        self.drive = Drive::new(&self.cfg);
        self.time_s = 0.0;
        self.decision_step = 0;
        self.counts = Counts::default();
        self.trace.poses.clear();
        self.trace.contacts.clear();
        Ok((x, y, heading_of(heading)))
    }

    /// Begins a step: checks the action, counts it, and either teleports from the goal
    /// (no physics) or starts the action's primitive.
    pub fn begin_step(&mut self, action: Action, rb: &mut RigidBody) -> Result<Begin, EnvError> {
        let n = self.num_actions();
        if action >= n {
            return Err(EnvError::InvalidAction { action, num_actions: n });
        }
        self.decision_step += 1;
        self.trace.poses.clear();
        self.trace.contacts.clear();
        self.counts.primitives += 1;
        if self.current_cell(rb)? == self.world.goal {
            self.teleport_to_respawn(rb);
            return Ok(Begin::Done(Event::Teleport));
        }
        let prim = match self.cfg.actions {
            ActionSet::Moves => Primitive::Go(Move::ALL[action]),
            ActionSet::Heading => match action {
                0 => Primitive::Go(nearest_move(raw_pose(rb).2)),
                1 => Primitive::Turn(1),
                _ => Primitive::Turn(-1),
            },
        };
        self.start_primitive(prim, rb).map(Begin::Run)
    }

    /// Ends a step with the primitive's event: reward, counters, the state.
    pub fn finish_step(&mut self, event: Event, rb: &RigidBody) -> Result<Step, EnvError> {
        let rewards = self.world.rewards;
        let reward = match event {
            Event::Teleport => {
                self.counts.goal += 1;
                rewards.goal
            }
            Event::WallBump => {
                self.counts.bumped += 1;
                rewards.wall
            }
            Event::TimedOut => {
                self.counts.timed_out += 1;
                rewards.step
            }
            _ => {
                self.counts.reached += 1;
                rewards.step
            }
        };
        if self.trace_period.is_some() {
            self.sample_pose(rb);
        }
        Ok(Step { state: self.current_state(rb)?, reward, event, terminated: false, truncated: false })
    }

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

    /// Trace samples due after a physics step.
    pub fn sample_trace(&mut self, rb: &RigidBody) {
        if let Some(period) = self.trace_period {
            while self.time_s >= self.next_sample_s {
                self.sample_pose(rb);
                self.next_sample_s += period;
            }
        }
    }

    /// Draws this primitive's actuation noise.
    fn draw_noise(&mut self) {
        let Some(n) = self.cfg.noise else { return };
        for g in &mut self.drive.gain {
            let e = match Normal::new(0.0, n.wheel_gain_sd) {
                Ok(d) => d.sample(&mut self.rng),
                Err(_) => 0.0,
            };
            *g = (1.0 + e).clamp(0.5, 1.5);
        }
        let slip: f64 = self.rng.random();
        self.drive.traction = if slip < n.slip_probability { n.slip_friction_factor } else { 1.0 };
    }

    /// Starts a primitive: its noise, its first phase.
    fn start_primitive(&mut self, prim: Primitive, rb: &RigidBody) -> Result<PrimRun, EnvError> {
        let (_, _, th0) = raw_pose(rb);
        let origin = self.current_cell(rb)?;
        let (ox, oy) = self.world.cell_center(origin);
        let cs = self.world.cell_size;
        self.draw_noise();
        let t0 = self.time_s;
        if let Some(p) = self.trace_period {
            self.next_sample_s = t0 + p;
        }
        let phase = match prim {
            Primitive::Go(m) => {
                let (dr, dc) = m.delta();
                let target = (ox + dc as f64 * cs, oy - dr as f64 * cs);
                Phase::Turn { heading: heading_of(m), then: Some(target) }
            }
            Primitive::Turn(q) => {
                let h = heading_of(nearest_move(th0)) + q as f64 * FRAC_PI_2;
                Phase::Turn { heading: wrap(h), then: None }
            }
        };
        Ok(PrimRun { ox, oy, t0, phase, contact_at: None })
    }

    fn teleport_to_respawn(&mut self, rb: &mut RigidBody) {
        let (x, y) = self.world.cell_center(self.world.respawn);
        rb.set_translation(Vector::new(x as Real, y as Real), true);
        rb.set_linvel(Vector::ZERO, true);
        rb.set_angvel(0.0, true);
        self.drive.stop();
    }

    /// Build facts and this robot's physics step, preset and action set.
    pub fn features(&self) -> Vec<(String, String)> {
        let mut f = crate::features();
        f.push(("physics.dt_s".into(), self.cfg.dt_s.to_string()));
        f.push(("robot.preset".into(), self.cfg.preset.name().into()));
        f.push(("robot.actions".into(), format!("{:?}", self.cfg.actions).to_lowercase()));
        f.push(("robot.noise".into(), if self.cfg.noise.is_some() { "on" } else { "off" }.into()));
        f
    }

    pub fn stats(&self) -> Vec<(String, f64)> {
        let c = &self.counts;
        [
            ("robot/sim_time_s", self.time_s),
            ("robot/physics_steps", c.physics_steps as f64),
            ("robot/rapier_steps", c.rapier_steps as f64),
            ("robot/primitives", c.primitives as f64),
            ("robot/contacts", c.contacts as f64),
            ("robot/reached", c.reached as f64),
            ("robot/bumped", c.bumped as f64),
            ("robot/timed_out", c.timed_out as f64),
            ("robot/goal", c.goal as f64),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect()
    }
}

impl RobotEnv {
    /// Builds the arena of `world` and a robot configured by `cfg` (validated against the
    /// world). Call [`Env::reset`] before stepping; until then the robot waits at rest
    /// at the centre of the respawn cell, facing north.
    pub fn new(world: &World, cfg: RobotConfig) -> Result<RobotEnv, RobotError> {
        let core = Core::new(world, cfg)?;
        let (x, y) = world.cell_center(world.respawn);
        let scene = Scene::new(&core.walls, &core.cfg, x, y, FRAC_PI_2);
        Ok(RobotEnv { core, scene, collector: Collector::default() })
    }

    /// [`RobotEnv::new`] with the world's own configuration ([`RobotConfig::from_world`]).
    pub fn from_world(world: &World) -> Result<RobotEnv, RobotError> {
        RobotEnv::new(world, RobotConfig::from_world(world)?)
    }

    /// The resolved configuration.
    pub fn config(&self) -> &RobotConfig {
        &self.core.cfg
    }

    /// The arena's walls, in collider order (names as in contact reports).
    pub fn walls(&self) -> &[Wall] {
        &self.core.walls
    }

    /// The time-out of one primitive, seconds.
    pub fn timeout_s(&self) -> f64 {
        self.core.timeout_s
    }

    /// [`crate::features`] plus this environment's physics step, preset and action set.
    pub fn features(&self) -> Vec<(String, String)> {
        self.core.features()
    }

    /// Test hook: sets the robot's velocity (to provoke the runaway check).
    #[doc(hidden)]
    pub fn debug_set_velocity(&mut self, vx: f64, vy: f64) {
        self.scene.phys.bodies[self.scene.robot].set_linvel(Vector::new(vx as Real, vy as Real), true);
    }

    fn body(&self) -> &RigidBody {
        &self.scene.phys.bodies[self.scene.robot]
    }

    /// One physics step under the commanded twist, with contact bookkeeping and the
    /// runaway checks. Allocates nothing unless tracing records a contact.
    fn physics_step(&mut self, v_cmd: f64, w_cmd: f64) -> Result<(), EnvError> {
        let phys = &mut self.scene.phys;
        let quarantined = !phys.quarantine().bodies().is_empty();
        let rb = &mut phys.bodies[self.scene.robot];
        self.core.drive_body(rb, v_cmd, w_cmd);
        if self.core.is_free(rb, &phys.integration_parameters) {
            Core::free_flight(rb, &phys.integration_parameters);
            // The quarantine is the last rapier step's (it failed then if it held the robot).
            return self.core.check_runaway(rb, quarantined);
        }
        self.scene.phys.step_with_events(&(), &self.collector);
        self.core.counts.rapier_steps += 1;

        // Contact starts and stops reported by rapier.
        let rc = self.scene.robot_collider;
        if let Ok(mut events) = self.collector.events.lock() {
            for e in events.drain(..) {
                let other = match (e.collider1(), e.collider2()) {
                    (a, b) if a == rc => b,
                    (a, b) if b == rc => a,
                    _ => continue,
                };
                let Some(wall) = self.scene.wall_of(other) else { continue };
                self.core.contact_event(matches!(e, CollisionEvent::Started(..)), wall);
            }
        }
        // Pressing, from the narrow phase: covers a robot that already touched a wall
        // and pushes on it again (no new contact start).
        self.core.pressing_now = pressing(&self.scene.phys, rc);
        self.check_runaway()
    }

    fn check_runaway(&self) -> Result<(), EnvError> {
        let quarantined = !self.scene.phys.quarantine().bodies().is_empty();
        self.core.check_runaway(self.body(), quarantined)
    }

    /// Runs one primitive to its end; the event says how it ended.
    fn run(&mut self, mut prim: PrimRun) -> Result<Event, EnvError> {
        loop {
            let (v, w) = match prim.next(&self.core, self.body()) {
                Next::End(e) => return Ok(e),
                Next::Command(v, w) => (v, w),
            };
            self.physics_step(v, w)?;
            let rb = &self.scene.phys.bodies[self.scene.robot];
            self.core.sample_trace(rb);
            prim.after_physics(&self.core);
        }
    }
}

/// Whether the robot's collider `rc` presses on a wall: a contact pair with an active
/// contact whose normal impulse in the last step exceeds [`PRESS_IMPULSE_NS`].
pub(crate) fn pressing(phys: &PhysicsWorld, rc: ColliderHandle) -> bool {
    phys.narrow_phase
        .contact_pairs_with(rc)
        .any(|pair| pair.has_any_active_contact() && pair.total_impulse_magnitude() as f64 > PRESS_IMPULSE_NS)
}

impl Env for RobotEnv {
    fn num_states(&self) -> usize {
        self.core.num_states()
    }

    fn num_actions(&self) -> usize {
        self.core.num_actions()
    }

    fn action_names(&self) -> Vec<String> {
        match self.core.cfg.actions {
            ActionSet::Moves => Move::ALL.iter().map(|m| m.name().to_string()).collect(),
            ActionSet::Heading => ["forward", "left", "right"].map(String::from).to_vec(),
        }
    }

    fn world(&self) -> &World {
        &self.core.world
    }

    fn state_cell(&self, state: State) -> usize {
        self.core.state_cell(state)
    }

    fn reset(&mut self, seed: u64, start: Start) -> Result<State, EnvError> {
        let (x, y, theta) = self.core.reset(seed, start)?;
        self.scene = Scene::new(&self.core.walls, &self.core.cfg, x, y, theta);
        if let Ok(mut e) = self.collector.events.lock() {
            e.clear();
        }
        self.core.current_state(self.body())
    }

    fn step(&mut self, action: Action) -> Result<Step, EnvError> {
        let robot = self.scene.robot;
        let event = match self.core.begin_step(action, &mut self.scene.phys.bodies[robot])? {
            Begin::Done(e) => e,
            Begin::Run(prim) => self.run(prim)?,
        };
        let rb = &self.scene.phys.bodies[robot];
        self.core.finish_step(event, rb)
    }

    fn sim_time_s(&self) -> f64 {
        self.core.time_s
    }

    fn set_trace(&mut self, period_s: Option<f64>) {
        self.core.trace_period = period_s.filter(|p| p.is_finite() && *p > 0.0);
    }

    fn take_trace(&mut self, out: &mut StepTrace) {
        std::mem::swap(&mut self.core.trace, out);
        self.core.trace.poses.clear();
        self.core.trace.contacts.clear();
    }

    fn pose(&self) -> PoseSample {
        self.core.pose(self.body())
    }

    fn stats(&self) -> Vec<(String, f64)> {
        self.core.stats()
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
