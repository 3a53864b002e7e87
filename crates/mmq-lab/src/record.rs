//! Recording runs to MCAP: the per-seed recorder the runner attaches as an observer when
//! a configuration asks for it (`RunConfig::record`), and nothing at all otherwise.

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

use mmq_core::Observer;
use mmq_log::{
    LiveConfig, LiveServer, LiveTap, LogError, McapRecorder, RecorderConfig, StepWindow, SwarmRecorder,
};

use crate::config::{EnvKind, RunConfig};
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

/// Opens the swarm's recorder (every robot in one file), which the swarm's seed takes
/// back from its observer and feeds itself.
pub fn open_swarm(rc: RecorderConfig) -> Result<Box<dyn Observer + Send>, LabError> {
    let path = rc.path.clone();
    let rec = SwarmRecorder::create(rc)
        .map_err(|e| LabError::Io { path, source: std::io::Error::other(e.to_string()) })?;
    Ok(Box::new(rec))
}

/// A factory for `run_all`: one recorder per seed in `out` when `cfg` records (the
/// swarm's for a swarm).
pub fn recorder_factory(
    cfg: &RunConfig,
    out: &Path,
) -> impl Fn(u64) -> Result<Option<Box<dyn Observer + Send>>, LabError> + Sync + use<> {
    let cfg = cfg.clone();
    let out = out.to_path_buf();
    move |seed| {
        let rc = recorder_config(&cfg, trajectory_path(&out, seed));
        if cfg.env == EnvKind::Swarm { rc.map(open_swarm).transpose() } else { rc.map(open).transpose() }
    }
}

/// A run served live to the Foxglove app: the server and the tap of the one seed it
/// shows (the run's first), whose observer also records when the run records.
pub struct LiveRun {
    server: LiveServer,
    tap: Mutex<Option<LiveTap>>,
    pose_rate_hz: f64,
    cfg: RunConfig,
    out: PathBuf,
}

impl std::fmt::Debug for LiveRun {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveRun").field("addr", &self.addr()).field("seed", &self.cfg.seed).finish()
    }
}

impl LiveRun {
    /// Starts the server (a bad address or a port in use fails here, before anything
    /// runs); `pose_rate_hz` thins the poses shown when the run does not record.
    pub fn start(
        c: &LiveConfig,
        cfg: &RunConfig,
        out: &Path,
        pose_rate_hz: f64,
    ) -> Result<LiveRun, LogError> {
        let mut c = c.clone();
        if cfg.env == EnvKind::Swarm {
            c.channels = mmq_log::SWARM_LIVE;
        }
        let server = LiveServer::start(&c)?;
        let tap = Mutex::new(Some(server.tap()));
        Ok(LiveRun { server, tap, pose_rate_hz, cfg: cfg.clone(), out: out.to_path_buf() })
    }

    /// Where clients connect.
    pub fn addr(&self) -> std::net::SocketAddr {
        self.server.addr()
    }

    /// Waits for the first client (see `LiveServer::wait_for_client`).
    pub fn wait_for_client(&self, timeout: Option<std::time::Duration>, stop: &AtomicBool) -> bool {
        self.server.wait_for_client(timeout, stop)
    }

    /// The observer of `seed` when it is the seed shown: its recorder (if the run
    /// records) with the live view attached, or a live-only recorder.
    pub fn observer(&self, seed: u64) -> Result<Option<Box<dyn Observer + Send>>, LabError> {
        if seed != self.cfg.seed {
            return Ok(None);
        }
        let Some(tap) = self.tap.lock().ok().and_then(|mut t| t.take()) else { return Ok(None) };
        let path = trajectory_path(&self.out, seed);
        let io =
            |path: PathBuf, e: LogError| LabError::Io { path, source: std::io::Error::other(e.to_string()) };
        if self.cfg.env == EnvKind::Swarm {
            let rec = match recorder_config(&self.cfg, path.clone()) {
                Some(rc) => SwarmRecorder::create(rc).map_err(|e| io(path, e))?.with_live(tap),
                None => {
                    let mut rc = RecorderConfig::new(PathBuf::new());
                    rc.pose_rate_hz = self.pose_rate_hz;
                    SwarmRecorder::live_only(rc, tap)
                }
            };
            return Ok(Some(Box::new(rec)));
        }
        let rec = match recorder_config(&self.cfg, path.clone()) {
            Some(rc) => McapRecorder::create(rc).map_err(|e| io(path, e))?.with_live(tap),
            None => {
                let mut rc = RecorderConfig::new(PathBuf::new());
                rc.pose_rate_hz = self.pose_rate_hz;
                McapRecorder::live_only(rc, tap)
            }
        };
        Ok(Some(Box::new(rec)))
    }

    /// Stops the server (clients are told, the port is freed).
    pub fn stop(self) {
        self.server.stop();
    }
}

/// The observers of a run's seeds for `run_all`: the live view's for the seed it shows,
/// a recorder in `out` for every other seed when `cfg` records.
pub fn observers<'a>(
    cfg: &RunConfig,
    out: &Path,
    live: Option<&'a LiveRun>,
) -> impl Fn(u64) -> Result<Option<Box<dyn Observer + Send>>, LabError> + Sync + use<'a> {
    let recorders = recorder_factory(cfg, out);
    move |seed| match live.and_then(|l| l.observer(seed).transpose()) {
        Some(o) => o.map(Some),
        None => recorders(seed),
    }
}

/// A whole run into `out` ([`crate::output::run_into`]): every seed recorded when `cfg`
/// records, the first one shown on `live` when given; the live server stops when the run
/// ends, its last messages sent.
pub fn run_recorded(
    out: &Path,
    run: &crate::Resolved,
    live: Option<LiveRun>,
    ctl: crate::runner::Control<'_>,
    claimed: &dyn Fn(usize),
) -> Result<crate::output::RunWritten, LabError> {
    // The observers (the live tap among them) finish before the server stops.
    let written = crate::output::run_into(out, run, &observers(run.cfg(), out, live.as_ref()), ctl, claimed);
    if let Some(l) = live {
        l.stop();
    }
    written
}

/// Reads a recording of `mmq run --record`, as far as it can be read (see
/// `LogContents::stop`). A file that cannot be read, or an MCAP file that is not such a
/// recording, is bad input.
pub fn read_recording(path: &Path) -> Result<mmq_log::LogContents, LabError> {
    let log = mmq_log::read_log(path).map_err(LabError::Recording)?;
    let decision = mmq_log::messages::topics::DECISION;
    if !log.metadata.contains_key("run") && !log.topics.contains_key(decision) {
        return Err(LabError::Config {
            file: path.display().to_string(),
            message: format!(
                "an MCAP file, but not a recording of this program (no `run` metadata, no {decision} \
                 topic); only recordings of runs (`record = true`) can be read"
            ),
        });
    }
    Ok(log)
}

/// [`verify`] with the re-run's log in the temporary folder (`TMPDIR`).
pub fn verify_in_temp_dir(log: &mmq_log::LogContents, stop: &AtomicBool) -> Result<Verdict, LabError> {
    let scratch = std::env::temp_dir();
    if !scratch.is_dir() {
        return Err(LabError::NoTempDir(scratch));
    }
    verify(log, &scratch, stop)
}

/// Most decision steps `verify` re-runs (10⁹: minutes to hours of work). A file that
/// records more is refused before anything runs (the configured horizon may be larger:
/// an interrupted run holds only its first steps).
pub const MAX_VERIFY_STEPS: u64 = 1_000_000_000;

/// What `verify` found.
#[derive(Debug)]
pub enum Verdict {
    /// The re-run reproduced every compared message bit for bit.
    Identical {
        /// Decisions compared.
        decisions: usize,
        /// Poses compared.
        poses: usize,
        /// Steps re-run.
        steps: u64,
        /// The file holds only a prefix of its run (an interrupted write): what it holds
        /// was checked, up to its last recorded step.
        truncated: bool,
    },
    /// The first difference.
    Differs(mmq_log::Mismatch),
    /// The stop flag was raised: the re-run stopped after `steps` steps, nothing concluded.
    Interrupted {
        /// Steps re-run before the stop.
        steps: u64,
    },
}

/// Passes a run to the recorder and raises `halt` once `limit` steps are done or `stop`
/// is raised.
struct Halting {
    rec: Box<dyn Observer + Send>,
    limit: u64,
    halt: std::sync::Arc<std::sync::atomic::AtomicBool>,
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
}

impl Observer for Halting {
    fn trace_period_s(&self) -> Option<f64> {
        self.rec.trace_period_s()
    }
    fn ledger_history(&self) -> bool {
        self.rec.ledger_history()
    }
    fn on_start(&mut self, info: &mmq_core::RunInfo<'_>, s: mmq_core::State, t: f64) {
        self.rec.on_start(info, s, t);
    }
    fn on_step(&mut self, r: &mmq_core::StepRecord<'_>) {
        self.rec.on_step(r);
        if r.t + 1 >= self.limit || self.stop.load(Ordering::Relaxed) {
            self.halt.store(true, Ordering::Relaxed);
        }
    }
    fn on_tables(&mut self, t: u64, s: f64, v: &[f64], q: &[f64]) {
        self.rec.on_tables(t, s, v, q);
    }
    fn on_finish(&mut self, t: u64, complete: bool) {
        self.rec.on_finish(t, complete);
    }
}

/// Removes a file when dropped (the re-run's scratch log, on every way out).
struct Scratch(PathBuf);

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// Re-runs the simulation described by a log's metadata (its `config.toml` and
/// `world.toml` attachments and the `seed` fact) with the same recorder settings, and
/// compares the two logs message by message.
///
/// A file that holds only a prefix of its run (an interrupted write) is checked as far as
/// it goes: the re-run stops after the last step it records, and the re-run's messages
/// past the file's last one are not compared. The re-run writes its log into the folder
/// `scratch` (which must exist) and removes it on every way out; it stops early, with
/// [`Verdict::Interrupted`], when `stop` is raised.
pub fn verify(log: &mmq_log::LogContents, scratch: &Path, stop: &AtomicBool) -> Result<Verdict, LabError> {
    let file = log.path.display().to_string();
    let bad = |message: String| LabError::Config { file: file.clone(), message };
    let job = Rerun::of(log)?;
    if !scratch.is_dir() {
        return Err(LabError::Io {
            path: scratch.to_path_buf(),
            source: std::io::Error::new(
                std::io::ErrorKind::NotFound,
                "the scratch folder for the re-run's log does not exist",
            ),
        });
    }
    let path = scratch.join(format!("verify-seed{}-{}.mcap", job.seed, std::process::id()));
    let _scratch = Scratch(path.clone());
    let steps = match job.run(&path, stop)? {
        Ran::Done(steps) => steps,
        Ran::Stopped(steps) => return Ok(Verdict::Interrupted { steps }),
    };
    let again = mmq_log::read_log(&path).map_err(|e| bad(e.to_string()))?;
    let compared =
        if job.truncated { mmq_log::compare_prefix(log, &again) } else { mmq_log::compare(log, &again) };
    Ok(match compared {
        Ok(()) => Verdict::Identical {
            decisions: log.decisions.len(),
            poses: log.poses.len(),
            steps,
            truncated: job.truncated,
        },
        Err(m) => Verdict::Differs(m),
    })
}

/// What a log asks to re-run: its run (baseline, tables and evaluation off: the log
/// holds the learner's own run), world, seed, how many steps it holds, and whether it
/// ends before its run did.
struct Rerun {
    run: crate::Resolved,
    seed: u64,
    limit: u64,
    truncated: bool,
}

impl Rerun {
    /// The re-run a log describes, or why it cannot be verified.
    fn of(log: &mmq_log::LogContents) -> Result<Rerun, LabError> {
        let file = log.path.display().to_string();
        let bad = |message: String| LabError::Config { file: file.clone(), message };
        let cfg_text = log.attachment("config.toml").ok_or_else(|| {
            bad("the log has no config.toml attachment; it was not written by a recorded run (`record = true`)"
                .into())
        })?;
        let mut cfg =
            RunConfig::from_toml(&String::from_utf8_lossy(&cfg_text.data), &format!("{file}#config.toml"))?;
        let mut world = log.world().map_err(|e| bad(e.to_string()))?;
        // The file holds the world as written; the run's `--robot` overrides are in its config.
        if !cfg.robot.is_empty() {
            let table = mmq_robot::apply_overrides(world.robot.as_ref(), &cfg.robot)
                .map_err(|e| bad(format!("its config.toml's robot overrides: {e}")))?;
            world.robot = Some(table);
        }
        let seed: u64 = log
            .run_fact("seed")
            .and_then(|s| s.parse().ok())
            .ok_or_else(|| bad("the log's run metadata has no numeric `seed`".into()))?;
        if cfg.record.is_none() {
            return Err(bad("the log's config has no [record] settings".into()));
        }
        if cfg.env == EnvKind::Swarm {
            return Err(bad(
                "a swarm's recording cannot be verified by a re-run; only a single robot's or grid's can"
                    .into(),
            ));
        }
        cfg.baseline = false;
        cfg.save_tables = false;
        cfg.eval_steps = 0;
        let run = crate::Resolved::with_world(cfg, world)?;
        let cfg = run.cfg();
        // Where the file ends: its "end" record (steps done), or its last recorded decision.
        let ended: Option<u64> =
            log.metadata.get("end").and_then(|e| e.get("steps")).and_then(|s| s.parse().ok());
        let truncated = !log.complete || ended.is_none();
        let limit = match ended.filter(|_| log.complete) {
            Some(n) => n,
            None => log.decisions.last().map_or(0, |d| d.msg.t.saturating_add(1)),
        };
        if limit > cfg.steps {
            return Err(bad(format!(
                "the file records {limit} steps but its config.toml asks for steps = {}",
                cfg.steps
            )));
        }
        if limit == 0 {
            return Err(bad("the file holds no decision step to verify".into()));
        }
        // What the file holds, not the configured horizon (an interrupted run of a huge one).
        if limit > MAX_VERIFY_STEPS {
            return Err(bad(format!(
                "the file records {limit} steps; verify re-runs at most {MAX_VERIFY_STEPS} steps \
                 (a damaged or hand-edited file?)"
            )));
        }
        // A damaged chunk in the middle is not a cut end: what follows it cannot be compared.
        if !log.problems.is_empty() {
            return Err(bad(format!(
                "the file is damaged, so it cannot be verified: {}",
                log.problems.join("; ")
            )));
        }
        Ok(Rerun { run, seed, limit, truncated })
    }

    /// Runs again, recording into `path`, until the file's last step or `stop`.
    fn run(&self, path: &Path, stop: &AtomicBool) -> Result<Ran, LabError> {
        // The recorder's window counts from the configured length; the run stops at `limit`.
        let rec = recorder_config(self.run.cfg(), path.to_path_buf()).map(open).transpose()?;
        let stopped = stop.load(Ordering::Relaxed);
        let halt = std::sync::Arc::new(AtomicBool::new(stopped));
        let user_stop = std::sync::Arc::new(AtomicBool::new(stopped));
        let limit = self.limit;
        let observer = rec.map(|rec| {
            Box::new(Halting { rec, limit, halt: halt.clone(), stop: user_stop.clone() })
                as Box<dyn Observer + Send>
        });
        let ctl = crate::runner::Control { stop: &halt, progress: &|_| {} };
        let done = AtomicBool::new(false);
        let result = std::thread::scope(|s| {
            // The caller's stop flag, passed on to the re-run (whose observer needs its own).
            s.spawn(|| {
                while !done.load(Ordering::Relaxed) {
                    if stop.load(Ordering::Relaxed) {
                        user_stop.store(true, Ordering::Relaxed);
                        halt.store(true, Ordering::Relaxed);
                        break;
                    }
                    std::thread::sleep(std::time::Duration::from_millis(20));
                }
            });
            let r = crate::resolved::run_seed(
                &self.run,
                self.seed,
                observer,
                ctl,
                crate::runner::memory_limit(1),
            );
            done.store(true, Ordering::Relaxed);
            r
        })?;
        let steps = result.run.steps_done;
        let stopped = stop.load(Ordering::Relaxed) || user_stop.load(Ordering::Relaxed);
        Ok(if stopped { Ran::Stopped(steps) } else { Ran::Done(steps) })
    }
}

/// How a re-run ended: its steps done, all it was to run or cut short by the stop flag.
enum Ran {
    Done(u64),
    Stopped(u64),
}
