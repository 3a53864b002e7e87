//! Damaged files: a log cut at any byte reads back as a prefix of the full log and says
//! where reading stopped; a corrupted byte loses at most its chunk (named as a problem)
//! or stops the reading there; nothing panics.

use mmq_core::seed::splitmix64;
use mmq_log::{LogContents, McapRecorder, RecorderConfig, read_log};

use crate::common::{self, record_grid};

fn assert_prefix(part: &LogContents, full: &LogContents, what: &str) {
    fn prefix<T: PartialEq + std::fmt::Debug>(a: &[T], b: &[T], what: &str, topic: &str) {
        assert!(a.len() <= b.len(), "{what}: {topic} has more messages than the full log");
        assert_eq!(a, &b[..a.len()], "{what}: {topic} is not a prefix");
    }
    prefix(&part.decisions, &full.decisions, what, "decisions");
    prefix(&part.emitted, &full.emitted, what, "emitted");
    prefix(&part.delivered, &full.delivered, what, "delivered");
    prefix(&part.poses, &full.poses, what, "poses");
    prefix(&part.teleports, &full.teleports, what, "teleports");
    assert!(part.messages <= full.messages);
}

#[test]
fn cut_files_recover_a_prefix_and_say_where_they_stopped() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("full.mcap");
    // Frequent flushes make many small chunks, so cuts land in all kinds of places.
    record_grid(&path, |c| c.flush_every_steps = 100, 2000, 4);
    let bytes = std::fs::read(&path).unwrap();
    let full = read_log(&path).unwrap();
    assert!(full.complete);
    let len = bytes.len();
    let mut cuts: Vec<usize> =
        vec![0, 1, 5, 8, 9, 16, 40, 100, 300, 1000, len / 4, len / 3, len / 2, len - 1];
    cuts.extend([len - 8, len - 9, len - 30, len - 200]);
    cuts.extend((0..40).map(|i| (splitmix64(i) % len as u64) as usize));
    cuts.sort_unstable();
    let mut last_messages = 0;
    let cut_path = dir.path().join("cut.mcap");
    for &cut in &cuts {
        std::fs::write(&cut_path, &bytes[..cut]).unwrap();
        let part = read_log(&cut_path).unwrap_or_else(|e| panic!("cut at {cut}: {e}"));
        let what = format!("cut at {cut} of {len}");
        assert!(!part.complete, "{what}");
        let stop = part.stop.as_ref().unwrap_or_else(|| panic!("{what}: no stop reported"));
        assert!(stop.offset <= cut as u64, "{what}: {stop}");
        assert_eq!(stop.file_len, cut as u64);
        assert_eq!(stop.messages, part.messages);
        assert!(!stop.reason.is_empty());
        assert_prefix(&part, &full, &what);
        assert!(part.messages >= last_messages, "{what}: fewer messages than a shorter cut");
        last_messages = part.messages;
        // The run's facts and world are written first and survive any cut past them.
        if part.messages > 0 {
            assert_eq!(part.run_fact("seed"), Some("4"), "{what}");
            assert!(part.world().is_ok(), "{what}");
        }
    }
    // Cuts in the summary section lose no message.
    std::fs::write(&cut_path, &bytes[..len - 30]).unwrap();
    assert_eq!(read_log(&cut_path).unwrap().messages, full.messages);
    // Half the file holds a good part of the run (flushed every 100 steps).
    std::fs::write(&cut_path, &bytes[..len / 2]).unwrap();
    assert!(read_log(&cut_path).unwrap().decisions.len() > 500);
}

#[test]
fn corrupted_bytes_are_noticed_without_panicking() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("full.mcap");
    record_grid(&path, |c| c.flush_every_steps = 100, 1500, 8);
    let bytes = std::fs::read(&path).unwrap();
    let full = read_log(&path).unwrap();
    let bad_path = dir.path().join("bad.mcap");
    let mut stopped = 0;
    for i in 0..60u64 {
        let at = 8 + (splitmix64(i + 100) % (bytes.len() as u64 - 8)) as usize;
        let mut bad = bytes.clone();
        bad[at] ^= 0x5A;
        std::fs::write(&bad_path, &bad).unwrap();
        let part = read_log(&bad_path).unwrap_or_else(|e| panic!("flip at {at}: {e}"));
        // A flipped byte in an index or the summary touches no message (the reader does not
        // need them); in a chunk's contents it loses that chunk, named as a problem, and
        // reading goes on; anywhere else it stops the reading, after a prefix of the run.
        if part.stop.is_some() {
            stopped += 1;
            assert_prefix(&part, &full, &format!("flip at {at}"));
        } else if !part.problems.is_empty() {
            stopped += 1;
            assert!(!part.complete && part.messages < full.messages, "flip at {at}: {:?}", part.problems);
            assert!(part.problems[0].contains("cannot be read"), "flip at {at}: {:?}", part.problems);
            // What was read is the full log less some decisions, in order.
            let mut rest = full.decisions.iter();
            assert!(part.decisions.iter().all(|d| rest.any(|f| f == d)), "flip at {at}");
        } else {
            mmq_log::compare(&full, &part).unwrap_or_else(|m| panic!("flip at {at} went unnoticed: {m}"));
            assert_eq!(part.messages, full.messages);
        }
    }
    assert!(stopped > 10, "only {stopped} of 60 corruptions were noticed");
}

#[test]
fn a_killed_run_leaves_the_steps_before_the_last_flush() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("live.mcap");
    let world = common::world("paper-9x9");
    let mut cfg = RecorderConfig::new(&path);
    cfg.flush_every_steps = 250;
    cfg.flush_interval = None;
    let mut rec = McapRecorder::create(cfg).unwrap();
    // Copy the file while the recorder is still open, as if the process died there.
    struct Snapshot<'a> {
        rec: &'a mut McapRecorder,
        at: u64,
        copy: std::path::PathBuf,
    }
    impl mmq_core::Observer for Snapshot<'_> {
        fn on_start(&mut self, i: &mmq_core::RunInfo<'_>, s: usize, t: f64) {
            self.rec.on_start(i, s, t)
        }
        fn on_step(&mut self, r: &mmq_core::StepRecord<'_>) {
            self.rec.on_step(r);
            if r.t + 1 == self.at {
                std::fs::copy(self.rec.path(), &self.copy).unwrap();
            }
        }
        fn on_finish(&mut self, t: u64, complete: bool) {
            self.rec.on_finish(t, complete)
        }
    }
    let copy = dir.path().join("killed.mcap");
    common::run_grid(&world, &mut Snapshot { rec: &mut rec, at: 1100, copy: copy.clone() }, 2000, 2, 0);
    let part = read_log(&copy).unwrap();
    let stop = part.stop.as_ref().expect("an unfinished file");
    assert!(stop.reason.contains("not finished") || stop.reason.contains("truncated"), "{stop}");
    // Flushed at 1000 steps; whatever of the open chunk the buffer let out is not readable.
    assert_eq!(part.decisions.len(), 1000);
    assert_eq!(part.decisions.last().unwrap().msg.t, 999);
}
