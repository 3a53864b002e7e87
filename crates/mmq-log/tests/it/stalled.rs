//! Viewers that subscribe and never read: the live view drops rather than buffers for
//! them (the SDK's per-client queue of `LiveConfig::backlog` messages, oldest dropped; a
//! client whose control queue fills is disconnected with a status saying why), the run
//! is not held by them, and stopping the server does not wait for them.

use std::sync::mpsc;
use std::time::Duration;

use mmq_log::live::{LiveConfig, LiveServer};
use mmq_log::messages::CHANNELS;
use mmq_log::{McapRecorder, RecorderConfig};

use crate::common;
use crate::live::{Client, In, local};

/// Waits for `f` on a thread of its own, at most `secs` (a hang fails the test instead
/// of stalling it).
fn within<T: Send + 'static>(secs: u64, what: &str, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(Duration::from_secs(secs))
        .unwrap_or_else(|_| panic!("{what}: still waiting after {secs} s"))
}

/// An open 200×200 world: its heat maps are some 200 kB of JSON each.
fn open_world(n: usize) -> mmq_core::World {
    let mut map = String::new();
    for r in 0..n {
        let row: String = (0..n)
            .map(|c| match (r, c) {
                (0, 0) => 'G',
                _ if r == n - 1 && c == n - 1 => 'S',
                _ => '.',
            })
            .collect();
        map.push_str(&row);
        map.push('\n');
    }
    mmq_core::World::parse(&format!("map = \"\"\"\n{map}\"\"\"\n"), "open.toml").unwrap()
}

#[test]
fn clients_that_do_not_read_are_dropped_and_do_not_hold_the_run() {
    // A small queue, so that a stalled client's control queue (time updates, at most 30
    // a second) fills within the run.
    let server = LiveServer::start(&LiveConfig { backlog: 16, ..local(20.0) }).unwrap();
    let addr = server.addr();
    let all: Vec<&str> = CHANNELS.iter().map(|c| c.0).collect();
    let mut stalled: Vec<Client> = (0..5)
        .map(|_| {
            let mut c = Client::connect(addr);
            c.subscribe(&all);
            c
        })
        .collect();
    // 600 steps of 0.1 s at 20×: 3 s of run, heat maps at every step (sent at most 30 a
    // second each: some 12 MB/s per client), with five clients that never read.
    let tap = server.tap();
    within(120, "the run", move || {
        let mut rec = McapRecorder::live_only(RecorderConfig::new(""), tap);
        common::run_grid(&open_world(200), &mut rec, 600, 5, 1);
    });
    // A stalled client that reads at last finds the status that explains the drops, the
    // one that says it was disconnected for not keeping up, then the close.
    let c = &mut stalled[0];
    let (mut told, mut dropped) = (false, false);
    let (closed, _) = c.until(60.0, |m, _| {
        if let In::Json(v) = m
            && v["op"] == "status"
        {
            let text = v["message"].as_str().unwrap_or_default();
            told |= text.contains("at most 16 messages wait for each viewer");
            dropped |= text.contains("backlog") && text.contains("full");
        }
        matches!(m, In::Closed)
    });
    assert!(closed, "the stalled client was not closed");
    assert!(told, "the client was not told how messages are dropped");
    assert!(dropped, "no status saying the client was dropped for not reading");
    // The server stops at once, whatever the four others do.
    within(30, "stopping the server", move || server.stop());
}
