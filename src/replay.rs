//! `mmq replay FILE`: summary, rendering and bit-for-bit verification of a recorded run,
//! or serving it to the Foxglove app (`--serve`).

use std::sync::atomic::{AtomicBool, Ordering};

use mmq_lab::record::{Verdict, verify};

use crate::Failure;
use crate::cli::ReplayArgs;

/// Runs `mmq replay`.
pub fn replay(a: ReplayArgs, stop: &AtomicBool) -> Result<(), Failure> {
    if let Some(addr) = &a.serve {
        crate::live::serve(&a.file, addr, stop)?;
        // Ctrl-C is how serving ends: a success, not an interruption.
        stop.store(false, Ordering::SeqCst);
        return Ok(());
    }
    let log = mmq_log::read_log(&a.file).map_err(crate::input_error)?;
    if !log.metadata.contains_key("run") && !log.topics.contains_key(mmq_log::messages::topics::DECISION) {
        return Err(crate::input_error(format!(
            "{}: an MCAP file, but not a recording of this program (no `run` metadata, no {} topic); \
             `mmq replay` reads the files of `mmq run --record`",
            a.file.display(),
            mmq_log::messages::topics::DECISION
        )));
    }
    if let Some(stop) = &log.stop {
        eprintln!(
            "warning: {}: read stopped at byte {} of {} ({}); recovered {} messages",
            a.file.display(),
            stop.offset,
            stop.file_len,
            stop.reason,
            stop.messages
        );
    }
    if a.summary || (a.render.is_none() && !a.verify) {
        print!("{}", mmq_log::summary(&log));
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
                "--render {}: only .svg output is supported",
                out.display()
            )));
        }
        mmq_log::render(&log, out, window)?;
        println!("wrote {}", out.display());
    }
    if a.verify {
        let scratch = tempdir()?;
        let verdict = verify(&log, &scratch);
        let _ = std::fs::remove_dir_all(&scratch);
        match verdict? {
            Verdict::Identical { decisions, poses } => {
                println!(
                    "verify: OK: the re-run matches the log bit for bit ({decisions} decisions, {poses} poses)"
                );
            }
            Verdict::Differs(m) => {
                return Err(Failure { code: crate::exit::RUNTIME, error: anyhow::anyhow!("verify: {m}") });
            }
        }
    }
    Ok(())
}

fn tempdir() -> Result<std::path::PathBuf, Failure> {
    let d = std::env::temp_dir().join(format!("mmq-verify-{}", std::process::id()));
    std::fs::create_dir_all(&d)?;
    Ok(d)
}
