//! End-to-end tests of the grid-optimal reference in `mmq run --reference` and in sweeps
//! (`reference = true`): the fraction of what the environment allows, next to the
//! fraction of the grid's optimum.

use crate::common::*;

#[test]
fn a_run_with_the_reference_reports_its_fraction_beside_the_optimums() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().to_string_lossy().into_owned();
    let o = mmq(&[
        "run",
        "--env",
        "robot",
        "--robot",
        "profile=realistic",
        "--learner",
        "q",
        "--reference",
        "--steps",
        "300",
        "--seeds",
        "2",
        "--no-baseline",
        "--eval-steps",
        "0",
        "--out",
        &out,
    ]);
    let (stdout, stderr) = text(&o);
    assert!(o.status.success(), "{stderr}");
    assert!(stdout.contains("fraction of the grid-optimal reference"), "{stdout}");
    let s = read_json(&d.path().join("summary.json"));
    for seed in s["seeds"].as_array().unwrap() {
        let (f, opt, reference) = (
            seed["perf/fraction_of_reference"].as_f64(),
            seed["perf/fraction_of_optimum"].as_f64().unwrap(),
            seed["reference/fraction_of_optimum"].as_f64().unwrap(),
        );
        // The realistic robot cannot earn the grid's optimum even with its best plan.
        assert!(reference > 0.0 && reference < 1.0, "{reference}");
        if let Some(f) = f {
            assert!((f - opt / reference).abs() < 1e-9, "{f} vs {opt} / {reference}");
        }
    }
}

#[test]
fn a_sweep_with_the_reference_stores_and_reports_its_fraction() {
    let d = tempfile::tempdir().unwrap();
    let spec = d.path().join("s.toml");
    let world = root().join("worlds/paper-9x9.toml");
    std::fs::write(
        &spec,
        format!(
            "name = \"r\"\nworld = {:?}\nlearner = [\"q\", \"mmq\"]\ndelay = [\"poisson:5\", \"none\"]\nsteps = 2000\nwindow = 100\neval_steps = 10\nbaseline = false\nreference = true\nseeds = 2\n",
            world.to_string_lossy()
        ),
    )
    .unwrap();
    let out = d.path().join("out");
    let o = mmq(&["sweep", &spec.to_string_lossy(), "--out", &out.to_string_lossy(), "-q"]);
    assert!(o.status.success(), "{}", text(&o).1);
    let o = mmq(&["sweep", "report", &out.to_string_lossy()]);
    assert!(o.status.success(), "{}", text(&o).1);
    let csv = std::fs::read_to_string(out.join("report/summary.csv")).unwrap();
    assert!(
        csv.contains("perf/fraction_of_reference") && csv.contains("reference/fraction_of_optimum"),
        "{csv}"
    );
    let md = std::fs::read_to_string(out.join("report/report.md")).unwrap();
    assert!(md.contains("Fraction of the grid-optimal reference"), "{md}");
}
