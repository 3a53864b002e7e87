//! `mmq replay FILE`: summary, rendering and bit-for-bit verification of a recorded run
//! (`mmq_report::replay`), or serving it to the Foxglove app (`--serve`,
//! `mmq_report::live`).

use std::sync::atomic::{AtomicBool, Ordering};

use mmq_lab::record::read_recording;

use crate::Failure;
use crate::cli::ReplayArgs;
use crate::progress::Bars;

/// Runs `mmq replay`.
pub fn replay(a: ReplayArgs, stop: &AtomicBool) -> Result<(), Failure> {
    if let Some(addr) = &a.serve {
        // Ctrl-C is how serving ends: a success, not an interruption.
        if mmq_report::live::serve(&a.file, addr, a.paused, stop, &Bars::new(false))? {
            stop.store(false, Ordering::SeqCst);
        }
        return Ok(());
    }
    let log = read_recording(&a.file)?;
    let summary = a.summary || (a.render.is_none() && !a.verify);
    // The summary says where reading stopped; otherwise one warning says it.
    if let Some(stop) = log.stop.as_ref().filter(|_| !summary) {
        eprintln!("{}", mmq_report::terminal::read_stopped(&a.file, stop));
    }
    if summary {
        say(&mmq_log::summary(&log).to_string())?;
    }
    if let Some(out) = &a.render {
        say(&mmq_report::replay::render(&log, out, a.from, a.to)?)?;
    }
    if a.verify
        && let Some(line) = mmq_report::replay::verify(&log, stop, &Bars::new(false))?
    {
        say(&line)?;
    }
    Ok(())
}

/// Writes to stdout; a reader that went away (`| head`) ends the output quietly.
fn say(text: &str) -> Result<(), Failure> {
    use std::io::Write;
    let mut o = std::io::stdout().lock();
    match o.write_all(text.as_bytes()).and_then(|()| o.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(Failure::from(e)),
        _ => Ok(()),
    }
}
