//! `mmq replay FILE`: summary, rendering and bit-for-bit verification of a recorded run,
//! or serving it to the Foxglove app (`--serve`).

use std::sync::atomic::{AtomicBool, Ordering};

use mmq_lab::record::{Verdict, read_recording, verify_in_temp_dir};

use crate::Failure;
use crate::cli::ReplayArgs;

/// Runs `mmq replay`.
pub fn replay(a: ReplayArgs, stop: &AtomicBool) -> Result<(), Failure> {
    if let Some(addr) = &a.serve {
        // Ctrl-C is how serving ends: a success, not an interruption.
        if crate::live::serve(&a.file, addr, a.paused, stop)? {
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
        say(format_args!("{}", mmq_log::summary(&log)))?;
    }
    if let Some(out) = &a.render {
        let window = match (a.from, a.to) {
            (None, None) => None,
            (f, t) => Some((f.unwrap_or(0), t.unwrap_or(u64::MAX))),
        };
        if let Some((from, to)) = window
            && from >= to
        {
            return Err(crate::input_error(format!(
                "--from {from} --to {to}: the window is empty; give --from below --to (decision steps)"
            )));
        }
        if out.extension().is_none_or(|e| e != "svg") {
            return Err(crate::input_error(format!(
                "--render {}: give the SVG's path, e.g. --render {}; a PNG of the same name is written next to it",
                out.display(),
                out.with_extension("svg").display()
            )));
        }
        let [svg, png] = mmq_log::render(&log, out, window)?;
        say(format_args!("wrote {} and {}\n", svg.display(), png.display()))?;
    }
    if a.verify {
        let v = verify_in_temp_dir(&log, stop)?;
        match mmq_report::terminal::verdict(&v) {
            // Exit 130 (the stop flag is up): nothing concluded.
            (text, _) if matches!(v, Verdict::Interrupted { .. }) => eprintln!("{text}"),
            (text, true) => say(format_args!("{text}\n"))?,
            (text, false) => {
                return Err(Failure { code: crate::exit::RUNTIME, error: anyhow::anyhow!("{text}") });
            }
        }
    }
    Ok(())
}

/// Writes to stdout; a reader that went away (`| head`) ends the output quietly.
fn say(text: std::fmt::Arguments<'_>) -> Result<(), Failure> {
    use std::io::Write;
    let mut o = std::io::stdout().lock();
    match o.write_fmt(text).and_then(|()| o.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(Failure::from(e)),
        _ => Ok(()),
    }
}
