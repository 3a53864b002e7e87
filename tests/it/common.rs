//! Helpers shared by the end-to-end tests: the repository root, running the `mmq` binary,
//! its output as text.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The repository root (the `mmq` package's directory).
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Runs `mmq ARGS` in the repository root, with `RUST_BACKTRACE=1` so that a panic shows.
pub fn mmq(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mmq"))
        .args(args)
        .current_dir(root())
        .env("RUST_BACKTRACE", "1")
        .output()
        .expect("the mmq binary runs")
}

/// Runs `mmq ARGS` in `dir` (to check that nothing depends on the repository root).
pub fn mmq_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mmq"))
        .args(args)
        .current_dir(dir)
        .env("RUST_BACKTRACE", "1")
        .output()
        .expect("the mmq binary runs")
}

/// (stdout, stderr) as text.
pub fn text(o: &Output) -> (String, String) {
    (String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned())
}

/// A JSON file, or a panic naming it.
pub fn read_json(p: &Path) -> serde_json::Value {
    let s = std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    serde_json::from_str(&s).unwrap_or_else(|e| panic!("{}: {e}: {s}", p.display()))
}

/// The expected message of a bad-input corpus file: its first line, `# expect: TEXT`.
pub fn expectation(p: &Path) -> String {
    let src = std::fs::read_to_string(p).unwrap();
    let first = src.lines().next().unwrap_or_default();
    assert!(first.starts_with("# expect:"), "{}: first line must be `# expect: ...`", p.display());
    first.trim_start_matches("# expect:").trim().to_string()
}
