//! Recording runs to MCAP: the per-seed recorder the runner attaches as an observer when
//! a configuration asks for it (`RunConfig::record`), and nothing at all otherwise.

use std::path::{Path, PathBuf};

use mmq_core::Observer;
use mmq_log::{McapRecorder, RecorderConfig, StepWindow};

use crate::config::RunConfig;
use crate::error::LabError;

/// The MCAP file of one seed in an output folder.
pub fn trajectory_path(out: &Path, seed: u64) -> PathBuf {
    out.join(format!("trajectory-seed{seed}.mcap"))
}

/// The recorder settings of `cfg` writing to `path`, or `None` when it records nothing.
pub fn recorder_config(cfg: &RunConfig, path: PathBuf) -> Option<RecorderConfig> {
    let r = cfg.record.as_ref()?;
    let mut rc = RecorderConfig::new(path);
    rc.pose_rate_hz = r.pose_rate_hz;
    if r.first.is_some() || r.last.is_some() {
        rc.window =
            Some(StepWindow { first: r.first.unwrap_or(0), last: r.last.unwrap_or(0), total: cfg.steps });
    }
    Some(rc)
}

/// Opens a recorder.
pub fn open(rc: RecorderConfig) -> Result<Box<dyn Observer + Send>, LabError> {
    let path = rc.path.clone();
    let rec = McapRecorder::create(rc)
        .map_err(|e| LabError::Io { path, source: std::io::Error::other(e.to_string()) })?;
    Ok(Box::new(rec))
}

/// A factory for `run_all`: one recorder per seed in `out` when `cfg` records.
pub fn recorder_factory(
    cfg: &RunConfig,
    out: &Path,
) -> impl Fn(u64) -> Result<Option<Box<dyn Observer + Send>>, LabError> + Sync + use<> {
    let cfg = cfg.clone();
    let out = out.to_path_buf();
    move |seed| recorder_config(&cfg, trajectory_path(&out, seed)).map(open).transpose()
}

/// What `verify` found.
#[derive(Debug)]
pub enum Verdict {
    /// The re-run reproduced every compared message bit for bit.
    Identical {
        /// Decisions compared.
        decisions: usize,
        /// Poses compared.
        poses: usize,
    },
    /// The first difference.
    Differs(mmq_log::Mismatch),
}

/// Re-runs the simulation described by a log's metadata (its `config.toml` and
/// `world.toml` attachments and the `seed` fact) with the same recorder settings, and
/// compares the two logs message by message.
pub fn verify(log: &mmq_log::LogContents, scratch: &Path) -> Result<Verdict, LabError> {
    let file = log.path.display().to_string();
    let bad = |message: String| LabError::Config { file: file.clone(), message };
    let cfg_text = log.attachment("config.toml").ok_or_else(|| {
        bad("the log has no config.toml attachment; it was not written by `mmq run --record`".into())
    })?;
    let mut cfg =
        RunConfig::from_toml(&String::from_utf8_lossy(&cfg_text.data), &format!("{file}#config.toml"))?;
    let world = log.world().map_err(|e| bad(e.to_string()))?;
    let seed: u64 = log
        .run_fact("seed")
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| bad("the log's run metadata has no numeric `seed`".into()))?;
    if cfg.record.is_none() {
        return Err(bad("the log's config has no [record] settings".into()));
    }
    // The learner's own run is what the log holds; the baseline and tables are not needed.
    cfg.baseline = false;
    cfg.save_tables = false;
    cfg.eval_steps = 0;
    let dist = cfg.validate()?;
    let path = scratch.join(format!("verify-seed{seed}.mcap"));
    let rec = recorder_config(&cfg, path.clone()).map(open).transpose()?;
    let stop = std::sync::atomic::AtomicBool::new(false);
    let ctl = crate::runner::Control { stop: &stop, progress: &|_| {} };
    crate::runner::run_seed(&cfg, &world, &dist, seed, rec, ctl, crate::runner::memory_limit(1))?;
    let again = mmq_log::read_log(&path).map_err(|e| bad(e.to_string()))?;
    Ok(match mmq_log::compare(log, &again) {
        Ok(()) => Verdict::Identical { decisions: log.decisions.len(), poses: log.poses.len() },
        Err(m) => Verdict::Differs(m),
    })
}
