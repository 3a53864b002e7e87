//! [`MultiArena`]: N robot arenas sharing one rapier world, stepped in lock-step.
//!
//! Every arena is the same arena of the same world file, **at the same coordinates**:
//! the walls exist once, and every robot collides with the walls but with no other
//! robot (collision groups: robots in group 1 filter group 2, walls in group 2 filter
//! group 1; rapier's broad phase drops robot–robot pairs). Offsetting the arenas in space
//! instead would change the f32 coordinates, and with them the rounding of every
//! position update and contact, so no arena could reproduce a single-arena run.
//!
//! Each arena keeps everything of [`RobotEnv`](crate::RobotEnv) but its rapier body (drive, controllers,
//! noise stream, clock, counters, trace) in the same code (`Core`, `PrimRun` in `env.rs`).
//! [`MultiArena::step_all`] runs one primitive in every arena, physics step by physics
//! step:
//!
//! 1. every arena whose primitive is still running commands its drive;
//! 2. if all of them are in free flight (see `docs/robot.md`), they are integrated
//!    without rapier, exactly as [`RobotEnv`](crate::RobotEnv) does; otherwise rapier steps the whole
//!    world once: the running robots are integrated and solved by rapier;
//! 3. an arena whose primitive has ended **waits**: before a rapier step its robot's
//!    velocity is set to zero, after it its pose and velocity are put back, so that it
//!    starts its next primitive as a [`RobotEnv`](crate::RobotEnv) would (which does not simulate between
//!    primitives). Far from the walls (every primitive but a time-out ends at a cell
//!    centre) rapier finds nothing to do for it. Within reach of a wall, rapier may
//!    report a contact start or stop for the waiting robot; a [`RobotEnv`](crate::RobotEnv) sees the same
//!    report on its next rapier step (same pose, and a robot in contact is never in free
//!    flight), so it is held back and delivered on the arena's next rapier step. Such
//!    waits are counted ([`MultiArena::near_wall_waits`]).
//!
//! Contact reports of one physics step may come in another order than in a
//! [`RobotEnv`](crate::RobotEnv) (rapier lists them in the order of its pair graph, which depends on the
//! other robots); everything else is the same.
//!
//! Whether the result is bit-identical to one [`RobotEnv`](crate::RobotEnv) per seed is tested in
//! `tests/robot/multi.rs`; see `docs/robot.md`, "Many arenas in one world".

use mmq_core::{Action, EnvError, Event, PoseSample, Start, State, Step, StepTrace, World};
use rapier2d::prelude::{
    ColliderHandle, CollisionEvent, Group, InteractionGroups, InteractionTestMode, PhysicsWorld, Real,
    RigidBodyHandle, Vector,
};

use crate::arena::{Collector, insert_robot, new_world, wall_of};
use crate::config::{RobotConfig, RobotError};
use crate::physics::pressing;
use crate::primitive::{Begin, Next, PrimRun};
use crate::robot::Core;

/// Collision groups of the robots: they meet walls only.
const ROBOT_GROUPS: InteractionGroups =
    InteractionGroups::new(Group::GROUP_1, Group::GROUP_2, InteractionTestMode::And);
/// Collision groups of the walls: they meet robots only.
const WALL_GROUPS: InteractionGroups =
    InteractionGroups::new(Group::GROUP_2, Group::GROUP_1, InteractionTestMode::And);

/// One arena: the robot's state and its body in the shared world.
struct Slot {
    core: Core,
    robot: RigidBodyHandle,
    collider: ColliderHandle,
    /// The running primitive.
    run: Option<PrimRun>,
    /// How the current step ended (set once the primitive ends or fails).
    end: Option<Result<Event, EnvError>>,
    /// A physics error happened since the last reset: the arena waits until reset.
    failed: bool,
    /// Rapier steps this arena waited through within reach of a wall.
    near_wall_waits: u64,
    /// Contact starts and stops (started, wall) reported while it waited: a RobotEnv
    /// sees them on its next rapier step.
    pending: Vec<(bool, usize)>,
}

/// N arenas of one world, each with its own robot, seed and actions, in one rapier world.
pub struct MultiArena {
    template: Core,
    phys: PhysicsWorld,
    collector: Collector,
    slots: Vec<Slot>,
    /// Scratch: (arena, v, ω) of the arenas that take this physics step.
    cmds: Vec<(usize, f64, f64)>,
    /// Scratch: whether each of `cmds` is in free flight.
    free: Vec<bool>,
    /// Scratch: the saved pose and velocity of the waiting arenas.
    saved: Vec<(usize, rapier2d::prelude::Pose, Vector, Real)>,
    /// World steps taken by rapier since the last reset.
    world_rapier_steps: u64,
    /// Physics steps (rapier or free flight) since the last reset.
    world_physics_steps: u64,
}

impl std::fmt::Debug for MultiArena {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MultiArena")
            .field("world", &self.template.world.name)
            .field("arenas", &self.slots.len())
            .field("world_physics_steps", &self.world_physics_steps)
            .field("world_rapier_steps", &self.world_rapier_steps)
            .finish_non_exhaustive()
    }
}

impl MultiArena {
    /// `n` arenas of `world` with robots configured by `cfg` (validated against the
    /// world). Call [`MultiArena::reset`] before stepping.
    pub fn new(world: &World, cfg: RobotConfig, n: usize) -> Result<MultiArena, RobotError> {
        let template = Core::new(world, cfg)?;
        let mut m = MultiArena {
            phys: new_world(&template.walls, &template.cfg, Some(WALL_GROUPS)),
            template,
            collector: Collector::default(),
            slots: Vec::with_capacity(n),
            cmds: Vec::with_capacity(n),
            free: Vec::with_capacity(n),
            saved: Vec::with_capacity(n),
            world_rapier_steps: 0,
            world_physics_steps: 0,
        };
        let (x, y) = world.cell_center(world.respawn);
        for _ in 0..n {
            let core = Core::new(world, m.template.cfg.clone())?;
            let (robot, collider) =
                insert_robot(&mut m.phys, &core.cfg, x, y, std::f64::consts::FRAC_PI_2, Some(ROBOT_GROUPS));
            m.slots.push(Slot {
                core,
                robot,
                collider,
                run: None,
                end: None,
                failed: false,
                near_wall_waits: 0,
                pending: Vec::new(),
            });
        }
        Ok(m)
    }

    /// The number of arenas.
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// Whether there are no arenas.
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// The resolved configuration (the same for every arena).
    pub fn config(&self) -> &RobotConfig {
        &self.template.cfg
    }

    /// Number of states of each arena (as [`mmq_core::Env::num_states`]).
    pub fn num_states(&self) -> usize {
        self.template.num_states()
    }

    /// Number of actions of each arena (as [`mmq_core::Env::num_actions`]).
    pub fn num_actions(&self) -> usize {
        self.template.num_actions()
    }

    /// Resets every arena: arena k as [`mmq_core::Env::reset`]`(seeds[k], start)` would
    /// reset a [`RobotEnv`](crate::RobotEnv)(crate::RobotEnv). The rapier world is rebuilt from scratch
    /// (no solver cache survives), so all arenas reset together. Returns the start states.
    /// After an error (an invalid [`Start::State`]) every arena reports an error until a
    /// reset succeeds.
    ///
    /// # Panics
    /// If `seeds.len()` is not the number of arenas.
    pub fn reset(&mut self, seeds: &[u64], start: Start) -> Result<Vec<State>, EnvError> {
        assert_eq!(seeds.len(), self.slots.len(), "one seed per arena");
        let mut poses = Vec::with_capacity(seeds.len());
        for (k, &seed) in seeds.iter().enumerate() {
            match self.slots[k].core.reset(seed, start) {
                Ok(p) => poses.push(p),
                Err(e) => {
                    // Half reset: no arena may step until a reset succeeds.
                    for slot in &mut self.slots {
                        slot.failed = true;
                    }
                    return Err(e);
                }
            }
        }
        self.phys = new_world(&self.template.walls, &self.template.cfg, Some(WALL_GROUPS));
        for (slot, &(x, y, theta)) in self.slots.iter_mut().zip(&poses) {
            let (robot, collider) =
                insert_robot(&mut self.phys, &slot.core.cfg, x, y, theta, Some(ROBOT_GROUPS));
            slot.robot = robot;
            slot.collider = collider;
            slot.run = None;
            slot.end = None;
            slot.failed = false;
            slot.near_wall_waits = 0;
            slot.pending.clear();
        }
        if let Ok(mut e) = self.collector.events.lock() {
            e.clear();
        }
        self.world_rapier_steps = 0;
        self.world_physics_steps = 0;
        self.slots.iter().map(|s| s.core.current_state(&self.phys.bodies[s.robot])).collect()
    }

    /// One decision step in every arena: arena k runs `actions[k]` to its end, as
    /// [`mmq_core::Env::step`] on a [`RobotEnv`](crate::RobotEnv)(crate::RobotEnv) would. Arenas whose
    /// primitive ends early wait for the others. An arena that fails (invalid action,
    /// physics error) reports its error and, after a physics error, keeps reporting one
    /// until [`MultiArena::reset`]; the others go on.
    ///
    /// # Panics
    /// If `actions.len()` is not the number of arenas.
    pub fn step_all(&mut self, actions: &[Action]) -> Vec<Result<Step, EnvError>> {
        assert_eq!(actions.len(), self.slots.len(), "one action per arena");
        for (slot, &a) in self.slots.iter_mut().zip(actions) {
            slot.run = None;
            slot.end = None;
            if slot.failed {
                let e = slot.core.physics_error("this arena failed earlier; reset it".into());
                slot.end = Some(Err(e));
                continue;
            }
            match slot.core.begin_step(a, &mut self.phys.bodies[slot.robot]) {
                Ok(Begin::Done(e)) => slot.end = Some(Ok(e)),
                Ok(Begin::Run(p)) => slot.run = Some(p),
                Err(e) => slot.end = Some(Err(e)),
            }
        }
        while self.physics_step() {}
        self.slots
            .iter_mut()
            .map(|slot| match slot.end.take() {
                Some(Ok(e)) => slot.core.finish_step(e, &self.phys.bodies[slot.robot]),
                Some(Err(e)) => Err(e),
                None => Err(slot.core.physics_error("primitive did not end".into())),
            })
            .collect()
    }

    /// One physics step of every running primitive; false when none is running.
    fn physics_step(&mut self) -> bool {
        self.cmds.clear();
        for (k, slot) in self.slots.iter_mut().enumerate() {
            let Some(run) = slot.run.as_mut() else { continue };
            match run.next(&slot.core, &self.phys.bodies[slot.robot]) {
                Next::Command(v, w) => self.cmds.push((k, v, w)),
                Next::End(e) => {
                    slot.end = Some(Ok(e));
                    slot.run = None;
                }
            }
        }
        if self.cmds.is_empty() {
            return false;
        }
        self.world_physics_steps += 1;
        let params = self.phys.integration_parameters;
        self.free.clear();
        for &(k, v, w) in &self.cmds {
            let slot = &mut self.slots[k];
            let rb = &mut self.phys.bodies[slot.robot];
            slot.core.drive_body(rb, v, w);
            self.free.push(slot.core.is_free(rb, &params));
        }
        if self.free.iter().all(|&f| f) {
            for &(k, _, _) in &self.cmds {
                Core::free_flight(&mut self.phys.bodies[self.slots[k].robot], &params);
            }
        } else {
            self.rapier_step(&params);
        }
        let quarantine = self.phys.quarantine().bodies();
        for &(k, _, _) in &self.cmds {
            let slot = &mut self.slots[k];
            let rb = &self.phys.bodies[slot.robot];
            if let Err(e) = slot.core.check_runaway(rb, quarantine.contains(&slot.robot)) {
                slot.end = Some(Err(e));
                slot.run = None;
                slot.failed = true;
                continue;
            }
            slot.core.after_physics(rb);
            if let Some(run) = slot.run.as_mut() {
                run.after_physics(&slot.core);
            }
        }
        true
    }

    /// Steps rapier once for the whole world, the waiting arenas held in place.
    fn rapier_step(&mut self, params: &rapier2d::prelude::IntegrationParameters) {
        self.world_rapier_steps += 1;
        // Waiting arenas: at rest during the step, then put back.
        self.saved.clear();
        let mut c = 0;
        for (k, slot) in self.slots.iter_mut().enumerate() {
            if self.cmds.get(c).is_some_and(|&(j, _, _)| j == k) {
                c += 1;
                continue;
            }
            let rb = &mut self.phys.bodies[slot.robot];
            if !slot.failed && !slot.core.is_clear(rb, params) {
                slot.near_wall_waits += 1;
            }
            self.saved.push((k, *rb.position(), rb.linvel(), rb.angvel()));
            rb.set_linvel(Vector::ZERO, false);
            rb.set_angvel(0.0, false);
        }
        self.phys.step_with_events(&(), &self.collector);
        for &(k, pose, lv, w) in &self.saved {
            let rb = &mut self.phys.bodies[self.slots[k].robot];
            rb.set_position(pose, false);
            rb.set_linvel(lv, false);
            rb.set_angvel(w, false);
        }
        for (&(k, _, _), &free) in self.cmds.iter().zip(&self.free) {
            if !free {
                self.slots[k].core.counts.rapier_steps += 1;
            }
        }
        // Contact starts and stops held back during waits, on the arena's first rapier
        // step since (where a RobotEnv would see them).
        for (&(k, _, _), &free) in self.cmds.iter().zip(&self.free) {
            let slot = &mut self.slots[k];
            if !free && !slot.pending.is_empty() {
                for &(started, wall) in &slot.pending {
                    slot.core.contact_event(started, wall);
                }
                slot.pending.clear();
            }
        }
        // Contact starts and stops, to the arena of the robot involved; a waiting
        // arena's are held back (a failed arena's dropped).
        if let Ok(mut events) = self.collector.events.lock() {
            for e in events.drain(..) {
                let (c1, c2) = (e.collider1(), e.collider2());
                let Some((k, other)) = self.slots.iter().enumerate().find_map(|(k, s)| {
                    if s.collider == c1 {
                        Some((k, c2))
                    } else if s.collider == c2 {
                        Some((k, c1))
                    } else {
                        None
                    }
                }) else {
                    continue;
                };
                let Some(wall) = wall_of(&self.phys, other) else { continue };
                let started = matches!(e, CollisionEvent::Started(..));
                let slot = &mut self.slots[k];
                if slot.run.is_some() {
                    slot.core.contact_event(started, wall);
                } else if !slot.failed {
                    slot.pending.push((started, wall));
                }
            }
        }
        for &(k, _, _) in &self.cmds {
            let slot = &mut self.slots[k];
            slot.core.pressing_now = pressing(&self.phys, slot.collider);
        }
    }

    /// The pose of arena `k`'s robot (as [`mmq_core::Env::pose`]).
    pub fn pose(&self, k: usize) -> PoseSample {
        let s = &self.slots[k];
        s.core.pose(&self.phys.bodies[s.robot])
    }

    /// Simulated time of arena `k`, seconds.
    pub fn sim_time_s(&self, k: usize) -> f64 {
        self.slots[k].core.time_s
    }

    /// Statistics of arena `k` (as [`mmq_core::Env::stats`]; `robot/rapier_steps`
    /// counts the steps on which a [`RobotEnv`](crate::RobotEnv)(crate::RobotEnv) would have stepped rapier).
    pub fn stats(&self, k: usize) -> Vec<(String, f64)> {
        self.slots[k].core.stats()
    }

    /// Rapier steps arena `k` waited through within reach of a wall since the last
    /// reset (its contact reports were held back to its next rapier step).
    pub fn near_wall_waits(&self, k: usize) -> u64 {
        self.slots[k].near_wall_waits
    }

    /// Physics steps of the world since the last reset, and how many of them stepped
    /// rapier.
    pub fn world_steps(&self) -> (u64, u64) {
        (self.world_physics_steps, self.world_rapier_steps)
    }

    /// Turns pose and contact tracing on (period in seconds) or off for every arena, as
    /// [`mmq_core::Env::set_trace`].
    pub fn set_trace(&mut self, period_s: Option<f64>) {
        for s in &mut self.slots {
            s.core.trace_period = period_s.filter(|p| p.is_finite() && *p > 0.0);
        }
    }

    /// Moves arena `k`'s trace of the last step into `out` (as
    /// [`mmq_core::Env::take_trace`]).
    pub fn take_trace(&mut self, k: usize, out: &mut StepTrace) {
        let core = &mut self.slots[k].core;
        std::mem::swap(&mut core.trace, out);
        core.clear_trace();
    }

    /// Arena `k`'s pose estimate (as [`mmq_core::Env::pose_estimate`]).
    pub fn pose_estimate(&self, k: usize) -> Option<PoseSample> {
        self.slots[k].core.estimate_sample()
    }

    /// Arena `k`'s true state where it differs from the belief (as
    /// [`mmq_core::Env::true_state`]).
    pub fn true_state(&self, k: usize) -> Option<State> {
        let s = &self.slots[k];
        s.core.real.as_ref()?;
        s.core.true_state(&self.phys.bodies[s.robot]).ok()
    }
}
