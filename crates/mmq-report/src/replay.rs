//! A recorded run for a front end: drawn to an SVG and a PNG over a window of decision
//! steps ([`render`]), or re-run and checked bit for bit ([`verify`]). Bad options name
//! their fields (`from`, `to`, `render`).

use std::path::Path;
use std::sync::atomic::AtomicBool;

use mmq_lab::record::{Verdict, verify_in_temp_dir};
use mmq_log::LogContents;

use crate::{Progress, ReportError};

/// The window of decision steps `from`..=`to` (either end open when not given); `None`
/// for the whole run. An empty window is bad input.
fn window(from: Option<u64>, to: Option<u64>) -> Result<Option<(u64, u64)>, ReportError> {
    let window = match (from, to) {
        (None, None) => None,
        (f, t) => Some((f.unwrap_or(0), t.unwrap_or(u64::MAX))),
    };
    match window {
        Some((from, to)) if from >= to => Err(ReportError::Option(format!(
            "`from` {from} `to` {to}: the window is empty; give `from` below `to` (decision steps)"
        ))),
        w => Ok(w),
    }
}

/// Draws `log` (the decision steps `from` to `to`) to the SVG `out` and a PNG next to it;
/// the line saying what it wrote. A path that does not end in `.svg` is bad input.
pub fn render(
    log: &LogContents,
    out: &Path,
    from: Option<u64>,
    to: Option<u64>,
) -> Result<String, ReportError> {
    let window = window(from, to)?;
    if out.extension().is_none_or(|e| e != "svg") {
        return Err(ReportError::Option(format!(
            "`render` {}: give the SVG's path, e.g. `render` {}; a PNG of the same name is written next to it",
            out.display(),
            out.with_extension("svg").display()
        )));
    }
    let [svg, png] = mmq_log::render(log, out, window)?;
    Ok(format!("wrote {} and {}\n", svg.display(), png.display()))
}

/// Re-runs the simulation `log` describes and compares: the verdict's line on a match,
/// `None` when `stop` cut the re-run short (a notice says so), an error on a difference.
pub fn verify(
    log: &LogContents,
    stop: &AtomicBool,
    progress: &dyn Progress,
) -> Result<Option<String>, ReportError> {
    let v = verify_in_temp_dir(log, stop)?;
    match crate::terminal::verdict(&v) {
        (text, _) if matches!(v, Verdict::Interrupted { .. }) => {
            progress.notice(&text);
            Ok(None)
        }
        (text, true) => Ok(Some(format!("{text}\n"))),
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
}
