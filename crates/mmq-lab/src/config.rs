//! Run configuration: everything a run depends on, resolved and validated before the
//! run starts, and saved next to its outputs (`config.toml`).

use std::path::PathBuf;

use mmq_core::{DelayDist, World};
use mmq_learn::{LearnerKind, LearnerSpec};
use serde::{Deserialize, Serialize};

use crate::error::LabError;

/// Which fidelity of the world.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EnvKind {
    /// The paper's tabular grid world.
    Grid,
    /// The rapier2d differential-drive robot in the same world.
    Robot,
    /// Several robots in one arena whose rewards wait for a radio consultation.
    Swarm,
}

impl EnvKind {
    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            EnvKind::Grid => "grid",
            EnvKind::Robot => "robot",
            EnvKind::Swarm => "swarm",
        }
    }

    /// The delay of a run that names none: `poisson:13`, or `none` for the swarm (its
    /// delays emerge from the radio).
    pub fn default_delay(self) -> &'static str {
        if self == EnvKind::Swarm { "none" } else { "poisson:13" }
    }
}

/// A resolved run configuration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunConfig {
    /// World file.
    pub world: PathBuf,
    /// Environment fidelity.
    pub env: EnvKind,
    /// The learner and its hyper-parameters.
    pub learner: LearnerSpec,
    /// Reward delay distribution spec (see `mmq_core::delay`), e.g. `poisson:13`.
    pub delay: String,
    /// Decision steps per seed (paper: 150,000).
    pub steps: u64,
    /// First master seed; seed i of the run is `seed + i`.
    pub seed: u64,
    /// Number of seeds.
    pub seeds: u64,
    /// Steps per row of the learning curves in `metrics.csv`.
    pub window: u64,
    /// Steps of greedy evaluation from `S` after learning (paper: 1000).
    pub eval_steps: u64,
    /// Also run undelayed Q-learning with the same world, seed, ε, q0 and horizon, the
    /// denominator of the relative performance (eq. 3).
    pub baseline: bool,
    /// Also run the reference `grid-optimal` (the world MDP's optimal policy, acting
    /// ε-greedily with the run's ε) on the same environment, seeds and steps: what the
    /// environment allows, the denominator of `perf/fraction_of_reference`.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub reference: bool,
    /// Write the Q-tables as `.npy`.
    pub save_tables: bool,
    /// Keep the delay channel's ground-truth ledger (needed by the oracle and logs).
    pub ledger: bool,
    /// Record every seed's trajectory to MCAP (`trajectory-seed<N>.mcap` in the output
    /// folder); absent: no recording, and no cost.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub record: Option<RecordSettings>,
    /// `KEY=VALUE` overrides of the world's `[robot]` table (`--robot`), applied in
    /// order when the world is loaded (see `mmq_robot::apply_overrides`); the grid
    /// ignores them once they are checked.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub robot: Vec<String>,
    /// `KEY=VALUE` overrides of the world's `[swarm]` table (`--swarm`), checked when the
    /// world is loaded (see `mmq_robot::swarm::apply_swarm_overrides`); only the swarm
    /// reads them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub swarm: Vec<String>,
}

/// Highest frame rate of a swarm recording, frames per second of simulated time: each
/// frame writes a transform per robot (two on the realistic profile), so every physics
/// step of 16 robots would be tens of thousands of messages per simulated second.
pub const MAX_SWARM_POSE_RATE_HZ: f64 = 100.0;

/// What `--record` writes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecordSettings {
    /// Robot pose samples per second of simulated time (0: every physics step).
    pub pose_rate_hz: f64,
    /// Record only the first this many steps (with `last`; absent: all steps).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub first: Option<u64>,
    /// Record only the last this many steps (with `first`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub last: Option<u64>,
}

impl Default for RecordSettings {
    fn default() -> Self {
        Self { pose_rate_hz: 10.0, first: None, last: None }
    }
}

impl RecordSettings {
    /// Recording at `pose_rate_hz` (the default 10 Hz when not given), only the `first`
    /// and `last` steps when given.
    pub fn new(pose_rate_hz: Option<f64>, first: Option<u64>, last: Option<u64>) -> Self {
        Self { pose_rate_hz: pose_rate_hz.unwrap_or(Self::default().pose_rate_hz), first, last }
    }
}

impl Default for RunConfig {
    fn default() -> Self {
        Self {
            world: PathBuf::from("worlds/paper-9x9.toml"),
            env: EnvKind::Grid,
            learner: LearnerSpec::default(),
            delay: "poisson:13".into(),
            steps: 150_000,
            seed: 0,
            seeds: 1,
            window: 1000,
            eval_steps: 1000,
            baseline: true,
            reference: false,
            save_tables: true,
            ledger: false,
            record: None,
            robot: Vec::new(),
            swarm: Vec::new(),
        }
    }
}

/// Largest number of decision steps accepted per seed.
pub const MAX_STEPS: u64 = 10_000_000_000;

impl RunConfig {
    /// Checks everything that can be checked without the world, and parses the delay.
    pub fn validate(&self) -> Result<DelayDist, LabError> {
        if self.steps == 0 || self.steps > MAX_STEPS {
            return Err(LabError::param(
                "steps",
                self.steps,
                "use a number of decision steps in 1..=10^10, e.g. 150000",
            ));
        }
        if self.seeds == 0 || self.seeds > 1_000_000 {
            return Err(LabError::param("seeds", self.seeds, "use a number of seeds in 1..=1000000"));
        }
        if self.seed.checked_add(self.seeds - 1).is_none() {
            return Err(LabError::param(
                "seed",
                self.seed,
                &format!(
                    "the {} seeds from it would pass 2^64 − 1; use a first seed of at most {}",
                    self.seeds,
                    u64::MAX - (self.seeds - 1)
                ),
            ));
        }
        if self.window == 0 {
            return Err(LabError::param("window", self.window, "use a window of at least 1 step"));
        }
        if self.eval_steps > MAX_STEPS {
            return Err(LabError::param("eval_steps", self.eval_steps, "use at most 10^10 steps"));
        }
        self.learner.validate()?;
        if self.env == EnvKind::Swarm && self.delay.trim() != "none" {
            return Err(LabError::param(
                "delay",
                &self.delay,
                "the swarm's delays emerge from its consultation (`swarm.consult`); use delay none",
            ));
        }
        if self.env == EnvKind::Swarm
            && let Some(r) = &self.record
        {
            if let Some((field, n)) =
                r.first.map(|n| ("record.first", n)).or(r.last.map(|n| ("record.last", n)))
            {
                return Err(LabError::param(
                    field,
                    n,
                    "the swarm's recordings hold every step; leave out the recording window",
                ));
            }
            if !(r.pose_rate_hz > 0.0 && r.pose_rate_hz <= MAX_SWARM_POSE_RATE_HZ) {
                return Err(LabError::param(
                    "record.pose_rate_hz",
                    r.pose_rate_hz,
                    "the swarm records frames of every robot at 0 < rate <= 100 per second \
                     (every physics step would be too many)",
                ));
            }
        }
        if self.env != EnvKind::Swarm && !self.swarm.is_empty() {
            return Err(LabError::param(
                "swarm",
                self.swarm.join(" "),
                "only the swarm reads them; use env swarm",
            ));
        }
        if let Some(r) = &self.record
            && !(r.pose_rate_hz.is_finite() && r.pose_rate_hz >= 0.0 && r.pose_rate_hz <= 10_000.0)
        {
            return Err(LabError::param(
                "record.pose_rate_hz",
                r.pose_rate_hz,
                "use poses per second in [0, 10000]; 0 records every physics step",
            ));
        }
        Ok(DelayDist::parse(&self.delay)?)
    }

    /// The learner of the undelayed baseline: Q-learning with the same parameters.
    pub fn baseline_learner(&self) -> LearnerSpec {
        LearnerSpec { params: self.learner.params, ..LearnerSpec::new(LearnerKind::Q) }
    }

    /// The undelayed Q-learning run that is this run's baseline, as a run of its own (on
    /// the swarm: without consultation).
    pub fn baseline_run(&self) -> RunConfig {
        let mut swarm = self.swarm.clone();
        if self.env == EnvKind::Swarm {
            swarm.push("consult=none".into());
        }
        RunConfig {
            learner: self.baseline_learner(),
            delay: "none".into(),
            baseline: false,
            reference: false,
            swarm,
            ..self.clone()
        }
    }

    /// Loads the world file.
    pub fn load_world(&self) -> Result<World, LabError> {
        let mut world = World::load(&self.world)?;
        if !self.robot.is_empty() {
            let table = mmq_robot::apply_overrides(world.robot.as_ref(), &self.robot)
                .map_err(|e| LabError::EnvBuild(format!("`robot`: {e}")))?;
            world.robot = Some(table);
        }
        if !self.swarm.is_empty() {
            let table = mmq_robot::swarm::apply_swarm_overrides(world.swarm.as_ref(), &self.swarm)
                .map_err(|e| LabError::EnvBuild(format!("`swarm`: {e}")))?;
            world.swarm = Some(table);
        }
        Ok(world)
    }

    /// The configuration as TOML text.
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).unwrap_or_else(|e| format!("# cannot serialise config: {e}\n"))
    }

    /// Parses a configuration from TOML text; `file` names it in errors. A `[learner]`
    /// table in the flat layout of older recordings is read as its learner's own settings
    /// ([`crate::settings::from_flat_layout`]); otherwise a `[learner.beyond]` table or a
    /// setting the learner does not have is an error naming it and the fix.
    pub fn from_toml(text: &str, file: &str) -> Result<RunConfig, LabError> {
        let cannot = |message: String| LabError::Config { file: file.into(), message };
        let mut table: toml::Table = toml::from_str(text).map_err(|e| cannot(e.message().trim().into()))?;
        if let Some(toml::Value::Table(learner)) = table.get_mut("learner") {
            if let Some(own) = crate::settings::from_flat_layout(learner) {
                *learner = own;
            }
            crate::settings::check_learner_table(learner).map_err(|e| cannot(e.to_string()))?;
        }
        toml::Value::Table(table).try_into().map_err(|e: toml::de::Error| cannot(e.message().trim().into()))
    }

    /// Decision steps the run makes in all, every seed's and their baselines' (the length
    /// of its progress).
    pub fn total_steps(&self) -> u64 {
        self.steps * self.seeds * (1 + u64::from(self.baseline) + u64::from(self.reference))
    }

    /// The master seeds of this run.
    pub fn seed_list(&self) -> Vec<u64> {
        (0..self.seeds).map(|i| self.seed.saturating_add(i)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_through_toml() {
        let c = RunConfig::default();
        assert_eq!(RunConfig::from_toml(&c.to_toml(), "c.toml").unwrap(), c);
    }

    /// A run's configuration lists its learner's settings only; the layout with every
    /// learner's settings in `[learner.beyond]`, or a setting of another learner, is
    /// refused with the field and the fix, never a panic.
    #[test]
    fn config_lists_the_learners_own_settings_and_refuses_others() {
        let c = RunConfig::default();
        let text = c.to_toml();
        assert!(text.contains("[learner]\nkind = \"mmq\"\nmax_delay = 50\n"), "{text}");
        for other in ["lasso", "lambda_hat", "trace_decay", "probe_rate", "kernel_width", "beyond"] {
            assert!(!text.contains(other), "{other} in {text}");
        }
        for (k, ..) in mmq_learn::catalogue() {
            let c = RunConfig { learner: LearnerSpec::new(k), ..RunConfig::default() };
            assert_eq!(RunConfig::from_toml(&c.to_toml(), "c.toml").unwrap(), c);
        }
        // The flat layout older recordings carry reads as the learner's own settings.
        let flat = text.replace("max_delay = 50\n", "lambda_hat = 13\nmax_delay = 12\n")
            + "\n[learner.beyond]\ntrace_decay = 0.9\nlasso = 0.1\n";
        let mut twelve = c.clone();
        twelve.learner.settings =
            mmq_learn::LearnerSettings::Mmq(mmq_learn::settings::MmqSettings { max_delay: 12 });
        assert_eq!(RunConfig::from_toml(&flat, "c.toml").unwrap(), twelve);
        // A `[learner.beyond]` table in the new layout is refused.
        let old = text.clone() + "\n[learner.beyond]\ntrace_decay = 0.9\nlasso = 0.1\n";
        let e = RunConfig::from_toml(&old, "c.toml").unwrap_err().to_string();
        assert!(e.starts_with("c.toml: `learner.beyond`: a learner's settings sit in [learner]"), "{e}");
        assert!(e.contains("(`mmq`: max_delay); delete the table"), "{e}");
        let old = text.replace("max_delay = 50\n", "max_delay = 50\nlasso = 0.3\n");
        let e = RunConfig::from_toml(&old, "c.toml").unwrap_err().to_string();
        assert!(e.contains("`lasso`: learner `mmq` has no such setting; its settings are max_delay"), "{e}");
        let dm = RunConfig { learner: LearnerSpec::new(LearnerKind::DeconvModel), ..RunConfig::default() };
        let old =
            dm.to_toml().replace("lasso = 0.1\n", "") + "\n[learner.beyond]\nlasso = 0.2\nkernel_width = 3\n";
        let e = RunConfig::from_toml(&old, "c.toml").unwrap_err().to_string();
        assert!(e.contains("move lasso into [learner] and delete the table"), "{e}");
        // Malformed input is an error too.
        for bad in ["learner = 3\n", "[learner]\nkind = 5\n", "[learner]\nkind = \"mmq\"\nbeyond = 1\n"] {
            assert!(RunConfig::from_toml(bad, "c.toml").is_err(), "{bad}");
        }
    }

    #[test]
    fn rejects_impossible_runs() {
        let mut c = RunConfig { steps: 0, ..RunConfig::default() };
        assert!(c.validate().unwrap_err().to_string().contains("`steps` = 0"));
        c.steps = 10;
        c.delay = "poisson:-2".into();
        assert!(c.validate().unwrap_err().to_string().contains("negative"));
        c.delay = "exponential:4".into();
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains("delay `exponential:4`") && e.contains("e.g. exponential:4s"), "{e}");
        c.delay = "exponential:4s".into();
        assert_eq!(c.validate().unwrap().unit(), mmq_core::DelayUnit::Seconds);
    }

    #[test]
    fn robot_overrides_apply_when_the_world_loads_and_round_trip() {
        let world = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../worlds/paper-9x9.toml"));
        let c = RunConfig {
            world,
            env: EnvKind::Robot,
            robot: vec!["profile=realistic".into(), "preset=kobuki".into()],
            ..RunConfig::default()
        };
        assert_eq!(RunConfig::from_toml(&c.to_toml(), "c.toml").unwrap(), c);
        let w = c.load_world().unwrap();
        let cfg = mmq_robot::RobotConfig::from_world(&w).unwrap();
        assert_eq!((cfg.profile, cfg.preset), (mmq_robot::Profile::Realistic, mmq_robot::Preset::Kobuki));
        let bad = RunConfig { robot: vec!["speed=1".into()], ..c };
        let e = bad.load_world().unwrap_err().to_string();
        assert!(e.contains("`robot`") && e.contains("speed"), "{e}");
    }
}
