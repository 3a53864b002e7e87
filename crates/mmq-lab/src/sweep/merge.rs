//! Merging the outputs of shards (or of any runs of one sweep) into one directory.

use std::path::{Path, PathBuf};

use super::plan::Plan;
use super::spec::SweepSpec;
use super::stats::is_result_metric;
use super::store::{finish_dir, is_finished, load_results, read_job, read_manifest, write_renamed};
use super::{MAX_JOB_BYTES, MAX_SPEC_BYTES, Metrics};
use crate::error::LabError;
use crate::output::write_atomic;

/// What [`merge`] did.
#[derive(Clone, Debug)]
pub struct MergeOutcome {
    /// Jobs of the sweep.
    pub jobs_total: usize,
    /// Jobs now finished in the merged directory.
    pub done: usize,
    /// Job files copied.
    pub copied: usize,
    /// `OUT/results.csv`.
    pub results_csv: PathBuf,
}

pub(super) fn same_results(a: &Metrics, b: &Metrics) -> bool {
    let f = |m: &Metrics| -> Vec<(String, u64)> {
        m.iter()
            .filter(|(k, _)| is_result_metric(k.as_str()))
            .map(|(k, v)| (k.to_string(), v.to_bits()))
            .collect()
    };
    f(a) == f(b)
}

/// Merges the outputs of shards (or of any runs of one sweep) into `out`: every
/// finished job file is copied, then `results.csv` and `sweep.json` are written. The
/// inputs must hold the same plan; a job finished in two inputs must agree.
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<MergeOutcome, LabError> {
    let first =
        dirs.first().ok_or_else(|| LabError::param("merge", "nothing", "give at least one directory"))?;
    let m0 = read_manifest(first)?;
    let plan = &m0.plan;
    for d in &dirs[1..] {
        let m = read_manifest(d)?;
        if &m.plan != plan {
            return Err(LabError::Config {
                file: d.join("sweep.json").display().to_string(),
                message: format!(
                    "holds another sweep than {} (its cells, seeds or parameters differ); merge only outputs of one spec",
                    first.display()
                ),
            });
        }
    }
    if let Ok(m) = read_manifest(out)
        && &m.plan != plan
    {
        return Err(LabError::Config {
            file: out.join("sweep.json").display().to_string(),
            message: "the output directory holds another sweep; give an empty output directory (`out`)"
                .into(),
        });
    }
    // One process writes into `out` at a time (`crate::lock`).
    let _lock = crate::lock::lock_out_dir(out)?;
    let mut have: Vec<Option<Metrics>> = load_results(out, plan);
    let mut copied = 0;
    for d in dirs.iter().filter(|d| d.as_path() != out) {
        let theirs = load_results(d, plan);
        for (j, r) in theirs.into_iter().enumerate() {
            let Some(r) = r else { continue };
            match &have[j] {
                Some(mine) if same_results(mine, &r) => {}
                Some(_) => return Err(differs(plan, d, j, "the result already merged")),
                None => {
                    copy_job(plan, d, out, j)?;
                    have[j] = Some(r);
                    copied += 1;
                }
            }
        }
    }
    let spec_text =
        mmq_core::files::read_bounded(&first.join("spec.toml"), MAX_SPEC_BYTES).unwrap_or_default();
    write_atomic(&out.join("spec.toml"), &spec_text)?;
    let (results_csv, _, _, done) = finish_dir(out, plan, &m0.spec_file, None)?;
    Ok(MergeOutcome { jobs_total: plan.jobs(), done, copied, results_csv })
}

/// Copies into `into` every job of `spec` finished in `from` that `into` does not hold
/// (a shard's, say), holding `into`'s lock; a job finished in both must agree. Returns
/// how many were copied. `from` need not hold this plan alone: jobs are found by their
/// cell and seed, so a store that ran other budgets too gives what this one needs.
pub fn merge_jobs(spec: &SweepSpec, from: &Path, into: &Path) -> Result<usize, LabError> {
    let plan = &spec.plan;
    let _lock = crate::lock::lock_out_dir(into)?;
    let mut copied = 0;
    for j in 0..plan.jobs() {
        if !is_finished(from, spec, j) {
            continue;
        }
        if is_finished(into, spec, j) {
            let (a, b) = (read_job(from, plan, j), read_job(into, plan, j));
            if let (Some(a), Some(b)) = (a, b)
                && !same_results(&a, &b)
            {
                return Err(differs(plan, from, j, &format!("the result in {}", into.display())));
            }
            continue;
        }
        copy_job(plan, from, into, j)?;
        copied += 1;
    }
    Ok(copied)
}

/// Copies job `j`'s file from the folder `from` into `into`, byte for byte.
fn copy_job(plan: &Plan, from: &Path, into: &Path, j: usize) -> Result<(), LabError> {
    let src = plan.job_path(from, j);
    let bytes = mmq_core::files::read_bounded(&src, MAX_JOB_BYTES).map_err(|e| LabError::Config {
        file: src.display().to_string(),
        message: format!("cannot read the job file: {e}"),
    })?;
    write_renamed(&plan.job_path(into, j), &bytes)
}

/// Job `j` in the folder `dir` holds another result than `other`.
fn differs(plan: &Plan, dir: &Path, j: usize, other: &str) -> LabError {
    let (c, seed) = plan.job(j);
    LabError::Config {
        file: plan.job_path(dir, j).display().to_string(),
        message: format!(
            "cell {} seed {seed} differs from {other}; were they run by different versions?",
            plan.cells[c].id
        ),
    }
}
