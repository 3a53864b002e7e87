//! `--live` of `mmq run` and `--serve` of `mmq replay`: the flags → an address and a
//! server of `mmq_log::live`; the first seed of a run is the one shown.

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::AtomicBool;

use mmq_core::Observer;
use mmq_lab::{LabError, RunConfig};
use mmq_log::{LiveConfig, LiveServer, LiveTap, McapRecorder, RecorderConfig};

use crate::Failure;

/// A running live view and the tap of the seed it shows.
pub struct Live {
    server: LiveServer,
    tap: Mutex<Option<LiveTap>>,
    seed: u64,
    pose_rate_hz: f64,
    cfg: RunConfig,
    out: PathBuf,
}

/// The address flag as a live configuration; a bad address is bad input (exit 3).
fn config(flag: &str, addr: &str, speed: f64, name: String) -> Result<LiveConfig, Failure> {
    let addr = mmq_log::live::parse_addr(addr).map_err(|e| crate::input_error(format!("{flag}: {e}")))?;
    if !(speed.is_finite() && speed >= 0.0) {
        return Err(crate::input_error(format!(
            "--live-speed {speed}: the real-time factor must be a number ≥ 0 (1: real time, 0: no pacing)"
        )));
    }
    Ok(LiveConfig { addr, speed, name })
}

/// Starts the live view of `mmq run` when `--live` was given.
pub fn start(
    addr: Option<&str>,
    speed: f64,
    pose_rate_hz: f64,
    cfg: &RunConfig,
    out: &Path,
) -> Result<Option<Live>, Failure> {
    let Some(addr) = addr else { return Ok(None) };
    let c = config(
        "--live",
        addr,
        speed,
        format!("mmq run: {} on {}", cfg.learner.kind().name(), cfg.world.display()),
    )?;
    let server = LiveServer::start(&c)?;
    eprintln!(
        "live view: ws://{} (Foxglove app: Open connection → Foxglove WebSocket); showing seed {}",
        server.addr(),
        cfg.seed
    );
    let tap = Mutex::new(Some(server.tap()));
    Ok(Some(Live { server, tap, seed: cfg.seed, pose_rate_hz, cfg: cfg.clone(), out: out.to_path_buf() }))
}

impl Live {
    /// The observer of `seed` when it is the seed shown: its recorder (if the run
    /// records) with the live view attached, or a live-only recorder.
    pub fn observer(&self, seed: u64) -> Result<Option<Box<dyn Observer + Send>>, LabError> {
        if seed != self.seed {
            return Ok(None);
        }
        let Some(tap) = self.tap.lock().ok().and_then(|mut t| t.take()) else { return Ok(None) };
        let path = mmq_lab::record::trajectory_path(&self.out, seed);
        let rec = match mmq_lab::record::recorder_config(&self.cfg, path.clone()) {
            Some(rc) => McapRecorder::create(rc)
                .map_err(|e| LabError::Io { path, source: std::io::Error::other(e.to_string()) })?
                .with_live(tap),
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

/// `mmq replay FILE --serve [ADDR]`: plays the file until Ctrl-C.
pub fn serve(file: &Path, addr: &str, stop: &AtomicBool) -> Result<(), Failure> {
    let name = format!("mmq replay: {}", file.file_name().map(|n| n.to_string_lossy()).unwrap_or_default());
    let c = config("--serve", addr, 1.0, name)?;
    let server = mmq_log::live::replay::serve_file(file, &c).map_err(|e| match &e {
        mmq_log::LogError::NotMcap { .. } => crate::input_error(e),
        _ => Failure::from(e),
    })?;
    let (t0, t1) = server.time_range();
    eprintln!(
        "serving {} ({} messages, {:.1} s of simulated time) on ws://{}: open it in the Foxglove app \
         (Open connection → Foxglove WebSocket), press play; Ctrl-C stops",
        file.display(),
        server.messages(),
        t1.saturating_sub(t0) as f64 * 1e-9,
        server.addr()
    );
    server.run(stop);
    Ok(())
}
