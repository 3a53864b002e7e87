//! Progress bars (indicatif) fed by the lab's progress callback.

use indicatif::{ProgressBar, ProgressStyle};

/// A bar over `total` steps, hidden when `quiet` or when stderr is not a terminal.
pub fn bar(total: u64, label: &str, quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(total);
    pb.set_style(
        ProgressStyle::with_template(
            "{msg:>12} [{elapsed_precise}] {wide_bar} {percent:>3}% {per_sec} eta {eta}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    pb.set_message(label.to_string());
    pb
}
