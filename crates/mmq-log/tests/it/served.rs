//! The served replay (`mmq replay FILE --serve`) on hostile and damaged files, through the
//! hardened reader: every regression file of `tests/regressions/mcap_read/` is a clear
//! error (no panic, no huge allocation), a FIFO, a device and a folder are refused at
//! once, a damaged chunk in the middle is skipped and named (by the server and by
//! `read_log`), and a file plays by itself from the first subscription unless asked to
//! wait for the app's play command.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use mmq_log::live::replay::{ServeOptions, serve_file};
use mmq_log::messages::topics;
use mmq_log::read_log;

use crate::common;
use crate::live::{Client, In, local};

fn regressions() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/regressions/mcap_read")
}

#[test]
fn every_mcap_regression_file_is_a_clear_error_when_served() {
    let never = AtomicBool::new(false);
    let mut files: Vec<PathBuf> = std::fs::read_dir(regressions())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    assert!(files.len() >= 4, "{files:?}");
    for f in files {
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        match serve_file(&f, &local(1.0), ServeOptions::default(), &never) {
            Ok(_) => assert!(name.starts_with("ok-"), "{name}: served"),
            Err(e) => {
                let text = e.to_string();
                assert!(!name.starts_with("ok-"), "{name}: {text}");
                assert!(text.contains(&name) && text.lines().count() == 1, "{name}: {text}");
            }
        }
    }
}

#[test]
fn a_fifo_a_device_and_a_folder_are_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe.mcap");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    let never = AtomicBool::new(false);
    for (path, says) in [
        (fifo.as_path(), "not a regular file"),
        (Path::new("/dev/zero"), "not a regular file"),
        (dir.path(), "a folder"),
    ] {
        let e = serve_file(path, &local(1.0), ServeOptions::default(), &never).unwrap_err().to_string();
        assert!(e.contains(says) && e.contains(&path.display().to_string()), "{e}");
        let e = read_log(path).unwrap_err().to_string();
        assert!(e.contains(says), "{e}");
    }
}

/// Top-level records of an MCAP file: (offset, opcode, body length).
fn records(bytes: &[u8]) -> Vec<(usize, u8, usize)> {
    let mut at = 8;
    let mut out = Vec::new();
    while at + 9 <= bytes.len() {
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
        out.push((at, bytes[at], len));
        if bytes[at] == 0x02 {
            break; // the footer
        }
        at += 9 + len;
    }
    out
}

#[test]
fn a_damaged_chunk_in_the_middle_is_skipped_and_named() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("g.mcap");
    common::record_grid(&path, |c| c.flush_every_steps = 100, 1500, 3);
    let full = read_log(&path).unwrap();
    assert!(full.complete);
    let mut bytes = std::fs::read(&path).unwrap();
    let chunks: Vec<_> = records(&bytes).into_iter().filter(|r| r.1 == 0x06).collect();
    assert!(chunks.len() >= 10, "{} chunks", chunks.len());
    let (at, _, len) = chunks[chunks.len() / 2];
    // A byte of the compressed records (past the header): the CRC no longer matches.
    bytes[at + 9 + len - len / 3] ^= 0x5A;
    let bad = dir.path().join("bad.mcap");
    std::fs::write(&bad, &bytes).unwrap();
    let log = read_log(&bad).unwrap();
    assert!(log.stop.is_none() && !log.complete, "{:?}", log.stop);
    assert!(log.problems[0].contains(&format!("the chunk at byte {at}")), "{:?}", log.problems);
    // The chunks after it were read: the run's last decision is there, some in between not.
    let (n, m) = (log.decisions.len(), full.decisions.len());
    assert!(n < m && n > m / 2, "{n} of {m}");
    assert_eq!(log.decisions.last(), full.decisions.last());
    assert!(mmq_log::summary(&log).to_string().contains("DAMAGED"));
    // Served: the same chunk is skipped and named.
    let never = AtomicBool::new(false);
    let server = serve_file(&bad, &local(1.0), ServeOptions::default(), &never).unwrap().unwrap();
    assert!(server.warnings().iter().any(|w| w.contains(&format!("byte {at}"))), "{:?}", server.warnings());
    assert_eq!(server.messages() as u64, log.messages);
}

#[test]
fn a_raised_stop_flag_ends_the_indexing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("g.mcap");
    common::record_grid(&path, |_| {}, 200, 3);
    let raised = AtomicBool::new(true);
    assert!(serve_file(&path, &local(1.0), ServeOptions::default(), &raised).unwrap().is_none());
}

/// Plays `path` and returns the first playback state and the decisions seen within a few
/// seconds by a client that only subscribes (as Lichtblick, which sends no playback
/// command).
fn watch(path: &Path, options: ServeOptions) -> (Option<u8>, usize) {
    let never = AtomicBool::new(false);
    let server = serve_file(path, &local(50.0), options, &never).unwrap().unwrap();
    let addr = server.addr();
    let stop = Arc::new(AtomicBool::new(false));
    let player = {
        let stop = stop.clone();
        std::thread::spawn(move || server.run(&stop).unwrap())
    };
    let mut c = Client::connect(addr);
    c.subscribe(&[topics::DECISION, topics::ARENA]);
    let mut state = None;
    let (_, got) = c.until(3.0, |m, _| {
        if let In::Playback { status, .. } = m {
            state.get_or_insert(*status);
        }
        false
    });
    stop.store(true, Ordering::SeqCst);
    player.join().unwrap();
    (state, got.iter().filter(|(t, _, _)| t == topics::DECISION).count())
}

#[test]
fn a_served_file_plays_by_itself_unless_asked_to_wait() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("g.mcap");
    common::record_grid(&path, |_| {}, 3000, 3);
    // 3000 steps of 0.1 s at 50×: 6 s of playback, of which the first 3 s are watched.
    let (state, decisions) = watch(&path, ServeOptions::default());
    assert_eq!(state, Some(0), "the state says playing");
    assert!(decisions > 100, "{decisions} decisions");
    let (state, decisions) = watch(&path, ServeOptions { paused: true });
    assert_eq!((state, decisions), (None, 0), "paused: nothing plays without a command");
}
