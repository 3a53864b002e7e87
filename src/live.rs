//! `--live` of `mmq run` and `--serve` of `mmq replay`: the flags → an address and a
//! server of `mmq_log::live`; the first seed of a run is the one shown.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use mmq_lab::RunConfig;
use mmq_lab::config::RecordSettings;
use mmq_lab::record::LiveRun;
use mmq_log::LiveConfig;

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
    Ok(LiveConfig { addr, speed, name })
}

/// Starts the live view of `mmq run` when `--live` was given.
pub fn start(a: &RunArgs, cfg: &RunConfig) -> Result<Option<LiveRun>, Failure> {
    let Some(addr) = a.live.as_deref() else { return Ok(None) };
    let name = format!("mmq run: {} on {}", cfg.learner.kind().name(), cfg.world.display());
    let pose_rate_hz = a.record_rate.unwrap_or(RecordSettings::default().pose_rate_hz);
    let live = LiveRun::start(&config("--live", addr, a.live_speed, name)?, cfg, &a.out, pose_rate_hz)?;
    eprintln!("{}", mmq_report::terminal::live_view(live.addr(), cfg.seed));
    Ok(Some(live))
}

/// `mmq replay FILE --serve [ADDR]`: plays the file until Ctrl-C.
pub fn serve(file: &Path, addr: &str, stop: &AtomicBool) -> Result<(), Failure> {
    let name = format!("mmq replay: {}", file.file_name().map(|n| n.to_string_lossy()).unwrap_or_default());
    let c = config("--serve", addr, 1.0, name)?;
    let server = mmq_log::live::replay::serve_file(file, &c).map_err(|e| match &e {
        mmq_log::LogError::NotMcap { .. } => crate::input_error(e),
        _ => Failure::from(e),
    })?;
    eprintln!(
        "{}",
        mmq_report::terminal::serving(file, server.messages(), server.time_range(), server.addr())
    );
    server.run(stop);
    Ok(())
}
