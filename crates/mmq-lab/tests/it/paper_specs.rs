//! The paper's figures are the sweep specs in `worlds/sweeps/paper-*.toml`: `mmq paper`
//! runs the copies shipped in the binary, `mmq sweep` the files. These tests hold the
//! copies to the files, the specs to the settings the paper states, and the budget rule
//! to what `--quick` and `--seed` promise.

use std::path::Path;

use mmq_lab::RunConfig;
use mmq_lab::config::EnvKind;
use mmq_lab::study::{self as paper, Budget};
use mmq_learn::LearnerKind;

/// The cells of the figure spec `name` (edited copies from `specs`) at `budget`.
fn configs(budget: Budget, specs: Option<&Path>, name: &str) -> Result<Vec<RunConfig>, mmq_lab::LabError> {
    Ok(paper::configs(&budget.spec(specs, name)?))
}

fn full(name: &str) -> Vec<RunConfig> {
    configs(Budget::default(), None, name).unwrap()
}

fn specs_dir() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../worlds/sweeps")
}

#[test]
fn every_paper_spec_file_is_shipped_unchanged() {
    let mut files: Vec<String> = std::fs::read_dir(specs_dir())
        .expect("worlds/sweeps")
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.starts_with("paper-") && n.ends_with(".toml"))
        .collect();
    files.sort();
    let mut shipped: Vec<String> = paper::SPECS.iter().map(|s| format!("{}.toml", s.0)).collect();
    shipped.sort();
    assert_eq!(files, shipped, "every worlds/sweeps/paper-*.toml is a figure `mmq paper` runs");
    for (name, text) in paper::SPECS {
        let on_disk = std::fs::read_to_string(specs_dir().join(format!("{name}.toml"))).expect("spec file");
        assert_eq!(&on_disk, text, "{name}");
    }
}

fn world(c: &RunConfig) -> String {
    c.world.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default()
}

fn eps_q0(c: &RunConfig) -> (f64, f64) {
    (c.learner.params.epsilon, c.learner.params.q0)
}

#[test]
fn the_figures_hold_the_settings_the_paper_states() {
    // Fig. 2: Q-learning on 3×3, Poisson means 0 to 20 in this order.
    let f2 = full("paper-fig2");
    let delays: Vec<String> = (0..=20).map(|l| format!("poisson:{l}")).collect();
    assert_eq!(f2.iter().map(|c| c.delay.clone()).collect::<Vec<_>>(), delays);
    assert!(f2.iter().all(|c| world(c) == "paper-3x3" && c.learner.kind() == LearnerKind::Q));
    assert!(f2.iter().all(|c| eps_q0(c) == (0.05, 10.0)));
    // Fig. 3: Poisson(5) on the three worlds, smallest first.
    let f3 = full("paper-fig3");
    assert_eq!(f3.iter().map(world).collect::<Vec<_>>(), ["paper-3x3", "paper-5x5", "paper-9x9"]);
    assert!(f3.iter().all(|c| c.delay == "poisson:5"));
    // Fig. 4: the fixed-delay learner with λ̂ = 17 − 10 … 17 + 10 under Poisson(17).
    let f4 = full("paper-fig4");
    let lambda_hats: Vec<usize> = f4
        .iter()
        .map(|c| match &c.learner.settings {
            mmq_learn::LearnerSettings::Fixed(f) => f.lambda_hat,
            s => panic!("Fig. 4 runs the fixed-delay learner, not {s:?}"),
        })
        .collect();
    assert_eq!(lambda_hats, (7..=27).collect::<Vec<_>>());
    assert!(f4.iter().all(|c| c.learner.kind() == LearnerKind::Fixed && c.delay == "poisson:17"));
    // Fig. 6: MMQ and Q-learning on 9×9, Poisson(13), λ̂max 50, on the grid and the robot.
    for (env, seeds, name) in [(EnvKind::Grid, 20, "paper-fig6"), (EnvKind::Robot, 5, "paper-fig6-robot")] {
        let f6 = full(name);
        let kinds: Vec<LearnerKind> = f6.iter().map(|c| c.learner.kind()).collect();
        assert_eq!(kinds, [LearnerKind::Mmq, LearnerKind::Q]);
        for c in &f6 {
            assert_eq!(
                (world(c), c.delay.as_str(), c.learner.settings.max_delay()),
                ("paper-9x9".into(), "poisson:13", (c.learner.kind() == LearnerKind::Mmq).then_some(50))
            );
            assert_eq!((c.env, c.seeds, c.steps, c.window), (env, seeds, 150_000, 2500));
            assert_eq!(eps_q0(c), (0.01, 20.0));
        }
    }
    // The sensitivity table: from the most exploring setting to Fig. 6's, MMQ then Q.
    // The sensitivity spec: the two more exploring settings of MMQ and Q, in product
    // order (the report adds Fig. 6's and sorts them).
    let s = full("paper-sensitivity");
    let rows: Vec<(f64, f64, LearnerKind)> =
        s.iter().map(|c| (eps_q0(c).0, eps_q0(c).1, c.learner.kind())).collect();
    use LearnerKind::{Mmq, Q};
    assert_eq!(rows, [(0.05, 10.0, Mmq), (0.02, 10.0, Mmq), (0.05, 10.0, Q), (0.02, 10.0, Q)]);
}

#[test]
fn a_smaller_budget_scales_every_figure_alike() {
    let o = Budget { quick: true, seed: Some(7), ..Budget::default() };
    let f6 = configs(o, None, "paper-fig6").unwrap();
    let h = configs(o, None, "paper-horizon").unwrap();
    assert_eq!((f6[0].steps, f6[0].window, f6[0].seeds, f6[0].seed), (30_000, 1000, 6, 7));
    // The horizon study runs four times Fig. 6's horizon at any budget.
    assert_eq!((h[0].steps, h[0].window, h[0].seeds), (120_000, 4000, 6));
    assert_eq!(h[0].learner.kind(), LearnerKind::Mmq);
    assert_eq!(o.paper_steps(), 30_000);
    assert!(configs(o, None, "paper-fig5").is_err());
}

/// A folder of specs replaces the built-in figure of the same name (an edited copy of
/// `paper-fig6.toml` gives Fig. 6 for the variant) and leaves the others; a folder that
/// is not one, and a bad copy, are errors naming the file.
#[test]
fn a_folder_of_specs_replaces_the_built_in_figure_of_the_same_name() {
    let d = tempfile::tempdir().unwrap();
    let f6 = paper::SPECS.iter().find(|s| s.0 == "paper-fig6").unwrap().1;
    assert!(f6.contains("epsilon = 0.01\n"));
    std::fs::write(d.path().join("paper-fig6.toml"), f6.replace("epsilon = 0.01\n", "epsilon = 0.2\n"))
        .unwrap();
    let o = Budget { quick: true, ..Budget::default() };
    let built_in = configs(o, None, "paper-fig6").unwrap();
    let specs = Some(d.path());
    let variant = configs(o, specs, "paper-fig6").unwrap();
    assert_eq!(variant.len(), built_in.len());
    for (v, b) in variant.iter().zip(&built_in) {
        assert_eq!((v.learner.params.epsilon, b.learner.params.epsilon), (0.2, 0.01));
        assert_eq!(
            (v.steps, v.seeds, v.learner.kind(), &v.delay),
            (b.steps, b.seeds, b.learner.kind(), &b.delay)
        );
    }
    assert_eq!(configs(o, specs, "paper-fig4").unwrap().len(), 21, "figures without a copy stay built in");

    std::fs::write(d.path().join("paper-fig2.toml"), "world = \"paper-3x3\"\nlearner = \"qq\"\n").unwrap();
    let e = configs(o, specs, "paper-fig2").unwrap_err().to_string();
    assert!(e.contains("paper-fig2.toml:2:11: learner:") && e.contains("unknown learner"), "{e}");
    let nowhere = d.path().join("nowhere");
    let e = configs(o, Some(&nowhere), "paper-fig6").unwrap_err().to_string();
    assert!(e.contains("nowhere") && e.contains("not a folder"), "{e}");
}

/// An edited spec's own seeds count where no flag overrides them: the budget rule
/// reads the spec's `seeds` (here 4 → ⌈1.2⌉ = 2 under `--quick`, 4 as written).
#[test]
fn an_edited_spec_keeps_its_own_seeds() {
    let d = tempfile::tempdir().unwrap();
    let f2 = paper::SPECS.iter().find(|s| s.0 == "paper-fig2").unwrap().1;
    std::fs::write(d.path().join("paper-fig2.toml"), f2.replace("seeds = 20\n", "seeds = 4\n")).unwrap();
    let specs = Some(d.path());
    let seeds = |b: Budget| configs(b, specs, "paper-fig2").unwrap()[0].seeds;
    assert_eq!(seeds(Budget::default()), 4);
    assert_eq!(seeds(Budget { steps: Some(3000), ..Budget::default() }), 4);
    assert_eq!(seeds(Budget { quick: true, ..Budget::default() }), 2);
    assert_eq!(seeds(Budget { quick: true, seeds: Some(3), ..Budget::default() }), 3);
}
