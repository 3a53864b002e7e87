//! `mmq replay FILE`: summary, rendering and bit-for-bit verification of a recorded run
//! (`mmq_report::replay`), or serving it to the Foxglove app (`--serve`,
//! `mmq_report::live`).

use std::sync::atomic::{AtomicBool, Ordering};

use mmq_report::replay::Replay;

use crate::Failure;
use crate::cli::ReplayArgs;
use crate::progress::Bars;

/// Runs `mmq replay`.
pub fn replay(a: ReplayArgs, stop: &AtomicBool) -> Result<(), Failure> {
    let bars = Bars::new(false);
    if let Some(addr) = &a.serve {
        // Ctrl-C is how serving ends: a success, not an interruption.
        if mmq_report::live::serve(&a.file, addr, a.paused, stop, &bars)? {
            stop.store(false, Ordering::SeqCst);
        }
        return Ok(());
    }
    let what =
        Replay { summary: a.summary, render: a.render.as_deref(), from: a.from, to: a.to, verify: a.verify };
    Ok(mmq_report::replay::replay(&a.file, &what, &mut std::io::stdout(), stop, &bars)?)
}
