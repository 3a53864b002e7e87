//! Fuzzes the sweep spec parser (`SweepSpec::parse`): any text gives a spec or an error
//! naming the file, never a panic, a hang or a huge allocation. Worlds are resolved
//! against a scratch directory that holds `w.toml` (the paper's 3×3 world).
#![no_main]

use std::path::PathBuf;
use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use mmq_lab::sweep::SweepSpec;

fn spec_path() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("mmq-fuzz-sweep-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("w.toml"), "map = \"\"\"\nG..\n...\n..S\n\"\"\"\n").unwrap();
        dir.join("spec.toml")
    })
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    match SweepSpec::parse(text, spec_path()) {
        Ok(s) => {
            assert!(s.plan.jobs() <= mmq_lab::sweep::MAX_JOBS);
        }
        Err(e) => {
            let _ = e.to_string();
        }
    }
});
