//! Writes one of every figure type, on synthetic data shaped like the paper's figures, to
//! a directory (default `/tmp/plot-check`) for a visual check:
//! `cargo run -p mmq-plot --example gallery -- [DIR]`.

use std::path::PathBuf;

use mmq_core::World;
use mmq_plot::{
    ARROW_N, ARROW_W, ActionProbabilities, GridHeatmap, LineChart, PolicyArrows, RefLine, Series,
};

fn world(name: &str) -> World {
    World::load(format!("{}/../../worlds/{name}.toml", env!("CARGO_MANIFEST_DIR"))).expect("shipped world")
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "/tmp/plot-check".into()));
    std::fs::create_dir_all(&dir)?;
    let mut written = Vec::new();

    // Fig. 2: relative performance vs mean delay λ, mean ± 95 % CI over seeds.
    let lambdas: Vec<f64> = (0..=10).map(f64::from).collect();
    let perf: Vec<f64> = lambdas.iter().map(|l| (-l / 3.0).exp()).collect();
    let ci: Vec<f64> = lambdas.iter().map(|l| 0.03 + 0.01 * l).collect();
    let mut c = LineChart::new(
        "Effect of the mean delay λ (3×3 world)",
        "mean delay λ (steps)",
        "relative performance",
    );
    c.series.push(
        Series::new("Q-learning", lambdas.clone(), perf.clone())
            .with_band(
                perf.iter().zip(&ci).map(|(p, c)| p - c).collect(),
                perf.iter().zip(&ci).map(|(p, c)| p + c).collect(),
            )
            .with_markers(),
    );
    c.ref_lines.push(RefLine::new("undelayed Q-learning", 1.0));
    written.extend(c.write(&dir.join("fig2-lambda"))?);

    // Fig. 6: relative performance over time, two learners, with bands.
    // One point per time step, with deterministic pseudo-noise: exercises decimation.
    let t: Vec<f64> = (1..=150_000).map(f64::from).collect();
    let noise = |t: f64| ((t * 12.9898).sin() * 43_758.545).fract() * 0.04;
    let mmq: Vec<f64> = t.iter().map(|t| 0.95 * (1.0 - (-t / 20_000.0).exp()) + noise(*t)).collect();
    let q: Vec<f64> = t.iter().map(|t| 0.02 * (t / 150_000.0).sin()).collect();
    let band = |v: &[f64], w: f64| -> (Vec<f64>, Vec<f64>) {
        (v.iter().map(|x| x - w).collect(), v.iter().map(|x| x + w).collect())
    };
    let (ml, mh) = band(&mmq, 0.04);
    let (ql, qh) = band(&q, 0.03);
    let mut c = LineChart::new(
        "Multiple-model vs single-model Q-learning, 9×9, λ = 13",
        "time step",
        "relative performance",
    );
    c.series.push(Series::new("multiple-model Q (λ̂ ≤ 50)", t.clone(), mmq).with_band(ml, mh));
    c.series.push(Series::new("Q-learning", t.clone(), q).with_band(ql, qh));
    c.ref_lines.push(RefLine::new("undelayed Q-learning", 1.0));
    c.ref_lines.push(RefLine::new("optimum", 10.0 / 17.0 / 0.55));
    written.extend(c.write(&dir.join("fig6-time"))?);

    // Fig. 4: performance vs delay-estimate error i.
    let i: Vec<f64> = (-10..=10).map(f64::from).collect();
    let p: Vec<f64> = i.iter().map(|i| 0.9 * (-(i * i) / 18.0).exp() + 0.05).collect();
    let mut c = LineChart::new(
        "Fixed-delay Q-learning, 9×9, λ = 17",
        "estimate error i = λ̂ − λ (steps)",
        "relative performance",
    );
    c.series.push(
        Series::new("fixed-delay Q", i.clone(), p.clone())
            .with_band(p.iter().map(|v| v - 0.06).collect(), p.iter().map(|v| v + 0.06).collect())
            .with_markers(),
    );
    c.series.push(Series::new("Q-learning", i.clone(), vec![0.02; i.len()]).with_markers());
    c.y_range = Some((-0.1, 1.1));
    written.extend(c.write(&dir.join("fig4-error"))?);

    // Earned vs received reward, log x and many series.
    let t: Vec<f64> = (0..=60).map(|k| 10f64.powf(1.0 + f64::from(k) / 12.0)).collect();
    let mut c = LineChart::new("Cumulative reward", "time step (log scale)", "cumulative reward");
    for (k, name) in [
        "earned, MMQ",
        "received, MMQ",
        "earned, Q",
        "received, Q",
        "earned, oracle",
        "received, oracle",
        "extra",
    ]
    .iter()
    .enumerate()
    {
        let f = 0.58 - 0.07 * k as f64;
        c.series.push(Series::new(*name, t.clone(), t.iter().map(|t| f * t - 13.0 * f).collect()));
    }
    c.x_log = true;
    written.extend(c.write(&dir.join("reward-logx"))?);

    // Degenerate chart.
    let mut c = LineChart::new("Empty", "x", "y");
    c.series.push(Series::new("nothing", vec![], vec![]));
    written.extend(c.write(&dir.join("empty"))?);

    // Gaps, a fixed y range that clips, a lone point, all-NaN series.
    let nan = f64::NAN;
    let mut c = LineChart::new("Gaps and clipping", "x (steps)", "y");
    c.series.push(Series::new(
        "gaps",
        (0..12).map(f64::from).collect(),
        vec![0.1, 0.5, 0.9, nan, 0.4, nan, 0.2, 0.6, 1.4, 0.7, 0.3, -0.5],
    ));
    c.series.push(Series::new("all NaN", vec![nan; 3], vec![nan; 3]));
    c.y_range = Some((0.0, 1.0));
    written.extend(c.write(&dir.join("gaps"))?);

    // Data in every corner: the legend goes outside, right of the plot.
    let x: Vec<f64> = (0..200).map(|k| f64::from(k) / 10.0).collect();
    let mut c = LineChart::new("Dense data", "time (s)", "signal (a.u.)");
    for (k, name) in ["sin", "cos", "sin 2x"].iter().enumerate() {
        let f = 1.0 + k as f64 * 0.7;
        c.series.push(Series::new(*name, x.clone(), x.iter().map(|t| (f * t).sin()).collect()));
    }
    written.extend(c.write(&dir.join("dense"))?);

    // Fig. 7: visits, 9×9.
    let w9 = world("paper-9x9");
    let visits: Vec<f64> = (0..81)
        .map(|c| {
            let (r, col) = w9.row_col(c);
            let d = (r as f64 - col as f64).abs();
            2000.0 * (-d / 1.5).exp() + 30.0 + 5.0 * (r + col) as f64
        })
        .collect();
    written.extend(
        GridHeatmap::new("How often each state is visited (MMQ)", &w9, visits.clone(), "visits")
            .write(&dir.join("fig7-visits"))?,
    );
    written.extend(
        GridHeatmap::new(
            "Visits, log scale",
            &w9,
            visits.iter().enumerate().map(|(i, v)| if i % 10 == 3 { 0.0 } else { v * v / 10.0 }).collect(),
            "visits",
        )
        .log()
        .write(&dir.join("fig7-visits-log"))?,
    );

    // Maze with blocked cells and a no-data cell.
    let maze = world("maze-15x15");
    let mut vals: Vec<f64> = (0..maze.num_cells()).map(|c| (c % 17) as f64 * 12.5).collect();
    vals[maze.index(1, 1)] = f64::NAN;
    written.extend(
        GridHeatmap::new("Visits in the 15×15 maze", &maze, vals, "visits")
            .write(&dir.join("maze-visits"))?,
    );

    // Fig. 8: deterministic policy, up/left towards G with ties, greedy path.
    let arrows: Vec<u8> = (0..81)
        .map(|c| {
            let (r, col) = w9.row_col(c);
            match (r == 0, col == 0) {
                (true, true) => 0b1111,
                (true, false) => ARROW_W,
                (false, true) => ARROW_N,
                _ if r == col => ARROW_N | ARROW_W,
                _ if r > col => ARROW_N,
                _ => ARROW_W,
            }
        })
        .collect();
    let path: Vec<usize> =
        (0..9).rev().flat_map(|k| [w9.index(k, k), w9.index(k.saturating_sub(1), k)]).collect();
    written.extend(
        PolicyArrows::new("Deterministic policy (MMQ)", &w9, arrows)
            .with_path(path)
            .write(&dir.join("fig8-policy"))?,
    );

    // Maze policy: arrows everywhere (all ties in the corridor).
    let maze_arrows: Vec<u8> = (0..maze.num_cells()).map(|c| 1 << (c % 4)).collect();
    written.extend(PolicyArrows::new("Maze policy", &maze, maze_arrows).write(&dir.join("maze-policy"))?);

    // Fig. 9: probabilistic policy.
    let probs: Vec<[f64; 4]> = (0..81)
        .map(|c| {
            let (r, col) = w9.row_col(c);
            let up: f64 = if r > col { 0.7 } else { 0.15 };
            let left = if col >= r { 0.7 } else { 0.15 };
            let rest = (1.0 - up - left).max(0.0) / 2.0;
            [up, rest, rest, left]
        })
        .collect();
    written.extend(
        ActionProbabilities::new("Probabilistic policy (MMQ)", &w9, probs).write(&dir.join("fig9-probs"))?,
    );
    let w3 = world("paper-3x3");
    let mut p3 = vec![[0.25; 4]; 9];
    p3[4] = [f64::NAN, 0.5, 0.5, 0.0];
    written.extend(ActionProbabilities::new("3×3, uniform", &w3, p3).write(&dir.join("probs-3x3"))?);

    // A one-row strip: wide and flat.
    let strip = mmq_plot::PolicyArrows {
        title: "Corridor".into(),
        grid: mmq_plot::GridLayout::open(12, 1),
        arrows: (0..12).map(|c| 1 << (c % 4)).collect(),
        highlight_path: vec![],
    };
    written.extend(strip.write(&dir.join("strip"))?);
    let corridor = world("corridor-7x3");
    let n = corridor.num_cells();
    written.extend(
        GridHeatmap::new("Corridor, constant values", &corridor, vec![42.0; n], "visits")
            .write(&dir.join("corridor-const"))?,
    );

    for p in written {
        println!("{}", p.display());
    }
    Ok(())
}
