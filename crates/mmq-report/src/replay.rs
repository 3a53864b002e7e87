//! A recorded run for a front end ([`replay`]): its summary, a drawing to an SVG and a
//! PNG over a window of decision steps, or a bit-for-bit check by re-running it. Bad
//! options name their fields (`from`, `to`, `render`).

use std::io::Write;
use std::path::Path;
use std::sync::atomic::AtomicBool;

use mmq_lab::record::{Verdict, read_recording, verify_in_temp_dir};
use mmq_log::LogContents;

use crate::{Progress, ReportError};

/// What to do with a recording (the options of `mmq replay`).
#[derive(Debug, Clone, Copy, Default)]
pub struct Replay<'a> {
    /// Say the summary (also when nothing else is asked).
    pub summary: bool,
    /// Draw to this SVG file and a PNG next to it.
    pub render: Option<&'a Path>,
    /// The first decision step to draw.
    pub from: Option<u64>,
    /// The last decision step to draw.
    pub to: Option<u64>,
    /// Re-run the simulation from the file's metadata and check it matches bit for bit.
    pub verify: bool,
}

/// Reads the recording `file` and does what `what` asks, writing the summary, the files
/// drawn and the verdict to `out`; a reader of `out` that went away (`| head`) ends the
/// output quietly. Without the summary, a warning says where reading stopped early. A
/// re-run that differs is an error after the rest was written.
pub fn replay(
    file: &Path,
    what: &Replay<'_>,
    out: &mut dyn Write,
    stop: &AtomicBool,
    progress: &dyn Progress,
) -> Result<(), ReportError> {
    let log = read_recording(file)?;
    let summary = what.summary || (what.render.is_none() && !what.verify);
    // The summary says where reading stopped; otherwise one warning says it.
    if let Some(stopped) = log.stop.as_ref().filter(|_| !summary) {
        progress.notice(&crate::terminal::read_stopped(file, stopped));
    }
    if summary {
        write(out, &mmq_log::summary(&log).to_string())?;
    }
    if let Some(svg) = what.render {
        write(out, &render(&log, svg, what.from, what.to)?)?;
    }
    if what.verify {
        write(out, &verify(&log, stop, progress)?)?;
    }
    Ok(())
}

/// Writes `text` to `out`; a reader that went away is not an error.
fn write(out: &mut dyn Write, text: &str) -> Result<(), ReportError> {
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(ReportError::Output(e)),
        _ => Ok(()),
    }
}

/// The window of decision steps `from`..=`to` (either end open when not given); `None`
/// for the whole run. An empty window is bad input.
fn window(from: Option<u64>, to: Option<u64>) -> Result<Option<(u64, u64)>, ReportError> {
    let window = match (from, to) {
        (None, None) => None,
        (f, t) => Some((f.unwrap_or(0), t.unwrap_or(u64::MAX))),
    };
    match window {
        Some((from, to)) if from >= to => Err(ReportError::InvalidOption(format!(
            "`from` {from} `to` {to}: the window is empty; give `from` below `to` (decision steps)"
        ))),
        w => Ok(w),
    }
}

/// Draws `log` (the decision steps `from` to `to`) to the SVG `out` and a PNG next to it;
/// the line saying what it wrote. A path that does not end in `.svg` is bad input.
fn render(log: &LogContents, out: &Path, from: Option<u64>, to: Option<u64>) -> Result<String, ReportError> {
    let window = window(from, to)?;
    if out.extension().is_none_or(|e| e != "svg") {
        return Err(ReportError::InvalidOption(format!(
            "`render` {}: give the SVG's path, e.g. `render` {}; a PNG of the same name is written next to it",
            out.display(),
            out.with_extension("svg").display()
        )));
    }
    let [svg, png] = mmq_log::render(log, out, window)?;
    Ok(format!("wrote {} and {}\n", svg.display(), png.display()))
}

/// Re-runs the simulation `log` describes and compares: the verdict's line on a match,
/// nothing when `stop` cut the re-run short (a notice says so), an error on a difference.
fn verify(log: &LogContents, stop: &AtomicBool, progress: &dyn Progress) -> Result<String, ReportError> {
    let v = verify_in_temp_dir(log, stop)?;
    match crate::terminal::verdict(&v) {
        (text, _) if matches!(v, Verdict::Interrupted { .. }) => {
            progress.notice(&text);
            Ok(String::new())
        }
        (text, true) => Ok(format!("{text}\n")),
        (text, false) => Err(ReportError::Differs(text)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_window_is_open_at_an_end_not_given_and_never_empty() {
        assert_eq!(window(None, None).unwrap(), None);
        assert_eq!(window(Some(5), None).unwrap(), Some((5, u64::MAX)));
        assert_eq!(window(None, Some(9)).unwrap(), Some((0, 9)));
        let e = window(Some(9), Some(9)).unwrap_err();
        assert!(e.is_input_error() && e.names_fields(), "{e}");
        assert!(e.to_string().starts_with("`from` 9 `to` 9: the window is empty"), "{e}");
    }

    /// A writer that fails with `kind`.
    struct Failing(std::io::ErrorKind);

    impl Write for Failing {
        fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
            Err(self.0.into())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn a_reader_that_went_away_is_not_an_error_but_a_full_disk_is() {
        assert!(write(&mut Failing(std::io::ErrorKind::BrokenPipe), "x").is_ok());
        let e = write(&mut Failing(std::io::ErrorKind::StorageFull), "x").unwrap_err();
        assert!(!e.is_input_error() && matches!(e, ReportError::Output(_)));
        let mut v = Vec::new();
        write(&mut v, "text\n").unwrap();
        assert_eq!(v, b"text\n");
    }
}
