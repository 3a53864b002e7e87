//! The plan of a sweep (cells in product order, seeds, swept axes), job indices and
//! paths, cell-id hashing, and shards (disjoint parts of the jobs).

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use serde::{Deserialize, Serialize};

use crate::error::LabError;

/// Cells, seeds and swept axes of a sweep: everything its outputs are keyed by. Shards
/// of one sweep have equal plans; [`super::merge`] checks it.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Plan {
    /// Name of the sweep (spec `name`, default the file stem).
    pub name: String,
    /// Free text (spec `description`).
    pub description: String,
    /// Parameter names, in the order of every cell's `params` ([`super::FIELDS`]).
    pub fields: Vec<String>,
    /// The fields given as lists (the swept axes), in [`super::FIELDS`] order.
    pub axes: Vec<String>,
    /// Master seeds run for every cell (a spec in parts: every seed of any part, in order
    /// of appearance; each cell runs its own, [`PlanCell::seeds`]).
    pub seeds: Vec<u64>,
    /// The cells in product order (first field outermost).
    pub cells: Vec<PlanCell>,
    /// Where each cell's jobs start (and after the last cell, the number of jobs) when
    /// cells have seeds of their own; `None` when every cell runs [`Plan::seeds`].
    /// Computed once, on first use.
    #[serde(skip)]
    starts: OnceLock<Option<Vec<usize>>>,
}

/// Plans are equal when what they say is (the job index is derived from it).
impl PartialEq for Plan {
    fn eq(&self, o: &Plan) -> bool {
        (&self.name, &self.description, &self.fields, &self.axes, &self.seeds, &self.cells)
            == (&o.name, &o.description, &o.fields, &o.axes, &o.seeds, &o.cells)
    }
}

/// One cell of the product.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlanCell {
    /// Stable id: hash of the parameters as written and of the world file's bytes.
    pub id: String,
    /// Every parameter's value as text, aligned with [`Plan::fields`].
    pub params: Vec<String>,
    /// The master seeds of this cell when they are its part's own (a spec in parts);
    /// absent: [`Plan::seeds`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seeds: Option<Vec<u64>>,
}

impl Plan {
    /// A plan of these cells.
    pub fn new(
        name: String,
        description: String,
        fields: Vec<String>,
        axes: Vec<String>,
        seeds: Vec<u64>,
        cells: Vec<PlanCell>,
    ) -> Plan {
        Plan { name, description, fields, axes, seeds, cells, starts: OnceLock::new() }
    }

    /// Number of (cell, seed) jobs.
    pub fn jobs(&self) -> usize {
        match self.starts() {
            None => self.cells.len() * self.seeds.len(),
            Some(s) => s[s.len() - 1],
        }
    }

    /// Whether every cell runs [`Plan::seeds`] (no cell has seeds of its own).
    pub fn uniform(&self) -> bool {
        self.starts().is_none()
    }

    /// Where the jobs of each cell start, and after the last one the number of jobs;
    /// `None` for a uniform plan, whose jobs are `cell × seeds + seed`.
    fn starts(&self) -> Option<&[usize]> {
        self.starts
            .get_or_init(|| {
                self.cells.iter().any(|c| c.seeds.is_some()).then(|| {
                    let mut v = Vec::with_capacity(self.cells.len() + 1);
                    v.push(0);
                    for c in 0..self.cells.len() {
                        v.push(v[c] + self.seeds_of(c).len());
                    }
                    v
                })
            })
            .as_deref()
    }

    /// The master seeds of cell `c`.
    pub fn seeds_of(&self, c: usize) -> &[u64] {
        self.cells[c].seeds.as_deref().unwrap_or(&self.seeds)
    }

    /// The jobs of cell `c`: consecutive, one per seed.
    pub fn cell_jobs(&self, c: usize) -> std::ops::Range<usize> {
        match self.starts() {
            None => c * self.seeds.len()..(c + 1) * self.seeds.len(),
            Some(s) => s[c]..s[c + 1],
        }
    }

    /// Cell index and master seed of job `j` (seeds vary fastest).
    pub fn job(&self, j: usize) -> (usize, u64) {
        match self.starts() {
            None => {
                let n = self.seeds.len().max(1);
                (j / n, self.seeds[j % n])
            }
            Some(s) => {
                // The last cell whose jobs start at or before j.
                let c = s.partition_point(|&x| x <= j) - 1;
                (c, self.seeds_of(c)[j - s[c]])
            }
        }
    }

    /// The value of `field` in cell `cell`.
    pub fn param(&self, cell: usize, field: &str) -> &str {
        let i = self.fields.iter().position(|f| f == field).unwrap_or(usize::MAX);
        self.cells[cell].params.get(i).map_or("", |s| s.as_str())
    }

    /// Distinct values of an axis in the order they appear.
    pub fn axis_values(&self, axis: &str) -> Vec<String> {
        let mut seen = Vec::<String>::new();
        for c in 0..self.cells.len() {
            let v = self.param(c, axis);
            if !seen.iter().any(|s| s == v) {
                seen.push(v.to_string());
            }
        }
        seen
    }

    /// The parameters that are the same in every cell, as `(field, value)`, without the
    /// learner settings that are fields of a cell (`max_delay`, `lambda_hat`) when no
    /// learner of the plan has them: they hold their defaults, which nothing reads.
    pub fn fixed(&self) -> Vec<(String, String)> {
        let learners: Vec<mmq_learn::LearnerKind> = self
            .axis_values("learner")
            .iter()
            .filter_map(|l| mmq_learn::LearnerKind::parse(l).ok())
            .collect();
        let read = |f: &str| {
            !super::cell::LEARNER_FIELDS.contains(&f)
                || learners.iter().any(|&k| crate::settings::has_setting(k, f))
        };
        self.fields
            .iter()
            .filter(|f| !self.axes.contains(f) && read(f))
            .map(|f| (f.clone(), if self.cells.is_empty() { String::new() } else { self.param(0, f).into() }))
            .collect()
    }

    pub(super) fn job_path(&self, dir: &Path, j: usize) -> PathBuf {
        let (c, seed) = self.job(j);
        dir.join("cells").join(&self.cells[c].id).join(format!("seed-{seed}.json"))
    }
}

/// 64-bit FNV-1a: a small, stable, dependency-free hash for ids (not for security).
pub(super) fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// The K-th of N disjoint parts of a sweep's jobs: job j belongs to shard
/// `j mod N + 1`, so every shard gets a share of every cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// K, in 1..=count.
    pub index: u64,
    /// N.
    pub count: u64,
}

impl Shard {
    /// Parses `K/N` with 1 ≤ K ≤ N ≤ [`super::MAX_JOBS`] (more shards than a sweep can
    /// have jobs would be empty).
    pub fn parse(s: &str) -> Result<Shard, LabError> {
        let bad = || {
            LabError::param(
                "shard",
                s,
                &format!(
                    "use K/N with 1 <= K <= N <= {} (the most jobs a sweep has), e.g. 2/8 (Slurm: --array=1-N)",
                    super::MAX_JOBS
                ),
            )
        };
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let index: u64 = k.trim().parse().map_err(|_| bad())?;
        let count: u64 = n.trim().parse().map_err(|_| bad())?;
        if index == 0 || index > count || count > super::MAX_JOBS as u64 {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }

    /// Whether job `j` is in this shard.
    pub fn contains(&self, j: usize) -> bool {
        (j as u64) % self.count == self.index - 1
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_are_disjoint_and_cover() {
        let shards: Vec<Shard> = (1..=3).map(|k| Shard::parse(&format!("{k}/3")).unwrap()).collect();
        for j in 0..50 {
            assert_eq!(shards.iter().filter(|s| s.contains(j)).count(), 1);
        }
        assert!(Shard::parse("1000000/1000000").is_ok());
        for bad in ["0/3", "4/3", "3", "a/b", "1/0", "1/1000001", "1/18446744073709551615"] {
            assert!(Shard::parse(bad).is_err(), "{bad}");
        }
    }
}
