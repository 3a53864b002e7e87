//! [`RobotEnv`]: the robot as an [`Env`]. A step runs one motion primitive to its end
//! (target reached, bump handled, or time-out) with fixed physics steps, then reports the
//! cell holding the robot's centre.

use std::f64::consts::FRAC_PI_2;
use std::fmt;

use mmq_core::{
    Action, Env, EnvError, Event, Move, PoseSample, Start, State, Step, StepTrace, Telemetry, World,
};
use rapier2d::prelude::{CollisionEvent, Real, RigidBody, Vector};

use crate::arena::{Collector, Scene, Wall};
use crate::config::{ActionSet, RobotConfig, RobotError};
use crate::physics::pressing;
use crate::primitive::{Begin, Next, PrimRun};
use crate::robot::Core;

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
            self.core.after_physics(rb);
            prim.after_physics(&self.core);
        }
    }
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
}

impl Telemetry for RobotEnv {
    fn sim_time_s(&self) -> f64 {
        self.core.time_s
    }

    fn set_trace(&mut self, period_s: Option<f64>) {
        self.core.trace_period = period_s.filter(|p| p.is_finite() && *p > 0.0);
    }

    fn take_trace(&mut self, out: &mut StepTrace) {
        std::mem::swap(&mut self.core.trace, out);
        self.core.clear_trace();
    }

    fn pose(&self) -> PoseSample {
        self.core.pose(self.body())
    }

    fn pose_estimate(&self) -> Option<PoseSample> {
        self.core.estimate_sample()
    }

    fn true_state(&self) -> Option<State> {
        self.core.real.as_ref()?;
        self.core.true_state(self.body()).ok()
    }

    fn stats(&self) -> Vec<(String, f64)> {
        self.core.stats()
    }
}
