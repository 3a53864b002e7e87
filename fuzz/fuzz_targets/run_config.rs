//! Fuzzes the run configuration (`config.toml`, also read back from MCAP attachments by
//! `mmq replay --verify`): `RunConfig::from_toml` then `validate` never panic, and a
//! valid configuration's table sizes are computed without overflow.
#![no_main]

use libfuzzer_sys::fuzz_target;
use mmq_lab::RunConfig;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(cfg) = RunConfig::from_toml(text, "fuzz.toml") else { return };
    let _ = cfg.to_toml();
    if cfg.validate().is_ok() {
        let _ = cfg.learner.table_bytes(250_000, 4);
        let _ = cfg.baseline_learner();
        // The seed list is what a run allocates first: bounded by `validate`.
        assert!(cfg.seeds <= 1_000_000);
        // The printed configuration reads back to itself.
        let back = RunConfig::from_toml(&cfg.to_toml(), "again.toml").expect("printed config parses");
        assert_eq!(back.to_toml(), cfg.to_toml());
    }
});
