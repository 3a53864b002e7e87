//! Progress of long work, fed by the lab's progress callback: a bar (indicatif) on a
//! terminal; plain lines every few seconds when stderr is a file or a pipe (a batch job's
//! log), with steps done of the total, the rate in steps/s and the time left; nothing with
//! `-q`.

use std::io::IsTerminal;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};

/// Seconds between two plain progress lines.
const LINE_EVERY: Duration = Duration::from_secs(5);

/// Progress over a number of decision steps.
#[derive(Debug)]
pub struct Progress {
    label: String,
    mode: Mode,
}

#[derive(Debug)]
enum Mode {
    Hidden,
    Bar(ProgressBar),
    Lines { start: Instant, done: AtomicU64, total: AtomicU64, last: Mutex<Instant> },
}

/// Progress over `total` steps: a bar on a terminal, plain lines otherwise, nothing when
/// `quiet`.
pub fn bar(total: u64, label: &str, quiet: bool) -> Progress {
    let mode = if quiet {
        Mode::Hidden
    } else if std::io::stderr().is_terminal() {
        let pb = ProgressBar::new(total);
        pb.set_style(
            ProgressStyle::with_template(
                "{msg:>12} [{elapsed_precise}] {wide_bar} {percent:>3}% {per_sec:.1} steps/s eta {eta}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        pb.set_message(label.to_string());
        Mode::Bar(pb)
    } else {
        let now = Instant::now();
        Mode::Lines {
            start: now,
            done: AtomicU64::new(0),
            total: AtomicU64::new(total),
            last: Mutex::new(now),
        }
    };
    Progress { label: label.to_string(), mode }
}

impl Progress {
    /// `n` more steps done.
    pub fn inc(&self, n: u64) {
        match &self.mode {
            Mode::Hidden => {}
            Mode::Bar(pb) => pb.inc(n),
            Mode::Lines { start, done, total, last } => {
                let d = done.fetch_add(n, Ordering::Relaxed) + n;
                let Ok(mut last) = last.try_lock() else { return };
                if last.elapsed() < LINE_EVERY {
                    return;
                }
                *last = Instant::now();
                let total = total.load(Ordering::Relaxed);
                let secs = start.elapsed().as_secs_f64().max(1e-9);
                let rate = d as f64 / secs;
                let left = if total > d && rate > 0.0 {
                    format!(", about {} left", duration((total - d) as f64 / rate))
                } else {
                    String::new()
                };
                let pct = if total > 0 {
                    format!(" ({:.0} %)", 100.0 * d as f64 / total as f64)
                } else {
                    String::new()
                };
                eprintln!(
                    "{}: {d} of {total} steps{pct}, {rate:.0} steps/s, {} elapsed{left}",
                    self.label,
                    duration(secs)
                );
            }
        }
    }

    /// Sets the total (when it is known only after planning).
    pub fn set_length(&self, total: u64) {
        match &self.mode {
            Mode::Hidden => {}
            Mode::Bar(pb) => pb.set_length(total),
            Mode::Lines { total: t, .. } => t.store(total, Ordering::Relaxed),
        }
    }

    /// Runs `f` with the bar out of the way (for printing a line).
    pub fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        match &self.mode {
            Mode::Bar(pb) => pb.suspend(f),
            _ => f(),
        }
    }

    /// Removes the bar; in plain-line mode, says how much was done and how fast.
    pub fn finish_and_clear(&self) {
        match &self.mode {
            Mode::Hidden => {}
            Mode::Bar(pb) => pb.finish_and_clear(),
            Mode::Lines { start, done, total, .. } => {
                let (d, secs) = (done.load(Ordering::Relaxed), start.elapsed().as_secs_f64().max(1e-9));
                eprintln!(
                    "{}: {d} of {} steps in {}, {:.0} steps/s",
                    self.label,
                    total.load(Ordering::Relaxed),
                    duration(secs),
                    d as f64 / secs
                );
            }
        }
    }
}

/// The reports' progress (`mmq_report::Progress`): one bar (or plain lines) per piece of
/// work, notices on stderr, nothing but errors with `-q`.
#[derive(Debug)]
pub struct Bars {
    quiet: bool,
    current: Mutex<Option<Progress>>,
}

impl Bars {
    /// Bars shown unless `quiet`.
    pub fn new(quiet: bool) -> Self {
        Bars { quiet, current: Mutex::new(None) }
    }

    fn current(&self) -> std::sync::MutexGuard<'_, Option<Progress>> {
        self.current.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

impl mmq_report::Progress for Bars {
    fn begin(&self, total: u64, label: &str) {
        *self.current() = Some(bar(total, label, self.quiet));
    }

    fn advance(&self, n: u64) {
        if let Some(p) = self.current().as_ref() {
            p.inc(n);
        }
    }

    fn end(&self) {
        if let Some(p) = self.current().take() {
            p.finish_and_clear();
        }
    }

    fn notice(&self, text: &str) {
        if !self.quiet {
            eprintln!("{text}");
        }
    }
}

/// A duration as "1 h 02 min", "3 min 05 s" or "42 s".
fn duration(secs: f64) -> String {
    let s = secs.round() as u64;
    match s {
        0..60 => format!("{s} s"),
        60..3600 => format!("{} min {:02} s", s / 60, s % 60),
        _ => format!("{} h {:02} min", s / 3600, (s % 3600) / 60),
    }
}

#[cfg(test)]
mod tests {
    use super::duration;

    #[test]
    fn durations_read_as_text() {
        assert_eq!(duration(42.4), "42 s");
        assert_eq!(duration(185.0), "3 min 05 s");
        assert_eq!(duration(3720.0), "1 h 02 min");
    }
}
