//! `mmq sweep`: run a spec's product of parameters over seeds (resumable, shardable),
//! merge shard outputs, and report them (`mmq_report::sweep_run` and
//! `mmq_report::sweep`).

use std::io::Write as _;
use std::sync::atomic::AtomicBool;

use mmq_report::sweep_run;

use crate::Failure;
use crate::cli::{SweepAction, SweepArgs};
use crate::progress::Bars;

/// Runs `mmq sweep`.
pub fn sweep(a: SweepArgs, stop: &AtomicBool) -> Result<(), Failure> {
    // Quiet or not, a report and a merge say the same.
    let bars = Bars::new(a.quiet);
    match a.action {
        Some(SweepAction::Report { dirs, out }) => {
            return Ok(sweep_run::report(&dirs, out.as_deref(), &bars)?);
        }
        Some(SweepAction::Merge { dirs, out }) => return Ok(sweep_run::merge(&dirs, &out, &bars)?),
        None => {}
    }
    let spec =
        a.spec.ok_or_else(|| crate::input_error("give a sweep spec: mmq sweep SPEC.toml --out DIR"))?;
    let out = a.out.ok_or_else(|| crate::input_error("give an output directory: --out DIR"))?;
    if a.dry_run {
        let plan = sweep_run::dry_run(&spec, a.shard.as_deref())?;
        // One write, errors ignored: `mmq sweep ... --dry-run | head` must not panic.
        let _ = std::io::stdout().lock().write_all(plan.as_bytes());
        return Ok(());
    }
    Ok(sweep_run::sweep(&spec, &out, a.shard.as_deref(), stop, &bars)?)
}
