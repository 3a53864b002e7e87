//! Stored results: `sweep.json` (the manifest), one file per finished job, written
//! by rename so that readers never see a part, and read back bit for bit.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::plan::{Plan, Shard};
use super::record::SeedRecord;
use super::spec::SweepSpec;
use super::stats::is_result_metric;
use super::{FORMAT, MAX_JOB_BYTES, MAX_MANIFEST_BYTES, Metrics};
use crate::error::LabError;
use crate::metric::{MetricId, MetricKind};
use crate::output::{csv_field, csv_number, write_atomic};

/// `sweep.json`: the plan and the status of one output directory.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// [`FORMAT`].
    pub format: String,
    /// Version of mmq that wrote it.
    pub mmq_version: String,
    /// The spec file as given on the command line (`merged` after a merge).
    pub spec_file: String,
    /// `K/N` when this directory holds one shard.
    pub shard: Option<String>,
    /// Jobs of the whole sweep.
    pub jobs_total: usize,
    /// Jobs this directory is responsible for (its shard, or all).
    pub jobs_here: usize,
    /// Of those, finished.
    pub done: usize,
    /// Whether every job this directory is responsible for is finished.
    pub complete: bool,
    /// Cells and seeds.
    pub plan: Plan,
}

/// One finished job, `cells/<cell-id>/seed-<n>.json`. Metric values are stored as text
/// in Rust's shortest round-trip form (`NaN`, `inf` included), so they read back bit
/// for bit; the `seed` metric is the job's seed as an integer (exact up to 2^64 − 1).
/// A job whose learner failed ([`mmq_learn::Learner::failure`]) is finished too: its
/// metrics are `seed` and `failed` (1), and `error` says why. Metrics with a step
/// ([`MetricId`]) are stored apart with their step as a number: the learning curve's
/// points as `[step, value]` and the learner's sampled figures as `[name, step, value]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct StoredJob {
    format: String,
    mmq_version: String,
    cell: String,
    seed: u64,
    params: BTreeMap<String, String>,
    metrics: BTreeMap<String, String>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    curve: Vec<(u64, String)>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    samples: Vec<(String, u64, String)>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    error: Option<String>,
    /// The seed's record, when the spec keeps them ([`SweepSpec::with_records`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    record: Option<SeedRecord>,
}

/// A number as a job file stores it: Rust's shortest round-trip text (`NaN`, `inf`).
pub(crate) fn encode(x: f64) -> String {
    if x.is_nan() { "NaN".into() } else { x.to_string() }
}

/// Reads job `j`'s file in `dir` if it is there and belongs to this plan's cell.
pub(super) fn read_job(dir: &Path, plan: &Plan, j: usize) -> Option<Metrics> {
    read_stored(dir, plan, j).and_then(|s| metrics_of(&s))
}

fn metrics_of(s: &StoredJob) -> Option<Metrics> {
    let number = |v: &str| v.parse::<f64>().ok();
    let named = s.metrics.iter().map(|(k, v)| Some((legacy_id(k), number(v)?)));
    let curve = s.curve.iter().map(|(t, v)| Some((MetricId::curve(*t), number(v)?)));
    let samples = s.samples.iter().map(|(k, t, v)| Some((MetricId::at(k, *t), number(v)?)));
    named.chain(curve).chain(samples).collect()
}

/// The id of a metric stored by name. Job files written by versions before metric ids
/// were typed hold the curve's points and the learner's samples among the named
/// metrics (`curve/2500`, `delay/median_est@10000`); those alone are read from their
/// text, so that their stores still report their curves.
fn legacy_id(name: &str) -> MetricId {
    let step = |t: &str| t.parse::<u64>().ok().filter(|_| t.bytes().all(|b| b.is_ascii_digit()));
    if let Some(t) = name.strip_prefix("curve/").and_then(step) {
        return MetricId::curve(t);
    }
    if let Some((k, t)) = name.rsplit_once('@')
        && let Some(t) = step(t)
    {
        return MetricId::at(k, t);
    }
    MetricId::named(name)
}

/// Whether job `j` of `spec` is finished in `dir`: its file is there, belongs to this
/// plan's cell, and holds the seed's record where the spec keeps records (a failed
/// job has none and is finished all the same).
pub(super) fn is_finished(dir: &Path, spec: &SweepSpec, j: usize) -> bool {
    read_stored(dir, &spec.plan, j).is_some_and(|s| {
        metrics_of(&s).is_some() && (!spec.keeps_records() || s.record.is_some() || s.error.is_some())
    })
}

/// Job `j`'s file in `dir`, if it is there and belongs to this plan's cell.
fn read_stored(dir: &Path, plan: &Plan, j: usize) -> Option<StoredJob> {
    let (c, seed) = plan.job(j);
    // A job file is a few KiB; anything else (a link to /dev/zero, a FIFO, a huge file)
    // is not a finished job and is run again.
    let text = mmq_core::files::read_text_bounded(&plan.job_path(dir, j), MAX_JOB_BYTES).ok()?;
    let s: StoredJob = serde_json::from_str(&text).ok()?;
    let cell = &plan.cells[c];
    // A field the cell does not give ("–": another part of the spec gives it) may be
    // missing from a file a spec without that field wrote: the cell id is the same.
    let params_match =
        plan.fields.iter().zip(&cell.params).all(|(f, v)| s.params.get(f).map_or(v == "–", |x| x == v));
    if s.format != FORMAT || s.cell != cell.id || s.seed != seed || !params_match {
        return None;
    }
    Some(s)
}

/// Writes job `j` as failed with `error`: finished, its metrics `seed` and `failed`.
pub(super) fn write_failed_job(dir: &Path, plan: &Plan, j: usize, error: &str) -> Result<(), LabError> {
    let (_, seed) = plan.job(j);
    let metrics: Metrics = [("seed".into(), seed as f64), ("failed".into(), 1.0)].into();
    write_stored(dir, plan, j, &metrics, Some(error), None)
}

/// Writes job `j`'s metrics, with its seed's record when given.
pub(super) fn write_job(
    dir: &Path,
    plan: &Plan,
    j: usize,
    metrics: &Metrics,
    record: Option<SeedRecord>,
) -> Result<(), LabError> {
    write_stored(dir, plan, j, metrics, None, record)
}

fn write_stored(
    dir: &Path,
    plan: &Plan,
    j: usize,
    metrics: &Metrics,
    error: Option<&str>,
    record: Option<SeedRecord>,
) -> Result<(), LabError> {
    let (c, seed) = plan.job(j);
    let cell = &plan.cells[c];
    let s = StoredJob {
        format: FORMAT.into(),
        mmq_version: env!("CARGO_PKG_VERSION").into(),
        cell: cell.id.clone(),
        seed,
        params: plan.fields.iter().cloned().zip(cell.params.iter().cloned()).collect(),
        metrics: metrics
            .iter()
            .filter(|(k, _)| k.kind() == MetricKind::Named)
            .map(|(k, v)| {
                // The seed as the integer it is: an f64 holds seeds exactly only below
                // 2^53 (where the two texts are the same).
                let text = if k.as_str() == "seed" { seed.to_string() } else { encode(*v) };
                (k.to_string(), text)
            })
            .collect(),
        curve: metrics.iter().filter_map(|(k, v)| Some((k.curve_step()?, encode(*v)))).collect(),
        samples: metrics
            .iter()
            .filter_map(|(k, v)| k.sample().map(|(name, t)| (name.to_string(), t, encode(*v))))
            .collect(),
        error: error.map(str::to_string),
        record,
    };
    let text = serde_json::to_string_pretty(&s).unwrap_or_default() + "\n";
    // A file larger than a reader takes would never count as finished: refuse it here.
    if text.len() as u64 > MAX_JOB_BYTES {
        return Err(LabError::Config {
            file: plan.job_path(dir, j).display().to_string(),
            message: format!(
                "this job's results take {:.1} MiB, more than the {} MiB a job file may hold; the seed \
                 records a study keeps (learning curves, the maps of a cell's first seed) are for worlds of \
                 a few thousand cells: run the spec with `mmq sweep`, which keeps the metrics only",
                text.len() as f64 / f64::from(1u32 << 20),
                MAX_JOB_BYTES >> 20
            ),
        });
    }
    write_renamed(&plan.job_path(dir, j), text.as_bytes())
}

/// Writes a job file with [`mmq_core::files::write_renamed`]: readers see the old file or
/// the new one, never a part, and a failed write leaves no temporary file. Unlike
/// [`write_atomic`] it does not wait for the disk (fsync): a job file lost or emptied by a
/// crash of the machine fails to parse, and the job is simply run again, while thousands
/// of short jobs are not slowed down.
pub(super) fn write_renamed(path: &Path, bytes: &[u8]) -> Result<(), LabError> {
    let io = |source| LabError::Io { path: path.to_path_buf(), source };
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(io)?;
    }
    mmq_core::files::write_renamed(path, bytes).map_err(io)
}

/// The seed records of every job of `plan` found in `dir` (None where missing, failed,
/// or stored without one).
pub fn load_records(dir: &Path, plan: &Plan) -> Vec<Option<SeedRecord>> {
    (0..plan.jobs()).into_par_iter().map(|j| read_stored(dir, plan, j).and_then(|s| s.record)).collect()
}

/// Finished results of every job of `plan` found in `dir` (None where missing).
pub fn load_results(dir: &Path, plan: &Plan) -> Vec<Option<Metrics>> {
    (0..plan.jobs()).into_par_iter().map(|j| read_job(dir, plan, j)).collect()
}

/// Why each job of `plan` found in `dir` failed (None where missing or not failed).
pub fn load_failures(dir: &Path, plan: &Plan) -> Vec<Option<String>> {
    (0..plan.jobs()).into_par_iter().map(|j| read_stored(dir, plan, j).and_then(|s| s.error)).collect()
}

/// Reads `DIR/sweep.json`.
pub fn read_manifest(dir: &Path) -> Result<Manifest, LabError> {
    let p = dir.join("sweep.json");
    let text = mmq_core::files::read_text_bounded(&p, MAX_MANIFEST_BYTES).map_err(|e| LabError::Config {
        file: p.display().to_string(),
        message: format!("not a sweep output directory ({e}); run a sweep into it first"),
    })?;
    let m: Manifest = serde_json::from_str(&text)
        .map_err(|e| LabError::Config { file: p.display().to_string(), message: e.to_string() })?;
    if m.format != FORMAT {
        return Err(LabError::Config {
            file: p.display().to_string(),
            message: format!("format `{}` is not {FORMAT}", m.format),
        });
    }
    Ok(m)
}

pub(super) fn write_manifest(dir: &Path, m: &Manifest) -> Result<(), LabError> {
    let text = serde_json::to_string_pretty(m).unwrap_or_default() + "\n";
    write_atomic(&dir.join("sweep.json"), text.as_bytes())
}

/// The tidy results table: a row per finished job in plan order (cells in product
/// order, seeds in spec order); columns `cell`, the swept parameters in [`super::FIELDS`]
/// order, `seed`, then every metric present in any row, in name order (empty where a
/// cell has no such metric, and for NaN). Returns the text and the number of rows.
pub fn results_csv(plan: &Plan, results: &[Option<Metrics>]) -> (String, usize) {
    let metrics: BTreeSet<&str> = results
        .iter()
        .flatten()
        .flat_map(|m| m.keys())
        .map(MetricId::as_str)
        .filter(|k| is_result_metric(k))
        .collect();
    let axes: Vec<usize> = plan.axes.iter().filter_map(|a| plan.fields.iter().position(|f| f == a)).collect();
    let mut out = String::from("cell");
    for &a in &axes {
        out.push(',');
        out.push_str(&csv_field(&plan.fields[a]));
    }
    out.push_str(",seed");
    for m in &metrics {
        out.push(',');
        out.push_str(&csv_field(m));
    }
    out.push('\n');
    let mut rows = 0;
    for (j, r) in results.iter().enumerate() {
        let Some(r) = r else { continue };
        let (c, seed) = plan.job(j);
        out.push_str(&plan.cells[c].id);
        for &a in &axes {
            out.push(',');
            out.push_str(&csv_field(&plan.cells[c].params[a]));
        }
        let _ = write!(out, ",{seed}");
        for m in &metrics {
            out.push(',');
            out.push_str(&r.get(*m).map_or(String::new(), |&x| csv_number(x)));
        }
        out.push('\n');
        rows += 1;
    }
    (out, rows)
}

/// Writes `DIR/results.csv` and `DIR/sweep.json` from the files in `dir`.
pub(super) fn finish_dir(
    dir: &Path,
    plan: &Plan,
    spec_file: &str,
    shard: Option<Shard>,
) -> Result<(PathBuf, usize, usize, usize), LabError> {
    let results = load_results(dir, plan);
    let (csv, rows) = results_csv(plan, &results);
    let csv_path = dir.join("results.csv");
    write_atomic(&csv_path, csv.as_bytes())?;
    let here: Vec<usize> = (0..plan.jobs()).filter(|&j| shard.is_none_or(|s| s.contains(j))).collect();
    let done = here.iter().filter(|&&j| results[j].is_some()).count();
    write_manifest(
        dir,
        &Manifest {
            format: FORMAT.into(),
            mmq_version: env!("CARGO_PKG_VERSION").into(),
            spec_file: spec_file.into(),
            shard: shard.map(|s| s.to_string()),
            jobs_total: plan.jobs(),
            jobs_here: here.len(),
            done,
            complete: done == here.len(),
            plan: plan.clone(),
        },
    )?;
    Ok((csv_path, rows, here.len(), done))
}

#[cfg(test)]
mod tests {
    use super::super::plan::PlanCell;
    use super::*;

    #[test]
    fn stored_numbers_read_back() {
        assert_eq!(encode(f64::INFINITY).parse::<f64>().unwrap(), f64::INFINITY);
        assert!(encode(f64::NAN).parse::<f64>().unwrap().is_nan());
    }

    /// The `seed` metric of a job file is its job's seed as an exact integer; below 2^53
    /// its text is the float's text, as before.
    #[test]
    fn seed_metric_is_stored_as_its_integer() {
        let dir = std::env::temp_dir().join(format!("mmq-store-seed-{}", std::process::id()));
        let cell = PlanCell { id: "c0".into(), params: vec![], seeds: None };
        for seed in [7u64, (1 << 53) + 1, u64::MAX] {
            let plan = Plan::new("s".into(), String::new(), vec![], vec![], vec![seed], vec![cell.clone()]);
            let metrics: Metrics = [("seed".into(), seed as f64), ("steps".into(), 2000.0)].into();
            write_job(&dir, &plan, 0, &metrics, None).unwrap();
            let text = std::fs::read_to_string(plan.job_path(&dir, 0)).unwrap();
            let stored: StoredJob = serde_json::from_str(&text).unwrap();
            assert_eq!(stored.metrics["seed"], seed.to_string());
            assert_eq!(stored.metrics["seed"].parse::<u64>().unwrap(), seed);
            if seed < 1 << 53 {
                assert_eq!(stored.metrics["seed"], encode(seed as f64));
            }
            assert_eq!(read_job(&dir, &plan, 0), Some(metrics));
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The curve's points and the learner's samples are stored apart, their steps as
    /// numbers, and read back as the same typed ids; a job file of an earlier version,
    /// which holds them among the named metrics, reads back the same.
    #[test]
    fn metrics_with_steps_are_stored_apart_and_read_back_typed() {
        let dir = std::env::temp_dir().join(format!("mmq-store-typed-{}", std::process::id()));
        let cell = PlanCell { id: "c0".into(), params: vec![], seeds: None };
        let plan = Plan::new("s".into(), String::new(), vec![], vec![], vec![4], vec![cell]);
        let metrics: Metrics = [
            ("seed".into(), 4.0),
            (MetricId::curve(2500), 0.25),
            (MetricId::at("delay/median_est", 10_000), 12.5),
            ("perf/relative".into(), 0.75),
        ]
        .into();
        write_job(&dir, &plan, 0, &metrics, None).unwrap();
        let text = std::fs::read_to_string(plan.job_path(&dir, 0)).unwrap();
        let stored: StoredJob = serde_json::from_str(&text).unwrap();
        assert_eq!(stored.metrics.keys().collect::<Vec<_>>(), ["perf/relative", "seed"]);
        assert_eq!(stored.curve, [(2500, "0.25".to_string())]);
        assert_eq!(stored.samples, [("delay/median_est".to_string(), 10_000, "12.5".to_string())]);
        let back = read_job(&dir, &plan, 0).unwrap();
        assert_eq!(back, metrics);
        let steps: Vec<Option<u64>> = back.keys().map(MetricId::curve_step).collect();
        assert_eq!(steps, [Some(2500), None, None, None]);
        // An earlier version's file: every metric by its text.
        let legacy = text.replace(
            "\"metrics\": {",
            "\"metrics\": {\n    \"curve/2500\": \"0.25\",\n    \"delay/median_est@10000\": \"12.5\",",
        );
        let legacy: StoredJob = serde_json::from_str(&legacy).unwrap();
        let legacy = StoredJob { curve: Vec::new(), samples: Vec::new(), ..legacy };
        let old = metrics_of(&legacy).unwrap();
        assert_eq!(old, metrics);
        assert_eq!(old.keys().map(MetricId::curve_step).collect::<Vec<_>>(), steps);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A job file larger than a reader takes is refused when written, naming the file:
    /// it would never count as finished, and its job would run again and again.
    #[test]
    fn a_job_too_large_to_read_back_is_refused_when_written() {
        use crate::trajectory::{CurveRow, Trajectory};
        let dir = std::env::temp_dir().join(format!("mmq-store-large-{}", std::process::id()));
        let cell = PlanCell { id: "c0".into(), params: vec![], seeds: None };
        let plan = Plan::new("s".into(), String::new(), vec![], vec![], vec![1], vec![cell]);
        let row = CurveRow { step: 1, earned: 0.1, received: 0.2, earned_cum: 0.3, received_cum: 0.4 };
        let big = SeedRecord::of(
            &crate::runner::SeedResult {
                seed: 1,
                complete: true,
                run: Trajectory { curve: vec![row; 200_000], ..Trajectory::default() },
                greedy_per_step: 0.0,
                greedy_path: Vec::new(),
                policy_arrows: Vec::new(),
                policy_probs: Vec::new(),
                values: Vec::new(),
                diagnostics: Default::default(),
                env_stats: Vec::new(),
                tables: Vec::new(),
                baseline: None,
                baseline_greedy_per_step: None,
                reference: None,
                wall_time_s: 0.0,
                learn_time_s: 0.0,
                failure: None,
            },
            false,
        );
        let metrics: Metrics = [("seed".into(), 1.0)].into();
        let e = write_job(&dir, &plan, 0, &metrics, Some(big)).unwrap_err().to_string();
        assert!(e.contains("seed-1.json") && e.contains("MiB") && e.contains("mmq sweep"), "{e}");
        assert!(!plan.job_path(&dir, 0).exists());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
