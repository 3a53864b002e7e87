//! Fuzzes the readers of a sweep's output directory: `sweep.json` (`read_manifest`) and
//! the per-job result files (`load_results`), which `mmq sweep` reads back on every
//! resume, merge and report. The first byte picks the file, the rest is its content. Any
//! content gives a manifest, a finished job or "not finished" / an error naming the
//! file, never a panic, a hang or a huge allocation. An accepted manifest survives a
//! JSON round trip; an accepted job is a JSON object naming this plan's cell and seed.
#![no_main]

use std::path::PathBuf;
use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use mmq_lab::sweep::{Manifest, Plan, SweepSpec, load_results, read_manifest};

/// A scratch output directory and the plan of a one-job sweep on the 3×3 world
/// (fuzz/seeds/sweep_store holds that sweep's real `sweep.json` and job file).
fn setup() -> &'static (PathBuf, Plan) {
    static S: OnceLock<(PathBuf, Plan)> = OnceLock::new();
    S.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("mmq-fuzz-store-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("w.toml"), "map = \"\"\"\nG..\n...\n..S\n\"\"\"\n").unwrap();
        let spec = "name = \"fuzz\"\nworld = \"w.toml\"\nlearner = [\"q\"]\ndelay = \"poisson:2\"\n\
                    steps = 100\nseeds = 1\n";
        let plan = SweepSpec::parse(spec, &dir.join("spec.toml")).unwrap().plan;
        (dir, plan)
    })
}

fuzz_target!(|data: &[u8]| {
    let Some((&which, body)) = data.split_first() else { return };
    let (dir, plan) = setup();
    if which % 2 == 0 {
        std::fs::write(dir.join("sweep.json"), body).unwrap();
        match read_manifest(dir) {
            Ok(m) => {
                assert_eq!(m.format, mmq_lab::sweep::FORMAT);
                let again: Manifest = serde_json::from_str(&serde_json::to_string(&m).unwrap()).unwrap();
                assert_eq!(format!("{again:?}"), format!("{m:?}"));
            }
            Err(e) => assert!(e.to_string().contains("sweep.json"), "{e}"),
        }
    } else {
        let (c, seed) = plan.job(0);
        let cell = dir.join("cells").join(&plan.cells[c].id);
        std::fs::create_dir_all(&cell).unwrap();
        std::fs::write(cell.join(format!("seed-{seed}.json")), body).unwrap();
        let results = load_results(dir, plan);
        assert_eq!(results.len(), plan.jobs());
        if results[0].is_some() {
            let v: serde_json::Value = serde_json::from_slice(body).unwrap();
            assert_eq!(v["cell"], plan.cells[c].id.as_str());
            assert_eq!(v["seed"], seed);
        }
    }
});
