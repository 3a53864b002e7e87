//! Progress of long work, fed by the libraries' callbacks: a bar (indicatif) on a
//! terminal; plain lines every few seconds when stderr is a file or a pipe (a batch job's
//! log), with steps done of the total, the rate in steps/s and the time left; with `-q`,
//! only notices.

use std::io::IsTerminal;
use std::sync::{PoisonError, RwLock};
use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};
use mmq_report::terminal::LineProgress;

/// Seconds between two plain progress lines.
const LINE_EVERY: Duration = Duration::from_secs(5);

/// How the current piece of work shows its progress.
#[derive(Debug)]
enum Mode {
    Bar(ProgressBar),
    Lines(LineProgress),
}

/// The libraries' `mmq_report::Progress`: one bar (or plain lines) per piece of work,
/// notices (such as files of an earlier output being replaced) and lines of detail on
/// stderr, the commands' output on stdout; with `-q`, notices and errors only.
#[derive(Debug)]
pub struct Bars {
    quiet: bool,
    current: RwLock<Option<Mode>>,
}

impl Bars {
    /// Bars shown unless `quiet`.
    pub fn new(quiet: bool) -> Self {
        Bars { quiet, current: RwLock::new(None) }
    }
}

impl mmq_report::Progress for Bars {
    /// A bar on a terminal, plain lines otherwise, nothing when quiet.
    fn begin(&self, total: u64, label: &str) {
        let mode = if self.quiet {
            None
        } else if std::io::stderr().is_terminal() {
            let style = ProgressStyle::with_template(
                "{msg:>12} [{elapsed_precise}] {wide_bar} {percent:>3}% {per_sec:.1} steps/s eta {eta}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar());
            Some(Mode::Bar(ProgressBar::new(total).with_style(style).with_message(label.to_string())))
        } else {
            Some(Mode::Lines(LineProgress::new(label, total, LINE_EVERY)))
        };
        *self.current.write().unwrap_or_else(PoisonError::into_inner) = mode;
    }

    fn advance(&self, n: u64) {
        match self.current.read().unwrap_or_else(PoisonError::into_inner).as_ref() {
            Some(Mode::Bar(pb)) => pb.inc(n),
            Some(Mode::Lines(p)) => {
                if let Some(line) = p.inc(n) {
                    eprintln!("{line}");
                }
            }
            None => {}
        }
    }

    /// Removes the bar; in plain-line mode, says how much was done and how fast.
    fn end(&self) {
        match self.current.write().unwrap_or_else(PoisonError::into_inner).take() {
            Some(Mode::Bar(pb)) => pb.finish_and_clear(),
            Some(Mode::Lines(p)) => eprintln!("{}", p.finish()),
            None => {}
        }
    }

    /// A line on stderr, with the bar out of the way; shown also when quiet.
    fn notice(&self, text: &str) {
        match self.current.read().unwrap_or_else(PoisonError::into_inner).as_ref() {
            Some(Mode::Bar(pb)) => pb.suspend(|| eprintln!("{text}")),
            _ => eprintln!("{text}"),
        }
    }

    /// A notice, except when quiet.
    fn line(&self, text: &str) {
        if !self.quiet {
            self.notice(text);
        }
    }

    /// On stdout.
    fn say(&self, text: &str) {
        print!("{text}");
    }
}
