//! The robot's configuration: presets from real robots, the `[robot]` table of a world
//! file (a preset plus per-field overrides), and its validation.
//!
//! Two stages, as in ripgrep's flags: [`RobotTable`] is the raw table as written (every
//! field optional, unknown fields rejected); [`RobotConfig`] is the resolved, validated
//! configuration with every value filled in. A `RobotConfig` serialises to a complete
//! table that parses back to itself, so a run can save the configuration it used.

use std::fmt;

use mmq_core::World;
use serde::{Deserialize, Serialize};

use crate::profile::{Profile, RealisticConfig, RealisticTable};

/// Why a robot configuration (or the arena built from it) was rejected.
///
/// Every message names the field, what is wrong and what would be accepted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RobotError {
    /// The `[robot]` table does not parse (unknown field, wrong type, unknown preset).
    #[error("robot config: {message}")]
    Parse {
        /// The parser's message (it names the field).
        message: String,
    },
    /// A field has a value outside its accepted range.
    #[error("robot config: field `{field}` = {value} is not accepted: {problem}; use {accepted}")]
    Invalid {
        /// The field, as written in the `[robot]` table.
        field: &'static str,
        /// The value given.
        value: String,
        /// What is wrong with it.
        problem: String,
        /// What would be accepted.
        accepted: String,
    },
    /// A `KEY=VALUE` override names no field of the `[robot]` table.
    #[error("robot override `{key}`: no such field; known fields: {known}")]
    UnknownKey {
        /// The key as given (dotted for sub-tables, e.g. `realistic.fix_rate_hz`).
        key: String,
        /// The fields accepted at that level.
        known: String,
    },
    /// A field of the `[swarm]` table (or a `--swarm` override) that is not accepted.
    #[error("swarm config: field `{field}` = {value} is not accepted: {problem}; use {accepted}")]
    Swarm {
        /// The field, as written in the `[swarm]` table.
        field: &'static str,
        /// The value given.
        value: String,
        /// What is wrong with it.
        problem: String,
        /// What would be accepted.
        accepted: String,
    },
    /// A `KEY=VALUE` override whose value does not fit the field, or text without `=`.
    #[error("robot override `{text}`: {problem}; use {accepted}")]
    BadValue {
        /// The override as given.
        text: String,
        /// What is wrong.
        problem: String,
        /// What would be accepted.
        accepted: String,
    },
}

/// A real robot whose published figures give the default parameters.
///
/// Sources are cited in `docs/robot.md`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Preset {
    /// ROBOTIS TurtleBot3 Burger (the default).
    #[default]
    Turtlebot3Burger,
    /// ROBOTIS TurtleBot3 Waffle (and Waffle Pi: same base).
    Turtlebot3Waffle,
    /// Yujin Robot Kobuki (the TurtleBot 2 base).
    Kobuki,
}

impl Preset {
    /// All presets.
    pub const ALL: [Preset; 3] = [Preset::Turtlebot3Burger, Preset::Turtlebot3Waffle, Preset::Kobuki];

    /// The name used in the `[robot]` table.
    pub fn name(self) -> &'static str {
        match self {
            Preset::Turtlebot3Burger => "turtlebot3-burger",
            Preset::Turtlebot3Waffle => "turtlebot3-waffle",
            Preset::Kobuki => "kobuki",
        }
    }

    /// The preset's full configuration (with the default controller, physics step,
    /// action set and no noise).
    pub fn config(self) -> RobotConfig {
        // (wheel base, radius, mass, max speed, max turn rate, max accel, max angular accel)
        let (b, r, m, v, w, a, alpha) = match self {
            Preset::Turtlebot3Burger => (0.160, 0.105, 1.0, 0.22, 2.84, 2.5, 3.2),
            Preset::Turtlebot3Waffle => (0.287, 0.220, 1.8, 0.26, 1.82, 2.5, 3.2),
            Preset::Kobuki => (0.230, 0.176, 2.35, 0.70, std::f64::consts::PI, 0.3, 3.5),
        };
        RobotConfig {
            preset: self,
            wheel_base_m: b,
            radius_m: r,
            mass_kg: m,
            max_speed_mps: v,
            max_turn_rate_radps: w,
            max_accel_mps2: a,
            max_angular_accel_radps2: alpha,
            wheel_friction: 0.8,
            wall_friction: 0.3,
            dt_s: DEFAULT_DT_S,
            actions: ActionSet::Moves,
            timeout_factor: 3.0,
            position_tolerance_m: 0.01,
            heading_tolerance_rad: 0.02,
            free_flight: true,
            cell_diagnostics: false,
            noise: None,
            profile: Profile::Ideal,
            realistic: RealisticConfig::for_preset(self),
        }
    }
}

impl fmt::Display for Preset {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The default physics step, seconds (60 Hz).
pub const DEFAULT_DT_S: f64 = 1.0 / 60.0;

/// Which motion primitives are the actions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum ActionSet {
    /// The paper's four moves in `Move::ALL` order (N, E, S, W): turn in place towards
    /// the neighbouring cell, then drive to its centre. State = cell.
    #[default]
    Moves,
    /// Forward one cell, turn left 90°, turn right 90°. State = cell × 4 + heading
    /// (0 = N, 1 = E, 2 = S, 3 = W).
    Heading,
}

impl ActionSet {
    /// The learner's table shape on a world of `cells` cells: (states, actions).
    pub fn table_shape(self, cells: usize) -> (usize, usize) {
        match self {
            ActionSet::Moves => (cells, 4),
            ActionSet::Heading => (cells * 4, 3),
        }
    }
}

/// Optional actuation noise, drawn from the environment's random stream (the seed given
/// to `reset`). Present in the `[robot.noise]` table ⇒ on; fields default as documented.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseConfig {
    /// Standard deviation of each wheel's speed gain, relative (gain = 1 + N(0, sd²),
    /// clamped to [0.5, 1.5]), redrawn for every primitive. Default 0.05.
    #[serde(default = "default_gain_sd")]
    pub wheel_gain_sd: f64,
    /// Probability that a primitive runs on a slippery floor. Default 0.05.
    #[serde(default = "default_slip_probability")]
    pub slip_probability: f64,
    /// Wheel–floor friction multiplier during a slippery primitive, in (0, 1]. Default 0.2.
    #[serde(default = "default_slip_friction_factor")]
    pub slip_friction_factor: f64,
}

fn default_gain_sd() -> f64 {
    0.05
}
fn default_slip_probability() -> f64 {
    0.05
}
fn default_slip_friction_factor() -> f64 {
    0.2
}

impl Default for NoiseConfig {
    fn default() -> Self {
        Self {
            wheel_gain_sd: default_gain_sd(),
            slip_probability: default_slip_probability(),
            slip_friction_factor: default_slip_friction_factor(),
        }
    }
}

/// The resolved robot configuration. Every field is documented with its unit.
///
/// Deserialising goes through [`RobotTable`] (preset first, then overrides, then
/// validation), so `toml::from_str::<RobotConfig>("preset = \"kobuki\"")` gives the full
/// Kobuki configuration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RobotTable", into = "RobotTable")]
pub struct RobotConfig {
    /// The preset the values started from.
    pub preset: Preset,
    /// Distance between the two wheels' contact points, metres.
    pub wheel_base_m: f64,
    /// Radius of the robot's disc footprint, metres.
    pub radius_m: f64,
    /// Mass, kilograms (the disc is uniform: moment of inertia ½·m·r²).
    pub mass_kg: f64,
    /// Largest forward or backward speed, and largest wheel surface speed, m/s.
    pub max_speed_mps: f64,
    /// Largest turn rate, rad/s.
    pub max_turn_rate_radps: f64,
    /// Largest linear acceleration of the motors, m/s².
    pub max_accel_mps2: f64,
    /// Largest angular acceleration of the motors, rad/s².
    pub max_angular_accel_radps2: f64,
    /// Wheel–floor friction coefficient μ (dimensionless): each wheel's traction impulse
    /// per step is at most μ·(m·g/2)·dt, with g = 9.81 m/s².
    pub wheel_friction: f64,
    /// Robot–wall friction coefficient (dimensionless).
    pub wall_friction: f64,
    /// Fixed physics step, seconds.
    pub dt_s: f64,
    /// The action set.
    pub actions: ActionSet,
    /// Time-out of a primitive as a multiple of its nominal duration (a half turn plus a
    /// one-cell drive at the limits), dimensionless.
    pub timeout_factor: f64,
    /// A drive ends when the robot's centre is this close to the target, metres.
    pub position_tolerance_m: f64,
    /// A turn ends when the heading is this close to the target, radians.
    pub heading_tolerance_rad: f64,
    /// Skip rapier on steps where the robot cannot touch any wall (its disc is farther
    /// than rapier's prediction distance + 2·|v|·dt + 1 cm from every wall) and integrate
    /// the free disc with rapier's own integrator instead: the trajectory is bit-identical
    /// to stepping rapier every time (tested), and several times faster. Default true.
    pub free_flight: bool,
    /// Also count the diagnostics per cell (`robot/cells/...` in `stats()`, see
    /// docs/robot.md): one figure per free cell, so off by default. Default false.
    pub cell_diagnostics: bool,
    /// Actuation noise; `None` (the default) is noise-free. The realistic profile turns
    /// it on with the defaults unless the table gives it.
    pub noise: Option<NoiseConfig>,
    /// How the robot knows its pose (`ideal`, the default, or `realistic`).
    pub profile: Profile,
    /// The realistic model's parameters (used by the realistic profile only; written to
    /// a table only then).
    pub realistic: RealisticConfig,
}

impl Default for RobotConfig {
    fn default() -> Self {
        Preset::default().config()
    }
}

/// The `[robot]` table as written: a preset (default `turtlebot3-burger`) and optional
/// overrides of every field of [`RobotConfig`]; each field means (and has the unit of)
/// the field of the same name there.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotTable {
    pub preset: Option<Preset>,
    pub wheel_base_m: Option<f64>,
    pub radius_m: Option<f64>,
    pub mass_kg: Option<f64>,
    pub max_speed_mps: Option<f64>,
    pub max_turn_rate_radps: Option<f64>,
    pub max_accel_mps2: Option<f64>,
    pub max_angular_accel_radps2: Option<f64>,
    pub wheel_friction: Option<f64>,
    pub wall_friction: Option<f64>,
    pub dt_s: Option<f64>,
    pub actions: Option<ActionSet>,
    pub timeout_factor: Option<f64>,
    pub position_tolerance_m: Option<f64>,
    pub heading_tolerance_rad: Option<f64>,
    pub free_flight: Option<bool>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cell_diagnostics: Option<bool>,
    pub noise: Option<NoiseConfig>,
    pub profile: Option<Profile>,
    pub realistic: Option<RealisticTable>,
}

/// The top-level fields of the `[robot]` table (`noise` and `realistic` are sub-tables).
pub const TABLE_FIELDS: [&str; 20] = [
    "preset",
    "wheel_base_m",
    "radius_m",
    "mass_kg",
    "max_speed_mps",
    "max_turn_rate_radps",
    "max_accel_mps2",
    "max_angular_accel_radps2",
    "wheel_friction",
    "wall_friction",
    "dt_s",
    "actions",
    "timeout_factor",
    "position_tolerance_m",
    "heading_tolerance_rad",
    "free_flight",
    "cell_diagnostics",
    "noise",
    "profile",
    "realistic",
];

/// The fields of the `[robot.noise]` table.
pub const NOISE_FIELDS: [&str; 3] = ["wheel_gain_sd", "slip_probability", "slip_friction_factor"];

impl From<RobotConfig> for RobotTable {
    fn from(c: RobotConfig) -> RobotTable {
        c.to_table()
    }
}

impl TryFrom<RobotTable> for RobotConfig {
    type Error = RobotError;

    fn try_from(t: RobotTable) -> Result<Self, RobotError> {
        let mut c = t.preset.unwrap_or_default().config();
        macro_rules! take {
            ($($f:ident),*) => { $( if let Some(v) = t.$f { c.$f = v; } )* };
        }
        take!(
            wheel_base_m,
            radius_m,
            mass_kg,
            max_speed_mps,
            max_turn_rate_radps,
            max_accel_mps2,
            max_angular_accel_radps2,
            wheel_friction,
            wall_friction,
            dt_s,
            actions,
            timeout_factor,
            position_tolerance_m,
            heading_tolerance_rad,
            free_flight,
            cell_diagnostics
        );
        c.noise = t.noise;
        c.profile = t.profile.unwrap_or_default();
        if let Some(r) = &t.realistic {
            if c.profile == Profile::Ideal {
                return Err(RobotError::Invalid {
                    field: "realistic",
                    value: "a table".into(),
                    problem: "the realistic model's parameters are given but `profile` is `ideal`".into(),
                    accepted:
                        "`profile = \"realistic\"` in the `[robot]` table, or no `[robot.realistic]` table"
                            .into(),
                });
            }
            c.realistic = r.resolve(c.preset);
        }
        if c.profile == Profile::Realistic && c.noise.is_none() {
            c.noise = Some(NoiseConfig::default());
        }
        c.validate()?;
        Ok(c)
    }
}

fn invalid(field: &'static str, value: f64, problem: impl Into<String>, accepted: &str) -> RobotError {
    RobotError::Invalid {
        field,
        value: value.to_string(),
        problem: problem.into(),
        accepted: accepted.into(),
    }
}

/// Checks `lo < v <= hi` (or `lo <= v` when `lo_closed`), finite.
pub(crate) fn check_range(
    field: &'static str,
    v: f64,
    lo: f64,
    lo_closed: bool,
    hi: f64,
    accepted: &str,
) -> Result<(), RobotError> {
    if v.is_nan() {
        return Err(invalid(field, v, "it is not a number", accepted));
    }
    if !v.is_finite() {
        return Err(invalid(field, v, "it is not finite", accepted));
    }
    let above = if lo_closed { v >= lo } else { v > lo };
    if !above {
        let p = if lo == 0.0 && !lo_closed {
            "it is not positive".to_string()
        } else {
            format!("it is below {lo}")
        };
        return Err(invalid(field, v, p, accepted));
    }
    if v > hi {
        return Err(invalid(field, v, format!("it is above {hi}"), accepted));
    }
    Ok(())
}

impl RobotConfig {
    /// The configuration of a world: its `[robot]` table if any (else the default
    /// TurtleBot3 Burger), validated against the world's cell size.
    pub fn from_world(world: &World) -> Result<RobotConfig, RobotError> {
        let cfg = match &world.robot {
            Some(t) => Self::from_table(t)?,
            None => Self::default(),
        };
        cfg.validate_for_world(world)?;
        Ok(cfg)
    }

    /// Parses and validates a `[robot]` table (without a world: see
    /// [`RobotConfig::validate_for_world`]).
    pub fn from_table(table: &toml::Table) -> Result<RobotConfig, RobotError> {
        let raw: RobotTable = table
            .clone()
            .try_into()
            .map_err(|e: toml::de::Error| RobotError::Parse { message: e.message().trim().to_string() })?;
        RobotConfig::try_from(raw)
    }

    /// Parses a `[robot]` table given as TOML text.
    pub fn from_toml(text: &str) -> Result<RobotConfig, RobotError> {
        let table: toml::Table = toml::from_str(text)
            .map_err(|e| RobotError::Parse { message: e.message().trim().to_string() })?;
        Self::from_table(&table)
    }

    /// Checks every field on its own (units and ranges).
    pub fn validate(&self) -> Result<(), RobotError> {
        const LEN: &str = "a length in metres in (0, 10]";
        check_range("wheel_base_m", self.wheel_base_m, 0.0, false, 10.0, LEN)?;
        check_range("radius_m", self.radius_m, 0.0, false, 10.0, LEN)?;
        check_range("mass_kg", self.mass_kg, 0.0, false, 1e4, "a mass in kilograms in (0, 10000]")?;
        check_range("max_speed_mps", self.max_speed_mps, 0.0, false, 20.0, "a speed in m/s in (0, 20]")?;
        check_range(
            "max_turn_rate_radps",
            self.max_turn_rate_radps,
            0.0,
            false,
            50.0,
            "a turn rate in rad/s in (0, 50]",
        )?;
        check_range(
            "max_accel_mps2",
            self.max_accel_mps2,
            0.0,
            false,
            100.0,
            "an acceleration in m/s² in (0, 100]",
        )?;
        check_range(
            "max_angular_accel_radps2",
            self.max_angular_accel_radps2,
            0.0,
            false,
            500.0,
            "an angular acceleration in rad/s² in (0, 500]",
        )?;
        check_range(
            "wheel_friction",
            self.wheel_friction,
            0.0,
            false,
            5.0,
            "a friction coefficient in (0, 5]",
        )?;
        check_range("wall_friction", self.wall_friction, 0.0, true, 5.0, "a friction coefficient in [0, 5]")?;
        check_range(
            "dt_s",
            self.dt_s,
            0.0,
            false,
            0.1,
            "a physics step in seconds in (0, 0.1], e.g. 0.016667",
        )?;
        check_range(
            "timeout_factor",
            self.timeout_factor,
            1.0,
            true,
            100.0,
            "a multiple in [1, 100], e.g. 3",
        )?;
        check_range(
            "position_tolerance_m",
            self.position_tolerance_m,
            0.0,
            false,
            0.1,
            "a distance in metres in (0, 0.1]",
        )?;
        check_range(
            "heading_tolerance_rad",
            self.heading_tolerance_rad,
            0.0,
            false,
            0.5,
            "an angle in radians in (0, 0.5]",
        )?;
        if self.wheel_base_m > 2.0 * self.radius_m {
            return Err(invalid(
                "wheel_base_m",
                self.wheel_base_m,
                format!("the wheels would stick out of the robot's disc (diameter {})", 2.0 * self.radius_m),
                "a wheel base at most 2 × `radius_m`",
            ));
        }
        if let Some(n) = &self.noise {
            check_range(
                "noise.wheel_gain_sd",
                n.wheel_gain_sd,
                0.0,
                true,
                0.5,
                "a relative standard deviation in [0, 0.5]",
            )?;
            check_range(
                "noise.slip_probability",
                n.slip_probability,
                0.0,
                true,
                1.0,
                "a probability in [0, 1]",
            )?;
            check_range(
                "noise.slip_friction_factor",
                n.slip_friction_factor,
                0.0,
                false,
                1.0,
                "a friction multiplier in (0, 1]",
            )?;
        }
        if self.profile == Profile::Realistic {
            self.realistic.validate()?;
        }
        Ok(())
    }

    /// Checks that the robot fits the world's cells: its diameter plus a 2 cm clearance on
    /// each side must not exceed `cell_size`, so that a robot at a cell's centre touches
    /// no wall.
    pub fn validate_for_world(&self, world: &World) -> Result<(), RobotError> {
        self.validate()?;
        let need = 2.0 * self.radius_m + 2.0 * CLEARANCE_M;
        if need > world.cell_size {
            let max_radius = world.cell_size / 2.0 - CLEARANCE_M;
            // Cells too small for any robot: only a larger cell helps.
            let fix = if max_radius < 0.001 {
                format!("a `cell_size` of at least {} m in the world file", round_up(need, 6))
            } else {
                format!(
                    "a radius at most {} m, or a `cell_size` of at least {} m in the world file",
                    (max_radius * 1e6).floor() / 1e6,
                    round_up(need, 6)
                )
            };
            return Err(invalid(
                "radius_m",
                self.radius_m,
                format!(
                    "the robot is too wide for the world's cells: diameter {} m plus 2 × {CLEARANCE_M} m clearance exceeds `cell_size` = {} m",
                    2.0 * self.radius_m,
                    world.cell_size
                ),
                &fix,
            ));
        }
        let steps = self.max_physics_steps(world.cell_size);
        if steps > MAX_PHYSICS_STEPS {
            let timeout = self.timeout_s(world.cell_size);
            return Err(invalid(
                "dt_s",
                self.dt_s,
                format!(
                    "one primitive may last up to {timeout:.3} s (its time-out), that is {steps:.0} physics steps of {} s, more than the {MAX_PHYSICS_STEPS:.0} a primitive may take: a run would crawl and answer a stop late",
                    self.dt_s
                ),
                &format!(
                    "a `dt_s` of at least {} s, higher speed or acceleration limits, or a lower `timeout_factor`",
                    round_up(timeout / MAX_PHYSICS_STEPS, 6)
                ),
            ));
        }
        Ok(())
    }

    /// The most physics steps one primitive can take on cells of `cell_size` metres: its
    /// time-out over the physics step.
    pub fn max_physics_steps(&self, cell_size: f64) -> f64 {
        self.timeout_s(cell_size) / self.dt_s
    }

    /// The [`RobotTable`] that resolves to this configuration (every field written).
    pub fn to_table(&self) -> RobotTable {
        RobotTable {
            preset: Some(self.preset),
            wheel_base_m: Some(self.wheel_base_m),
            radius_m: Some(self.radius_m),
            mass_kg: Some(self.mass_kg),
            max_speed_mps: Some(self.max_speed_mps),
            max_turn_rate_radps: Some(self.max_turn_rate_radps),
            max_accel_mps2: Some(self.max_accel_mps2),
            max_angular_accel_radps2: Some(self.max_angular_accel_radps2),
            wheel_friction: Some(self.wheel_friction),
            wall_friction: Some(self.wall_friction),
            dt_s: Some(self.dt_s),
            actions: Some(self.actions),
            timeout_factor: Some(self.timeout_factor),
            position_tolerance_m: Some(self.position_tolerance_m),
            heading_tolerance_rad: Some(self.heading_tolerance_rad),
            free_flight: Some(self.free_flight),
            cell_diagnostics: self.cell_diagnostics.then_some(true),
            noise: self.noise,
            profile: Some(self.profile),
            realistic: (self.profile == Profile::Realistic)
                .then(|| RealisticTable::from_config(&self.realistic)),
        }
    }

    /// Nominal duration of a one-cell move, seconds: a half turn and a one-cell drive,
    /// each with a trapezoidal (or triangular) speed profile at the limits.
    pub fn nominal_primitive_s(&self, cell_size: f64) -> f64 {
        profile_time(std::f64::consts::PI, self.max_turn_rate_radps, self.max_angular_accel_radps2)
            + profile_time(cell_size, self.max_speed_mps, self.max_accel_mps2)
    }

    /// Time-out of a primitive on a world with cells of `cell_size` metres, seconds.
    pub fn timeout_s(&self, cell_size: f64) -> f64 {
        self.timeout_factor * self.nominal_primitive_s(cell_size)
    }
}

/// Clearance required between the robot at a cell's centre and the cell's sides, metres.
pub const CLEARANCE_M: f64 = 0.02;

/// The most physics steps a primitive may need (its time-out over `dt_s`). The shipped
/// presets need 400–900; this bound is about 30× that, and keeps the worst primitive
/// (a time-out against a wall) well under a second of wall time, so a stop is answered
/// within a second whatever the settings.
pub const MAX_PHYSICS_STEPS: f64 = 25_000.0;

/// `x` rounded up to `digits` decimals (a bound suggested in a message stays a bound).
fn round_up(x: f64, digits: i32) -> f64 {
    let k = 10f64.powi(digits);
    (x * k).ceil() / k
}

/// Time to cover `d` starting and ending at rest with speed limit `v` and acceleration
/// limit `a`.
fn profile_time(d: f64, v: f64, a: f64) -> f64 {
    if d * a <= v * v { 2.0 * (d / a).sqrt() } else { d / v + v / a }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_roundtrip_through_toml() {
        for p in Preset::ALL {
            let c = p.config();
            c.validate().unwrap();
            let text = toml::to_string(&c).unwrap();
            let back: RobotConfig = toml::from_str(&text).unwrap();
            assert_eq!(back, c, "{text}");
        }
    }

    #[test]
    fn preset_then_overrides() {
        let c = RobotConfig::from_toml("preset = \"kobuki\"\nmax_speed_mps = 0.5\n[noise]\n").unwrap();
        assert_eq!(c.preset, Preset::Kobuki);
        assert_eq!(c.max_speed_mps, 0.5);
        assert_eq!(c.wheel_base_m, 0.230);
        assert_eq!(c.noise, Some(NoiseConfig::default()));
    }

    #[test]
    fn nominal_time_of_the_burger() {
        let c = RobotConfig::default();
        let t = c.nominal_primitive_s(0.5);
        // A half turn (1.99 s) and a 0.5 m drive (2.36 s).
        assert!((t - 4.35).abs() < 0.01, "{t}");
    }
    #[test]
    fn settings_that_would_crawl_are_refused_with_a_fix() {
        let world =
            mmq_core::World::parse("name = \"w\"\ncell_size = 0.5\nmap = \"\"\"\nS.\n.G\n\"\"\"\n", "w.toml")
                .unwrap();
        for p in Preset::ALL {
            let steps = p.config().max_physics_steps(world.cell_size);
            assert!((400.0..=1000.0).contains(&steps), "{p:?}: {steps}");
        }
        // Burger: 4.354 s nominal × 3 = 13.063 s; at dt 1e-4 s that is 130 633 steps, and the
        // smallest dt accepted is 13.063 / 25 000 = 0.00052253 s, rounded up.
        let slow = RobotConfig { dt_s: 1e-4, ..RobotConfig::default() };
        let e = slow.validate_for_world(&world).unwrap_err().to_string();
        assert!(e.contains("`dt_s`") && e.contains("130") && e.contains("at least 0.000523 s"), "{e}");
        let crawl = RobotConfig { max_speed_mps: 1e-3, ..RobotConfig::default() };
        assert!(crawl.validate_for_world(&world).is_err());
        // Cells too small for any robot: the fix is a larger cell, never "a radius of 0 m".
        let tiny = mmq_core::World::parse(
            "name = \"w\"\ncell_size = 1e-9\nmap = \"\"\"\nS.\n.G\n\"\"\"\n",
            "w.toml",
        );
        if let Ok(tiny) = tiny {
            let e = RobotConfig::default().validate_for_world(&tiny).unwrap_err().to_string();
            assert!(e.contains("a `cell_size` of at least 0.25 m") && !e.contains("radius at most"), "{e}");
        }
    }
}
