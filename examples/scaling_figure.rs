//! Draws how `deconv-model`'s cost grows with the world from the measurements of
//! `tools/scaling.sh`: steps per CPU-second and peak memory against the number of
//! state-action pairs, one series per construction the CSV holds (the defaults, the visit
//! count, the cheaper refits).
//!
//! ```sh
//! bash tools/scaling.sh > docs/performance/scaling.csv
//! cargo run --release --example scaling_figure -- docs/performance/scaling.csv docs/performance
//! ```
//!
//! Writes `scaling-speed.{svg,png}` and `scaling-memory.{svg,png}` into the folder.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use mmq_plot::{LineChart, Series};

/// One row of the CSV: the construction, the pairs, steps per CPU-second, peak RSS in MB.
struct Row {
    construction: String,
    pairs: f64,
    steps_per_s: f64,
    rss_mb: f64,
}

/// Reads the CSV of `tools/scaling.sh` (at most 1 MB), naming the file, line and field of
/// anything it cannot read.
fn read_rows(path: &Path) -> Result<Vec<Row>, String> {
    let meta = std::fs::metadata(path).map_err(|e| format!("{}: {e}", path.display()))?;
    if meta.len() > 1 << 20 {
        return Err(format!(
            "{}: {} bytes, more than the 1 MB a measurement table takes",
            path.display(),
            meta.len()
        ));
    }
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let column = |name: &str| {
        header.iter().position(|h| *h == name).ok_or_else(|| {
            format!(
                "{}: no column `{name}` in the header; make the file with tools/scaling.sh",
                path.display()
            )
        })
    };
    let (c, p, s, m) =
        (column("construction")?, column("pairs")?, column("steps_per_cpu_s")?, column("peak_rss_mb")?);
    let mut rows = Vec::new();
    for (i, line) in lines.enumerate().filter(|(_, l)| !l.trim().is_empty()) {
        let fields: Vec<&str> = line.split(',').collect();
        let number = |k: usize, name: &str| -> Result<f64, String> {
            let text = fields.get(k).copied().unwrap_or("");
            text.trim()
                .parse::<f64>()
                .map_err(|_| format!("{} line {}: `{name}` is {text:?}, not a number", path.display(), i + 2))
        };
        rows.push(Row {
            construction: fields.get(c).copied().unwrap_or("").to_string(),
            pairs: number(p, "pairs")?,
            steps_per_s: number(s, "steps_per_cpu_s")?,
            rss_mb: number(m, "peak_rss_mb")?,
        });
    }
    if rows.is_empty() {
        return Err(format!("{}: no measurements below the header", path.display()));
    }
    Ok(rows)
}

/// One chart of `value` against the pairs, a series per construction in the order met.
fn chart(rows: &[Row], title: &str, y_label: &str, value: fn(&Row) -> f64) -> LineChart {
    let mut chart = LineChart::new(title, "state-action pairs (log scale)", y_label);
    chart.x_log = true;
    let mut names: Vec<&str> = Vec::new();
    for r in rows {
        if !names.contains(&r.construction.as_str()) {
            names.push(&r.construction);
        }
    }
    for name in names {
        let mine: Vec<&Row> = rows.iter().filter(|r| r.construction == name).collect();
        let label = format!("deconv-model, {}", name.replace('-', " "));
        chart.series.push(
            Series::new(
                label,
                mine.iter().map(|r| r.pairs).collect(),
                mine.iter().map(|r| value(r)).collect(),
            )
            .with_markers(),
        );
    }
    chart
}

fn run(csv: &Path, dir: &Path) -> Result<Vec<PathBuf>, String> {
    let rows = read_rows(csv)?;
    let mut files =
        chart(&rows, "Speed as the world grows", "thousand steps per CPU-second", |r| r.steps_per_s / 1e3)
            .write(&dir.join("scaling-speed"))
            .map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut memory = chart(&rows, "Memory as the world grows", "peak resident memory (MB)", |r| r.rss_mb);
    memory.y_range = Some((0.0, rows.iter().map(|r| r.rss_mb).fold(0.0, f64::max) * 1.1));
    files.extend(memory.write(&dir.join("scaling-memory")).map_err(|e| format!("{}: {e}", dir.display()))?);
    Ok(files)
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [csv, dir] = args.as_slice() else {
        eprintln!("usage: scaling_figure SCALING.csv OUT_DIR (the CSV of tools/scaling.sh)");
        return ExitCode::from(2);
    };
    match run(Path::new(csv), Path::new(dir)) {
        Ok(files) => {
            for f in files {
                println!("wrote {}", f.display());
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
