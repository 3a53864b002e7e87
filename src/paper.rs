//! `mmq paper`: the paper's report (`mmq_report::paper`) from the command line's flags,
//! with progress bars.

use std::sync::atomic::{AtomicBool, Ordering};

use mmq_lab::config::EnvKind;
use mmq_lab::study::Budget;
use mmq_lab::sweep::Shard;
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
        budget: Budget { quick: a.quick, steps: a.steps, seeds: a.seeds, seed: a.seed },
        out: a.out.clone(),
        specs: a.specs,
        shard: a.shard.as_deref().map(Shard::parse).transpose()?,
        merge: a.merge,
    };
    mmq_report::paper::paper(&req, stop, &progress::Bars::new(a.quiet))?;
    if stop.load(Ordering::SeqCst) {
        eprintln!("interrupted: the report covers the seeds that finished; the same command again resumes");
    }
    Ok(())
}
