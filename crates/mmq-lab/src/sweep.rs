//! Parameter sweeps: a TOML spec whose fields are run parameters, each one value or a
//! list (an axis); the product of the axes gives the cells, each run for every seed.
//! A (cell, seed) pair is a job. Jobs are run in parallel, each result is written
//! atomically as it finishes (`cells/<cell-id>/seed-<n>.json`) so that an interrupted
//! sweep resumes where it stopped, `--shard K/N` picks a deterministic disjoint part of
//! the jobs, [`merge`] joins shard outputs, and [`results_csv`] is one tidy table whose
//! bytes depend on neither the thread count nor the sharding.
//!
//! Layout of an output directory:
//!
//! ```text
//! DIR/spec.toml                    copy of the spec, as given
//! DIR/sweep.json                   the plan (cells, seeds) and this directory's status
//! DIR/cells/<cell-id>/seed-<n>.json  one finished job: cell parameters and metrics
//! DIR/results.csv                  a row per finished job
//! ```
//!
//! A cell's id is a hash of its parameters as written and of its world file's bytes, so
//! results survive reordering or extending the spec, and a changed world is recomputed.
//! The undelayed baseline of relative performance depends on neither the learner nor
//! the delay, so each distinct baseline is computed once per process and shared by the
//! cells that need it (bit-identical to [`crate::run_seed`]'s own baseline).

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::fmt::Write as _;
use std::marker::PhantomData;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use mmq_core::stats::MeanCi;
use mmq_core::{DelayDist, World};
use mmq_learn::{LearnerKind, LearnerSpec, spec::Params};
use rayon::prelude::*;
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use serde::{Deserialize, Serialize};
use toml::Spanned;

use crate::config::{EnvKind, RunConfig};
use crate::error::LabError;
use crate::output::write_atomic;
use crate::runner::{Control, SeedResult, Trajectory, memory_limit, run_seed};
use crate::summary::seed_metrics;

/// Format tag of `sweep.json` and of the per-job files.
pub const FORMAT: &str = "mmq-sweep/1";

/// The run parameters a spec may set or sweep, in the canonical order: the order of
/// the product (first = outermost) and of the parameter columns in CSV files.
pub const FIELDS: [&str; 14] = [
    "world",
    "env",
    "learner",
    "delay",
    "max_delay",
    "lambda_hat",
    "alpha",
    "gamma",
    "epsilon",
    "q0",
    "steps",
    "window",
    "eval_steps",
    "baseline",
];

/// Per-seed metrics under their stable names (see [`crate::summary::seed_metrics`]).
pub type Metrics = BTreeMap<String, f64>;

// ---------------------------------------------------------------------------------------
// The spec file
// ---------------------------------------------------------------------------------------

/// One value or a list of values of a spec field.
#[derive(Debug)]
enum OneOrMany<T> {
    One(T),
    Many(Vec<T>),
}

impl<T> OneOrMany<T> {
    fn into_vec(self) -> Vec<T> {
        match self {
            OneOrMany::One(x) => vec![x],
            OneOrMany::Many(v) => v,
        }
    }
}

impl<'de, T: Deserialize<'de>> Deserialize<'de> for OneOrMany<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<T>(PhantomData<T>);
        impl<'de, T: Deserialize<'de>> Visitor<'de> for V<T> {
            type Value = OneOrMany<T>;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("a value or a list of values")
            }
            fn visit_bool<E: de::Error>(self, v: bool) -> Result<Self::Value, E> {
                T::deserialize(de::value::BoolDeserializer::<E>::new(v)).map(OneOrMany::One)
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Self::Value, E> {
                T::deserialize(de::value::I64Deserializer::<E>::new(v)).map(OneOrMany::One)
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Self::Value, E> {
                T::deserialize(de::value::U64Deserializer::<E>::new(v)).map(OneOrMany::One)
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Self::Value, E> {
                T::deserialize(de::value::F64Deserializer::<E>::new(v)).map(OneOrMany::One)
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Self::Value, E> {
                T::deserialize(de::value::StrDeserializer::<E>::new(v)).map(OneOrMany::One)
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
                let mut v = Vec::new();
                while let Some(x) = seq.next_element()? {
                    v.push(x);
                }
                Ok(OneOrMany::Many(v))
            }
        }
        d.deserialize_any(V(PhantomData))
    }
}

/// `seeds = N` (N seeds from `seed`) or `seeds = [s1, s2, ...]` (explicit master seeds).
#[derive(Debug)]
enum SeedsField {
    Count(u64),
    List(Vec<u64>),
}

impl<'de> Deserialize<'de> for SeedsField {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = SeedsField;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("a number of seeds or a list of master seeds")
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<SeedsField, E> {
                u64::try_from(v)
                    .map(SeedsField::Count)
                    .map_err(|_| E::invalid_value(de::Unexpected::Signed(v), &self))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<SeedsField, E> {
                Ok(SeedsField::Count(v))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<SeedsField, A::Error> {
                let mut v = Vec::new();
                while let Some(x) = seq.next_element()? {
                    v.push(x);
                }
                Ok(SeedsField::List(v))
            }
        }
        d.deserialize_any(V)
    }
}

type Field<T> = Option<Spanned<OneOrMany<T>>>;

/// The spec as written (see docs/sweeps.md for every field).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSpec {
    name: Option<String>,
    description: Option<String>,
    world: Field<String>,
    env: Field<String>,
    learner: Field<String>,
    delay: Field<String>,
    max_delay: Field<u64>,
    lambda_hat: Field<u64>,
    alpha: Field<f64>,
    gamma: Field<f64>,
    epsilon: Field<f64>,
    q0: Field<f64>,
    steps: Field<u64>,
    window: Field<u64>,
    eval_steps: Field<u64>,
    baseline: Field<bool>,
    seeds: Option<Spanned<SeedsField>>,
    seed: Option<Spanned<u64>>,
    /// Learner parameters beyond the paper (`[beyond]` table: trace decay, ...), each
    /// a value or a list, passed to the learner's `beyond` settings by name.
    beyond: Option<BTreeMap<String, Spanned<OneOrMany<toml::Value>>>>,
}

/// Where in the spec text an error is, for messages `FILE:LINE:COLUMN: FIELD: ...`.
struct Source<'a> {
    file: &'a str,
    text: &'a str,
}

impl Source<'_> {
    fn line_col(&self, offset: usize) -> (usize, usize) {
        let offset = offset.min(self.text.len());
        let before = &self.text[..offset];
        let line = before.matches('\n').count() + 1;
        let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
        (line, col)
    }

    fn error(&self, offset: usize, field: &str, message: impl Into<String>) -> LabError {
        let (line, column) = self.line_col(offset);
        LabError::Spec {
            file: self.file.to_string(),
            line,
            column,
            field: field.to_string(),
            message: message.into(),
        }
    }

    /// The key of the `key = value` line that holds `offset` (or the nearest one above).
    fn key_at(&self, offset: usize) -> Option<String> {
        let before = &self.text[..offset.min(self.text.len())];
        for line in before.lines().rev() {
            let t = line.trim_start();
            if t.starts_with('[') && !t.starts_with("[[") && t.trim_end().ends_with(']') {
                return None;
            }
            let key: String =
                t.chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_' || *c == '-').collect();
            if !key.is_empty() && t[key.len()..].trim_start().starts_with('=') {
                return Some(key);
            }
        }
        None
    }

    /// A TOML syntax or type error, with its line, column and field.
    fn toml_error(&self, e: &toml::de::Error) -> LabError {
        let offset = e.span().map_or(0, |s| s.start);
        let message = e.message().trim().replace('\n', "; ");
        let field = between(&message, "field `", "`")
            .or_else(|| self.key_at(offset))
            .unwrap_or_else(|| "syntax".into());
        let message = if message.starts_with("unknown field") {
            format!("{message}; see docs/sweeps.md")
        } else {
            message
        };
        self.error(offset, &field, message)
    }
}

fn between(s: &str, open: &str, close: &str) -> Option<String> {
    let i = s.find(open)? + open.len();
    let j = s[i..].find(close)?;
    Some(s[i..i + j].to_string())
}

/// A field's values with their place in the spec.
struct Values<T> {
    name: &'static str,
    values: Vec<T>,
    listed: bool,
    offset: usize,
}

impl<T> Values<T> {
    fn new(name: &'static str, field: Field<T>, default: T) -> Self {
        match field {
            None => Values { name, values: vec![default], listed: false, offset: 0 },
            Some(s) => {
                let offset = s.span().start;
                let (listed, values) = match s.into_inner() {
                    OneOrMany::One(x) => (false, vec![x]),
                    m @ OneOrMany::Many(_) => (true, m.into_vec()),
                };
                Values { name, values, listed, offset }
            }
        }
    }

    /// The name of item `i` in messages: `delay` or `delay[2]`.
    fn item(&self, i: usize) -> String {
        if self.listed { format!("{}[{i}]", self.name) } else { self.name.to_string() }
    }
}

/// The parsed, validated spec with its resolved worlds and every cell's configuration.
#[derive(Debug)]
pub struct SweepSpec {
    /// The spec file as given.
    pub file: PathBuf,
    /// Its text (copied into the output directory).
    pub text: String,
    /// Cells, seeds and swept axes.
    pub plan: Plan,
    /// Per cell: its run configuration (world path resolved; one seed; no tables).
    configs: Vec<RunConfig>,
    /// Per cell: index into `worlds`.
    world_of: Vec<usize>,
    /// Distinct worlds.
    worlds: Vec<World>,
}

/// Cells, seeds and swept axes of a sweep: everything its outputs are keyed by. Shards
/// of one sweep have equal plans; [`merge`] checks it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    /// Name of the sweep (spec `name`, default the file stem).
    pub name: String,
    /// Free text (spec `description`).
    pub description: String,
    /// Parameter names, in the order of every cell's `params` ([`FIELDS`]).
    pub fields: Vec<String>,
    /// The fields given as lists (the swept axes), in [`FIELDS`] order.
    pub axes: Vec<String>,
    /// Master seeds run for every cell.
    pub seeds: Vec<u64>,
    /// The cells in product order (first field outermost).
    pub cells: Vec<PlanCell>,
}

/// One cell of the product.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlanCell {
    /// Stable id: hash of the parameters as written and of the world file's bytes.
    pub id: String,
    /// Every parameter's value as text, aligned with [`Plan::fields`].
    pub params: Vec<String>,
}

impl Plan {
    /// Number of (cell, seed) jobs.
    pub fn jobs(&self) -> usize {
        self.cells.len() * self.seeds.len()
    }

    /// Cell index and master seed of job `j` (seeds vary fastest).
    pub fn job(&self, j: usize) -> (usize, u64) {
        let n = self.seeds.len().max(1);
        (j / n, self.seeds[j % n])
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

    /// The parameters that are the same in every cell, as `(field, value)`.
    pub fn fixed(&self) -> Vec<(String, String)> {
        self.fields
            .iter()
            .filter(|f| !self.axes.contains(f))
            .map(|f| (f.clone(), if self.cells.is_empty() { String::new() } else { self.param(0, f).into() }))
            .collect()
    }

    fn job_path(&self, dir: &Path, j: usize) -> PathBuf {
        let (c, seed) = self.job(j);
        dir.join("cells").join(&self.cells[c].id).join(format!("seed-{seed}.json"))
    }
}

/// Largest number of jobs a spec may describe. Every cell is built in memory (about
/// 1.3 KB each), so this also bounds what a short spec can make `mmq sweep` allocate:
/// at most ~1.3 GB, and a million jobs is far beyond a cluster's week of paper-sized runs.
pub const MAX_JOBS: usize = 1_000_000;
/// Largest sweep spec file read, bytes: a spec is a small text file.
pub const MAX_SPEC_BYTES: u64 = 1 << 20;
/// Largest job file read, bytes: one job's metrics are a few KiB.
pub const MAX_JOB_BYTES: u64 = 1 << 20;
/// Largest `sweep.json` read, bytes: the plan of the largest accepted sweep.
pub const MAX_MANIFEST_BYTES: u64 = 512 << 20;

impl SweepSpec {
    /// Reads and validates a spec file. Relative world paths are resolved against the
    /// spec file's directory.
    pub fn load(path: &Path) -> Result<SweepSpec, LabError> {
        let cannot = |message: String| LabError::Config { file: path.display().to_string(), message };
        // At most MAX_SPEC_BYTES of a regular file: `/dev/zero` or a FIFO must neither
        // hang nor take all memory.
        let text = mmq_core::files::read_text_bounded(path, MAX_SPEC_BYTES).map_err(|e| match e {
            mmq_core::files::ReadError::TooLarge { .. } => cannot(format!(
                "the sweep spec is larger than {} MiB; a spec is a small TOML file (see docs/sweeps.md)",
                MAX_SPEC_BYTES >> 20
            )),
            e => cannot(format!("cannot read the sweep spec: {e}")),
        })?;
        Self::parse(&text, path)
    }

    /// Parses and validates spec text; `file` names it in errors and anchors relative
    /// world paths.
    pub fn parse(text: &str, file: &Path) -> Result<SweepSpec, LabError> {
        let file_name = file.display().to_string();
        let src = Source { file: &file_name, text };
        let raw: RawSpec = toml::from_str(text).map_err(|e| src.toml_error(&e))?;
        let d = RunConfig::default();
        let dl = LearnerSpec::default();
        let dp = Params::default();
        let world = match raw.world {
            Some(w) => Values::new("world", Some(w), String::new()),
            None => {
                return Err(src.error(
                    0,
                    "world",
                    "missing field `world`: give a world file (relative to the spec's directory), or a list of them",
                ));
            }
        };
        let env = Values::new("env", raw.env, "grid".to_string());
        let learner = Values::new("learner", raw.learner, "mmq".to_string());
        let delay = Values::new("delay", raw.delay, d.delay.clone());
        let max_delay = Values::new("max_delay", raw.max_delay, dl.max_delay as u64);
        let lambda_hat = Values::new("lambda_hat", raw.lambda_hat, dl.lambda_hat as u64);
        let alpha = Values::new("alpha", raw.alpha, dp.alpha);
        let gamma = Values::new("gamma", raw.gamma, dp.gamma);
        let epsilon = Values::new("epsilon", raw.epsilon, dp.epsilon);
        let q0 = Values::new("q0", raw.q0, dp.q0);
        let steps = Values::new("steps", raw.steps, d.steps);
        let window = Values::new("window", raw.window, d.window);
        let eval_steps = Values::new("eval_steps", raw.eval_steps, d.eval_steps);
        let baseline = Values::new("baseline", raw.baseline, d.baseline);

        // Texts of every field's values, in FIELDS order, checked for empty lists and
        // repeated values (which would make two cells with one id).
        let mut texts: Vec<(String, Vec<String>, bool, usize)> = vec![
            text_of(&world, |s| s.clone()),
            text_of(&env, |s| s.clone()),
            text_of(&learner, |s| s.clone()),
            text_of(&delay, |s| s.clone()),
            text_of(&max_delay, u64::to_string),
            text_of(&lambda_hat, u64::to_string),
            text_of(&alpha, f64::to_string),
            text_of(&gamma, f64::to_string),
            text_of(&epsilon, f64::to_string),
            text_of(&q0, f64::to_string),
            text_of(&steps, u64::to_string),
            text_of(&window, u64::to_string),
            text_of(&eval_steps, u64::to_string),
            text_of(&baseline, bool::to_string),
        ];
        debug_assert!(texts.iter().map(|t| t.0.as_str()).eq(FIELDS));
        // `[beyond]`: fields `beyond.KEY` after the others, in key order.
        let beyond: Vec<(String, Values<toml::Value>)> = raw
            .beyond
            .unwrap_or_default()
            .into_iter()
            .map(|(k, v)| {
                let offset = v.span().start;
                let (listed, values) = match v.into_inner() {
                    OneOrMany::One(x) => (false, vec![x]),
                    m @ OneOrMany::Many(_) => (true, m.into_vec()),
                };
                (k, Values { name: "beyond", values, listed, offset })
            })
            .collect();
        for (k, v) in &beyond {
            texts.push((
                format!("beyond.{k}"),
                v.values.iter().map(value_text).collect(),
                v.listed,
                v.offset,
            ));
        }
        for (name, vals, _, offset) in &texts {
            let name = name.as_str();
            if vals.is_empty() {
                return Err(src.error(*offset, name, "the list is empty; give at least one value"));
            }
            let mut seen = BTreeSet::new();
            for v in vals {
                if !seen.insert(v) {
                    return Err(src.error(*offset, name, format!("`{v}` is listed twice")));
                }
            }
        }

        // Every value on its own, against the rules of `mmq run`.
        let envs: Vec<EnvKind> = env
            .values
            .iter()
            .enumerate()
            .map(|(i, e)| match e.as_str() {
                "grid" => Ok(EnvKind::Grid),
                "robot" => Ok(EnvKind::Robot),
                _ => Err(src.error(
                    env.offset,
                    &env.item(i),
                    format!("`{e}` is not an environment; use grid or robot"),
                )),
            })
            .collect::<Result<_, _>>()?;
        let learners: Vec<LearnerKind> = learner
            .values
            .iter()
            .enumerate()
            .map(|(i, l)| {
                LearnerKind::parse(l).map_err(|e| src.error(learner.offset, &learner.item(i), e.to_string()))
            })
            .collect::<Result<_, _>>()?;
        let check = |offset: usize, item: String, cfg: RunConfig| -> Result<(), LabError> {
            cfg.validate().map(|_| ()).map_err(|e| src.error(offset, &item, plain_message(&e)))
        };
        for (i, x) in delay.values.iter().enumerate() {
            check(delay.offset, delay.item(i), RunConfig { delay: x.clone(), ..d.clone() })?;
        }
        for (vals, set) in [
            (&alpha, (|p: &mut Params, x| p.alpha = x) as fn(&mut Params, f64)),
            (&gamma, |p, x| p.gamma = x),
            (&epsilon, |p, x| p.epsilon = x),
            (&q0, |p, x| p.q0 = x),
        ] {
            for (i, &x) in vals.values.iter().enumerate() {
                let mut cfg = d.clone();
                set(&mut cfg.learner.params, x);
                check(vals.offset, vals.item(i), cfg)?;
            }
        }
        for (vals, set) in [
            (&steps, (|c: &mut RunConfig, x| c.steps = x) as fn(&mut RunConfig, u64)),
            (&window, |c, x| c.window = x),
            (&eval_steps, |c, x| c.eval_steps = x),
        ] {
            for (i, &x) in vals.values.iter().enumerate() {
                let mut cfg = d.clone();
                set(&mut cfg, x);
                check(vals.offset, vals.item(i), cfg)?;
            }
        }
        for vals in [&max_delay, &lambda_hat] {
            for (i, &x) in vals.values.iter().enumerate() {
                if usize::try_from(x).is_err() || x > 1_000_000 {
                    return Err(src.error(
                        vals.offset,
                        &vals.item(i),
                        format!("{x} is not accepted; use at most 1000000 steps"),
                    ));
                }
            }
        }

        for (k, v) in &beyond {
            for (i, x) in v.values.iter().enumerate() {
                let item = if v.listed { format!("beyond.{k}[{i}]") } else { format!("beyond.{k}") };
                let learner = with_beyond(&LearnerSpec::default(), &[(k.as_str(), x)])
                    .map_err(|m| src.error(v.offset, &item, m))?;
                learner
                    .validate()
                    .map_err(|e| src.error(v.offset, &item, plain_message(&LabError::Learner(e))))?;
            }
        }

        // Seeds.
        let seeds: Vec<u64> = match (raw.seeds, raw.seed) {
            (Some(s), first) => {
                let offset = s.span().start;
                match s.into_inner() {
                    SeedsField::Count(n) => {
                        if n == 0 || n > 1_000_000 {
                            return Err(src.error(offset, "seeds", format!("{n} is not accepted; use a number of seeds in 1..=1000000, or a list of master seeds")));
                        }
                        let (first_at, first) =
                            first.map_or((offset, 0), |f| (f.span().start, f.into_inner()));
                        if first.checked_add(n - 1).is_none() {
                            return Err(src.error(first_at, "seed", format!("{first} is not accepted: the {n} seeds from it would pass 2^64 − 1; use a first seed of at most {}", u64::MAX - (n - 1))));
                        }
                        (0..n).map(|i| first + i).collect()
                    }
                    SeedsField::List(v) => {
                        if let Some(f) = first {
                            return Err(src.error(f.span().start, "seed", "`seed` (the first of `seeds` seeds) cannot be combined with a list of seeds; list them all in `seeds`"));
                        }
                        if v.is_empty() {
                            return Err(src.error(
                                offset,
                                "seeds",
                                "the list is empty; give at least one seed",
                            ));
                        }
                        let mut seen = BTreeSet::new();
                        for s in &v {
                            if !seen.insert(*s) {
                                return Err(src.error(offset, "seeds", format!("seed {s} is listed twice")));
                            }
                        }
                        v
                    }
                }
            }
            (None, first) => vec![first.map_or(0, |f| f.into_inner())],
        };

        // Worlds: loaded once each, hashed for the cell ids.
        let base = file.parent().map(Path::to_path_buf).unwrap_or_default();
        let mut worlds = Vec::new();
        let mut world_paths = Vec::new();
        let mut world_digests = Vec::new();
        for (i, w) in world.values.iter().enumerate() {
            let p = Path::new(w);
            let path = if p.is_absolute() { p.to_path_buf() } else { base.join(p) };
            // World::load reads at most MAX_FILE_BYTES (or takes the shipped copy); the
            // digest is of the text it parsed.
            let loaded =
                World::load(&path).map_err(|e| src.error(world.offset, &world.item(i), e.to_string()))?;
            let bytes = loaded.source.clone().into_bytes();
            worlds.push(loaded);
            world_paths.push(path);
            world_digests.push(format!("{:016x}", fnv1a(&bytes)));
        }

        // The product, first field outermost.
        let lens: Vec<usize> = texts.iter().map(|t| t.1.len()).collect();
        let n_cells = lens.iter().try_fold(1usize, |a, &l| a.checked_mul(l)).unwrap_or(usize::MAX);
        if n_cells.saturating_mul(seeds.len()) > MAX_JOBS {
            return Err(src.error(
                0,
                "seeds",
                format!(
                    "{n_cells} cells × {} seeds is more than {MAX_JOBS} jobs; split the sweep",
                    seeds.len()
                ),
            ));
        }
        let mut cells = Vec::with_capacity(n_cells);
        let mut configs = Vec::with_capacity(n_cells);
        let mut world_of = Vec::with_capacity(n_cells);
        let mut ids = HashMap::new();
        let mut idx = vec![0usize; texts.len()];
        for _ in 0..n_cells {
            let params: Vec<String> = idx.iter().zip(&texts).map(|(&i, t)| t.1[i].clone()).collect();
            let mut key = String::from("mmq-sweep-cell/1\n");
            for ((f, ..), v) in texts.iter().zip(&params) {
                let _ = writeln!(key, "{f}={v}");
            }
            let _ = writeln!(key, "world_bytes={}", world_digests[idx[0]]);
            let id = format!("{:016x}", fnv1a(key.as_bytes()));
            if let Some(other) = ids.insert(id.clone(), cells.len()) {
                return Err(LabError::Config {
                    file: file_name.clone(),
                    message: format!(
                        "cells {other} and {} hash to the same id {id}; change a value slightly",
                        cells.len()
                    ),
                });
            }
            let mut cfg = RunConfig {
                world: world_paths[idx[0]].clone(),
                env: envs[idx[1]],
                learner: LearnerSpec {
                    kind: learners[idx[2]],
                    params: Params {
                        alpha: alpha.values[idx[6]],
                        gamma: gamma.values[idx[7]],
                        epsilon: epsilon.values[idx[8]],
                        q0: q0.values[idx[9]],
                    },
                    lambda_hat: lambda_hat.values[idx[5]] as usize,
                    max_delay: max_delay.values[idx[4]] as usize,
                    ..LearnerSpec::default()
                },
                delay: delay.values[idx[3]].clone(),
                steps: steps.values[idx[10]],
                seed: seeds[0],
                seeds: 1,
                window: window.values[idx[11]],
                eval_steps: eval_steps.values[idx[12]],
                baseline: baseline.values[idx[13]],
                save_tables: false,
                ledger: false,
                ..RunConfig::default()
            };
            if !beyond.is_empty() {
                let pairs: Vec<(&str, &toml::Value)> = beyond
                    .iter()
                    .zip(&idx[FIELDS.len()..])
                    .map(|((k, v), &i)| (k.as_str(), &v.values[i]))
                    .collect();
                cfg.learner = with_beyond(&cfg.learner, &pairs)
                    .and_then(|l| l.validate().map(|_| l).map_err(|e| e.to_string()))
                    .map_err(|m| LabError::Config {
                        file: file_name.clone(),
                        message: format!("cell {} ({}): {m}", cells.len(), params.join(", ")),
                    })?;
            }
            cells.push(PlanCell { id, params });
            configs.push(cfg);
            world_of.push(idx[0]);
            // Odometer: the last field varies fastest.
            for k in (0..idx.len()).rev() {
                idx[k] += 1;
                if idx[k] < lens[k] {
                    break;
                }
                idx[k] = 0;
            }
        }
        let name = raw.name.unwrap_or_else(|| {
            file.file_stem().map_or_else(|| "sweep".into(), |s| s.to_string_lossy().into_owned())
        });
        let plan = Plan {
            name,
            description: raw.description.unwrap_or_default(),
            fields: texts.iter().map(|t| t.0.clone()).collect(),
            axes: texts.iter().filter(|t| t.2).map(|t| t.0.clone()).collect(),
            seeds,
            cells,
        };
        Ok(SweepSpec { file: file.to_path_buf(), text: text.to_string(), plan, configs, world_of, worlds })
    }

    /// The run configuration of cell `c` (one seed, no tables).
    pub fn config(&self, c: usize) -> &RunConfig {
        &self.configs[c]
    }

    /// The world of cell `c`.
    pub fn world(&self, c: usize) -> &World {
        &self.worlds[self.world_of[c]]
    }
}

fn text_of<T>(v: &Values<T>, f: impl Fn(&T) -> String) -> (String, Vec<String>, bool, usize) {
    (v.name.to_string(), v.values.iter().map(f).collect(), v.listed, v.offset)
}

/// A TOML value as a parameter text: strings bare, numbers in shortest form.
fn value_text(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        toml::Value::Integer(i) => i.to_string(),
        toml::Value::Float(f) => f.to_string(),
        toml::Value::Boolean(b) => b.to_string(),
        other => other.to_string(),
    }
}

/// `base` with `beyond.KEY = value` for every pair, through the learner's serde form,
/// so that every learner parameter this build knows can be set by name.
fn with_beyond(base: &LearnerSpec, pairs: &[(&str, &toml::Value)]) -> Result<LearnerSpec, String> {
    let mut v = toml::Value::try_from(base).map_err(|e| e.to_string())?;
    let table = v.as_table_mut().ok_or("the learner is not a table")?;
    let beyond = table.entry("beyond").or_insert_with(|| toml::Value::Table(toml::Table::new()));
    let beyond = beyond.as_table_mut().ok_or("`beyond` is not a table")?;
    for (k, x) in pairs {
        beyond.insert((*k).to_string(), (*x).clone());
    }
    v.try_into::<LearnerSpec>().map_err(|e| {
        let m = e.message().trim().replace('\n', "; ");
        if m.contains("unknown field `beyond`") {
            "this build's learners take no parameters beyond the paper's".to_string()
        } else {
            m
        }
    })
}

/// A lab error's message without the command-line flag it names (`--alpha = 2 ...` →
/// `2 ...`), for spec messages that name the field themselves.
fn plain_message(e: &LabError) -> String {
    match e {
        LabError::InvalidParam { value, accepted, .. } => format!("{value} is not accepted; {accepted}"),
        LabError::Learner(mmq_learn::LearnError::InvalidParam { value, accepted, .. }) => {
            format!("{value} is not accepted; {accepted}")
        }
        LabError::Delay(d) => d.to_string(),
        other => other.to_string(),
    }
}

/// 64-bit FNV-1a: a small, stable, dependency-free hash for ids (not for security).
fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

// ---------------------------------------------------------------------------------------
// Shards
// ---------------------------------------------------------------------------------------

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
    /// Parses `K/N` with 1 ≤ K ≤ N.
    pub fn parse(s: &str) -> Result<Shard, LabError> {
        let bad = || LabError::param("--shard", s, "use K/N with 1 <= K <= N, e.g. 2/8 (Slurm: --array=1-N)");
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let index: u64 = k.trim().parse().map_err(|_| bad())?;
        let count: u64 = n.trim().parse().map_err(|_| bad())?;
        if index == 0 || index > count {
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

// ---------------------------------------------------------------------------------------
// Stored results
// ---------------------------------------------------------------------------------------

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
/// for bit.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct StoredJob {
    format: String,
    mmq_version: String,
    cell: String,
    seed: u64,
    params: BTreeMap<String, String>,
    metrics: BTreeMap<String, String>,
}

fn encode(x: f64) -> String {
    if x.is_nan() { "NaN".into() } else { x.to_string() }
}

/// Reads job `j`'s file in `dir` if it is there and belongs to this plan's cell.
fn read_job(dir: &Path, plan: &Plan, j: usize) -> Option<Metrics> {
    let (c, seed) = plan.job(j);
    // A job file is a few KiB; anything else (a link to /dev/zero, a FIFO, a huge file)
    // is not a finished job and is run again.
    let text = mmq_core::files::read_text_bounded(&plan.job_path(dir, j), MAX_JOB_BYTES).ok()?;
    let s: StoredJob = serde_json::from_str(&text).ok()?;
    let cell = &plan.cells[c];
    let params_match =
        plan.fields.iter().zip(&cell.params).all(|(f, v)| s.params.get(f).is_some_and(|x| x == v));
    if s.format != FORMAT || s.cell != cell.id || s.seed != seed || !params_match {
        return None;
    }
    s.metrics.iter().map(|(k, v)| v.parse::<f64>().ok().map(|x| (k.clone(), x))).collect()
}

fn write_job(dir: &Path, plan: &Plan, j: usize, metrics: &Metrics) -> Result<(), LabError> {
    let (c, seed) = plan.job(j);
    let cell = &plan.cells[c];
    let s = StoredJob {
        format: FORMAT.into(),
        mmq_version: env!("CARGO_PKG_VERSION").into(),
        cell: cell.id.clone(),
        seed,
        params: plan.fields.iter().cloned().zip(cell.params.iter().cloned()).collect(),
        metrics: metrics.iter().map(|(k, v)| (k.clone(), encode(*v))).collect(),
    };
    let text = serde_json::to_string_pretty(&s).unwrap_or_default() + "\n";
    write_renamed(&plan.job_path(dir, j), text.as_bytes())
}

/// Writes `bytes` to a temporary file and renames it to `path`: readers see the old file
/// or the new one, never a part. Unlike [`write_atomic`] it does not wait for the disk
/// (fsync): a job file lost or emptied by a crash of the machine fails to parse, and
/// the job is simply run again, while thousands of short jobs are not slowed down.
fn write_renamed(path: &Path, bytes: &[u8]) -> Result<(), LabError> {
    let io = |source| LabError::Io { path: path.to_path_buf(), source };
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(io)?;
    }
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.tmp{}", std::process::id()));
    std::fs::write(&tmp, bytes).map_err(io)?;
    std::fs::rename(&tmp, path).map_err(io)
}

/// Finished results of every job of `plan` found in `dir` (None where missing).
pub fn load_results(dir: &Path, plan: &Plan) -> Vec<Option<Metrics>> {
    (0..plan.jobs()).into_par_iter().map(|j| read_job(dir, plan, j)).collect()
}

/// Reads `DIR/sweep.json`.
pub fn read_manifest(dir: &Path) -> Result<Manifest, LabError> {
    let p = dir.join("sweep.json");
    let text = mmq_core::files::read_text_bounded(&p, MAX_MANIFEST_BYTES).map_err(|e| LabError::Config {
        file: p.display().to_string(),
        message: format!("not a sweep output directory ({e}); run `mmq sweep SPEC --out DIR` first"),
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

fn write_manifest(dir: &Path, m: &Manifest) -> Result<(), LabError> {
    let text = serde_json::to_string_pretty(m).unwrap_or_default() + "\n";
    write_atomic(&dir.join("sweep.json"), text.as_bytes())
}

/// Whether a metric is a result (a column of `results.csv`): run-to-run timings and the
/// bookkeeping keys are not.
fn is_result_metric(k: &str) -> bool {
    k != "seed" && k != "complete" && !k.starts_with("time/")
}

/// A CSV field, quoted when needed.
pub(crate) fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) || s.starts_with(' ') || s.ends_with(' ') {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// A number for CSV: shortest round-trip form, empty for NaN, `inf`/`-inf`.
fn csv_num(x: f64) -> String {
    if x.is_nan() { String::new() } else { x.to_string() }
}

/// The tidy results table: a row per finished job in plan order (cells in product
/// order, seeds in spec order); columns `cell`, the swept parameters in [`FIELDS`]
/// order, `seed`, then every metric present in any row, in name order (empty where a
/// cell has no such metric, and for NaN). Returns the text and the number of rows.
pub fn results_csv(plan: &Plan, results: &[Option<Metrics>]) -> (String, usize) {
    let metrics: BTreeSet<&str> = results
        .iter()
        .flatten()
        .flat_map(|m| m.keys())
        .map(String::as_str)
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
            out.push_str(&r.get(*m).map_or(String::new(), |&x| csv_num(x)));
        }
        out.push('\n');
        rows += 1;
    }
    (out, rows)
}

/// Writes `DIR/results.csv` and `DIR/sweep.json` from the files in `dir`.
fn finish_dir(
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

// ---------------------------------------------------------------------------------------
// Running
// ---------------------------------------------------------------------------------------

/// What a sweep reports while it runs (the CLI prints it).
#[derive(Debug)]
pub enum SweepEvent<'a> {
    /// After reading the output directory, before any work.
    Planned {
        /// Jobs of the whole sweep.
        jobs_total: usize,
        /// Jobs of this shard (all without `--shard`).
        jobs_here: usize,
        /// Of those, already finished (skipped).
        done: usize,
        /// Distinct undelayed baselines to compute first.
        baselines: usize,
        /// Decision steps to run (jobs and baselines), for a progress bar.
        steps: u64,
    },
    /// A job finished and its result was written.
    JobDone {
        /// Cell id.
        cell: &'a str,
        /// Cell index in the plan.
        cell_index: usize,
        /// Master seed.
        seed: u64,
        /// Jobs finished so far in this process.
        finished: usize,
        /// Jobs this process set out to run.
        of: usize,
        /// Wall-clock seconds of the job.
        wall_s: f64,
    },
}

/// Callback for [`SweepEvent`]s.
pub type EventSink<'a> = dyn Fn(&SweepEvent<'_>) + Sync + 'a;

/// What [`run_sweep`] did.
#[derive(Clone, Debug)]
pub struct SweepOutcome {
    /// Jobs of the whole sweep.
    pub jobs_total: usize,
    /// Jobs of this shard.
    pub jobs_here: usize,
    /// Jobs found finished and skipped.
    pub skipped: usize,
    /// Jobs run and written by this call.
    pub ran: usize,
    /// Jobs of this shard still unfinished (after an interruption).
    pub left: usize,
    /// `DIR/results.csv`.
    pub results_csv: PathBuf,
    /// Its number of rows.
    pub rows: usize,
}

/// Key of an undelayed baseline: everything it depends on.
fn baseline_key(spec: &SweepSpec, c: usize, seed: u64) -> String {
    let cfg = spec.config(c);
    let p = cfg.learner.params;
    format!(
        "{}|{}|{}|{}|{}|{}|{}|{}|{}|{seed}",
        spec.world_of[c],
        cfg.env.name(),
        p.alpha,
        p.gamma,
        p.epsilon,
        p.q0,
        cfg.steps,
        cfg.window,
        cfg.eval_steps
    )
}

/// An undelayed baseline shared by the jobs that need it.
struct SharedBaseline {
    /// Jobs still to use it.
    users: AtomicUsize,
    /// Its state.
    slot: Mutex<Slot>,
}

/// The state of a shared baseline.
enum Slot {
    /// Not computed yet.
    Pending,
    /// The trajectory and its greedy evaluation.
    Ready(Arc<(Trajectory, f64)>),
    /// Unavailable: interrupted, failed, or no longer needed.
    Gone,
}

/// The undelayed Q-learning run of cell `c`'s baseline: what [`run_seed`] runs as its
/// baseline, as a run of its own.
fn baseline_config(cfg: &RunConfig) -> RunConfig {
    RunConfig { learner: cfg.baseline_learner(), delay: "none".into(), baseline: false, ..cfg.clone() }
}

/// Runs the jobs of `shard` (all without) that `out` does not hold yet, writing each
/// result as it finishes, then `results.csv` and `sweep.json`. Stops early (leaving
/// every finished result) when `ctl.stop` is set.
pub fn run_sweep(
    spec: &SweepSpec,
    out: &Path,
    shard: Option<Shard>,
    ctl: Control<'_>,
    events: &EventSink<'_>,
) -> Result<SweepOutcome, LabError> {
    let plan = &spec.plan;
    let spec_file = spec.file.display().to_string();
    write_atomic(&out.join("spec.toml"), spec.text.as_bytes())?;
    // The manifest first, so that a directory killed at once is still recognisable.
    finish_dir(out, plan, &spec_file, shard)?;
    let here: Vec<usize> = (0..plan.jobs()).filter(|&j| shard.is_none_or(|s| s.contains(j))).collect();
    let have: Vec<bool> = here.par_iter().map(|&j| read_job(out, plan, j).is_some()).collect();
    let pending: Vec<usize> = here.iter().zip(&have).filter(|x| !*x.1).map(|x| *x.0).collect();
    let skipped = here.len() - pending.len();

    // Refuse tables that cannot fit before running anything.
    let parallel = rayon::current_num_threads().min(pending.len()).max(1);
    let limit = memory_limit(parallel);
    let mut checked = BTreeSet::new();
    for &j in &pending {
        let c = plan.job(j).0;
        if checked.insert(c) {
            let cfg = spec.config(c);
            let (entries, bytes) = cfg.learner.table_bytes(spec.world(c).num_cells(), 4);
            if bytes > limit {
                return Err(mmq_learn::LearnError::TooLarge {
                    learner: cfg.learner.kind.name(),
                    entries,
                    need_gib: bytes as f64 / (1u128 << 30) as f64,
                    limit_gib: limit as f64 / (1u128 << 30) as f64,
                }
                .into());
            }
        }
    }

    // Distinct baselines of the pending jobs, each with the number of jobs that use it.
    let mut shared: HashMap<String, SharedBaseline> = HashMap::new();
    let mut base_steps = 0;
    for &j in &pending {
        let (c, seed) = plan.job(j);
        if spec.config(c).baseline {
            let e = shared.entry(baseline_key(spec, c, seed)).or_insert_with(|| {
                base_steps += spec.config(c).steps;
                SharedBaseline { users: AtomicUsize::new(0), slot: Mutex::new(Slot::Pending) }
            });
            e.users.fetch_add(1, Ordering::Relaxed);
        }
    }
    let steps: u64 = pending.iter().map(|&j| spec.config(plan.job(j).0).steps).sum::<u64>() + base_steps;
    events(&SweepEvent::Planned {
        jobs_total: plan.jobs(),
        jobs_here: here.len(),
        done: skipped,
        baselines: shared.len(),
        steps,
    });

    let failed = AtomicBool::new(false);
    let first_error = Mutex::new(None::<LabError>);
    let fail = |e: LabError| {
        failed.store(true, Ordering::SeqCst);
        let mut g = first_error.lock().unwrap_or_else(|p| p.into_inner());
        if g.is_none() {
            *g = Some(e);
        }
    };
    let halted = || ctl.stop.load(Ordering::Relaxed) || failed.load(Ordering::Relaxed);
    let dists: Vec<DelayDist> = spec.configs.iter().map(RunConfig::validate).collect::<Result<_, _>>()?;
    let optimum: Vec<f64> = spec.worlds.iter().map(|w| mmq_core::optimum(w).gain).collect();
    let ceilings: Vec<Option<f64>> = (0..spec.configs.len())
        .map(|c| crate::summary::ceiling_per_step(spec.config(c), spec.world(c)))
        .collect();

    // The baseline of job (c, seed): computed by the first job that asks, awaited by
    // the others that ask meanwhile, dropped after its last user.
    let baseline_of = |c: usize, seed: u64| -> Option<Arc<(Trajectory, f64)>> {
        let s = &shared[&baseline_key(spec, c, seed)];
        let mut slot = s.slot.lock().unwrap_or_else(|p| p.into_inner());
        if matches!(*slot, Slot::Pending) {
            let cfg = baseline_config(spec.config(c));
            *slot = match run_seed(&cfg, spec.world(c), &DelayDist::None, seed, None, ctl, limit) {
                Ok(r) if r.complete => Slot::Ready(Arc::new((r.run, r.greedy_per_step))),
                Ok(_) => Slot::Gone,
                Err(e) => {
                    fail(e);
                    Slot::Gone
                }
            };
        }
        let b = match &*slot {
            Slot::Ready(b) => Some(b.clone()),
            _ => None,
        };
        if s.users.fetch_sub(1, Ordering::AcqRel) == 1 {
            *slot = Slot::Gone;
        }
        b
    };

    let finished = AtomicUsize::new(0);
    pending.par_iter().for_each(|&j| {
        if halted() {
            return;
        }
        let (c, seed) = plan.job(j);
        let cfg = spec.config(c);
        let base = if cfg.baseline {
            match baseline_of(c, seed) {
                Some(b) => Some(b),
                None => return, // interrupted or failed
            }
        } else {
            None
        };
        if halted() {
            return;
        }
        let run_cfg = RunConfig { baseline: false, ..cfg.clone() };
        let mut r: SeedResult = match run_seed(&run_cfg, spec.world(c), &dists[c], seed, None, ctl, limit) {
            Ok(r) => r,
            Err(e) => return fail(e),
        };
        if !r.complete {
            return;
        }
        if let Some(b) = base {
            r.baseline = Some(b.0.clone());
            r.baseline_greedy_per_step = Some(b.1);
        }
        let metrics = seed_metrics(&r, optimum[spec.world_of[c]], ceilings[c]);
        if let Err(e) = write_job(out, plan, j, &metrics) {
            return fail(e);
        }
        let n = finished.fetch_add(1, Ordering::SeqCst) + 1;
        events(&SweepEvent::JobDone {
            cell: &plan.cells[c].id,
            cell_index: c,
            seed,
            finished: n,
            of: pending.len(),
            wall_s: r.wall_time_s,
        });
    });

    let (results_csv, rows, jobs_here, done) = finish_dir(out, plan, &spec_file, shard)?;
    if let Some(e) = first_error.into_inner().unwrap_or_else(|p| p.into_inner()) {
        return Err(e);
    }
    Ok(SweepOutcome {
        jobs_total: plan.jobs(),
        jobs_here,
        skipped,
        ran: finished.into_inner(),
        left: jobs_here - done,
        results_csv,
        rows,
    })
}

// ---------------------------------------------------------------------------------------
// Merging
// ---------------------------------------------------------------------------------------

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

fn same_results(a: &Metrics, b: &Metrics) -> bool {
    let f = |m: &Metrics| -> Vec<(String, u64)> {
        m.iter().filter(|(k, _)| is_result_metric(k)).map(|(k, v)| (k.clone(), v.to_bits())).collect()
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
            message: "the output directory holds another sweep; choose an empty --out".into(),
        });
    }
    let mut have: Vec<Option<Metrics>> = load_results(out, plan);
    let mut copied = 0;
    for d in dirs.iter().filter(|d| d.as_path() != out) {
        let theirs = load_results(d, plan);
        for (j, r) in theirs.into_iter().enumerate() {
            let Some(r) = r else { continue };
            match &have[j] {
                Some(mine) if same_results(mine, &r) => {}
                Some(_) => {
                    let (c, seed) = plan.job(j);
                    return Err(LabError::Config {
                        file: plan.job_path(d, j).display().to_string(),
                        message: format!(
                            "cell {} seed {seed} differs from the result already merged; were they run by different versions?",
                            plan.cells[c].id
                        ),
                    });
                }
                None => {
                    let src = plan.job_path(d, j);
                    let bytes =
                        mmq_core::files::read_bounded(&src, MAX_JOB_BYTES).map_err(|e| LabError::Config {
                            file: src.display().to_string(),
                            message: format!("cannot read the job file: {e}"),
                        })?;
                    write_renamed(&plan.job_path(out, j), &bytes)?;
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

// ---------------------------------------------------------------------------------------
// Report
// ---------------------------------------------------------------------------------------

/// Mean and 95 % interval of every metric of one cell over its finished seeds.
#[derive(Clone, Debug)]
pub struct CellStats {
    /// Cell index in the plan.
    pub cell: usize,
    /// Finished seeds.
    pub n: usize,
    /// Per metric (results only, non-finite values left out).
    pub metrics: BTreeMap<String, MeanCi>,
    /// Why a metric is absent (relative performance where a baseline earned ≤ 0).
    pub notes: Vec<String>,
}

/// Per-cell statistics of `results`.
pub fn cell_stats(plan: &Plan, results: &[Option<Metrics>]) -> Vec<CellStats> {
    let ns = plan.seeds.len();
    (0..plan.cells.len())
        .map(|c| {
            let done: Vec<&Metrics> = results[c * ns..(c + 1) * ns].iter().flatten().collect();
            let (metrics, notes) = crate::summary::aggregate(&done, is_result_metric);
            CellStats { cell: c, n: done.len(), metrics, notes }
        })
        .collect()
}

/// The per-cell table in tidy (long) form: `cell`, the swept parameters, `metric`,
/// `n`, `mean`, `ci95` (half-width of the 95 % interval), `std`.
pub fn summary_csv(plan: &Plan, stats: &[CellStats]) -> String {
    let mut out = String::from("cell");
    for a in &plan.axes {
        out.push(',');
        out.push_str(&csv_field(a));
    }
    out.push_str(",metric,n,mean,ci95,std\n");
    for s in stats {
        for (k, m) in &s.metrics {
            out.push_str(&plan.cells[s.cell].id);
            for a in &plan.axes {
                out.push(',');
                out.push_str(&csv_field(plan.param(s.cell, a)));
            }
            let _ = writeln!(
                out,
                ",{},{},{},{},{}",
                csv_field(k),
                m.n,
                csv_num(m.mean),
                csv_num(m.ci95),
                csv_num(m.std)
            );
        }
    }
    out
}

/// Headline metrics of reports: (name, label, shown as a percentage).
pub const HEADLINE: [(&str, &str, bool); 6] = [
    ("perf/relative", "relative performance", true),
    ("perf/fraction_of_ceiling", "fraction of ε-soft ceiling", true),
    ("perf/fraction_of_optimum", "fraction of optimum", true),
    ("perf/regret", "regret (reward)", false),
    ("eval/greedy_fraction_of_optimum", "greedy eval. (of optimum)", true),
    ("reward/earned_per_step", "earned / step", false),
];

/// A markdown report: the fixed parameters and a table of the headline metrics per cell.
pub fn summary_markdown(plan: &Plan, stats: &[CellStats]) -> String {
    let mut out = format!("# Sweep `{}`\n\n", plan.name);
    if !plan.description.is_empty() {
        let _ = writeln!(out, "{}\n", plan.description.trim());
    }
    let done: usize = stats.iter().map(|s| s.n).sum();
    let _ = writeln!(
        out,
        "{} cells × {} seeds = {} jobs; {done} finished. Means over seeds with 95 % confidence intervals (Student's t).\n",
        plan.cells.len(),
        plan.seeds.len(),
        plan.jobs()
    );
    let fixed = plan.fixed();
    if !fixed.is_empty() {
        out.push_str("Fixed: ");
        let parts: Vec<String> = fixed.iter().map(|(k, v)| format!("{k} = `{v}`")).collect();
        out.push_str(&parts.join(", "));
        out.push_str(".\n\n");
    }
    let shown: Vec<_> =
        HEADLINE.iter().filter(|h| stats.iter().any(|s| s.metrics.contains_key(h.0))).collect();
    out.push_str("| cell |");
    for a in &plan.axes {
        let _ = write!(out, " {a} |");
    }
    out.push_str(" seeds |");
    for h in &shown {
        let _ = write!(out, " {} |", h.1);
    }
    out.push_str("\n|---|");
    for _ in 0..plan.axes.len() + 1 + shown.len() {
        out.push_str("---|");
    }
    out.push('\n');
    for s in stats {
        let _ = write!(out, "| `{}` |", plan.cells[s.cell].id);
        for a in &plan.axes {
            let _ = write!(out, " {} |", plan.param(s.cell, a).replace('|', "\\|"));
        }
        let _ = write!(out, " {} |", s.n);
        for h in &shown {
            let _ =
                write!(out, " {} |", s.metrics.get(h.0).map_or("–".into(), |m| crate::format::mean(m, h.2)));
        }
        out.push('\n');
    }
    for s in stats {
        for note in &s.notes {
            let _ = writeln!(out, "\n- `{}`: {note}", plan.cells[s.cell].id);
        }
    }
    out.push_str("\nEvery metric of every cell: `summary.csv`; every seed: `results.csv`.\n");
    out
}

/// The value of an axis as a number for plots: numeric fields as they are, `delay` as
/// its mean in steps; None for names (world, env, learner).
pub fn axis_number(field: &str, value: &str) -> Option<f64> {
    match field {
        "delay" => DelayDist::parse(value).ok().map(|d| d.mean()),
        "world" | "env" | "learner" | "baseline" => None,
        _ => value.parse::<f64>().ok(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(text: &str) -> Result<SweepSpec, LabError> {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../worlds/sweeps");
        SweepSpec::parse(text, &dir.join("t.toml"))
    }

    #[test]
    fn product_order_ids_and_errors() {
        let s = spec(
            "world = \"../paper-3x3.toml\"\nlearner = [\"q\", \"mmq\"]\ndelay = [\"none\", \"poisson:2\", \"const:3\"]\nsteps = 100\nseeds = 2\nseed = 5\n",
        )
        .unwrap();
        let p = &s.plan;
        assert_eq!(p.axes, ["learner", "delay"]);
        assert_eq!(p.seeds, [5, 6]);
        assert_eq!(p.cells.len(), 6);
        assert_eq!(p.param(1, "delay"), "poisson:2");
        assert_eq!(p.param(3, "learner"), "mmq");
        assert_eq!(p.job(3), (1, 6));
        assert_eq!(s.config(4).learner.kind, LearnerKind::Mmq);
        let ids: BTreeSet<_> = p.cells.iter().map(|c| &c.id).collect();
        assert_eq!(ids.len(), 6);
        // Reordering the lists keeps the ids of the cells.
        let t = spec(
            "world = \"../paper-3x3.toml\"\nlearner = [\"mmq\", \"q\"]\ndelay = [\"const:3\", \"none\", \"poisson:2\"]\nsteps = 100\nseeds = 2\nseed = 5\n",
        )
        .unwrap();
        let ids2: BTreeSet<_> = t.plan.cells.iter().map(|c| &c.id).collect();
        assert_eq!(ids, ids2);

        let e = spec("world = \"../paper-3x3.toml\"\nalpha = [0.1, 2]\n").unwrap_err().to_string();
        assert!(e.contains("t.toml:2:9: alpha[1]: 2 is not accepted"), "{e}");
        let e = spec("world = \"../paper-3x3.toml\"\nlearnr = \"q\"\n").unwrap_err().to_string();
        assert!(e.contains("t.toml:2:1: learnr: unknown field"), "{e}");
        let e = spec("world = \"../paper-3x3.toml\"\nsteps = \"many\"\n").unwrap_err().to_string();
        assert!(e.contains("t.toml:2:9: steps: invalid type"), "{e}");
    }

    /// A few bytes must not describe more than MAX_JOBS jobs (every cell is built in
    /// memory), and `/dev/zero` as a spec is refused as not a regular file.
    #[test]
    fn refuses_specs_too_large_to_build() {
        let alphas: Vec<String> = (0..101).map(|i| format!("{}", i as f64 / 100.0)).collect();
        let list = format!("[{}]", alphas.join(", "));
        let text = format!(
            "world = \"../paper-3x3.toml\"\nalpha = {list}\ngamma = [{}]\nepsilon = {list}\nseeds = 2\n",
            (0..99).map(|i| format!("{}", i as f64 / 100.0)).collect::<Vec<_>>().join(", ")
        );
        let e = spec(&text).unwrap_err().to_string();
        assert!(e.contains("1009899 cells × 2 seeds is more than 1000000 jobs"), "{e}");
        if Path::new("/dev/zero").exists() {
            let e = SweepSpec::load(Path::new("/dev/zero")).unwrap_err().to_string();
            assert!(e.contains("/dev/zero") && e.contains("not a regular file"), "{e}");
        }
    }

    #[test]
    fn shards_are_disjoint_and_cover() {
        let shards: Vec<Shard> = (1..=3).map(|k| Shard::parse(&format!("{k}/3")).unwrap()).collect();
        for j in 0..50 {
            assert_eq!(shards.iter().filter(|s| s.contains(j)).count(), 1);
        }
        for bad in ["0/3", "4/3", "3", "a/b", "1/0"] {
            assert!(Shard::parse(bad).is_err(), "{bad}");
        }
    }

    /// The shared baseline gives the same metrics as `run_seed`'s own baseline.
    #[test]
    fn shared_baseline_is_run_seeds_baseline() {
        let s = spec("world = \"../paper-3x3.toml\"\nlearner = \"mmq\"\ndelay = \"poisson:2\"\nmax_delay = 4\nsteps = 3000\n").unwrap();
        let stop = AtomicBool::new(false);
        let ctl = Control { stop: &stop, progress: &|_| {} };
        let cfg = s.config(0);
        let dist = cfg.validate().unwrap();
        let whole = run_seed(cfg, s.world(0), &dist, 7, None, ctl, 1 << 30).unwrap();
        let mut part =
            run_seed(&RunConfig { baseline: false, ..cfg.clone() }, s.world(0), &dist, 7, None, ctl, 1 << 30)
                .unwrap();
        let base =
            run_seed(&baseline_config(cfg), s.world(0), &DelayDist::None, 7, None, ctl, 1 << 30).unwrap();
        part.baseline = Some(base.run);
        part.baseline_greedy_per_step = Some(base.greedy_per_step);
        let opt = mmq_core::optimum(s.world(0)).gain;
        let a = seed_metrics(&whole, opt, None);
        let b = seed_metrics(&part, opt, None);
        assert!(a.contains_key("perf/relative"));
        assert!(same_results(&a, &b), "{a:?}\n{b:?}");
    }

    #[test]
    fn csv_quotes_and_numbers() {
        assert_eq!(csv_field("hist:1,2"), "\"hist:1,2\"");
        assert_eq!(csv_num(f64::NAN), "");
        assert_eq!(csv_num(0.1), "0.1");
        assert_eq!(encode(f64::INFINITY).parse::<f64>().unwrap(), f64::INFINITY);
        assert!(encode(f64::NAN).parse::<f64>().unwrap().is_nan());
    }
}
