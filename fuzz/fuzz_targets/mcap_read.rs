//! Fuzzes `mmq_log::read_log` on arbitrary bytes (seeded with real recordings, see
//! fuzz/seeds/mcap_read): a damaged or truncated file gives its readable prefix and a
//! reason, or a "not an MCAP file" error, never a panic, a hang or a huge allocation.
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
            assert!(log.complete != log.stop.is_some());
            if let Some(stop) = &log.stop {
                assert!(stop.offset <= stop.file_len, "{stop}");
            }
            let _ = mmq_log::summary(&log);
            let _ = log.world();
        }
        Err(e) => {
            let _ = e.to_string();
        }
    }
});
