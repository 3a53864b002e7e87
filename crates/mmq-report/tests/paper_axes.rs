//! `mmq paper --specs` with edited figure specs: lists of delays, worlds and λ̂ shorter and
//! longer than the paper's are run and labelled by their values in report.md and the
//! CSVs, and a spec that cannot make its figure is refused with its file and field.
//! Tiny budgets (one seed, a few hundred steps) keep every test fast.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use mmq_lab::config::EnvKind;
use mmq_lab::study::Budget;
use mmq_report::ReportError;
use mmq_report::paper::{PaperRequest, paper};

struct Quiet;
impl mmq_report::Progress for Quiet {}

/// The shipped figure spec `name` with the line starting `key =` (and any list it opens)
/// replaced by `line`.
fn edited(name: &str, key: &str, line: &str) -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../worlds/sweeps");
    let text = std::fs::read_to_string(root.join(format!("{name}.toml"))).unwrap();
    let mut out = Vec::new();
    let mut skipping = false;
    for l in text.lines() {
        if skipping {
            skipping = !l.starts_with(']');
            continue;
        }
        if l.starts_with(&format!("{key} =")) {
            out.push(line.to_string());
            skipping = l.ends_with('[');
        } else {
            out.push(l.to_string());
        }
    }
    assert!(out.iter().any(|l| l == line), "{name} has no `{key}`");
    out.join("\n") + "\n"
}

/// Runs `fig` of the report with the specs `files` (name, text) in a folder of their own.
fn run(fig: &str, files: &[(&str, String)]) -> (tempfile::TempDir, Result<PathBuf, ReportError>) {
    let d = tempfile::tempdir().unwrap();
    let specs = d.path().join("specs");
    std::fs::create_dir(&specs).unwrap();
    for (name, text) in files {
        std::fs::write(specs.join(format!("{name}.toml")), text).unwrap();
    }
    let out = d.path().join("out");
    let req = PaperRequest {
        fig: fig.into(),
        envs: vec![EnvKind::Grid],
        budget: Budget { quick: true, seeds: Some(1), steps: Some(600), seed: None },
        out: out.clone(),
        specs: Some(specs),
        shard: None,
        merge: Vec::new(),
    };
    let r = paper(&req, &AtomicBool::new(false), &Quiet).map(|_| out);
    (d, r)
}

fn csv(path: &Path) -> Vec<HashMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let head: Vec<String> = lines.next().unwrap().split(',').map(str::to_string).collect();
    lines.map(|l| head.iter().cloned().zip(l.split(',').map(str::to_string)).collect()).collect()
}

/// The table rows of the report's section `heading` (up to the next section), the
/// section's one table.
fn rows(report: &str, heading: &str) -> Vec<String> {
    let at = report.find(heading).unwrap_or_else(|| panic!("no {heading}"));
    let section = &report[at..];
    let end = section[1..].find("\n## ").map_or(section.len(), |i| i + 1);
    // The table's lines without its header (the first) and its rule.
    section[..end].lines().filter(|l| l.starts_with("| ")).skip(1).map(String::from).collect()
}

fn delays(lambdas: &[u32]) -> String {
    let items: Vec<String> = lambdas.iter().map(|l| format!("\"poisson:{l}\"")).collect();
    format!("delay = [{}]", items.join(", "))
}

#[test]
fn fig2_is_labelled_by_each_delay_s_mean_for_three_and_for_25_delays() {
    for lambdas in [vec![2u32, 6, 9], (0..25).map(|i| 2 * i).collect::<Vec<_>>()] {
        let (_d, out) = run("2", &[("paper-fig2", edited("paper-fig2", "delay", &delays(&lambdas)))]);
        let out = out.unwrap();
        let got: Vec<String> = csv(&out.join("fig2.csv")).iter().map(|r| r["lambda"].clone()).collect();
        let want: Vec<String> = lambdas.iter().map(u32::to_string).collect();
        assert_eq!(got, want);
        let report = std::fs::read_to_string(out.join("report.md")).unwrap();
        let table = rows(&report, "## Fig. 2");
        // Not the paper's plan: every λ that ran is a row, labelled by its value.
        let labels: Vec<String> =
            table.iter().map(|r| r.split('|').nth(1).unwrap().trim().to_string()).collect();
        assert_eq!(labels, want, "{report}");
        if lambdas.len() == 3 {
            // λ = 6 is poisson:6 (the second setting), not the list index.
            assert!(table[1].starts_with("| 6 | — | — | "), "{}", table[1]);
        } else {
            // The paper's values only where it has one, at its own setting.
            assert!(table[0].starts_with("| 0 | 100 % | 100 % | "), "{}", table[0]);
            assert!(table[10].starts_with("| 20 | lowest | ≈ 81 % | "), "{}", table[10]);
            assert!(table[24].starts_with("| 48 | — | — | "), "{}", table[24]);
        }
        assert!(report.contains("is not exactly the paper's setting"), "{report}");
    }
}

#[test]
fn fig2_on_another_world_shows_no_paper_values() {
    let spec = edited("paper-fig2", "delay", &delays(&[0, 3, 20]));
    let spec = spec.replace("world = \"paper-3x3\"", "world = \"paper-5x5\"");
    let (_d, out) = run("2", &[("paper-fig2", spec)]);
    let report = std::fs::read_to_string(out.unwrap().join("report.md")).unwrap();
    let table = rows(&report, "## Fig. 2");
    assert_eq!(table.len(), 3);
    assert!(table.iter().all(|r| r.contains("| — | — |")), "{table:?}");
    assert!(report.contains("Setting: 5×5,"), "{report}");
}

#[test]
fn fig2_names_the_learner_that_ran() {
    let spec =
        edited("paper-fig2", "delay", &delays(&[0, 4])).replace("learner = \"q\"", "learner = \"mmq\"");
    let (_d, out) = run("2", &[("paper-fig2", spec)]);
    let report = std::fs::read_to_string(out.unwrap().join("report.md")).unwrap();
    assert!(report.contains("Setting: 3×3, MMQ (λ̂max = 50), ε = 0.05"), "{report}");
    assert!(rows(&report, "## Fig. 2").iter().all(|r| r.contains("| — | — |")), "{report}");
}

#[test]
fn fig3_is_labelled_by_each_world_for_two_and_for_four_worlds() {
    for (worlds, labels) in [
        (vec!["paper-3x3", "paper-5x5"], vec!["3×3", "5×5"]),
        (vec!["paper-3x3", "corridor-7x3", "paper-5x5", "paper-9x9"], vec!["3×3", "7×3", "5×5", "9×9"]),
    ] {
        let list: Vec<String> = worlds.iter().map(|w| format!("\"{w}\"")).collect();
        let line = format!("world = [{}]", list.join(", "));
        let (_d, out) = run("3", &[("paper-fig3", edited("paper-fig3", "world", &line))]);
        let out = out.unwrap();
        let report = std::fs::read_to_string(out.join("report.md")).unwrap();
        let table = rows(&report, "## Fig. 3");
        let got: Vec<&str> = table.iter().map(|r| r.split('|').nth(1).unwrap().trim()).collect();
        assert_eq!(got, labels, "{report}");
        // The reference's value is the 3×3 world's, whatever its position.
        assert!(table[0].contains("| ≈ 85 % |"), "{}", table[0]);
        if worlds.len() == 4 {
            assert!(table[1].contains("| 7×3 | — | — |"), "{}", table[1]);
        }
        // The CSV names each curve by its world, never by a position.
        for r in csv(&out.join("fig3.csv")) {
            assert!(labels.contains(&r["world"].as_str()), "{}", r["world"]);
        }
    }
}

#[test]
fn fig4_is_labelled_by_each_lambda_hat_for_a_shorter_and_a_longer_range() {
    for hats in [vec![15u64, 16, 17], (0..=40).collect::<Vec<_>>()] {
        let items: Vec<String> = hats.iter().map(u64::to_string).collect();
        let line = format!("lambda_hat = [{}]", items.join(", "));
        let (_d, out) = run("4", &[("paper-fig4", edited("paper-fig4", "lambda_hat", &line))]);
        let out = out.unwrap();
        let rows_csv = csv(&out.join("fig4.csv"));
        let got: Vec<u64> = rows_csv.iter().map(|r| r["lambda_hat"].parse().unwrap()).collect();
        assert_eq!(got, hats);
        // i = λ̂ − 17 (the spec's Poisson(17)), from each setting's own λ̂.
        for r in &rows_csv {
            let (i, hat): (i64, i64) = (r["i"].parse().unwrap(), r["lambda_hat"].parse().unwrap());
            assert_eq!(i, hat - 17);
        }
        let report = std::fs::read_to_string(out.join("report.md")).unwrap();
        let (lo, hi) =
            if hats.len() == 3 { ("| i = −2 |", "| i = 0 |") } else { ("| i = −17 |", "| i = +23 |") };
        assert!(report.contains(lo) && report.contains(hi), "{report}");
        if hats.len() == 3 {
            // The paper's ±10 and its peak are not part of this range.
            assert!(!report.contains("≈ 0") && !report.contains("near 0"), "{report}");
        }
    }
}

#[test]
fn a_spec_that_cannot_make_its_figure_is_refused_with_its_file_and_field() {
    let fig4 = edited("paper-fig4", "lambda_hat", "lambda_hat = 17");
    // A setting the figure does not vary, given several values.
    let fig2 =
        edited("paper-fig2", "delay", &delays(&[0, 5])).replace("epsilon = 0.05", "epsilon = [0.05, 0.1]");
    let (_d, e) = run("2", &[("paper-fig2", fig2)]);
    let e = e.unwrap_err();
    assert!(e.is_input_error());
    let msg = e.to_string();
    assert!(msg.contains("paper-fig2.toml: `epsilon`: Fig. 2 varies only `delay`"), "{msg}");
    // Two delays of one mean would be one point twice.
    let fig2 = edited("paper-fig2", "delay", "delay = [\"poisson:5\", \"const:5\"]");
    let msg = run("2", &[("paper-fig2", fig2)]).1.unwrap_err().to_string();
    assert!(msg.contains("`delay`: two settings have mean delay λ = 5"), "{msg}");
    // Fig. 4 without the fixed learner has no λ̂ axis.
    let fig4_q = fig4.replace("learner = \"fixed\"", "learner = \"q\"").replace("lambda_hat = 17\n", "");
    let msg = run("4", &[("paper-fig4", fig4_q)]).1.unwrap_err().to_string();
    assert!(
        msg.contains("paper-fig4.toml: `learner`: Fig. 4's axis is the `fixed` learner's `lambda_hat`"),
        "{msg}"
    );
    // The sensitivity table joins its spec with Fig. 6's: one world for both.
    let sens = edited("paper-sensitivity", "world", "world = \"paper-5x5\"");
    let msg = run("sens", &[("paper-sensitivity", sens)]).1.unwrap_err().to_string();
    assert!(msg.contains("paper-sensitivity.toml (with the built-in paper-fig6.toml): `world`:"), "{msg}");
    // The horizon study runs one setting.
    let horizon = edited("paper-horizon", "learner", "learner = [\"mmq\", \"q\"]");
    let msg = run("6", &[("paper-horizon", horizon)]).1.unwrap_err().to_string();
    assert!(msg.contains("paper-horizon.toml: `learner`: The horizon study runs one setting"), "{msg}");
    // Fig. 6 compares MMQ with Q-learning.
    let fig6 = edited("paper-fig6", "learner", "learner = [\"mmq\", \"q\", \"q-lambda\"]");
    let msg = run("6", &[("paper-fig6", fig6)]).1.unwrap_err().to_string();
    assert!(msg.contains("paper-fig6.toml: `learner`: Fig. 6 compares exactly two settings"), "{msg}");
}
