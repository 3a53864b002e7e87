//! `mmq paper --quick --fig all` end to end: every file the report names exists, and the
//! report's numbers are the CSVs' numbers.

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
