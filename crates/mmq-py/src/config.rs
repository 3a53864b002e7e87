//! Python arguments → resolved Rust configuration: shipped worlds by name, delay specs,
//! the robot's `[robot]` table edited by `preset`, `profile` and `overrides`, start
//! rules; every failure becomes `mmq.ConfigError` naming the keyword argument and the fix.

use std::path::Path;

use mmq_core::{DelayDist, Env, Start, Telemetry, World};
use mmq_grid::GridEnv;
use mmq_robot::{RobotConfig, RobotEnv};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString};

use crate::ConfigError;

/// A `ConfigError` naming the argument `arg`.
pub fn config_err(arg: &str, message: impl std::fmt::Display) -> PyErr {
    ConfigError::new_err(format!("{arg}: {message}"))
}

/// The names of the shipped worlds.
pub fn shipped_names() -> Vec<&'static str> {
    mmq_core::shipped::WORLDS.iter().map(|(n, _)| *n).collect()
}

/// A shipped world by name, or a world file by path.
pub fn load_world(world: &str) -> PyResult<World> {
    // The shipped worlds are embedded once, in mmq-core.
    if let Some((name, text)) = mmq_core::shipped::WORLDS.iter().find(|(n, _)| *n == world) {
        let mut w = World::parse(text, &format!("{name}.toml")).map_err(|e| config_err("world", e))?;
        w.name = (*name).to_string();
        return Ok(w);
    }
    if !Path::new(world).exists() {
        return Err(config_err(
            "world",
            format!(
                "`{world}` is neither a shipped world nor an existing file; use one of {} or the path of a world file (docs/worlds.md)",
                shipped_names().join(", ")
            ),
        ));
    }
    World::load(world).map_err(|e| config_err("world", e))
}

/// A delay distribution from its spec string (`none`, `const:13`, `poisson:13`, ...).
pub fn parse_delay(spec: &str) -> PyResult<DelayDist> {
    DelayDist::parse(spec).map_err(|e| config_err("delay", e))
}

/// The start rule: `"world"` (the world file's rule), `"respawn"` (the cell `S`) or a
/// state index.
pub fn parse_start(start: &Bound<'_, PyAny>) -> PyResult<Start> {
    if let Ok(s) = start.extract::<String>() {
        return match s.as_str() {
            "world" => Ok(Start::World),
            "respawn" => Ok(Start::Respawn),
            _ => Err(config_err(
                "start",
                format!("`{s}` is not a start rule; use \"world\", \"respawn\" or a free cell's state index"),
            )),
        };
    }
    if start.is_instance_of::<PyBool>() {
        return Err(config_err("start", "use \"world\", \"respawn\" or a free cell's state index"));
    }
    match start.extract::<u64>() {
        Ok(s) => Ok(Start::State(s as usize)),
        Err(_) => Err(config_err("start", "use \"world\", \"respawn\" or a free cell's state index")),
    }
}

/// A Python value as a TOML value (bool, int, float, str, list, dict).
pub fn to_toml(key: &str, v: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
    let bad = || {
        config_err(
            "overrides",
            format!("`{key}` has a value of type {}; use a bool, number, string, list or dict", type_name(v)),
        )
    };
    if v.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        return v.extract::<i64>().map(toml::Value::Integer).map_err(|_| bad());
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(v.extract()?));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(v.extract()?));
    }
    if let Ok(l) = v.cast::<PyList>() {
        return l.iter().map(|x| to_toml(key, &x)).collect::<PyResult<Vec<_>>>().map(toml::Value::Array);
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, x) in d.iter() {
            let k: String = k.extract().map_err(|_| bad())?;
            t.insert(k.clone(), to_toml(&format!("{key}.{k}"), &x)?);
        }
        return Ok(toml::Value::Table(t));
    }
    // NumPy scalars and anything else numeric.
    if let Ok(x) = v.extract::<f64>() {
        return Ok(toml::Value::Float(x));
    }
    Err(bad())
}

fn type_name(v: &Bound<'_, PyAny>) -> String {
    v.get_type().name().map(|n| n.to_string()).unwrap_or_else(|_| "?".into())
}

/// Sets `key` (dotted for nested tables: `noise.slip`) in `table`.
fn set_dotted(table: &mut toml::Table, key: &str, value: toml::Value) -> PyResult<()> {
    let mut parts: Vec<&str> = key.split('.').collect();
    let last = parts.pop().unwrap_or(key);
    if last.is_empty() || parts.iter().any(|p| p.is_empty()) {
        return Err(config_err(
            "overrides",
            format!("`{key}` is not a field name; use e.g. max_speed_mps or noise.slip"),
        ));
    }
    let mut t = table;
    for p in parts {
        let entry = t.entry(p.to_string()).or_insert_with(|| toml::Value::Table(toml::Table::new()));
        t = match entry {
            toml::Value::Table(inner) => inner,
            _ => {
                return Err(config_err(
                    "overrides",
                    format!("`{key}`: `{p}` is a value, not a table of fields"),
                ));
            }
        };
    }
    // A dict merges into an existing table field by field.
    match (t.get_mut(last), value) {
        (Some(toml::Value::Table(old)), toml::Value::Table(new)) => {
            for (k, v) in new {
                old.insert(k, v);
            }
        }
        (_, v) => {
            t.insert(last.to_string(), v);
        }
    }
    Ok(())
}

/// The world's `[robot]` table edited by `preset`, `profile` and `overrides` (generic
/// TOML edits: any field the robot's table accepts can be set), then validated.
pub fn robot_world(
    world: &World,
    preset: Option<&str>,
    profile: Option<&str>,
    overrides: Option<&Bound<'_, PyDict>>,
) -> PyResult<World> {
    let mut w = world.clone();
    if preset.is_none() && profile.is_none() && overrides.is_none_or(|o| o.is_empty()) {
        return Ok(w);
    }
    let mut table = w.robot.take().unwrap_or_default();
    if let Some(p) = preset {
        // A new preset starts from the preset's values: the world's own overrides stay.
        table.insert("preset".into(), toml::Value::String(p.into()));
    }
    if let Some(p) = profile {
        table.insert("profile".into(), toml::Value::String(p.into()));
    }
    if let Some(o) = overrides {
        for (k, v) in o.iter() {
            let key: String = k.extract().map_err(|_| config_err("overrides", "keys must be strings"))?;
            let value = to_toml(&key, &v)?;
            set_dotted(&mut table, &key, value)?;
        }
    }
    w.robot = Some(table);
    Ok(w)
}

/// Which robot settings the caller gave: `preset`, `profile`, the `overrides` keys.
#[derive(Clone, Debug, Default)]
pub struct Edits {
    /// `preset` was given.
    pub preset: bool,
    /// `profile` was given.
    pub profile: bool,
    /// The keys of `overrides`.
    pub keys: Vec<String>,
}

impl Edits {
    /// The edits of these arguments.
    pub fn of(preset: Option<&str>, profile: Option<&str>, overrides: Option<&Bound<'_, PyDict>>) -> Edits {
        let keys = overrides
            .map(|o| o.keys().iter().filter_map(|k| k.extract::<String>().ok()).collect())
            .unwrap_or_default();
        Edits { preset: preset.is_some(), profile: profile.is_some(), keys }
    }

    /// Whether anything was given.
    pub fn any(&self) -> bool {
        self.preset || self.profile || !self.keys.is_empty()
    }

    /// The argument a robot error `msg` is about: an override key it names, else
    /// `profile` or `preset` if it names them, else the world file's table.
    fn blame(&self, msg: &str) -> &'static str {
        let top = |k: &String| k.split('.').next().unwrap_or(k).to_string();
        if self.keys.iter().any(|k| msg.contains(&format!("`{}`", top(k))) || msg.contains(k.as_str())) {
            "overrides"
        } else if self.profile && msg.contains("profile") {
            "profile"
        } else if self.preset && msg.contains("preset") {
            "preset"
        } else if !self.keys.is_empty() {
            "overrides"
        } else if self.any() {
            if self.profile { "profile" } else { "preset" }
        } else {
            "world"
        }
    }
}

/// Builds the robot of `world`, naming the argument that made it fail.
pub fn robot_env(world: &World, edits: &Edits) -> PyResult<RobotEnv> {
    let cfg = RobotConfig::from_world(world).map_err(|e| {
        let msg = e.to_string();
        config_err(edits.blame(&msg), format!("{msg} (the world's [robot] table; see docs/robot.md)"))
    })?;
    RobotEnv::new(world, cfg).map_err(|e| {
        let msg = e.to_string();
        config_err(edits.blame(&msg), msg)
    })
}

/// The grid or the robot, behind one type so that the channel and the vector
/// environment are written once. The grid stays inline (its step is the hot path); the
/// robot, much larger, is boxed.
#[derive(Debug)]
#[allow(clippy::large_enum_variant)]
pub enum AnyEnv {
    /// The paper's grid world.
    Grid(GridEnv),
    /// The rapier2d robot.
    Robot(Box<RobotEnv>),
}

macro_rules! both {
    ($self:ident, $e:ident => $body:expr) => {
        match $self {
            AnyEnv::Grid($e) => $body,
            AnyEnv::Robot($e) => $body,
        }
    };
}

impl Env for AnyEnv {
    fn num_states(&self) -> usize {
        both!(self, e => e.num_states())
    }
    fn num_actions(&self) -> usize {
        both!(self, e => e.num_actions())
    }
    fn action_names(&self) -> Vec<String> {
        both!(self, e => e.action_names())
    }
    fn world(&self) -> &World {
        both!(self, e => e.world())
    }
    fn state_cell(&self, state: usize) -> usize {
        both!(self, e => e.state_cell(state))
    }
    fn reset(&mut self, seed: u64, start: Start) -> Result<usize, mmq_core::EnvError> {
        both!(self, e => e.reset(seed, start))
    }
    #[inline]
    fn step(&mut self, action: usize) -> Result<mmq_core::Step, mmq_core::EnvError> {
        both!(self, e => e.step(action))
    }
}

impl Telemetry for AnyEnv {
    fn sim_time_s(&self) -> f64 {
        both!(self, e => e.sim_time_s())
    }
    fn set_trace(&mut self, period_s: Option<f64>) {
        both!(self, e => e.set_trace(period_s))
    }
    fn take_trace(&mut self, out: &mut mmq_core::StepTrace) {
        both!(self, e => e.take_trace(out))
    }
    fn pose(&self) -> mmq_core::PoseSample {
        both!(self, e => e.pose())
    }
    fn pose_estimate(&self) -> Option<mmq_core::PoseSample> {
        both!(self, e => e.pose_estimate())
    }
    fn true_state(&self) -> Option<usize> {
        both!(self, e => e.true_state())
    }
    fn stats(&self) -> Vec<(String, f64)> {
        both!(self, e => e.stats())
    }
}

/// Which fidelity.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// `mmq/Grid-v0`.
    Grid,
    /// `mmq/Robot-v0`.
    Robot,
}

impl Kind {
    /// Parses `"grid"` or `"robot"`.
    pub fn parse(s: &str) -> PyResult<Kind> {
        match s {
            "grid" => Ok(Kind::Grid),
            "robot" => Ok(Kind::Robot),
            _ => Err(config_err("env", format!("`{s}` is not an environment; use \"grid\" or \"robot\""))),
        }
    }
}

/// Everything needed to build one environment (cheap to clone: the world is shared).
#[derive(Clone, Debug)]
pub struct EnvSpec {
    /// Fidelity.
    pub kind: Kind,
    /// The world (with the robot table already edited).
    pub world: World,
    /// The robot settings given.
    pub edits: Edits,
}

impl EnvSpec {
    /// Resolves the arguments of `mmq/Grid-v0` and `mmq/Robot-v0`.
    pub fn resolve(
        kind: &str,
        world: &str,
        preset: Option<&str>,
        profile: Option<&str>,
        overrides: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<EnvSpec> {
        let kind = Kind::parse(kind)?;
        let base = load_world(world)?;
        let edits = Edits::of(preset, profile, overrides);
        if kind == Kind::Grid && edits.any() {
            return Err(config_err(
                if edits.preset {
                    "preset"
                } else if edits.profile {
                    "profile"
                } else {
                    "overrides"
                },
                "the grid has no robot; use mmq/Robot-v0 for robot settings",
            ));
        }
        let world = robot_world(&base, preset, profile, overrides)?;
        let spec = EnvSpec { kind, world, edits };
        spec.build()?; // refuse bad settings now, not at the first reset
        Ok(spec)
    }

    /// A fresh environment.
    pub fn build(&self) -> PyResult<AnyEnv> {
        Ok(match self.kind {
            Kind::Grid => AnyEnv::Grid(GridEnv::new(&self.world)),
            Kind::Robot => AnyEnv::Robot(Box::new(robot_env(&self.world, &self.edits)?)),
        })
    }
}
