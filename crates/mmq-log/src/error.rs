//! The one error type of mmq-log; every variant names the file or address concerned.

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
    /// The MCAP library refused (for an I/O failure, the operating system's reason).
    #[error("{}: cannot {action}: {}", path.display(), mcap_cause(source))]
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
    /// A log with nothing usable for what was asked (no message to play).
    #[error("{}: {message}", path.display())]
    Unreadable {
        /// The file.
        path: PathBuf,
        /// Why, and what can be done.
        message: String,
    },
    /// A live-view address that is not one.
    #[error("live view address `{addr}`: {reason}")]
    LiveAddress {
        /// The address as given.
        addr: String,
        /// What is wrong and how to write it.
        reason: String,
    },
    /// The live view server could not start (port in use, address not on this machine).
    #[error("live view: cannot listen on {addr}: {message}")]
    LiveServer {
        /// The address.
        addr: std::net::SocketAddr,
        /// The cause, with the fix.
        message: String,
    },
}

/// The reason of an MCAP error: the operating system's own words for an I/O failure
/// ("File too large (os error 27)"), not the library's generic "I/O error".
fn mcap_cause(e: &mcap::McapError) -> String {
    match e {
        mcap::McapError::Io(io) => io.to_string(),
        other => other.to_string(),
    }
}

impl LogError {
    /// Whether the error is the user's input (a bad address) rather than the system.
    pub fn is_input_error(&self) -> bool {
        matches!(self, Self::LiveAddress { .. })
    }
}
