//! Run outputs, each written atomically (temp file + rename, so a kill at any instant
//! leaves the old file or the new one): `config.toml` before the run, then
//! `summary.json`, `metrics.csv`, `policy.csv` and the Q-tables as `.npy`.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use mmq_core::World;
use mmq_learn::Table;

use crate::config::RunConfig;
use crate::error::LabError;
use crate::runner::SeedResult;
use crate::summary::Summary;

/// Writes `bytes` to `path` atomically.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), LabError> {
    let io = |source| LabError::Io { path: path.to_path_buf(), source };
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(io)?;
    }
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.tmp{}", std::process::id()));
    let mut f = std::fs::File::create(&tmp).map_err(io)?;
    f.write_all(bytes).map_err(io)?;
    f.sync_all().map_err(io)?;
    drop(f);
    std::fs::rename(&tmp, path).map_err(io)
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
/// (the robot's `Env::stats`) add one column per figure, `env/<name>`, holding the
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

/// Writes every output of a finished (or interrupted) run.
pub fn write_results(
    dir: &Path,
    cfg: &RunConfig,
    world: &World,
    results: &[SeedResult],
    complete: bool,
) -> Result<(Summary, Vec<PathBuf>), LabError> {
    let summary = Summary::new(cfg, world, results, complete);
    let mut files = vec![write_summary(dir, &summary)?];
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
    Ok((summary, files))
}

#[cfg(test)]
mod tests {
    use super::*;

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
    fn atomic_write_replaces_whole_files() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("sub/x.txt");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "two");
        assert_eq!(std::fs::read_dir(d.path().join("sub")).unwrap().count(), 1);
    }
}
