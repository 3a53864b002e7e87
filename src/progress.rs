//! Progress of long work, fed by the lab's progress callback: a bar (indicatif) on a
//! terminal; plain lines every few seconds when stderr is a file or a pipe (a batch job's
//! log), with steps done of the total, the rate in steps/s and the time left; nothing with
//! `-q`.

use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};
use mmq_report::terminal::LineProgress;

/// Seconds between two plain progress lines.
const LINE_EVERY: Duration = Duration::from_secs(5);

/// Progress over a number of decision steps.
#[derive(Debug)]
pub struct Progress {
    mode: Mode,
}

#[derive(Debug)]
enum Mode {
    Hidden,
    Bar(ProgressBar),
    Lines(LineProgress),
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
        Mode::Lines(LineProgress::new(label, total, LINE_EVERY))
    };
    Progress { mode }
}

impl Progress {
    /// `n` more steps done.
    pub fn inc(&self, n: u64) {
        match &self.mode {
            Mode::Hidden => {}
            Mode::Bar(pb) => pb.inc(n),
            Mode::Lines(p) => {
                if let Some(line) = p.inc(n) {
                    eprintln!("{line}");
                }
            }
        }
    }

    /// Sets the total (when it is known only after planning).
    pub fn set_length(&self, total: u64) {
        match &self.mode {
            Mode::Hidden => {}
            Mode::Bar(pb) => pb.set_length(total),
            Mode::Lines(p) => p.set_length(total),
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
            Mode::Lines(p) => eprintln!("{}", p.finish()),
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
