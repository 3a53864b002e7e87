//! Fuzzes `mmq_log::read_log` on arbitrary bytes (seeded with real recordings, see
//! fuzz/seeds/mcap_read): a damaged or truncated file gives its readable prefix and a
//! reason, or a "not an MCAP file" error, never a panic, a hang or a huge allocation; a
//! file read to its end whose counts disagree is summarised as damaged.
#![no_main]

use std::path::PathBuf;
use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;

fn scratch() -> &'static PathBuf {
    static P: OnceLock<PathBuf> = OnceLock::new();
    P.get_or_init(|| std::env::temp_dir().join(format!("mmq-fuzz-{}.mcap", std::process::id())))
}

fuzz_target!(|data: &[u8]| {
    let path = scratch();
    std::fs::write(path, data).unwrap();
    match mmq_log::read_log(path) {
        Ok(log) => {
            assert_eq!(log.file_len, data.len() as u64);
            // Complete means read to the end and agreeing with the file's statistics.
            assert_eq!(log.complete, log.stop.is_none() && log.problems.is_empty());
            if let Some(stop) = &log.stop {
                assert!(stop.offset <= stop.file_len, "{stop}");
            }
            let text = mmq_log::summary(&log).to_string();
            // A file whose counts disagree is never summarised as complete.
            if log.stop.is_none() && !log.problems.is_empty() {
                assert!(text.contains("DAMAGED"), "{text}");
            }
            let _ = log.world();
        }
        Err(e) => {
            let _ = e.to_string();
        }
    }
});
