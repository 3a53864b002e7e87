//! The native side of `mmq.pettingzoo.swarm_v0`: a [`SwarmEnv`] (several rapier robots
//! in one arena, deciding asynchronously, their rewards delivered when a radio
//! consultation completes) driven one call at a time from Python: seeded resets (the
//! CLI's seed tree, so a seed gives the lab's swarm trajectory), actions for the waiting
//! robots, and `advance` (with the GIL released) returning the steps that ended.

use mmq_core::{Env, SeedTree, Stream, World};
use mmq_robot::swarm::{SWARM_FIELDS, SwarmConfig, SwarmEnv, SwarmStep};
use mmq_robot::{Profile, RobotConfig, RobotError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyString, PyTuple};

use crate::config::{config_err, load_world, robot_world, to_toml};
use crate::env::action_arg;
use crate::{env_err, seed_arg};

/// One delivery: (decision that earned it, value, earned at s, consultation delay s,
/// hops).
pub type DeliveryRow = (u64, f64, f64, f64, u32);

/// One ended step: (robot, decision, state, earned reward, event, time s, delivered,
/// deliveries, consultation (delay s, hops) or None, true state (realistic) or None).
pub type StepRow =
    (usize, u64, usize, f64, &'static str, f64, f64, Vec<DeliveryRow>, Option<(f64, u32)>, Option<usize>);

/// The world's `[robot]` table edited by `robot`: a dict of fields (dotted keys reach
/// nested tables, e.g. `{"profile": "realistic", "noise.slip": 0.02}`) or a list of
/// `KEY=VALUE` texts (the CLI's `--robot`).
fn robot_table(world: &World, robot: Option<&Bound<'_, PyAny>>) -> PyResult<World> {
    let Some(r) = robot.filter(|r| !r.is_none()) else { return Ok(world.clone()) };
    if let Ok(d) = r.cast::<PyDict>() {
        return robot_world(world, None, None, Some(d)).map_err(|e| {
            let msg = e.to_string();
            config_err("robot", msg.split_once(": ").map_or(msg.as_str(), |(_, m)| m))
        });
    }
    let texts: Vec<String> = if r.is_instance_of::<PyString>() {
        vec![r.extract()?]
    } else if r.is_instance_of::<PyList>() || r.is_instance_of::<PyTuple>() {
        r.extract().map_err(|_| config_err("robot", "a list of robot settings holds KEY=VALUE strings"))?
    } else {
        return Err(config_err(
            "robot",
            "use a dict of robot fields, e.g. {\"profile\": \"realistic\"}, or a list of KEY=VALUE strings",
        ));
    };
    let table =
        mmq_robot::apply_overrides(world.robot.as_ref(), &texts).map_err(|e| config_err("robot", e))?;
    let mut w = world.clone();
    w.robot = Some(table);
    Ok(w)
}

/// The world's `[swarm]` table with the fields of `swarm` set, resolved and checked.
fn swarm_config(world: &World, swarm: Option<&Bound<'_, PyDict>>) -> PyResult<SwarmConfig> {
    let mut table = world.swarm.clone().unwrap_or_default();
    let mut keys = Vec::new();
    if let Some(d) = swarm {
        for (k, v) in d.iter() {
            let key: String = k.extract().map_err(|_| config_err("swarm", "field names are strings"))?;
            if !SWARM_FIELDS.contains(&key.as_str()) {
                return Err(config_err(
                    &key,
                    format!("not a field of the swarm; use one of {}", SWARM_FIELDS.join(", ")),
                ));
            }
            if key == "learners" {
                return Err(config_err(
                    &key,
                    "the lab's `mmq run` assigns its own learners with it; here your agents act for the \
                     robots (one policy for all of them is parameter sharing): leave it out",
                ));
            }
            if v.is_none() {
                continue;
            }
            let value = to_toml(&key, &v).map_err(|_| {
                config_err(&key, "use a number, a string or a list (as in a world's [swarm] table)")
            })?;
            table.insert(key.clone(), value);
            keys.push(key);
        }
    }
    SwarmConfig::from_table(&table, world).map_err(|e| swarm_err(&e, &keys))
}

/// A swarm error as `ConfigError`, naming the field it is about.
fn swarm_err(e: &RobotError, given: &[String]) -> PyErr {
    let msg = e.to_string();
    match e {
        RobotError::Swarm { field, .. } => config_err(field, msg),
        _ => {
            let field = given.iter().find(|k| msg.contains(&format!("`{k}`")) || msg.contains(k.as_str()));
            config_err(field.map_or("swarm", |k| k.as_str()), msg)
        }
    }
}

/// The native side of one swarm environment, usable from any thread (one call at a
/// time).
#[pyclass(module = "mmq._mmq")]
#[derive(Debug)]
pub struct SwarmCore {
    env: SwarmEnv,
    realistic: bool,
    /// (name, width, height, cell size in metres, goal cell, respawn cell).
    facts: (String, usize, usize, f64, usize, usize),
    ascii: String,
    action_names: Vec<String>,
    out: Vec<SwarmStep>,
}

#[pymethods]
impl SwarmCore {
    /// A new swarm of `world` (a shipped name or a path) with the robot settings `robot`
    /// (dict or KEY=VALUE list) and the swarm fields `swarm` (dict); every argument is
    /// checked here (`ConfigError` naming it otherwise).
    #[new]
    #[pyo3(signature = (world, robot=None, swarm=None))]
    fn new(
        world: &str,
        robot: Option<&Bound<'_, PyAny>>,
        swarm: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let base = load_world(world)?;
        let world = robot_table(&base, robot)?;
        let cfg = RobotConfig::from_world(&world).map_err(|e| config_err("robot", e))?;
        // The single robot's checks and its action names (the swarm's robots are alike).
        let single = mmq_robot::RobotEnv::new(&world, cfg.clone()).map_err(|e| config_err("robot", e))?;
        let action_names = single.action_names();
        let swarm = swarm_config(&world, swarm)?;
        let realistic = cfg.profile == Profile::Realistic;
        let env = SwarmEnv::new(&world, cfg, swarm).map_err(|e| config_err("swarm", e))?;
        let facts =
            (world.name.clone(), world.width, world.height, world.cell_size, world.goal, world.respawn);
        Ok(SwarmCore { env, realistic, facts, ascii: world.ascii(), action_names, out: Vec::new() })
    }

    /// Number of robots.
    #[getter]
    fn robots(&self) -> usize {
        self.env.robots()
    }

    /// States per robot.
    #[getter]
    fn num_states(&self) -> usize {
        self.env.num_states()
    }

    /// Actions per robot.
    #[getter]
    fn num_actions(&self) -> usize {
        self.env.num_actions()
    }

    /// Action names in index order.
    #[getter]
    fn action_names(&self) -> Vec<String> {
        self.action_names.clone()
    }

    /// Whether the robots' state is a belief (the realistic profile).
    #[getter]
    fn realistic(&self) -> bool {
        self.realistic
    }

    /// The consultation model: `none`, `peers` or `server`.
    #[getter]
    fn consult(&self) -> &'static str {
        self.env.swarm().consult.name()
    }

    /// (name, width, height, cell size in metres, goal cell, respawn cell).
    #[getter]
    fn world_facts(&self) -> (String, usize, usize, f64, usize, usize) {
        self.facts.clone()
    }

    /// The map as text (`#` blocked, `G` goal, `S` respawn, `.` free), one line per row.
    #[getter]
    fn ascii(&self) -> String {
        self.ascii.clone()
    }

    /// The cell of a state.
    fn state_cell(&self, state: usize) -> PyResult<usize> {
        if state >= self.env.num_states() {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "state {state} is out of range; use 0..{}",
                self.env.num_states()
            )));
        }
        Ok(self.env.state_cell(state))
    }

    /// Starts an episode from master seed `seed` (environment and radio streams as the
    /// CLI derives them); every robot waits for an action. Returns every robot's state.
    fn reset(&mut self, seed: &Bound<'_, PyAny>) -> PyResult<Vec<usize>> {
        let tree = SeedTree::new(seed_arg(seed)?);
        self.out.clear();
        self.env.reset(tree.seed(Stream::Env), tree.seed(Stream::Delay)).map_err(env_err)
    }

    /// Every robot's true state (the cell of its true pose; its state on the ideal
    /// profile).
    fn true_states(&self) -> PyResult<Vec<usize>> {
        self.env.true_states().map_err(env_err)
    }

    /// Whether robot `robot` waits for an action.
    fn waiting(&self, robot: usize) -> bool {
        self.env.waiting(robot)
    }

    /// Starts waiting robot `robot`'s primitive for `action`.
    fn act(&mut self, robot: usize, action: &Bound<'_, PyAny>) -> PyResult<()> {
        let a = action_arg(action, self.env.num_actions())?;
        if robot >= self.env.robots() || !self.env.waiting(robot) {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "robot {robot} is not waiting for an action (a robot waits after a reset and once its step was returned)"
            )));
        }
        self.env.act(robot, a).map_err(env_err)
    }

    /// Parks robot `robot`: it takes no more actions and stands still.
    fn park(&mut self, robot: usize) {
        self.env.park(robot);
    }

    /// Runs the shared physics (without the GIL) until at least one primitive ends;
    /// returns the steps that ended, in robot order (empty when no robot is running).
    fn advance(&mut self, py: Python<'_>) -> PyResult<Vec<StepRow>> {
        let (env, out) = (&mut self.env, &mut self.out);
        out.clear();
        py.detach(|| env.advance(out)).map_err(env_err)?;
        let truth = if self.realistic && !out.is_empty() {
            Some(self.env.true_states().map_err(env_err)?)
        } else {
            None
        };
        Ok(self
            .out
            .iter()
            .map(|s| {
                let deliveries = s
                    .deliveries
                    .iter()
                    .map(|d| (d.decision, d.value, d.emitted_s, d.delay_s, d.hops))
                    .collect();
                let true_state = truth.as_ref().map(|t| t[s.robot]);
                (
                    s.robot,
                    s.decision,
                    s.step.state,
                    s.step.reward,
                    s.step.event.name(),
                    s.time_s,
                    s.delivered,
                    deliveries,
                    s.consultation,
                    true_state,
                )
            })
            .collect())
    }

    /// Simulated time since the reset, seconds.
    #[getter]
    fn time_s(&self) -> f64 {
        self.env.time_s()
    }

    /// Every robot's true pose: [(x m, y m, heading rad, simulated time s)].
    fn poses(&self) -> Vec<(f64, f64, f64, f64)> {
        self.env.poses().iter().map(|p| (p.x, p.y, p.theta, p.time_s)).collect()
    }

    /// Every robot's pose estimate (realistic profile), else None per robot.
    fn estimates(&self) -> Vec<Option<(f64, f64, f64, f64)>> {
        self.env.estimates().iter().map(|p| p.map(|p| (p.x, p.y, p.theta, p.time_s))).collect()
    }

    /// The rewards earned but not delivered yet, per robot: [(count, sum)].
    fn in_flight(&self) -> Vec<(u64, f64)> {
        self.env.in_flight()
    }

    /// The delays that emerged since the reset, per robot: [(emitted, delivered, lost,
    /// [delay s], [hops])].
    #[allow(clippy::type_complexity)]
    fn delays(&self) -> Vec<(u64, u64, u64, Vec<f32>, Vec<u8>)> {
        self.env
            .delays()
            .iter()
            .map(|d| (d.emitted, d.delivered, d.lost, d.delays_s.clone(), d.hops.clone()))
            .collect()
    }

    /// Robot `robot`'s counters and diagnostics.
    fn stats(&self, robot: usize) -> Vec<(String, f64)> {
        self.env.stats(robot)
    }
}
