//! The paper's figures as sweep specs (`worlds/sweeps/paper-*.toml`): each spec's cells
//! are exactly the settings `mmq paper` runs for its figure at the paper's budget, so
//! that `mmq sweep` on a spec, or on a copy with one line changed, is the same study.

use std::path::{Path, PathBuf};

use mmq_lab::RunConfig;
use mmq_lab::config::EnvKind;
use mmq_lab::paper::{self, PaperOptions};
use mmq_lab::sweep::SweepSpec;

fn spec(name: &str) -> SweepSpec {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../worlds/sweeps").join(format!("{name}.toml"));
    SweepSpec::load(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A setting and its master seeds as text, with what only says where it comes from
/// (the world's path; the baseline flag: the paper attaches the undelayed baseline
/// itself) left out.
fn key(c: &RunConfig, seeds: &[u64]) -> String {
    let stem = c.world.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let c = RunConfig {
        world: PathBuf::from(stem),
        baseline: false,
        save_tables: false,
        seed: 0,
        seeds: 0,
        ..c.clone()
    };
    format!("{c:?} seeds {seeds:?}")
}

fn spec_keys(names: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = names
        .iter()
        .flat_map(|n| {
            let s = spec(n);
            (0..s.plan.cells.len()).map(|c| key(s.config(c), &s.plan.seeds)).collect::<Vec<_>>()
        })
        .collect();
    v.sort();
    v
}

fn code_keys(cfgs: Vec<RunConfig>) -> Vec<String> {
    let mut v: Vec<String> = cfgs.iter().map(|c| key(c, &c.seed_list())).collect();
    v.sort();
    v
}

#[test]
fn every_paper_figure_spec_holds_exactly_the_figures_settings() {
    let grid = PaperOptions::new(false, EnvKind::Grid);
    let robot = PaperOptions::new(false, EnvKind::Robot);
    let cases: [(&[&str], Vec<RunConfig>); 7] = [
        (&["paper-fig2"], paper::fig2_configs(&grid)),
        (&["paper-fig3"], paper::fig3_configs(&grid)),
        (&["paper-fig4"], paper::fig4_configs(&grid)),
        (&["paper-fig6"], paper::fig6_configs(&grid)),
        (&["paper-fig6-robot"], paper::fig6_configs(&robot)),
        (&["paper-horizon"], paper::horizon_configs(&grid)),
        (&["paper-sensitivity", "paper-fig6"], paper::sensitivity_configs(&grid)),
    ];
    for (names, cfgs) in cases {
        let (from_spec, from_code) = (spec_keys(names), code_keys(cfgs));
        assert!(!from_code.is_empty());
        let only_spec: Vec<&String> = from_spec.iter().filter(|k| !from_code.contains(k)).collect();
        let only_code: Vec<&String> = from_code.iter().filter(|k| !from_spec.contains(k)).collect();
        assert!(
            only_spec.is_empty() && only_code.is_empty() && from_spec.len() == from_code.len(),
            "{names:?}: only in the spec: {only_spec:#?}\nonly in the paper: {only_code:#?}"
        );
    }
}

#[test]
fn the_comparison_of_settings_would_see_a_changed_line() {
    // The check above is only as good as `key`: a spec that differs in one setting
    // must not compare equal.
    let grid = PaperOptions::new(false, EnvKind::Grid);
    let mut cfgs = paper::fig6_configs(&grid);
    cfgs[0].learner.params.epsilon = 0.02;
    assert_ne!(spec_keys(&["paper-fig6"]), code_keys(cfgs));
}
