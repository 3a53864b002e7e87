//! Run outputs, each written atomically (temp file + rename, so a kill at any instant
//! leaves the old file or the new one, and a failed write leaves no temporary file):
//! `config.toml` before the run, then `metrics.csv`, `policy.csv`, the Q-tables as `.npy`
//! and, last, `summary.json`, so that a summary saying "complete" speaks for every output.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use mmq_core::World;
use mmq_learn::Table;

use crate::config::RunConfig;
use crate::error::LabError;
use crate::runner::SeedResult;
use crate::summary::Summary;

/// Writes `bytes` to `path` atomically ([`mmq_core::files::write_atomic`]), creating its
/// folder if needed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), LabError> {
    let io = |source| LabError::Io { path: path.to_path_buf(), source };
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(io)?;
    }
    mmq_core::files::write_atomic(path, bytes).map_err(io)
}

/// A CSV field as every CSV of mmq writes it: quoted (RFC 4180) when it holds a comma,
/// a quote or a line break, or starts or ends with a space; as it is otherwise.
pub fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) || s.starts_with(' ') || s.ends_with(' ') {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// A number as a CSV field: Rust's shortest round-trip form, `inf`/`-inf`, and empty for
/// NaN (an absent value).
pub fn csv_number(x: f64) -> String {
    if x.is_nan() { String::new() } else { x.to_string() }
}

/// The folder of a report that holds its studies' stores (`mmq paper`'s `runs/`).
pub const RUNS: &str = "runs";

/// What kind of output a folder holds, for [`claim_out_dir`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutKind {
    /// `mmq run`: config, summary, metrics, policy, tables, recordings.
    Run,
    /// `mmq paper`: a report with figures and CSVs, and its studies' stores in `runs/`
    /// (kept: the same command again resumes from them).
    Report,
}

impl OutKind {
    /// Whether `name` is a file this kind of output writes (or a temporary file of one).
    fn owns(self, name: &str) -> bool {
        let ext = name.rsplit_once('.').map_or("", |(_, e)| e);
        if name.starts_with('.') && name.contains(".tmp") {
            return true;
        }
        match self {
            OutKind::Run => {
                matches!(name, "config.toml" | "summary.json" | "metrics.csv" | "policy.csv")
                    || (name.contains("_seed") && ext == "npy")
                    || (name.starts_with("trajectory-seed") && ext == "mcap")
            }
            OutKind::Report => name == "report.md" || matches!(ext, "svg" | "png" | "csv"),
        }
    }

    /// Whether `name` is a folder this kind of output keeps from one run to the next.
    fn keeps(self, name: &str) -> bool {
        self == OutKind::Report && name == RUNS
    }
}

/// Makes `dir` ready for a new output of `kind`: creates it, or, when it holds a previous
/// output of the same kind, removes that output's files, so that no file of an earlier
/// run is left beside the new one. A folder holding any other file is refused
/// ([`LabError::OutDirInUse`]) and left untouched. Returns how many files were removed.
pub fn claim_out_dir(dir: &Path, kind: OutKind) -> Result<usize, LabError> {
    let io = |source| LabError::Io { path: dir.to_path_buf(), source };
    std::fs::create_dir_all(dir).map_err(io)?;
    let mut ours = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(io)? {
        let entry = entry.map_err(io)?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if crate::lock::is_lock_file(&name) {
            // The folder's lock (held by the caller): neither an output nor foreign.
            continue;
        }
        let is_file = entry.file_type().map_err(io)?.is_file();
        if entry.file_type().map_err(io)?.is_dir() && kind.keeps(&name) {
            continue;
        }
        if !is_file || !kind.owns(&name) {
            return Err(LabError::OutDirInUse {
                path: dir.to_path_buf(),
                example: if is_file { name } else { format!("{name}/") },
            });
        }
        ours.push(entry.path());
    }
    for p in &ours {
        std::fs::remove_file(p).map_err(|source| LabError::Io { path: p.clone(), source })?;
    }
    Ok(ours.len())
}

/// Saves the resolved configuration (before the run starts).
pub fn write_config(dir: &Path, cfg: &RunConfig) -> Result<PathBuf, LabError> {
    let p = dir.join("config.toml");
    write_atomic(&p, cfg.to_toml().as_bytes())?;
    Ok(p)
}

/// Writes the summary as pretty JSON.
pub fn write_summary(dir: &Path, s: &Summary) -> Result<PathBuf, LabError> {
    let p = dir.join("summary.json");
    let text = serde_json::to_string_pretty(s).unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}"));
    write_atomic(&p, text.as_bytes())?;
    Ok(p)
}

/// Column names of `metrics.csv`.
pub const METRICS_COLUMNS: &str = "seed,step,reward/earned,reward/received,reward/earned_cum,reward/received_cum,baseline/earned_cum,perf/relative";

/// Learning curves of every seed, one row per window. Environments with summary figures
/// (the robot's `Telemetry::stats`) add one column per figure, `env/<name>`, holding the
/// seed's value for the whole run on each of its rows.
pub fn metrics_csv(results: &[SeedResult]) -> String {
    let mut out = String::from(METRICS_COLUMNS);
    let env_keys: Vec<&str> = results
        .iter()
        .find(|r| !r.env_stats.is_empty())
        .map_or(Vec::new(), |r| r.env_stats.iter().map(|(k, _)| k.as_str()).collect());
    for k in &env_keys {
        let _ = write!(out, ",env/{k}");
    }
    out.push('\n');
    for r in results {
        let env_cells: String = env_keys
            .iter()
            .map(|k| {
                let v = r.env_stats.iter().find(|(n, _)| n == k).map(|(_, v)| *v);
                format!(",{}", v.map_or(String::new(), |v| v.to_string()))
            })
            .collect();
        for (i, row) in r.run.curve.iter().enumerate() {
            let base = r.baseline.as_ref().and_then(|b| b.curve.get(i)).map(|b| b.earned_cum);
            let rel = base.filter(|&b| b > 0.0).map(|b| row.earned_cum / b);
            let _ = writeln!(
                out,
                "{},{},{},{},{},{},{},{}{env_cells}",
                r.seed,
                row.step,
                row.earned,
                row.received,
                row.earned_cum,
                row.received_cum,
                base.map_or(String::new(), |b| b.to_string()),
                rel.map_or(String::new(), |x| x.to_string())
            );
        }
    }
    out
}

/// Per-state visits, values and policies of every seed.
pub fn policy_csv(world: &World, results: &[SeedResult]) -> String {
    let mut out = String::from("seed,state,row,col,free,visits,value,greedy,p_N,p_E,p_S,p_W\n");
    let names = ["N", "E", "S", "W"];
    for r in results {
        for s in 0..r.policy_arrows.len() {
            let cell = s.min(world.num_cells() - 1);
            let (row, col) = world.row_col(cell);
            let greedy: String = names
                .iter()
                .enumerate()
                .filter(|(a, _)| r.policy_arrows[s] & (1 << a) != 0)
                .map(|x| *x.1)
                .collect();
            let p = &r.policy_probs[s];
            let pr = |a: usize| p.get(a).map_or(String::new(), |x| x.to_string());
            let _ = writeln!(
                out,
                "{},{s},{row},{col},{},{},{},{greedy},{},{},{},{}",
                r.seed,
                u8::from(world.is_free(cell)),
                r.run.visits.get(s).copied().unwrap_or(0),
                if r.values[s].is_finite() { r.values[s].to_string() } else { String::new() },
                pr(0),
                pr(1),
                pr(2),
                pr(3)
            );
        }
    }
    out
}

/// A table as a NumPy `.npy` file (format 1.0, little-endian float64, C order), so
/// `numpy.load` reads it with no code of ours.
pub fn npy_bytes(t: &Table) -> Vec<u8> {
    let shape = match t.shape.len() {
        1 => format!("({},)", t.shape[0]),
        _ => format!("({})", t.shape.iter().map(|d| d.to_string()).collect::<Vec<_>>().join(", ")),
    };
    let mut header = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': {shape}, }}");
    // Magic (6) + version (2) + length (2) + header + '\n' is a multiple of 64.
    let total = 10 + header.len() + 1;
    header.push_str(&" ".repeat((64 - total % 64) % 64));
    header.push('\n');
    let mut out = Vec::with_capacity(10 + header.len() + t.data.len() * 8);
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    for x in &t.data {
        out.extend_from_slice(&x.to_le_bytes());
    }
    out
}

/// Writes every output of a finished (or interrupted) run; `stop` cuts the summary short
/// (see [`Summary::new_until`]).
pub fn write_results(
    dir: &Path,
    cfg: &RunConfig,
    world: &World,
    results: &[SeedResult],
    complete: bool,
    stop: &dyn Fn() -> bool,
) -> Result<(Summary, Vec<PathBuf>), LabError> {
    let summary = Summary::new_until(cfg, world, results, complete, stop);
    let mut files = Vec::new();
    let p = dir.join("metrics.csv");
    write_atomic(&p, metrics_csv(results).as_bytes())?;
    files.push(p);
    let p = dir.join("policy.csv");
    write_atomic(&p, policy_csv(world, results).as_bytes())?;
    files.push(p);
    for r in results {
        for t in &r.tables {
            let p = dir.join(format!("{}_seed{}.npy", t.name, r.seed));
            write_atomic(&p, &npy_bytes(t))?;
            files.push(p);
        }
    }
    // The summary last: once it says "complete", every other output is in place.
    files.push(write_summary(dir, &summary)?);
    Ok((summary, files))
}

/// What [`run_into`] did.
#[derive(Debug)]
pub struct RunWritten {
    /// The summary written last.
    pub summary: Summary,
    /// Whether the stop flag cut the run short (the summary then says partial).
    pub interrupted: bool,
    /// One message per seed that lost output it should have written (a recording that
    /// could not be written); the summary then says incomplete. See [`RunWritten::check`].
    pub lost: Vec<String>,
}

impl RunWritten {
    /// An error when a seed lost output: written results are never a complete run
    /// unless every file of every seed is in place.
    pub fn check(&self, dir: &Path) -> Result<(), LabError> {
        if self.lost.is_empty() {
            Ok(())
        } else {
            Err(LabError::LostOutput { dir: dir.to_path_buf(), lost: self.lost.clone() })
        }
    }
}

/// A whole run into `dir`, as `mmq run` and Python's `mmq.run` do it: takes the folder's
/// lock ([`crate::lock`]: a folder another process writes into is refused) and claims
/// the folder (`claimed` hears how many files of an earlier run it replaces), writes
/// `config.toml`, runs every seed with `observers`, then writes the results, the summary
/// last, and gives the lock back.
pub fn run_into(
    dir: &Path,
    run: &crate::Resolved,
    observers: &crate::runner::ObserverFactory<'_>,
    ctl: crate::runner::Control<'_>,
    claimed: &dyn Fn(usize),
) -> Result<RunWritten, LabError> {
    // What the run would refuse (a robot configuration, tables that do not fit) was
    // refused when it was resolved, before the folder is touched.
    let (cfg, world) = (run.cfg(), run.world());
    let _lock = crate::lock::lock_out_dir(dir)?;
    claimed(claim_out_dir(dir, OutKind::Run)?);
    write_config(dir, cfg)?;
    let outcome = crate::exec::run_all(run, observers, ctl)?;
    let lost = outcome.failures().into_iter().map(str::to_string).collect();
    let stopped = || ctl.stop.load(std::sync::atomic::Ordering::Relaxed);
    let (summary, _) = write_results(dir, cfg, world, &outcome.results, !outcome.interrupted, &stopped)?;
    // A stop during the summary leaves it without its ceiling, and incomplete.
    let interrupted = outcome.interrupted || !summary.complete;
    Ok(RunWritten { summary, interrupted, lost })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_quotes_and_numbers() {
        assert_eq!(csv_field("hist:1,2"), "\"hist:1,2\"");
        assert_eq!(csv_field("say \"hi\""), "\"say \"\"hi\"\"\"");
        assert_eq!(csv_field("poisson:3"), "poisson:3");
        assert_eq!(csv_number(f64::NAN), "");
        assert_eq!(csv_number(0.1), "0.1");
        assert_eq!(csv_number(f64::NEG_INFINITY), "-inf");
    }

    #[test]
    fn npy_header_is_aligned_and_data_follows() {
        let t = Table { name: "q".into(), shape: vec![2, 3], data: vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.5] };
        let b = npy_bytes(&t);
        let hlen = u16::from_le_bytes([b[8], b[9]]) as usize;
        assert_eq!((10 + hlen) % 64, 0);
        let header = std::str::from_utf8(&b[10..10 + hlen]).unwrap();
        assert!(header.contains("'shape': (2, 3)") && header.ends_with('\n'));
        assert_eq!(b.len(), 10 + hlen + 48);
        assert_eq!(f64::from_le_bytes(b[b.len() - 8..].try_into().unwrap()), 5.5);
    }

    #[test]
    fn a_previous_run_is_replaced_and_foreign_files_are_kept() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("run");
        assert_eq!(claim_out_dir(&out, OutKind::Run).unwrap(), 0);
        for f in ["config.toml", "summary.json", "q_seed7.npy", "trajectory-seed7.mcap", ".x.tmp12"] {
            std::fs::write(out.join(f), "old").unwrap();
        }
        assert_eq!(claim_out_dir(&out, OutKind::Run).unwrap(), 5);
        assert_eq!(std::fs::read_dir(&out).unwrap().count(), 0);
        std::fs::write(out.join("notes.txt"), "mine").unwrap();
        std::fs::write(out.join("summary.json"), "old").unwrap();
        let e = claim_out_dir(&out, OutKind::Run).unwrap_err();
        assert!(e.to_string().contains("notes.txt"), "{e}");
        assert!(out.join("summary.json").is_file(), "nothing is removed when the folder is refused");
        // A report folder is not a run folder.
        let rep = d.path().join("rep");
        std::fs::create_dir_all(&rep).unwrap();
        std::fs::write(rep.join("fig2.png"), "old").unwrap();
        assert_eq!(claim_out_dir(&rep, OutKind::Report).unwrap(), 1);
        std::fs::write(rep.join("q_seed0.npy"), "old").unwrap();
        assert!(claim_out_dir(&rep, OutKind::Report).is_err());
    }

    #[test]
    fn atomic_write_replaces_whole_files() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("sub/x.txt");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "two");
        assert_eq!(std::fs::read_dir(d.path().join("sub")).unwrap().count(), 1);
    }
}
