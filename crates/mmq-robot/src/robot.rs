//! [`Core`]: everything of one robot but its rapier body — configuration, drive,
//! controller state, noise stream, clock, counters, trace, and (realistic profile) its
//! odometry, localisation and estimator. [`crate::RobotEnv`] owns one with its rapier
//! world.

use std::f64::consts::FRAC_PI_2;

use mmq_core::seed::rng_from_seed;
use mmq_core::{
    Action, EnvError, Event, Move, PoseSample, Rng, Start, StartRule, State, Step, StepTrace, World,
};
use rand::RngExt;
use rand_distr::{Distribution, Normal};
use rapier2d::prelude::{Real, RigidBody, Vector};

use crate::arena::{Wall, walls};
use crate::config::{ActionSet, RobotConfig, RobotError};
use crate::controller::{Limits, wrap};
use crate::diagnostics::{Diagnostics, Expected};
use crate::drive::Drive;
use crate::primitive::{Begin, Phase, PrimRun, Primitive, heading_of, move_index, nearest_move, raw_pose};
use crate::profile::Profile;
use crate::realistic::Realistic;

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

/// Everything of one robot but its rapier body: configuration, drive, controller
/// state, noise stream, clock, counters and trace. [`crate::RobotEnv`] owns one with its
/// rapier world. Methods that need the body take it as an argument.
pub(crate) struct Core {
    pub world: World,
    pub cfg: RobotConfig,
    pub walls: Vec<Wall>,
    pub drive: Drive,
    pub limits: Limits,
    pub rng: Rng,
    pub free_non_goal: Vec<usize>,
    pub timeout_s: f64,
    pub time_s: f64,
    pub decision_step: u64,
    pub counts: Counts,
    pub trace_period: Option<f64>,
    pub trace: StepTrace,
    pub next_sample_s: f64,
    /// Set by a physics step: a robot–wall contact started during it.
    pub started_now: bool,
    /// Set by a physics step: the robot pressed on a wall during it.
    pub pressing_now: bool,
    /// The realistic profile's odometry, localiser and estimator (`None`: ideal).
    pub real: Option<Box<Realistic>>,
    /// Diagnostics since the last reset.
    pub diag: Diagnostics,
    /// The grid's expectation for the running step.
    expected: Option<Expected>,
}

impl Core {
    pub fn new(world: &World, cfg: RobotConfig) -> Result<Core, RobotError> {
        cfg.validate_for_world(world)?;
        let walls = walls(world);
        let free_non_goal = world.free_cells().filter(|&c| c != world.goal).collect();
        let cfg_profile = cfg.profile;
        let cfg_for_real = cfg.clone();
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
            real: (cfg_profile == Profile::Realistic).then(|| Box::new(Realistic::new(&cfg_for_real))),
            diag: Diagnostics::new(world, cfg_for_real.cell_diagnostics),
            expected: None,
        })
    }

    pub fn num_states(&self) -> usize {
        self.cfg.actions.table_shape(self.world.num_cells()).0
    }

    pub fn num_actions(&self) -> usize {
        self.cfg.actions.table_shape(self.world.num_cells()).1
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

    /// The state the learner sees: the believed cell (and heading), which is the true
    /// one for the ideal profile.
    pub fn current_state(&self, rb: &RigidBody) -> Result<State, EnvError> {
        let cell = self.believed_cell(rb)?;
        Ok(match self.cfg.actions {
            ActionSet::Moves => cell,
            ActionSet::Heading => cell * 4 + move_index(nearest_move(self.control_pose(rb).2)),
        })
    }

    /// The state of the true pose.
    pub fn true_state(&self, rb: &RigidBody) -> Result<State, EnvError> {
        let cell = self.current_cell(rb)?;
        Ok(match self.cfg.actions {
            ActionSet::Moves => cell,
            ActionSet::Heading => cell * 4 + move_index(nearest_move(raw_pose(rb).2)),
        })
    }

    /// The pose the controllers act on: the estimate (realistic) or the truth (ideal).
    pub fn control_pose(&self, rb: &RigidBody) -> (f64, f64, f64) {
        match &self.real {
            Some(r) => r.estimate(),
            None => raw_pose(rb),
        }
    }

    /// The pose estimate as a sample (realistic only).
    pub fn estimate_sample(&self) -> Option<PoseSample> {
        let (x, y, theta) = self.real.as_ref()?.estimate();
        Some(PoseSample { time_s: self.time_s, x, y, theta })
    }

    /// The cell the robot believes it is in: the true cell (ideal), or the free cell
    /// holding the estimate (realistic). An estimate outside the arena counts in the
    /// nearest cell; one inside a blocked cell counts in the free neighbour (of the 8)
    /// whose centre is nearest, or the true cell if there is none.
    pub fn believed_cell(&self, rb: &RigidBody) -> Result<usize, EnvError> {
        let Some(real) = &self.real else { return self.current_cell(rb) };
        let (x, y, _) = real.estimate();
        let w = &self.world;
        let cs = w.cell_size;
        if !(x.is_finite() && y.is_finite()) {
            return Err(self.physics_error(format!("non-finite pose estimate ({x}, {y})")));
        }
        let col = libm::floor(x / cs).clamp(0.0, (w.width - 1) as f64) as usize;
        let row_up = libm::floor(y / cs).clamp(0.0, (w.height - 1) as f64) as usize;
        let cell = w.index(w.height - 1 - row_up, col);
        if w.is_free(cell) {
            return Ok(cell);
        }
        let (r0, c0) = w.row_col(cell);
        let mut best: Option<(f64, usize)> = None;
        for dr in -1i64..=1 {
            for dc in -1i64..=1 {
                let (r, c) = (r0 as i64 + dr, c0 as i64 + dc);
                if r < 0 || c < 0 || r >= w.height as i64 || c >= w.width as i64 {
                    continue;
                }
                let n = w.index(r as usize, c as usize);
                if !w.is_free(n) {
                    continue;
                }
                let (nx, ny) = w.cell_center(n);
                let d2 = (nx - x) * (nx - x) + (ny - y) * (ny - y);
                if best.is_none_or(|(b, _)| d2 < b) {
                    best = Some((d2, n));
                }
            }
        }
        match best {
            Some((_, n)) => Ok(n),
            None => self.current_cell(rb),
        }
    }

    pub fn pose(&self, rb: &RigidBody) -> PoseSample {
        let (x, y, theta) = raw_pose(rb);
        PoseSample { time_s: self.time_s, x, y, theta }
    }

    fn sample_pose(&mut self, rb: &RigidBody) {
        let p = self.pose(rb);
        if self.trace.poses.last().is_none_or(|l| l.time_s != p.time_s) {
            self.trace.poses.push(p);
            if let Some(e) = self.estimate_sample() {
                self.trace.estimates.push(e);
            }
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
        self.clear_trace();
        self.diag.clear();
        self.expected = None;
        let th = heading_of(heading);
        if let Some(real) = &mut self.real {
            // The body is put at (x, y, θ) as f32 by the caller: start from that pose.
            let pose = (x as Real as f64, y as Real as f64, th as Real as f64);
            real.reset(seed, pose);
            self.drive.gain = real.calibration;
        }
        Ok((x, y, th))
    }

    /// Begins a step: checks the action, counts it, and either teleports from the goal
    /// (no physics) or starts the action's primitive.
    pub fn begin_step(&mut self, action: Action, rb: &mut RigidBody) -> Result<Begin, EnvError> {
        let n = self.num_actions();
        if action >= n {
            return Err(EnvError::InvalidAction { action, num_actions: n });
        }
        self.decision_step += 1;
        self.clear_trace();
        self.counts.primitives += 1;
        let true_cell = self.current_cell(rb)?;
        let mv = match self.cfg.actions {
            ActionSet::Moves => Some(Move::ALL[action]),
            ActionSet::Heading => (action == 0).then(|| nearest_move(raw_pose(rb).2)),
        };
        self.expected = Some(Expected { cell: true_cell, mv, t0: self.time_s });
        if true_cell == self.world.goal {
            self.teleport_to_respawn(rb);
            return Ok(Begin::Done(Event::Teleport));
        }
        let prim = match self.cfg.actions {
            ActionSet::Moves => Primitive::Go(Move::ALL[action]),
            ActionSet::Heading => match action {
                0 => Primitive::Go(nearest_move(self.control_pose(rb).2)),
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
        let true_cell = self.current_cell(rb)?;
        let believed = self.believed_cell(rb)?;
        let loc_error = self.real.as_ref().map(|r| {
            let (ex, ey, _) = r.estimate();
            let (x, y, _) = raw_pose(rb);
            libm::hypot(ex - x, ey - y)
        });
        if let Some(e) = self.expected.take() {
            self.diag.record(&self.world, &e, true_cell, reward, event, believed, loc_error, self.time_s);
        }
        Ok(Step { state: self.current_state(rb)?, reward, event, terminated: false, truncated: false })
    }

    /// Empties the trace of the step.
    pub fn clear_trace(&mut self) {
        self.trace.poses.clear();
        self.trace.contacts.clear();
        self.trace.estimates.clear();
        self.trace.fixes.clear();
    }

    /// After a physics step: (realistic) odometry, localisation and the filter; then the
    /// trace samples due.
    pub fn after_physics(&mut self, rb: &RigidBody) {
        if let Some(real) = &mut self.real {
            let fix =
                real.after_physics(self.drive.v, self.drive.w, self.cfg.dt_s, self.time_s, raw_pose(rb));
            if let (Some((x, y, theta)), Some(_)) = (fix, self.trace_period) {
                self.trace.fixes.push(PoseSample { time_s: self.time_s, x, y, theta });
            }
        }
        self.sample_trace(rb);
    }

    /// Trace samples due after a physics step.
    fn sample_trace(&mut self, rb: &RigidBody) {
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
        if let Some(real) = &mut self.real {
            // The motors' gain (counted by the encoders) times the wheels' rolling radius
            // ÷ the nominal one (fixed per reset; unseen).
            real.motor_gain = self.drive.gain;
            self.drive.gain[0] *= real.calibration[0];
            self.drive.gain[1] *= real.calibration[1];
        }
        let slip: f64 = self.rng.random();
        self.drive.traction = if slip < n.slip_probability { n.slip_friction_factor } else { 1.0 };
    }

    /// Starts a primitive: its noise, its first phase.
    fn start_primitive(&mut self, prim: Primitive, rb: &RigidBody) -> Result<PrimRun, EnvError> {
        let (_, _, th0) = self.control_pose(rb);
        let origin = self.believed_cell(rb)?;
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
        let pose = raw_pose(rb);
        if let Some(real) = &mut self.real {
            real.relocalise(pose);
        }
    }

    /// Build facts and this robot's physics step, preset and action set.
    pub fn features(&self) -> Vec<(String, String)> {
        let mut f = crate::features();
        f.push(("physics.dt_s".into(), self.cfg.dt_s.to_string()));
        f.push(("robot.preset".into(), self.cfg.preset.name().into()));
        f.push(("robot.actions".into(), format!("{:?}", self.cfg.actions).to_lowercase()));
        f.push(("robot.noise".into(), if self.cfg.noise.is_some() { "on" } else { "off" }.into()));
        f.push(("robot.profile".into(), self.cfg.profile.name().into()));
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
        .chain(self.diag.stats(self.time_s, self.real.is_some()))
        .chain(self.diag.cell_stats())
        .collect()
    }
}
