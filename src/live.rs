//! `--live` of `mmq run` and `--serve` of `mmq replay`: the flags → an address and a
//! server of `mmq_log::live`; the first seed of a run is the one shown.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use mmq_lab::RunConfig;
use mmq_lab::config::RecordSettings;
use mmq_lab::record::LiveRun;
use mmq_log::LiveConfig;
use mmq_log::live::replay::ServeOptions;

use crate::Failure;
use crate::cli::RunArgs;

/// The address flag as a live configuration; a bad address is bad input (exit 3).
fn config(flag: &str, addr: &str, speed: f64, name: String) -> Result<LiveConfig, Failure> {
    let addr = mmq_log::live::parse_addr(addr).map_err(|e| crate::input_error(format!("{flag}: {e}")))?;
    if !(speed.is_finite() && speed >= 0.0) {
        return Err(crate::input_error(format!(
            "--live-speed {speed}: the real-time factor must be a number ≥ 0 (1: real time, 0: no pacing)"
        )));
    }
    Ok(LiveConfig { addr, speed, ..LiveConfig::new(name) })
}

/// Starts the live view of `mmq run` when `--live` was given; with `--live-wait`, waits
/// for the first viewer (at most the seconds given; Ctrl-C ends the wait).
pub fn start(a: &RunArgs, cfg: &RunConfig) -> Result<Option<LiveRun>, Failure> {
    let Some(addr) = a.live.as_deref() else { return Ok(None) };
    let name = format!("mmq run: {} on {}", cfg.learner.kind().name(), cfg.world.display());
    let pose_rate_hz = a.record_rate.unwrap_or(RecordSettings::default().pose_rate_hz);
    let c = config("--live", addr, a.live_speed, name)?;
    let wait = match a.live_wait {
        Some(Some(s)) if !(s.is_finite() && s > 0.0) => {
            return Err(crate::input_error(format!(
                "--live-wait {s}: give the most seconds to wait for a viewer (> 0), or no number to wait until one connects"
            )));
        }
        Some(s) => Some(s.map(Duration::from_secs_f64)),
        None => None,
    };
    let live = LiveRun::start(&c, cfg, &a.out, pose_rate_hz)?;
    if let Some(w) = mmq_log::live::exposure_warning(live.addr(), false) {
        eprintln!("{w}");
    }
    eprintln!("{}", mmq_report::terminal::live_view(live.addr(), cfg.seed));
    if let Some(timeout) = wait {
        eprintln!("waiting for a viewer to connect (Ctrl-C stops)");
        if !live.wait_for_client(timeout, &crate::STOP) && !crate::STOP.load(Ordering::SeqCst) {
            eprintln!("no viewer connected within --live-wait; the run goes on");
        }
    }
    Ok(Some(live))
}

/// `mmq replay FILE --serve [ADDR]`: plays the file until Ctrl-C; `false` when Ctrl-C
/// came before serving started.
pub fn serve(file: &Path, addr: &str, paused: bool, stop: &AtomicBool) -> Result<bool, Failure> {
    let name = format!("mmq replay: {}", file.file_name().map(|n| n.to_string_lossy()).unwrap_or_default());
    let c = config("--serve", addr, 1.0, name)?;
    let started = mmq_log::live::replay::serve_file(file, &c, ServeOptions { paused }, stop);
    let server = match started {
        Ok(Some(s)) => s,
        Ok(None) => return Ok(false),
        // A port in use is the system's; anything about the file is bad input.
        Err(e @ mmq_log::LogError::LiveServer { .. }) => return Err(Failure::from(e)),
        Err(e) => return Err(crate::input_error(e)),
    };
    if let Some(w) = mmq_log::live::exposure_warning(server.addr(), true) {
        eprintln!("{w}");
    }
    for w in server.warnings() {
        eprintln!("warning: {}: {w}", file.display());
    }
    eprintln!(
        "{}",
        mmq_report::terminal::serving(file, server.messages(), server.time_range(), server.addr())
    );
    if !paused {
        eprintln!(
            "playback starts at 1x when a viewer subscribes (--paused: wait for the app's play button)"
        );
    }
    server.run(stop)?;
    Ok(true)
}
