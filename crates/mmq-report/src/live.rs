//! The live view for a front end: a run's first seed served to the Foxglove app
//! ([`start`]), or a recorded file played to it ([`serve`]). The options are checked (a
//! bad address or speed names its field), the server started, and where to connect and
//! how to watch told through [`Progress::notice`].

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use mmq_lab::RunConfig;
use mmq_lab::config::RecordSettings;
use mmq_lab::record::LiveRun;
use mmq_log::LiveConfig;
use mmq_log::live::replay::ServeOptions;

use crate::{Progress, ReportError};

/// How a run is served live (the fields `live`, `live_speed` and `live_wait`).
#[derive(Debug, Clone)]
pub struct LiveOptions {
    /// The address: `HOST:PORT` or a port (see `mmq_log::live::parse_addr`).
    pub addr: String,
    /// Seconds of simulated time per second while a client watches (0: no pacing).
    pub speed: f64,
    /// Wait for the first viewer before running: at most the seconds given, or (`None`)
    /// until one connects or the stop flag is raised.
    pub wait: Option<Option<f64>>,
}

/// The live configuration of the address given as the field `field`; a bad address or
/// speed is bad input naming its field.
fn config(field: &str, addr: &str, speed: f64, name: String) -> Result<LiveConfig, ReportError> {
    let addr =
        mmq_log::live::parse_addr(addr).map_err(|e| ReportError::InvalidOption(format!("`{field}`: {e}")))?;
    if !(speed.is_finite() && speed >= 0.0) {
        return Err(ReportError::InvalidOption(format!(
            "`live_speed` {speed}: the real-time factor must be a number ≥ 0 (1: real time, 0: no pacing)"
        )));
    }
    Ok(LiveConfig { addr, speed, ..LiveConfig::new(name) })
}

/// The wait for a viewer as a timeout (`None`: until one connects); a number of seconds
/// that is not > 0 is bad input.
fn wait_timeout(wait: Option<f64>) -> Result<Option<Duration>, ReportError> {
    match wait {
        Some(s) if !(s.is_finite() && s > 0.0) => Err(ReportError::InvalidOption(format!(
            "`live_wait` {s}: give the most seconds to wait for a viewer (> 0), or no number to wait until one connects"
        ))),
        s => Ok(s.map(Duration::from_secs_f64)),
    }
}

/// Starts the live view of the run `cfg` writing into `out` (its first seed is shown),
/// before anything runs: a bad address or a port in use stops here. With `o.wait`, waits
/// for the first viewer (at most the seconds given; `stop` ends the wait).
pub fn start(
    o: &LiveOptions,
    cfg: &RunConfig,
    out: &Path,
    stop: &AtomicBool,
    progress: &dyn Progress,
) -> Result<LiveRun, ReportError> {
    let name = format!("mmq run: {} on {}", cfg.learner.kind().name(), cfg.world.display());
    let pose_rate_hz = cfg.record.as_ref().map_or(RecordSettings::default().pose_rate_hz, |r| r.pose_rate_hz);
    let c = config("live", &o.addr, o.speed, name)?;
    let wait = o.wait.map(wait_timeout).transpose()?;
    let live = LiveRun::start(&c, cfg, out, pose_rate_hz)?;
    if let Some(w) = mmq_log::live::exposure_warning(live.addr(), false) {
        progress.notice(&w);
    }
    progress.notice(&crate::terminal::live_view(live.addr(), cfg.seed));
    if let Some(timeout) = wait {
        progress.notice("waiting for a viewer to connect (Ctrl-C stops)");
        if !live.wait_for_client(timeout, stop) && !stop.load(Ordering::SeqCst) {
            progress.notice("no viewer connected within --live-wait; the run goes on");
        }
    }
    Ok(live)
}

/// Plays the recording `file` to the Foxglove app on `addr` (the field `serve`) until
/// `stop` is raised, from the first subscription on or, when `paused`, from the app's
/// play command; `false` when the stop came before serving started. A file that cannot
/// be served is bad input; a port in use is not.
pub fn serve(
    file: &Path,
    addr: &str,
    paused: bool,
    stop: &AtomicBool,
    progress: &dyn Progress,
) -> Result<bool, ReportError> {
    let name = format!("mmq replay: {}", file.file_name().map(|n| n.to_string_lossy()).unwrap_or_default());
    let c = config("serve", addr, 1.0, name)?;
    let server = match mmq_log::live::replay::serve_file(file, &c, ServeOptions { paused }, stop) {
        Ok(Some(s)) => s,
        Ok(None) => return Ok(false),
        Err(e @ mmq_log::LogError::LiveServer { .. }) => return Err(e.into()),
        Err(e) => return Err(mmq_lab::LabError::Recording(e).into()),
    };
    if let Some(w) = mmq_log::live::exposure_warning(server.addr(), true) {
        progress.notice(&w);
    }
    for w in server.warnings() {
        progress.notice(&format!("warning: {}: {w}", file.display()));
    }
    let (messages, range) = (server.messages(), server.time_range());
    progress.notice(&crate::terminal::serving(file, messages, range, server.addr()));
    if !paused {
        progress.notice(
            "playback starts at 1x when a viewer subscribes (--paused: wait for the app's play button)",
        );
    }
    server.run(stop)?;
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bad_address_speed_or_wait_is_bad_input_naming_its_field() {
        let e = config("serve", "nowhere", 1.0, "x".into()).unwrap_err();
        assert!(e.is_input_error() && e.names_fields() && e.to_string().starts_with("`serve`: "), "{e}");
        let e = config("live", "8765", -1.0, "x".into()).unwrap_err();
        assert!(e.to_string().starts_with("`live_speed` -1: "), "{e}");
        assert_eq!(config("live", "9000", 0.0, "x".into()).unwrap().addr.port(), 9000);
        assert!(wait_timeout(Some(0.0)).unwrap_err().to_string().starts_with("`live_wait` 0: "));
        assert_eq!(wait_timeout(Some(1.5)).unwrap(), Some(Duration::from_millis(1500)));
        assert_eq!(wait_timeout(None).unwrap(), None);
    }
}
