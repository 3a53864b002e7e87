//! The one error type of mmq-log; every variant names the file concerned.

use std::path::PathBuf;

/// What went wrong writing, reading or drawing a log.
#[derive(Debug, thiserror::Error)]
pub enum LogError {
    /// The file system refused.
    #[error("{}: cannot {action}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What was being done ("create the log", "read the log", ...).
        action: &'static str,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The MCAP library refused.
    #[error("{}: cannot {action}: {source}", path.display())]
    Mcap {
        /// The file.
        path: PathBuf,
        /// What was being done.
        action: &'static str,
        /// The cause.
        #[source]
        source: mcap::McapError,
    },
    /// The file does not start with the MCAP magic bytes.
    #[error("{}: not an MCAP file (it does not start with the MCAP magic bytes)", path.display())]
    NotMcap {
        /// The file.
        path: PathBuf,
    },
    /// The log holds no usable world file (needed to draw the arena).
    #[error("{}: {message}", path.display())]
    NoWorld {
        /// The log file.
        path: PathBuf,
        /// Why (missing attachment, or the world error).
        message: String,
    },
}
