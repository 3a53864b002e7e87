//! `mmq paper --quick --fig all` end to end: every file the report names exists, and the
//! report's numbers are the CSVs' numbers; Fig. 6 from `mmq paper` and from `mmq sweep`
//! on its shipped spec agree.

use std::collections::HashMap;
use std::path::PathBuf;
use std::process::Command;

fn csv(path: &std::path::Path) -> Vec<HashMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let head: Vec<String> = lines.next().unwrap().split(',').map(str::to_string).collect();
    lines.map(|l| head.iter().cloned().zip(l.split(',').map(str::to_string)).collect()).collect()
}

/// A mean and its interval as the report prints them: "99.3 ± 3.2 %", Unicode minus.
fn pct(mean: &str, ci: &str) -> String {
    let (m, c): (f64, f64) = (mean.parse().unwrap(), ci.parse().unwrap());
    let signed = |x: f64| {
        let s = format!("{x:.1}");
        if s == "-0.0" { "0.0".to_string() } else { s.replacen('-', "−", 1) }
    };
    format!("{} ± {} %", signed(100.0 * m), signed(100.0 * c))
}

#[test]
fn quick_paper_report_is_complete_and_consistent() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("paper");
    let o = Command::new(env!("CARGO_BIN_EXE_mmq"))
        .args(["paper", "--quick", "--fig", "all", "--env", "both", "-q", "--out"])
        .arg(&out)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();

    // Every linked file exists and is not empty; every figure has its SVG and PNG.
    let mut linked = Vec::new();
    for part in report.split("](").skip(1) {
        let name = part.split(')').next().unwrap();
        linked.push(name.to_string());
        let p: PathBuf = out.join(name);
        assert!(p.is_file() && std::fs::metadata(&p).unwrap().len() > 0, "{name} is missing");
        if let Some(stem) = name.strip_suffix(".png") {
            assert!(out.join(format!("{stem}.svg")).is_file(), "{stem}.svg is missing");
        }
    }
    for fig in [
        "fig2",
        "fig3",
        "fig4",
        "fig6",
        "fig7",
        "fig8",
        "fig9",
        "fig10",
        "fig11",
        "fig12",
        "fig6-robot",
        "fig8-robot",
    ] {
        assert!(linked.contains(&format!("{fig}.png")), "{fig} is not in the report");
    }

    // Fig. 2's table rows are the CSV's values.
    let fig2 = csv(&out.join("fig2.csv"));
    for l in [0usize, 3, 10, 20] {
        let row = &fig2[l];
        assert_eq!(row["lambda"], l.to_string());
        let want = pct(&row["mean"], &row["ci95"]);
        let line = report.lines().find(|x| x.starts_with(&format!("| {l} |"))).unwrap();
        assert!(line.ends_with(&format!("| {want} |")), "{line} vs {want}");
    }
    // The sensitivity table is the CSV's.
    for row in csv(&out.join("sensitivity.csv")) {
        let want = format!(
            "| {} | {} | {} | {} |",
            row["epsilon"],
            row["q0"],
            row["learner"],
            pct(&row["relative"], &row["relative_ci95"])
        );
        assert!(report.contains(&want), "missing {want}");
    }
    // Fig. 4: the extremes in the table are the CSV's first and last rows.
    let fig4 = csv(&out.join("fig4.csv"));
    let first = pct(&fig4[0]["mean"], &fig4[0]["ci95"]);
    assert!(report.contains(&format!("| i = −10 | ≈ 0 | ≈ 0 | {first} |")), "fig 4 i = −10");
    // The headline lists the grid and the robot side by side.
    let head = report.lines().find(|l| l.starts_with("| MMQ relative performance")).unwrap();
    let cells: Vec<&str> = head.split('|').map(str::trim).filter(|c| !c.is_empty()).collect();
    assert_eq!(cells.len(), 5, "{head}");
    // The grid's is a number; the robot's too, unless a quick-budget baseline earned
    // nothing, and then it is absent and the report says why.
    assert!(cells[3].contains(" ± ") && cells[3].ends_with(" %"), "{head}");
    assert!((cells[4].contains(" ± ") && cells[4].ends_with(" %")) || cells[4] == "—", "{head}");
    assert!(report.contains("Relative performance is absent where the undelayed baseline earned ≤ 0"));
    // Every figure says where it differs from the paper, and the horizon is shown.
    assert!(report.matches("**Where we differ from the paper:**").count() >= 6, "{report}");
    assert!(linked.contains(&"horizon.png".to_string()) && linked.contains(&"fig6-delay.png".to_string()));
}

/// Fig. 6 both ways: `mmq paper --fig 6` and `mmq sweep` on the figure's shipped spec
/// (`worlds/sweeps/paper-fig6.toml`, with only the budget lines changed) run the same
/// jobs, so the paper's learning curves equal the means of the sweep's per-job curves
/// at every point, for both learners.
#[test]
fn fig6_from_the_paper_and_from_its_sweep_spec_agree() {
    let (steps, seeds, window) = (1200u64, 3u64, 20u64);
    let d = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_mmq"))
            .args(args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap();
        assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
    };
    let paper = d.path().join("paper");
    let p = paper.to_string_lossy().into_owned();
    run(&[
        "paper",
        "--fig",
        "6",
        "--steps",
        &steps.to_string(),
        "--seeds",
        &seeds.to_string(),
        "-q",
        "--out",
        &p,
    ]);

    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let shipped = std::fs::read_to_string(root.join("worlds/sweeps/paper-fig6.toml")).unwrap();
    let mut changed = 0;
    let text: String = shipped
        .lines()
        .map(|l| {
            let new = match l.split(" = ").next() {
                Some("steps") => format!("steps = {steps}"),
                Some("seeds") => format!("seeds = {seeds}"),
                Some("window") => format!("window = {window}"),
                _ => return l.to_string(),
            };
            changed += 1;
            new
        })
        .collect::<Vec<_>>()
        .join("\n");
    assert_eq!(changed, 3, "the spec lost a line this test changes");
    let spec = d.path().join("fig6.toml");
    std::fs::write(&spec, text).unwrap();
    let sweep = d.path().join("sweep");
    run(&["sweep", &spec.to_string_lossy(), "-q", "--out", &sweep.to_string_lossy()]);

    // The paper: per learner and curve point, the mean over seeds of the reward earned
    // per step in that window.
    let paper_rows = csv(&paper.join("fig6-rewards.csv"));
    // The sweep: per job, `curve/<step>` is the same quantity.
    let jobs = csv(&sweep.join("results.csv"));
    let mut compared = 0;
    for (series, learner) in [("MMQ_earned", "mmq"), ("Q_earned", "q")] {
        let rows: Vec<_> = paper_rows.iter().filter(|r| r["series"] == series).collect();
        assert_eq!(rows.len() as u64, steps / window, "{series}: one point per window");
        for r in rows {
            let of_jobs: Vec<f64> = jobs
                .iter()
                .filter(|j| j["learner"] == learner)
                .map(|j| j[&format!("curve/{}", r["step"])].parse().unwrap())
                .collect();
            assert_eq!(of_jobs.len() as u64, seeds);
            let mean = of_jobs.iter().sum::<f64>() / seeds as f64;
            let from_paper: f64 = r["mean"].parse().unwrap();
            assert!(
                (mean - from_paper).abs() < 1e-12,
                "{series} at step {}: paper {from_paper}, sweep {mean}",
                r["step"]
            );
            compared += 1;
        }
    }
    assert_eq!(compared, 2 * steps / window);
}

/// The learner comparison reports, beside relative performance, the fraction of the
/// ε-soft ceiling and the regret, and both agree with the fraction of the optimum:
/// regret = optimum × steps × (1 − fraction), and ceiling fraction ÷ fraction =
/// optimum ÷ ceiling, one ratio above 1 for every learner of a world and ε.
#[test]
fn the_learner_comparison_reports_the_ceiling_and_the_regret() {
    let steps = 600.0;
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("comparison");
    let o = Command::new(env!("CARGO_BIN_EXE_mmq"))
        .args(["paper", "--quick", "--fig", "comparison", "--steps", "600", "--seeds", "1", "-q", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(out.join("comparison.csv")).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let mut ratios: HashMap<(String, String), Vec<f64>> = HashMap::new();
    let mut checked = 0;
    // Rows whose delay spec holds commas are quoted; the others split on commas.
    for row in lines.filter(|l| !l.contains('"')) {
        let r: HashMap<&str, &str> = head.iter().copied().zip(row.split(',')).collect();
        let optimum = match r["world"] {
            "paper-9x9" => 10.0 / 17.0,
            "maze-15x15" => 10.0 / 33.0,
            w => panic!("unexpected world {w}"),
        };
        let num = |k: &str| -> f64 { r[k].parse().unwrap_or_else(|_| panic!("{k} = {:?} in {row}", r[k])) };
        let (fraction, ceiling, regret) = (num("fraction"), num("ceiling_fraction"), num("regret"));
        let expected = optimum * steps * (1.0 - fraction);
        assert!(
            (regret - expected).abs() < 1e-6 * expected.abs().max(1.0),
            "{row}: regret {regret}, {expected}"
        );
        if fraction.abs() > 1e-3 {
            ratios
                .entry((r["world"].to_string(), r["epsilon"].to_string()))
                .or_default()
                .push(ceiling / fraction);
        }
        checked += 1;
    }
    assert!(checked > 200, "only {checked} rows");
    for ((world, eps), rs) in &ratios {
        assert!(rs.iter().all(|x| (x - rs[0]).abs() < 1e-9 && *x > 1.0), "{world} ε {eps}: {rs:?}");
    }
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("| fraction of the ε-soft ceiling | regret (reward) |"), "{report}");
}

/// `--specs DIR` runs an edited copy of a figure's spec instead of the built-in one:
/// the learner comparison on another world with two learners, and Fig. 6 at another ε,
/// each with its report section; the report names the replaced specs.
#[test]
fn edited_figure_specs_give_the_figure_for_the_variant() {
    let d = tempfile::tempdir().unwrap();
    let specs = d.path().join("specs");
    std::fs::create_dir(&specs).unwrap();
    std::fs::write(
        specs.join("paper-comparison.toml"),
        "learner = [\"q\", \"deconv-q\"]\nq0 = 10\nsteps = 150000\nwindow = 2500\n\
         [[part]]\nworld = \"paper-5x5\"\ndelay = \"poisson:3\"\nepsilon = 0.1\nseeds = 2\n",
    )
    .unwrap();
    let f6 = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/worlds/sweeps/paper-fig6.toml"))
        .unwrap();
    std::fs::write(specs.join("paper-fig6.toml"), f6.replace("epsilon = 0.01\n", "epsilon = 0.05\n"))
        .unwrap();
    let out = d.path().join("report");
    let o = Command::new(env!("CARGO_BIN_EXE_mmq"))
        .args(["paper", "--quick", "--fig", "6,comparison", "--steps", "600", "-q", "--specs"])
        .arg(&specs)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        md.contains("replace the built-in ones of the same name: paper-fig6.toml, paper-comparison.toml"),
        "{md}"
    );
    assert!(md.contains("Setting of Fig. 6: ε = 0.05"), "{md}");
    let csv = std::fs::read_to_string(out.join("comparison.csv")).unwrap();
    // Two seeds in the spec are one in a quick run.
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    assert_eq!(rows.len(), 2, "{csv}");
    assert!(rows[0].starts_with("paper-5x5,poisson:3,0.1,q,false,1,"), "{csv}");
    assert!(rows[1].starts_with("paper-5x5,poisson:3,0.1,deconv-q,false,1,"), "{csv}");
    // The comparison's section is laid out from the settings that ran, not the shipped
    // study's: its world's headline table, its one delay and ε, its two learners.
    let section = &md[md.find("## The learner comparison").expect("the comparison's section")..];
    assert!(section.contains("\n### 5×5, Poisson λ = 3\n"), "{section}");
    assert!(section.contains("\n### paper-5x5: relative performance for every delay\n"), "{section}");
    assert!(section.contains("| learner | λ = 3 |"), "{section}");
    assert!(section.contains("\n| q | 0.1 | ") && section.contains("\n| deconv-q | 0.1 | "), "{section}");
    assert!(
        !section.contains("9×9") && !section.contains("maze") && !section.contains("| mmq |"),
        "{section}"
    );
}

/// Runs `mmq paper --fig 2,3,4` on a tiny budget with the given edited figure specs and
/// returns the report and the three figures' CSVs.
fn edited_early_figures(
    fig2_delays: &str,
    fig3_worlds: &str,
    fig4_hats: &str,
) -> (String, [Vec<HashMap<String, String>>; 3]) {
    let d = tempfile::tempdir().unwrap();
    let specs = d.path().join("specs");
    std::fs::create_dir(&specs).unwrap();
    let shipped = |name: &str| {
        std::fs::read_to_string(format!("{}/worlds/sweeps/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap()
    };
    let replace_line = |text: String, key: &str, value: &str| -> String {
        let mut out = String::new();
        let mut skipping = false;
        for line in text.lines() {
            if skipping {
                skipping = !line.starts_with(']');
                continue;
            }
            if line.starts_with(&format!("{key} = ")) {
                out.push_str(&format!("{key} = {value}\n"));
                skipping = line.ends_with('[');
                continue;
            }
            out.push_str(line);
            out.push('\n');
        }
        out
    };
    std::fs::write(
        specs.join("paper-fig2.toml"),
        replace_line(shipped("paper-fig2.toml"), "delay", fig2_delays),
    )
    .unwrap();
    std::fs::write(
        specs.join("paper-fig3.toml"),
        replace_line(shipped("paper-fig3.toml"), "world", fig3_worlds),
    )
    .unwrap();
    std::fs::write(
        specs.join("paper-fig4.toml"),
        replace_line(shipped("paper-fig4.toml"), "lambda_hat", fig4_hats),
    )
    .unwrap();
    let out = d.path().join("report");
    let o = Command::new(env!("CARGO_BIN_EXE_mmq"))
        .args(["paper", "--quick", "--fig", "2,3,4", "--seeds", "2", "--steps", "3000", "-q", "--specs"])
        .arg(&specs)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    (md, [csv(&out.join("fig2.csv")), csv(&out.join("fig3.csv")), csv(&out.join("fig4.csv"))])
}

/// A CSV row's mean as the report prints it: "—" where it is absent (NaN).
fn shown(row: &HashMap<String, String>) -> String {
    if row["mean"] == "NaN" { "—".to_string() } else { pct(&row["mean"], &row["ci95"]) }
}

fn column(rows: &[HashMap<String, String>], key: &str) -> Vec<String> {
    let mut v: Vec<String> = Vec::new();
    for r in rows {
        if v.last() != Some(&r[key]) {
            v.push(r[key].clone());
        }
    }
    v
}

/// Figs. 2–4 from edited specs with fewer settings than the paper's: every label is the
/// setting's own value (λ, the world's size, λ̂ and i), in the plan's order.
#[test]
fn edited_early_figures_with_fewer_settings_are_labelled_by_their_values() {
    let (md, [f2, f3, f4]) = edited_early_figures(
        r#"["poisson:0", "poisson:5", "poisson:10", "poisson:15", "poisson:20"]"#,
        r#"["paper-9x9", "paper-3x3"]"#,
        "[15, 17, 19]",
    );
    assert_eq!(column(&f2, "lambda"), ["0", "5", "10", "15", "20"]);
    // The paper's reference points that ran are the table's rows, with the CSV's values.
    for l in ["0", "10", "20"] {
        let row = f2.iter().find(|r| r["lambda"] == l).unwrap();
        let line = md
            .lines()
            .find(|x| x.starts_with(&format!("| {l} |")))
            .unwrap_or_else(|| panic!("λ = {l}: {md}"));
        assert!(line.ends_with(&format!("| {} |", shown(row))), "{line}");
    }
    assert!(!md.lines().any(|x| x.starts_with("| 3 |")), "λ = 3 did not run: {md}");
    assert_eq!(column(&f3, "world"), ["9×9", "3×3"]);
    assert!(
        md.contains("| 9×9 | falls with size | ≈ 1 % |") && md.contains("| 3×3 | falls with size | ≈ 85 % |")
    );
    assert_eq!(column(&f4, "i"), ["-2", "0", "2"]);
    assert_eq!(column(&f4, "lambda_hat"), ["15", "17", "19"]);
    let last = shown(&f4[2]);
    assert!(md.contains(&format!("| i = +2 | — | — | {last} |")), "{md}");
    assert!(md.contains("| i = −2 | — | — |"), "{md}");
}

/// The same with more settings than the paper's: a longer λ range, a fourth world, a
/// wider λ̂ range.
#[test]
fn edited_early_figures_with_more_settings_are_labelled_by_their_values() {
    let delays: Vec<String> = (0..=20).map(|k| format!("\"poisson:{}\"", 2 * k)).collect();
    let (md, [f2, f3, f4]) = edited_early_figures(
        &format!("[{}]", delays.join(", ")),
        r#"["paper-3x3", "paper-5x5", "paper-9x9", "corridor-7x3"]"#,
        &format!("[{}]", (5..=29).map(|k| k.to_string()).collect::<Vec<_>>().join(", ")),
    );
    let want: Vec<String> = (0..=20).map(|k| (2 * k).to_string()).collect();
    assert_eq!(column(&f2, "lambda"), want);
    let row = f2.iter().find(|r| r["lambda"] == "20").unwrap();
    let line = md.lines().find(|x| x.starts_with("| 20 | lowest |")).unwrap();
    assert!(line.ends_with(&format!("| {} |", shown(row))), "{line}");
    assert!(!md.lines().any(|x| x.starts_with("| 3 |")), "λ = 3 did not run: {md}");
    assert_eq!(column(&f3, "world"), ["3×3", "5×5", "9×9", "7×3"]);
    // The paper's worlds are 3×3, 5×5 and 9×9: it has no value for a fourth.
    assert!(md.contains("| 7×3 | — | — |"), "{md}");
    let is: Vec<String> = (-12..=12).map(|i: i64| i.to_string()).collect();
    assert_eq!(column(&f4, "i"), is);
    assert_eq!(f4.last().unwrap()["lambda_hat"], "29");
    assert!(md.contains("| i = −12 | — | — |") && md.contains("| i = +12 | — | — |"), "{md}");
}
