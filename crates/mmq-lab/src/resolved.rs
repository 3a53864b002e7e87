//! A run configuration resolved once into what runs: its world loaded with the robot and
//! swarm settings applied, its delay parsed, its learner settings typed (they are, in
//! the configuration) and every field checked, the robot's arena built once and the
//! tables' memory counted. [`run_seed`], the executor, recorded runs, replay
//! verification, sweeps and the Python package take a [`Resolved`], so a delay or a
//! world is parsed once.

use std::sync::Arc;

use mmq_core::{DelayDist, Observer, World};

use crate::config::RunConfig;
use crate::error::LabError;
use crate::trajectory::{Control, SeedResult};

/// A run configuration with its loaded world and parsed delay, checked.
#[derive(Clone, Debug)]
pub struct Resolved {
    cfg: RunConfig,
    world: Arc<World>,
    dist: DelayDist,
}

impl Resolved {
    /// Loads the configuration's world (its robot and swarm settings applied) and checks
    /// everything a run would refuse.
    pub fn new(cfg: RunConfig) -> Result<Resolved, LabError> {
        // The fields first (a bad field is named before a world is read), then the world.
        let dist = cfg.validate()?;
        let world = Arc::new(cfg.load_world()?);
        Resolved::fitting(cfg, world, dist)
    }

    /// The configuration on a world already loaded (with its robot and swarm settings
    /// applied), checked as [`Resolved::new`] checks.
    pub fn with_world(cfg: RunConfig, world: impl Into<Arc<World>>) -> Result<Resolved, LabError> {
        let dist = cfg.validate()?;
        Resolved::fitting(cfg, world.into(), dist)
    }

    /// The parts, once the robot's arena builds and the seeds' tables fit.
    fn fitting(cfg: RunConfig, world: Arc<World>, dist: DelayDist) -> Result<Resolved, LabError> {
        crate::runner::check_fits(&cfg, &world)?;
        Ok(Resolved { cfg, world, dist })
    }

    /// Parts a caller resolved itself: a sweep's cell (checked at plan time, its world
    /// shared by its cells) or a baseline (undelayed).
    pub(crate) fn from_parts(cfg: RunConfig, world: Arc<World>, dist: DelayDist) -> Resolved {
        Resolved { cfg, world, dist }
    }

    /// The configuration.
    pub fn cfg(&self) -> &RunConfig {
        &self.cfg
    }

    /// The world, with the configuration's robot and swarm settings applied.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The parsed delay.
    pub fn dist(&self) -> &DelayDist {
        &self.dist
    }

    /// The same run with another configuration on the same world and delay (a re-run of
    /// one seed without its baseline, say); the caller keeps what it changes valid.
    pub(crate) fn with_cfg(&self, cfg: RunConfig) -> Resolved {
        Resolved { cfg, world: self.world.clone(), dist: self.dist.clone() }
    }

    /// The undelayed Q-learning baseline of this run, on the same world.
    pub(crate) fn baseline(&self) -> Resolved {
        Resolved { cfg: self.cfg.baseline_run(), world: self.world.clone(), dist: DelayDist::None }
    }
}

/// Runs one seed: learning under delay, greedy evaluation, then the baseline (when the
/// configuration asks for one).
pub fn run_seed(
    run: &Resolved,
    seed: u64,
    observer: Option<Box<dyn Observer + Send>>,
    ctl: Control<'_>,
    mem_limit: u128,
) -> Result<SeedResult, LabError> {
    let (cfg, world, dist) = (run.cfg(), run.world(), run.dist());
    crate::runner::run_seed_as(cfg, world, dist, seed, observer, ctl, mem_limit, cfg.baseline, None)
}
