//! `mmq paper`: the paper's report (`mmq_report::paper`) from the command line's flags,
//! with progress bars and a closing line.

use std::sync::atomic::{AtomicBool, Ordering};

use mmq_lab::config::EnvKind;
use mmq_report::paper::PaperRequest;

use crate::cli::{EnvChoice, PaperArgs};
use crate::{Failure, progress};

/// Runs `mmq paper`.
pub fn paper(a: PaperArgs, stop: &AtomicBool) -> Result<(), Failure> {
    let envs = match a.env {
        EnvChoice::Grid => vec![EnvKind::Grid],
        EnvChoice::Robot => vec![EnvKind::Robot],
        EnvChoice::Both => vec![EnvKind::Grid, EnvKind::Robot],
    };
    // One process writes into the folder at a time.
    let _lock = mmq_lab::lock::lock_out_dir(&a.out)?;
    let req = PaperRequest {
        fig: a.fig,
        envs,
        quick: a.quick,
        seeds: a.seeds,
        steps: a.steps,
        seed: a.seed,
        out: a.out.clone(),
        specs: a.specs,
    };
    let done = mmq_report::paper::paper(&req, stop, &progress::Bars::new(a.quiet))?;
    println!("wrote {} ({} files) in {:.1} s", done.report.display(), done.files, done.wall_s);
    if stop.load(Ordering::SeqCst) {
        eprintln!("interrupted: the report covers what finished");
    }
    Ok(())
}
