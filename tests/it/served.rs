//! `mmq replay` end to end on hostile inputs and outputs: `--serve` on every MCAP
//! regression file, a FIFO, `/dev/zero` and a folder exits 3 at once with one line;
//! a served file stops at the first SIGTERM and warns when it listens on every
//! interface; `--verify` of a file with a damaged chunk in the middle exits 3 saying so;
//! a closed stdout (`| head`) ends the output quietly; `--live-wait` gives up after its
//! timeout.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

use crate::common::{mmq, root, text};

/// Asserts exit 3 with one line naming `path` and no panic.
fn refused(args: &[&str], path: &Path, says: &str) {
    let o = mmq(args);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(3), "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
    assert!(err.contains(&path.display().to_string()) && err.contains(says), "{args:?}: {err}");
}

#[test]
fn serving_a_regression_file_a_fifo_a_device_or_a_folder_exits_3() {
    let dir = root().join("tests/regressions/mcap_read");
    let mut files: Vec<PathBuf> =
        std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).filter(|p| p.is_file()).collect();
    files.sort();
    assert!(!files.is_empty());
    for f in &files {
        refused(&["replay", f.to_str().unwrap(), "--serve", "127.0.0.1:0"], f, "");
    }
    let tmp = tempfile::tempdir().unwrap();
    let fifo = tmp.path().join("pipe.mcap");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    for (p, says) in [
        (fifo.as_path(), "not a regular file"),
        (Path::new("/dev/zero"), "not a regular file"),
        (tmp.path(), "a folder"),
    ] {
        refused(&["replay", p.to_str().unwrap(), "--serve", "127.0.0.1:0"], p, says);
        refused(&["replay", p.to_str().unwrap()], p, says);
    }
}

/// A recording of `steps` grid steps in `dir`.
fn recording(dir: &Path, steps: &str) -> PathBuf {
    let o = mmq(&["run", "-q", "--steps", steps, "--seed", "2", "--record", "--out", dir.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o).1);
    dir.join("trajectory-seed2.mcap")
}

#[test]
fn a_served_file_stops_at_the_first_sigterm_and_warns_on_every_interface() {
    let tmp = tempfile::tempdir().unwrap();
    let file = recording(tmp.path(), "2000");
    let mut child = Command::new(env!("CARGO_BIN_EXE_mmq"))
        .args(["replay", file.to_str().unwrap(), "--serve", "0.0.0.0:0"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = BufReader::new(child.stderr.take().unwrap());
    let mut seen = String::new();
    while !seen.contains("serving ") {
        let mut line = String::new();
        assert!(err.read_line(&mut line).unwrap() > 0, "no serving line: {seen}");
        seen.push_str(&line);
    }
    assert!(
        seen.contains("warning: listening on 0.0.0.0:") && seen.contains("control its playback"),
        "{seen}"
    );
    let pid = child.id().to_string();
    assert!(Command::new("kill").args(["-TERM", &pid]).status().unwrap().success());
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || tx.send(child.wait().unwrap()).unwrap());
    let status = rx.recv_timeout(Duration::from_secs(30)).expect("still serving after SIGTERM");
    assert_eq!(status.code(), Some(0), "serving ends with Ctrl-C or SIGTERM: a success");
}

/// Top-level records of an MCAP file: (offset, opcode, body length).
fn records(bytes: &[u8]) -> Vec<(usize, u8, usize)> {
    let mut at = 8;
    let mut out = Vec::new();
    while at + 9 <= bytes.len() && bytes[at] != 0x02 {
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
        out.push((at, bytes[at], len));
        at += 9 + len;
    }
    out
}

#[test]
fn verifying_a_file_with_a_damaged_middle_chunk_exits_3() {
    let tmp = tempfile::tempdir().unwrap();
    // Flushed every 10,000 steps: three chunks at least.
    let file = recording(tmp.path(), "30000");
    let mut bytes = std::fs::read(&file).unwrap();
    let chunks: Vec<_> = records(&bytes).into_iter().filter(|r| r.1 == 0x06).collect();
    assert!(chunks.len() >= 3, "{} chunks", chunks.len());
    let (at, _, len) = chunks[chunks.len() / 2];
    bytes[at + 9 + len - len / 3] ^= 0x5A;
    std::fs::write(&file, &bytes).unwrap();
    let o = mmq(&["replay", file.to_str().unwrap(), "--verify"]);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(err.contains("damaged") && err.contains(&format!("the chunk at byte {at}")), "{err}");
    // The summary says so too.
    let o = mmq(&["replay", file.to_str().unwrap()]);
    assert!(text(&o).0.contains("DAMAGED"), "{}", text(&o).0);
}

#[test]
fn a_closed_stdout_ends_the_output_quietly() {
    let tmp = tempfile::tempdir().unwrap();
    let file = recording(tmp.path(), "500");
    for _ in 0..4 {
        let mut child = Command::new(env!("CARGO_BIN_EXE_mmq"))
            .args(["replay", file.to_str().unwrap()])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // As `| head -0`: the reader goes away before the summary is written.
        drop(child.stdout.take());
        let o = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(0), "{err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn live_wait_gives_up_after_its_timeout() {
    let tmp = tempfile::tempdir().unwrap();
    let o = mmq(&[
        "run",
        "-q",
        "--steps",
        "100",
        "--out",
        tmp.path().to_str().unwrap(),
        "--live",
        "127.0.0.1:0",
        "--live-wait",
        "0.3",
    ]);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(
        err.contains("waiting for a viewer") && err.contains("no viewer connected within --live-wait"),
        "{err}"
    );
    let o = mmq(&["run", "-q", "--steps", "100", "--live-wait", "0.3"]);
    assert_eq!(o.status.code(), Some(2), "--live-wait needs --live: {}", text(&o).1);
    let out = tmp.path().join("zero");
    let o = mmq(&[
        "run",
        "-q",
        "--steps",
        "100",
        "--out",
        out.to_str().unwrap(),
        "--live",
        "0",
        "--live-wait",
        "0",
    ]);
    assert_eq!(o.status.code(), Some(3), "{}", text(&o).1);
}
