//! [`SwarmEnv`]: several differential-drive robots in one rapier world, each with the
//! single robot's dynamics and profile, deciding asynchronously in simulated time, whose
//! rewards reach them when a consultation over a radio network completes.
//!
//! A robot asks for an action when its primitive ends; the others keep moving. The
//! caller gives every waiting robot an action ([`SwarmEnv::act`]) and then
//! [`SwarmEnv::advance`]s the shared physics until at least one primitive ends; the
//! steps that ended are reported in robot order. A robot that bumps into another robot
//! backs off as it does from a wall and earns the swarm's `bump_penalty`. A robot
//! teleported from the goal lands in the respawn cell, or, when another robot is within
//! a cell of it, in the nearest cell clear of every robot.
//!
//! With one robot and `consult = "none"` the swarm is the single robot bit for bit: the
//! same rapier world, the same streams, the same physics steps (a test holds this).

pub mod config;
mod deliver;
mod step;

use mmq_core::seed::splitmix64;
use mmq_core::{Action, EnvError, Event, PoseSample, Start, State, World};
use rapier2d::prelude::{ColliderHandle, PhysicsWorld, RigidBodyHandle};

pub use self::config::{
    Consult, Learners, MAX_ROBOTS, SWARM_FIELDS, Starts, SwarmConfig, apply_swarm_overrides,
};
use self::deliver::Post;
pub use self::deliver::{Delivery, RobotDelays, SwarmStep};

use crate::arena::{Collector, Wall, insert_robot, new_world};
use crate::config::{RobotConfig, RobotError};
use crate::primitive::{Begin, PrimRun, raw_pose};
use crate::robot::Core;

/// What a robot is doing.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Doing {
    /// Waiting for an action (after a reset, or once its step was reported).
    Waiting,
    /// Running a primitive.
    Running(PrimRun),
    /// Its step ended without physics (the goal's teleport); reported by the next
    /// [`SwarmEnv::advance`].
    Ended(Event),
    /// Parked: it takes no more actions and stands still.
    Parked,
}

/// One robot of the swarm: its core, its rapier body and what it is doing.
struct Member {
    core: Core,
    body: RigidBodyHandle,
    collider: ColliderHandle,
    doing: Doing,
    /// The command of the next physics step.
    cmd: (f64, f64),
    /// Whether the running primitive's first contact was with another robot (`None`:
    /// no contact yet).
    first_contact_robot: Option<bool>,
    /// Primitives that ended in a bump into another robot, since the reset.
    robot_bumps: u64,
}

/// The seed of robot `i`'s environment stream: robot 0 has the swarm's own seed, so a
/// swarm of one is the single robot.
pub fn robot_seed(seed: u64, i: usize) -> u64 {
    if i == 0 { seed } else { splitmix64(seed ^ splitmix64(0x5377_6172_6d00_0000 ^ i as u64)) }
}

/// The swarm environment.
pub struct SwarmEnv {
    world: World,
    cfg: RobotConfig,
    swarm: SwarmConfig,
    walls: Vec<Wall>,
    members: Vec<Member>,
    phys: PhysicsWorld,
    collector: Collector,
    post: Post,
    /// Pose frames of every robot every `period` seconds of simulated time (`None`: off).
    trace_period: Option<f64>,
    next_frame_s: f64,
    frames: Vec<SwarmFrame>,
}

/// Every robot's pose (and estimate, realistic profile) at one instant.
#[derive(Clone, Debug, PartialEq)]
pub struct SwarmFrame {
    /// Simulated time, seconds.
    pub time_s: f64,
    /// Every robot's true pose, robot order.
    pub poses: Vec<PoseSample>,
    /// Every robot's pose estimate (`None` on the ideal profile).
    pub estimates: Vec<Option<PoseSample>>,
}

impl std::fmt::Debug for SwarmEnv {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SwarmEnv")
            .field("world", &self.world.name)
            .field("robots", &self.members.len())
            .field("consult", &self.swarm.consult)
            .finish_non_exhaustive()
    }
}

impl SwarmEnv {
    /// Builds the arena of `world` with `swarm.robots` robots configured by `cfg`.
    /// Call [`SwarmEnv::reset`] before acting.
    pub fn new(world: &World, cfg: RobotConfig, swarm: SwarmConfig) -> Result<SwarmEnv, RobotError> {
        let mut members = Vec::with_capacity(swarm.robots);
        for _ in 0..swarm.robots {
            members.push(Member {
                core: Core::new(world, cfg.clone())?,
                body: RigidBodyHandle::invalid(),
                collider: ColliderHandle::invalid(),
                doing: Doing::Waiting,
                cmd: (0.0, 0.0),
                first_contact_robot: None,
                robot_bumps: 0,
            });
        }
        let walls = crate::arena::walls(world);
        let phys = new_world(&walls, &cfg, None);
        let post = Post::new(&swarm, world)?;
        Ok(SwarmEnv {
            world: world.clone(),
            cfg,
            swarm,
            walls,
            members,
            phys,
            collector: Collector::default(),
            post,
            trace_period: None,
            next_frame_s: 0.0,
            frames: Vec::new(),
        })
    }

    /// The number of robots.
    pub fn robots(&self) -> usize {
        self.members.len()
    }

    /// The resolved robot configuration (every robot's).
    pub fn config(&self) -> &RobotConfig {
        &self.cfg
    }

    /// The resolved swarm configuration.
    pub fn swarm(&self) -> &SwarmConfig {
        &self.swarm
    }

    /// The world.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// States per robot (the single robot's table shape).
    pub fn num_states(&self) -> usize {
        self.members[0].core.num_states()
    }

    /// Actions per robot.
    pub fn num_actions(&self) -> usize {
        self.members[0].core.num_actions()
    }

    /// The cell of a state.
    pub fn state_cell(&self, state: State) -> usize {
        self.members[0].core.state_cell(state)
    }

    /// Simulated time since the reset, seconds (one clock for the swarm).
    pub fn time_s(&self) -> f64 {
        self.members[0].core.time_s
    }

    /// Starts an episode: every robot at its start, at rest, waiting for an action.
    /// `seed` seeds the robots' streams ([`robot_seed`]), `net_seed` the radio's.
    /// Returns every robot's state.
    pub fn reset(&mut self, seed: u64, net_seed: u64) -> Result<Vec<State>, EnvError> {
        self.reset_inner(seed, net_seed, None)
    }

    /// [`SwarmEnv::reset`] with robot 0 put at `first` (`Start::Respawn`: the single
    /// robot's greedy evaluation); a later robot whose start is taken moves on to the next
    /// free cell.
    pub fn reset_from(&mut self, seed: u64, net_seed: u64, first: Start) -> Result<Vec<State>, EnvError> {
        self.reset_inner(seed, net_seed, Some(first))
    }

    fn reset_inner(
        &mut self,
        seed: u64,
        net_seed: u64,
        first: Option<Start>,
    ) -> Result<Vec<State>, EnvError> {
        let mut taken: Vec<usize> = Vec::with_capacity(self.members.len());
        let mut poses = Vec::with_capacity(self.members.len());
        let heading_states = self.num_states() > self.world.num_cells();
        for (i, m) in self.members.iter_mut().enumerate() {
            let s = robot_seed(seed, i);
            let start = match (&self.swarm.starts, first) {
                (_, Some(f)) if i == 0 => f,
                (Starts::Cells(cells), _) => Start::State(cells[i] * if heading_states { 4 } else { 1 }),
                (Starts::Random, _) => Start::World,
            };
            let mut pose = m.core.reset(s, start)?;
            let cell = self.world.cell_at(pose.0, pose.1).unwrap_or(self.world.respawn);
            if taken.contains(&cell) {
                let next = next_free(&self.world, cell, &taken)
                    .ok_or(EnvError::InvalidStart(cell * if heading_states { 4 } else { 1 }))?;
                pose = m.core.reset(s, Start::State(next * if heading_states { 4 } else { 1 }))?;
                taken.push(next);
            } else {
                taken.push(cell);
            }
            poses.push(pose);
        }
        self.phys = new_world(&self.walls, &self.cfg, None);
        for (m, &(x, y, th)) in self.members.iter_mut().zip(&poses) {
            (m.body, m.collider) = insert_robot(&mut self.phys, &self.cfg, x, y, th, None);
            m.doing = Doing::Waiting;
            m.cmd = (0.0, 0.0);
            m.first_contact_robot = None;
            m.robot_bumps = 0;
        }
        if let Ok(mut e) = self.collector.events.lock() {
            e.clear();
        }
        self.post.reset(net_seed, self.members.len());
        self.frames.clear();
        self.next_frame_s = 0.0;
        self.sample_frames();
        self.members.iter().map(|m| m.core.current_state(&self.phys.bodies[m.body])).collect()
    }

    /// Whether robot `robot` waits for an action.
    pub fn waiting(&self, robot: usize) -> bool {
        self.members.get(robot).is_some_and(|m| m.doing == Doing::Waiting)
    }

    /// Gives waiting robot `robot` its next action: its primitive starts now.
    pub fn act(&mut self, robot: usize, action: Action) -> Result<(), EnvError> {
        let n = self.members.len();
        let Some(m) = self.members.get_mut(robot) else {
            return Err(EnvError::Physics {
                step: 0,
                message: format!("no robot {robot} in a swarm of {n}"),
            });
        };
        if m.doing != Doing::Waiting {
            let message =
                format!("robot {robot} is not waiting for an action (its primitive is still running)");
            return Err(EnvError::Physics { step: m.core.decision_step, message });
        }
        m.first_contact_robot = None;
        m.doing = match m.core.begin_step(action, &mut self.phys.bodies[m.body])? {
            Begin::Done(e) => Doing::Ended(e),
            Begin::Run(prim) => Doing::Running(prim),
        };
        if m.doing == Doing::Ended(Event::Teleport) {
            self.clear_landing(robot);
        }
        Ok(())
    }

    /// After robot `robot`'s goal teleport to the respawn cell: if another robot is
    /// within a cell of it, the robot lands instead at the free, non-goal cell nearest
    /// the respawn cell (then the lowest index) that is at least a cell away from every
    /// other robot. With one robot nothing moves.
    fn clear_landing(&mut self, robot: usize) {
        let cs = self.world.cell_size;
        let others: Vec<(f64, f64)> = (self.members.iter().enumerate())
            .filter(|&(j, _)| j != robot)
            .map(|(_, m)| {
                let (x, y, _) = raw_pose(&self.phys.bodies[m.body]);
                (x, y)
            })
            .collect();
        let clear = |(x, y): (f64, f64)| others.iter().all(|&(ox, oy)| libm::hypot(ox - x, oy - y) >= cs);
        let w = &self.world;
        let home = w.cell_center(w.respawn);
        if clear(home) {
            return;
        }
        let dist = |c: usize| {
            let (x, y) = w.cell_center(c);
            libm::hypot(x - home.0, y - home.1)
        };
        let mut cells: Vec<usize> =
            w.free_cells().filter(|&c| c != w.goal && clear(w.cell_center(c))).collect();
        cells.sort_by(|&a, &b| dist(a).total_cmp(&dist(b)).then(a.cmp(&b)));
        let Some(&cell) = cells.first() else { return };
        let (x, y) = w.cell_center(cell);
        let m = &mut self.members[robot];
        let rb = &mut self.phys.bodies[m.body];
        let mut pose = *rb.position();
        pose.translation =
            rapier2d::prelude::Vector::new(x as rapier2d::prelude::Real, y as rapier2d::prelude::Real);
        rb.set_position(pose, true);
        let p = raw_pose(rb);
        if let Some(real) = &mut m.core.real {
            real.relocalise(p);
        }
    }

    /// Parks robot `robot`: it takes no more actions and stands still (its budget is
    /// spent). A parked robot still moves if pushed.
    pub fn park(&mut self, robot: usize) {
        if let Some(m) = self.members.get_mut(robot) {
            m.doing = Doing::Parked;
        }
    }

    /// Runs the shared physics until at least one robot's primitive ends, and appends
    /// the steps that ended, in robot order, to `out`. Returns at once (with nothing)
    /// when no robot is running a primitive.
    pub fn advance(&mut self, out: &mut Vec<SwarmStep>) -> Result<(), EnvError> {
        loop {
            let mut any_running = false;
            let mut ended = false;
            for m in &mut self.members {
                match &mut m.doing {
                    Doing::Running(prim) => {
                        any_running = true;
                        match prim.next(&m.core, &self.phys.bodies[m.body]) {
                            crate::primitive::Next::End(e) => {
                                m.doing = Doing::Ended(e);
                                ended = true;
                            }
                            crate::primitive::Next::Command(v, w) => m.cmd = (v, w),
                        }
                    }
                    Doing::Ended(_) => ended = true,
                    Doing::Waiting | Doing::Parked => m.cmd = (0.0, 0.0),
                }
            }
            if ended {
                return self.finish_ended(out);
            }
            if !any_running {
                return Ok(());
            }
            self.physics_step()?;
            for m in &mut self.members {
                let rb = &self.phys.bodies[m.body];
                m.core.after_physics(rb);
                if let Doing::Running(prim) = &mut m.doing {
                    prim.after_physics(&m.core);
                }
            }
            self.sample_frames();
        }
    }

    /// Finishes every ended step: its reward, its consultation, the robot's deliveries.
    fn finish_ended(&mut self, out: &mut Vec<SwarmStep>) -> Result<(), EnvError> {
        let positions: Vec<(f64, f64)> = self
            .members
            .iter()
            .map(|m| {
                let (x, y, _) = raw_pose(&self.phys.bodies[m.body]);
                (x, y)
            })
            .collect();
        for (i, m) in self.members.iter_mut().enumerate() {
            let Doing::Ended(event) = m.doing else { continue };
            let rb = &self.phys.bodies[m.body];
            let mut step = m.core.finish_step(event, rb)?;
            if event == Event::WallBump && m.first_contact_robot == Some(true) {
                step.reward = self.swarm.bump_penalty;
                m.robot_bumps += 1;
            }
            m.doing = Doing::Waiting;
            let decision = m.core.decision_step - 1;
            let now = m.core.time_s;
            out.push(self.post.after_step(i, decision, now, step, &positions));
        }
        Ok(())
    }

    /// Records a frame of every robot's pose every `period_s` seconds of simulated time
    /// (from the next reset or frame on; `None` or a non-positive period: off). Frames
    /// cost nothing while off.
    pub fn set_trace(&mut self, period_s: Option<f64>) {
        self.trace_period = period_s.filter(|p| p.is_finite() && *p > 0.0);
        self.next_frame_s = self.time_s();
    }

    /// Moves the frames recorded since the last call into `out` (emptied first), oldest
    /// first.
    pub fn take_frames(&mut self, out: &mut Vec<SwarmFrame>) {
        out.clear();
        std::mem::swap(&mut self.frames, out);
    }

    /// A frame of every robot if one is due.
    fn sample_frames(&mut self) {
        let Some(period) = self.trace_period else { return };
        let now = self.time_s();
        if now < self.next_frame_s {
            return;
        }
        while self.next_frame_s <= now {
            self.next_frame_s += period;
        }
        let (poses, estimates) = (self.poses(), self.estimates());
        self.frames.push(SwarmFrame { time_s: now, poses, estimates });
    }

    /// Every robot's true pose.
    pub fn poses(&self) -> Vec<PoseSample> {
        self.members.iter().map(|m| m.core.pose(&self.phys.bodies[m.body])).collect()
    }

    /// Every robot's pose estimate (realistic profile), else `None`.
    pub fn estimates(&self) -> Vec<Option<PoseSample>> {
        self.members.iter().map(|m| m.core.estimate_sample()).collect()
    }

    /// Every robot's true state (what the learner would see without estimation error).
    pub fn true_states(&self) -> Result<Vec<State>, EnvError> {
        self.members.iter().map(|m| m.core.true_state(&self.phys.bodies[m.body])).collect()
    }

    /// Robot `robot`'s true state where its state is a belief (the realistic profile),
    /// as the single robot's `Env::true_state`; `None` for the ideal profile.
    pub fn true_state(&self, robot: usize) -> Option<State> {
        let m = self.members.get(robot)?;
        m.core.real.as_ref()?;
        m.core.true_state(&self.phys.bodies[m.body]).ok()
    }

    /// Primitives of robot `robot` that ended in a bump into another robot.
    pub fn robot_bumps(&self, robot: usize) -> u64 {
        self.members.get(robot).map_or(0, |m| m.robot_bumps)
    }

    /// Robot `robot`'s counters and diagnostics, as the single robot reports them.
    pub fn stats(&self, robot: usize) -> Vec<(String, f64)> {
        self.members.get(robot).map(|m| m.core.stats()).unwrap_or_default()
    }

    /// The emerged delays so far, per robot.
    pub fn delays(&self) -> &[RobotDelays] {
        self.post.delays()
    }

    /// The rewards emitted but not delivered yet, per robot (count, sum).
    pub fn in_flight(&self) -> Vec<(u64, f64)> {
        self.post.in_flight()
    }
}

/// The first free, non-goal cell after `cell` in reading order (wrapping) that is not
/// `taken`.
fn next_free(world: &World, cell: usize, taken: &[usize]) -> Option<usize> {
    let n = world.num_cells();
    (1..n).map(|d| (cell + d) % n).find(|&c| world.is_free(c) && c != world.goal && !taken.contains(&c))
}
