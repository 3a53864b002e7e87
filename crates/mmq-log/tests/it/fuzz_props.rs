//! Property-based fuzzing of the MCAP reader (proptest; seconds in CI): a small real
//! recording, cut at random lengths and with random bytes overwritten, must read back as
//! a readable prefix with the reason reading stopped, or be refused as "not an MCAP file";
//! never a panic, a hang or a huge allocation. Long coverage-guided runs: `fuzz/`
//! (`cargo fuzz run mcap_read`, docs/robustness.md).

use std::path::Path;
use std::sync::OnceLock;

use mmq_core::{DelayDist, DelayedReward, Env, Observer, RunInfo, Start, StepTrace, World};
use mmq_grid::GridEnv;
use mmq_log::{LogContents, McapRecorder, RecorderConfig, read_log};
use proptest::prelude::*;

/// A finished 300-step grid recording, flushed every 50 steps (several chunks).
fn recording() -> &'static (Vec<u8>, LogContents) {
    static REC: OnceLock<(Vec<u8>, LogContents)> = OnceLock::new();
    REC.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("small.mcap");
        let world = World::parse("map = \"\"\"\nG..\n.#.\n..S\n\"\"\"\n", "small.toml").unwrap();
        let mut cfg = RecorderConfig::new(&path);
        cfg.flush_every_steps = 50;
        let mut rec = McapRecorder::create(cfg).unwrap();
        let dist = DelayDist::parse("poisson:3").unwrap();
        let mut ch = DelayedReward::new(GridEnv::new(&world), &dist, true);
        let mut s = ch.reset(1, 2, Start::World).unwrap();
        let names = ch.env().action_names();
        let info = RunInfo {
            world: &world,
            seed: 1,
            learner: "prop",
            action_names: &names,
            config_toml: "",
            env_kind: "grid",
            facts: &[],
            start_pose: None,
        };
        rec.on_start(&info, s, 0.0);
        let trace = StepTrace::default();
        let steps = 300;
        for t in 0..steps {
            let a = (t as usize * 7 + t as usize / 3) % 4;
            let st = ch.step(a).unwrap();
            rec.on_step(&ch.record(s, a, None, false, &st, &trace));
            s = st.step.state;
        }
        rec.on_finish(steps, true);
        drop(rec);
        let bytes = std::fs::read(&path).unwrap();
        let full = read_log(&path).unwrap();
        assert!(full.complete && full.decisions.len() == steps as usize);
        (bytes, full)
    })
}

/// Reads `bytes` from a fresh file and checks what the reader promises.
fn read_back(bytes: &[u8], dir: &Path) -> Option<LogContents> {
    let p = dir.join("case.mcap");
    std::fs::write(&p, bytes).unwrap();
    match read_log(&p) {
        Ok(log) => {
            assert_eq!(log.file_len, bytes.len() as u64);
            // Complete: read to the end, and nothing in it disagrees with its statistics.
            assert_eq!(log.complete, log.stop.is_none() && log.problems.is_empty(), "{:?}", log.problems);
            if let Some(stop) = &log.stop {
                assert!(stop.offset <= stop.file_len, "{stop}");
                assert_eq!(stop.messages, log.messages);
                assert!(!stop.reason.is_empty());
            }
            let _ = mmq_log::summary(&log);
            Some(log)
        }
        Err(e) => {
            let msg = e.to_string();
            assert!(msg.contains("case.mcap"), "the error names the file: {msg}");
            None
        }
    }
}

fn config() -> ProptestConfig {
    ProptestConfig { cases: 200, failure_persistence: None, ..ProptestConfig::default() }
}

proptest! {
    #![proptest_config(config())]

    /// A cut file reads as a prefix of the full one (what was before the cut is kept
    /// whole or dropped chunk by chunk, never altered).
    #[test]
    fn truncated_files_read_a_prefix(frac in 0.0f64..1.0) {
        let (bytes, full) = recording();
        let cut = (frac * bytes.len() as f64) as usize;
        let dir = tempfile::tempdir().unwrap();
        if let Some(log) = read_back(&bytes[..cut], dir.path()) {
            prop_assert!(!log.complete || cut == bytes.len());
            prop_assert!(log.decisions.len() <= full.decisions.len());
            prop_assert_eq!(&log.decisions[..], &full.decisions[..log.decisions.len()]);
            prop_assert_eq!(&log.delivered[..], &full.delivered[..log.delivered.len()]);
        }
    }

    /// Random bytes overwritten anywhere (headers, lengths, CRCs, compressed data):
    /// nothing panics, and a damaged chunk is dropped rather than misread.
    #[test]
    fn mutated_files_never_panic(
        edits in prop::collection::vec((0.0f64..1.0, any::<u8>()), 1..8),
        cut in prop::option::of(0.0f64..1.0),
    ) {
        let (bytes, _) = recording();
        let mut b = bytes.clone();
        for (at, v) in edits {
            let i = ((at * b.len() as f64) as usize).min(b.len() - 1);
            b[i] = v;
        }
        if let Some(c) = cut {
            b.truncate((c * b.len() as f64) as usize);
        }
        let dir = tempfile::tempdir().unwrap();
        read_back(&b, dir.path());
    }

    /// Length fields set to huge values (the classic way to make a reader allocate
    /// without bound): every 8-byte window of the first records, set to all ones or to a
    /// large power of two.
    #[test]
    fn huge_length_fields_do_not_allocate_without_bound(at in 8usize..4096, big in prop::sample::select(vec![u64::MAX, 1 << 40, 1 << 33, 1 << 31, 0x7fff_ffff_ffff_ffff])) {
        let (bytes, _) = recording();
        let mut b = bytes.clone();
        let at = at.min(b.len() - 8);
        b[at..at + 8].copy_from_slice(&big.to_le_bytes());
        let dir = tempfile::tempdir().unwrap();
        read_back(&b, dir.path());
    }

    /// Arbitrary bytes after the MCAP magic.
    #[test]
    fn garbage_after_the_magic(tail in prop::collection::vec(any::<u8>(), 0..2000)) {
        let mut b = b"\x89MCAP0\r\n".to_vec();
        b.extend(tail);
        let dir = tempfile::tempdir().unwrap();
        read_back(&b, dir.path());
    }
}
