//! `mmq`: the command-line interface. The only place that knows clap, anyhow and
//! progress bars; it maps library errors to one-line messages and exit codes ([`exit`];
//! all of them, with examples, in docs/robustness.md).

mod cli;
mod paper;
mod progress;
mod replay;
mod run;
mod suite;
mod sweep;
mod world_cmd;

use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

use clap::Parser;

/// Exit codes besides 0 (success) and 2 (usage error: unknown flag, missing argument; from
/// clap).
pub mod exit {
    /// Runtime failure (I/O, physics).
    pub const RUNTIME: u8 = 1;
    /// Bad input (world file, config, impossible parameter).
    pub const INPUT: u8 = 3;
    /// Interrupted (Ctrl-C / SIGTERM); finished outputs were written, marked partial.
    pub const INTERRUPTED: u8 = 130;
}

/// An error with its exit code.
#[derive(Debug)]
pub struct Failure {
    /// Exit code.
    pub code: u8,
    /// The error.
    pub error: anyhow::Error,
}

impl<E: Into<anyhow::Error>> From<E> for Failure {
    fn from(e: E) -> Self {
        let error: anyhow::Error = e.into();
        let code = if mmq_report::terminal::is_input_error(&*error) { exit::INPUT } else { exit::RUNTIME };
        Failure { code, error }
    }
}

/// Raised by Ctrl-C or SIGTERM: every loop stops at its next check.
static STOP: AtomicBool = AtomicBool::new(false);

/// Bad input: exit code 3.
pub fn input_error(msg: impl std::fmt::Display) -> Failure {
    Failure { code: exit::INPUT, error: anyhow::anyhow!("{msg}") }
}

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    // SIGINT and SIGTERM (the `termination` feature): ask every loop to stop.
    let _ = ctrlc::set_handler(|| {
        if STOP.swap(true, Ordering::SeqCst) {
            // A second Ctrl-C ends at once.
            std::process::exit(i32::from(exit::INTERRUPTED));
        }
    });
    let threads = args.threads.map(mmq_lab::exec::set_threads).transpose();
    let result = threads.map_err(Failure::from).and_then(|_| dispatch(args.command, &STOP));
    match result {
        Ok(()) if STOP.load(Ordering::SeqCst) => ExitCode::from(exit::INTERRUPTED),
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            let text = mmq_report::terminal::one_line(f.error.chain().map(ToString::to_string));
            let named = mmq_report::terminal::names_fields(&*f.error);
            eprintln!("error: {}", if named { mmq_lab::fields::as_flags(&text) } else { text });
            ExitCode::from(f.code)
        }
    }
}

fn dispatch(command: cli::Command, stop: &AtomicBool) -> Result<(), Failure> {
    match command {
        cli::Command::Run(a) => run::run(a, stop),
        cli::Command::World(a) => world_cmd::world(a),
        cli::Command::Paper(a) => paper::paper(a, stop),
        cli::Command::Sweep(a) => sweep::sweep(a, stop),
        cli::Command::Suite(a) => suite::suite(a, stop),
        cli::Command::Replay(a) => replay::replay(a, stop),
        cli::Command::Learners => {
            print!("{}", mmq_report::terminal::learners());
            Ok(())
        }
    }
}
