//! The parsed, validated spec: every field's values checked against the rules of
//! `mmq run`, the seeds, the worlds loaded once each, and the product of the axes as
//! cells, each with its run configuration.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use mmq_core::World;
use mmq_learn::{LearnerKind, LearnerSpec};
use toml::Spanned;

use super::cell::{Axis, CellFields, LEARNER_FIELDS};
use super::plan::{Plan, PlanCell, fnv1a};
use super::syntax::{META, Meta, SeedsField, Source};
use super::{FIELDS, MAX_JOBS, MAX_SPEC_BYTES};
use crate::config::{EnvKind, RunConfig};
use crate::error::LabError;
use crate::settings::{has_setting, learners_with, with_settings};

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
    pub(super) configs: Vec<RunConfig>,
    /// Per cell: index into `worlds`.
    pub(super) world_of: Vec<usize>,
    /// Distinct worlds, each with its robot setting applied (world-major: world `w`
    /// with robot setting `r` is `w × settings + r`).
    pub(super) worlds: Vec<World>,
    /// Points of the learning curve stored per job (0: none; spec `curve`).
    pub(super) curve: u64,
}

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
        let meta: Meta = toml::from_str(text).map_err(|e| src.toml_error(&e))?;
        let doc: BTreeMap<Spanned<String>, Spanned<toml::Value>> =
            toml::from_str(text).map_err(|e| src.toml_error(&e))?;

        // The cell fields the spec gives; a key that is neither one nor a spec field is
        // refused by the cells' own deserialisation.
        let mut given = BTreeMap::new();
        for (key, value) in doc {
            let (at, name) = (key.span().start, key.into_inner());
            if META.contains(&name.as_str()) {
                continue;
            }
            if let Err(m) = CellFields::from_values([(name.as_str(), value.get_ref())])
                && m.starts_with("unknown field")
            {
                return Err(src.error(at, &name, format!("{m}; see docs/sweeps.md")));
            }
            given.insert(name, value);
        }
        // The fields in FIELDS order (absent ones at their defaults), then `robot` and
        // `curve` only when given, so that the cell ids of specs without them stay as
        // they were; then the learner settings.
        let defaults = match toml::Value::try_from(CellFields::default()) {
            Ok(toml::Value::Table(t)) => t,
            _ => unreachable!("a struct serialises to a table"),
        };
        let mut axes = Vec::new();
        for name in FIELDS {
            match (given.remove(name), defaults.get(name)) {
                (Some(v), _) => axes.push(Axis::given(name.to_string(), v)),
                (None, Some(d)) if name != "world" => axes.push(Axis::default_of(name, d.clone())),
                (None, _) => {
                    return Err(src.error(
                        0,
                        "world",
                        "missing field `world`: give a world file (relative to the spec's directory), or a list of them",
                    ));
                }
            }
        }
        if let Some(v) = given.remove("robot") {
            axes.push(Axis::given("robot".into(), v));
        }
        debug_assert!(given.is_empty(), "a cell field outside FIELDS and robot: {given:?}");
        let n_fields = axes.len();
        // Every value of a cell field on its own: its type, and its canonical text.
        for axis in &mut axes {
            for i in 0..axis.values.len() {
                let cell = CellFields::from_values([(axis.name.as_str(), &axis.values[i])])
                    .map_err(|m| src.error(axis.offset, &axis.item(i), m))?;
                axis.texts[i] = cell.text(&axis.name).unwrap_or_default();
            }
        }
        if let Some(c) = &meta.curve {
            let n = toml::Value::Integer(*c.get_ref() as i64);
            axes.push(Axis { offset: c.span().start, ..Axis::default_of("curve", n) });
        }
        // `[settings]` (or `[beyond]`, its name in stored specs): fields `settings.KEY`
        // after the others, in key order.
        let (prefix, table) = match (meta.settings, meta.beyond) {
            (Some(_), Some(b)) => {
                let at = b.values().next().map_or(0, |v| v.span().start);
                return Err(src.error(at, "beyond", "give the learner settings in one table, [settings]"));
            }
            (Some(t), None) => ("settings", t),
            (None, Some(b)) => ("beyond", b),
            (None, None) => ("settings", Default::default()),
        };
        let settings_at = axes.len();
        let keys: Vec<String> = table.keys().cloned().collect();
        axes.extend(table.into_iter().map(|(k, v)| Axis::given(format!("{prefix}.{k}"), v)));
        for axis in &axes {
            if axis.values.is_empty() {
                return Err(src.error(axis.offset, &axis.name, "the list is empty; give at least one value"));
            }
            let mut seen = BTreeSet::new();
            for v in &axis.texts {
                if !seen.insert(v) {
                    return Err(src.error(axis.offset, &axis.name, format!("`{v}` is listed twice")));
                }
            }
        }
        let at = |name: &str| axes.iter().position(|a| a.name == name);
        let (world, env, learner) =
            (&axes[0], &axes[at("env").unwrap_or(1)], &axes[at("learner").unwrap_or(2)]);

        // Every value against the rules of `mmq run`.
        for axis in &axes[..n_fields] {
            for (i, v) in axis.values.iter().enumerate() {
                let cell = CellFields::from_values([(axis.name.as_str(), v)])
                    .map_err(|m| src.error(axis.offset, &axis.item(i), m))?;
                check_value(&axis.name, &cell).map_err(|m| src.error(axis.offset, &axis.item(i), m))?;
            }
        }
        let learners: Vec<LearnerKind> =
            learner.texts.iter().filter_map(|l| LearnerKind::parse(l).ok()).collect();
        // A learner setting (`max_delay`, `lambda_hat` when given, those of `[settings]`)
        // applies to the cells whose learner has it; one no learner of the sweep has is an
        // error, and each value is checked by the first learner that has it.
        let learner_settings = axes
            .iter()
            .filter(|a| a.given && LEARNER_FIELDS.contains(&a.name.as_str()))
            .map(|a| (a.name.as_str(), a))
            .chain(keys.iter().map(String::as_str).zip(&axes[settings_at..]));
        for (k, axis) in learner_settings {
            let Some(&kind) = learners.iter().find(|&&l| has_setting(l, k)) else {
                let names: Vec<&str> = learners.iter().map(|l| l.name()).collect();
                let with = learners_with(k);
                let fix = if with.is_empty() {
                    "no learner has it; remove it (`mmq learners` and docs/sweeps.md list the settings)"
                        .to_string()
                } else {
                    format!("add a learner that has it ({}) to `learner`, or remove it", with.join(", "))
                };
                return Err(src.error(
                    axis.offset,
                    &axis.name,
                    format!("no learner of the sweep ({}) has this setting; {fix}", names.join(", ")),
                ));
            };
            for (i, x) in axis.values.iter().enumerate() {
                with_settings(&LearnerSpec::new(kind), &[(k, x)])
                    .map_err(|e| src.error(axis.offset, &axis.item(i), plain_message(&e)))?;
            }
        }
        let seeds = seeds_of(&src, meta.seeds, meta.seed)?;

        // Worlds: loaded once each, hashed for the cell ids.
        let robot_at = at("robot");
        let robot = robot_at.map(|k| &axes[k]);
        let base = file.parent().map(Path::to_path_buf).unwrap_or_default();
        let mut worlds = Vec::new();
        let mut world_paths = Vec::new();
        let mut world_digests = Vec::new();
        for (i, w) in world.texts.iter().enumerate() {
            let p = Path::new(w);
            let path = if p.is_absolute() { p.to_path_buf() } else { base.join(p) };
            // World::load reads at most MAX_FILE_BYTES (or takes the shipped copy); the
            // digest is of the text it parsed.
            let loaded =
                World::load(&path).map_err(|e| src.error(world.offset, &world.item(i), e.to_string()))?;
            let bytes = loaded.source.clone().into_bytes();
            match robot {
                None => worlds.push(loaded),
                Some(r) => {
                    for (k, setting) in r.values.iter().enumerate() {
                        let overrides = CellFields::from_values([("robot", setting)]).map(|c| c.robot.0);
                        worlds.push(
                            overrides
                                .and_then(|o| with_robot(&loaded, &o))
                                .map_err(|m| src.error(r.offset, &r.item(k), format!("{m} (world `{w}`)")))?,
                        );
                    }
                }
            }
            world_paths.push(path);
            world_digests.push(format!("{:016x}", fnv1a(&bytes)));
        }
        let robot_settings = robot.map_or(1, |r| r.values.len());
        if let Some(r) = robot
            && !env.texts.iter().any(|e| e == EnvKind::Robot.name())
        {
            return Err(src.error(
                r.offset,
                "robot",
                "no cell runs the robot; add \"robot\" to `env` (e.g. env = [\"grid\", \"robot\"]), or remove `robot`",
            ));
        }
        if let Some(c) = &meta.curve {
            let steps = &axes[at("steps").unwrap_or(10)].values;
            let windows = &axes[at("window").unwrap_or(11)].values;
            check_curve(&src, *c.get_ref(), c.span().start, steps, windows)?;
        }

        // The product, first field outermost.
        let lens: Vec<usize> = axes.iter().map(|a| a.values.len()).collect();
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
        let mut idx = vec![0usize; axes.len()];
        for _ in 0..n_cells {
            let params: Vec<String> = idx.iter().zip(&axes).map(|(&i, a)| a.texts[i].clone()).collect();
            let mut key = String::from("mmq-sweep-cell/1\n");
            for (a, v) in axes.iter().zip(&params) {
                // Learner settings enter the id as `beyond.KEY`, so that a spec keeps its
                // cell ids whichever name its table has.
                let f = a
                    .name
                    .strip_prefix("settings.")
                    .map_or_else(|| a.name.clone(), |k| format!("beyond.{k}"));
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
            // The cell's values, deserialised into its fields and then its configuration.
            let in_cell = |k: usize| (k < n_fields).then(|| (axes[k].name.as_str(), &axes[k].values[idx[k]]));
            let settings: Vec<(&str, &toml::Value)> = keys
                .iter()
                .zip(&idx[settings_at..])
                .zip(&axes[settings_at..])
                .map(|((k, &i), a)| (k.as_str(), &a.values[i]))
                .collect();
            let cfg = CellFields::from_values((0..axes.len()).filter_map(in_cell))
                .map_err(|message| LabError::Config { file: file_name.clone(), message })
                .and_then(|cell| cell.run_config(world_paths[idx[0]].clone(), seeds[0], &settings))
                .map_err(|e| LabError::Config {
                    file: file_name.clone(),
                    message: format!("cell {} ({}): {}", cells.len(), params.join(", "), plain_message(&e)),
                })?;
            cells.push(PlanCell { id, params });
            configs.push(cfg);
            world_of.push(idx[0] * robot_settings + robot_at.map_or(0, |k| idx[k]));
            // Odometer: the last field varies fastest.
            for k in (0..idx.len()).rev() {
                idx[k] += 1;
                if idx[k] < lens[k] {
                    break;
                }
                idx[k] = 0;
            }
        }
        let name = meta.name.unwrap_or_else(|| {
            file.file_stem().map_or_else(|| "sweep".into(), |s| s.to_string_lossy().into_owned())
        });
        let plan = Plan {
            name,
            description: meta.description.unwrap_or_default(),
            fields: axes.iter().map(|a| a.name.clone()).collect(),
            axes: axes.iter().filter(|a| a.listed).map(|a| a.name.clone()).collect(),
            seeds,
            cells,
        };
        Ok(SweepSpec {
            file: file.to_path_buf(),
            text: text.to_string(),
            plan,
            configs,
            world_of,
            worlds,
            curve: meta.curve.map_or(0, |c| c.into_inner()),
        })
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

/// The master seeds: `seeds = N` from `seed` (default 0), or the listed ones.
fn seeds_of(
    src: &Source<'_>,
    seeds: Option<Spanned<SeedsField>>,
    first: Option<Spanned<u64>>,
) -> Result<Vec<u64>, LabError> {
    let Some(s) = seeds else { return Ok(vec![first.map_or(0, |f| f.into_inner())]) };
    let offset = s.span().start;
    match s.into_inner() {
        SeedsField::Count(n) => {
            if n == 0 || n > 1_000_000 {
                return Err(src.error(
                    offset,
                    "seeds",
                    format!(
                        "{n} is not accepted; use a number of seeds in 1..=1000000, or a list of master seeds"
                    ),
                ));
            }
            let (first_at, first) = first.map_or((offset, 0), |f| (f.span().start, f.into_inner()));
            if first.checked_add(n - 1).is_none() {
                return Err(src.error(first_at, "seed", format!("{first} is not accepted: the {n} seeds from it would pass 2^64 − 1; use a first seed of at most {}", u64::MAX - (n - 1))));
            }
            Ok((0..n).map(|i| first + i).collect())
        }
        SeedsField::List(v) => {
            if let Some(f) = first {
                return Err(src.error(f.span().start, "seed", "`seed` (the first of `seeds` seeds) cannot be combined with a list of seeds; list them all in `seeds`"));
            }
            if v.is_empty() {
                return Err(src.error(offset, "seeds", "the list is empty; give at least one seed"));
            }
            let mut seen = BTreeSet::new();
            for s in &v {
                if !seen.insert(*s) {
                    return Err(src.error(offset, "seeds", format!("seed {s} is listed twice")));
                }
            }
            Ok(v)
        }
    }
}

/// A value of a cell field, alone in `cell`, against the rules of `mmq run`. Worlds are
/// loaded, and robot settings applied to them, once each where the product is built.
fn check_value(name: &str, cell: &CellFields) -> Result<(), String> {
    match name {
        "world" => Ok(()),
        "robot" if cell.robot.is_empty() => {
            Err("no overrides; give KEY=VALUE overrides of the [robot] table, e.g. \"profile=ideal\"".into())
        }
        "max_delay" | "lambda_hat" => {
            let x = if name == "max_delay" { cell.max_delay } else { cell.lambda_hat };
            if usize::try_from(x).is_err() || x > 1_000_000 {
                return Err(format!("{x} is not accepted; use at most 1000000 steps"));
            }
            Ok(())
        }
        _ => cell
            .run_config(PathBuf::new(), 0, &[])
            .and_then(|c| c.validate())
            .map(|_| ())
            .map_err(|e| plain_message(&e)),
    }
}

/// `curve = n` points must fall on the windows of every cell's curve.
fn check_curve(
    src: &Source<'_>,
    n: u64,
    offset: usize,
    steps: &[toml::Value],
    windows: &[toml::Value],
) -> Result<(), LabError> {
    if n == 0 || n > 1000 {
        return Err(src.error(
            offset,
            "curve",
            format!("{n} is not accepted; use a number of points in 1..=1000, e.g. 15"),
        ));
    }
    let ints = |v: &[toml::Value]| {
        v.iter().filter_map(toml::Value::as_integer).map(|x| x as u64).collect::<Vec<_>>()
    };
    for &st in &ints(steps) {
        for &w in &ints(windows) {
            if !st.is_multiple_of(n) || !(st / n).is_multiple_of(w) {
                return Err(src.error(offset, "curve", format!(
                    "{st} steps in {n} points of {} steps each do not fall on windows of {w} steps; choose `curve` so that steps / curve is a multiple of `window`",
                    st as f64 / n as f64
                )));
            }
        }
    }
    Ok(())
}

/// `world` with the robot overrides applied to its `[robot]` table, checked as the
/// robot will read it (the grid ignores the table).
fn with_robot(world: &World, overrides: &[String]) -> Result<World, String> {
    let table = mmq_robot::apply_overrides(world.robot.as_ref(), overrides).map_err(|e| e.to_string())?;
    let mut w = world.clone();
    w.robot = Some(table);
    mmq_robot::RobotConfig::from_world(&w).map_err(|e| e.to_string())?;
    Ok(w)
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
        LabError::Setting { message, .. } => message.clone(),
        other => other.to_string(),
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
        assert_eq!(s.config(4).learner.kind(), LearnerKind::Mmq);
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

    /// `robot` is an axis of settings, each `KEY=VALUE` overrides (one string or a
    /// list); it is applied to the cell's world and run configuration, and bad input
    /// names the item and the fix.
    #[test]
    fn robot_settings_are_an_axis() {
        let base = "world = \"../paper-3x3.toml\"\nenv = [\"grid\", \"robot\"]\nsteps = 100\n";
        let s = spec(&format!(
            "{base}robot = [\"profile=ideal\", [\"profile=realistic\", \"preset=kobuki\"]]\ndelay = \"exponential:4s\"\n"
        ))
        .unwrap();
        let p = &s.plan;
        assert_eq!(p.axes, ["env", "robot"]);
        assert_eq!(p.cells.len(), 4);
        assert_eq!(p.param(3, "robot"), "profile=realistic preset=kobuki");
        assert_eq!(p.param(3, "env"), "robot");
        assert_eq!(s.config(3).robot, ["profile=realistic", "preset=kobuki"]);
        assert_eq!(s.config(3).env, EnvKind::Robot);
        let cfg = mmq_robot::RobotConfig::from_world(s.world(3)).unwrap();
        assert_eq!((cfg.profile, cfg.preset), (mmq_robot::Profile::Realistic, mmq_robot::Preset::Kobuki));
        let cfg = mmq_robot::RobotConfig::from_world(s.world(2)).unwrap();
        assert_eq!(cfg.profile, mmq_robot::Profile::Ideal);
        // Different settings are different worlds (and baselines); the delay in seconds
        // is accepted as in `mmq run`.
        assert_ne!(s.world_of[2], s.world_of[3]);
        assert_eq!(s.config(0).validate().unwrap().unit(), mmq_core::DelayUnit::Seconds);
        // One string with several overrides is one setting.
        let t = spec(&format!("{base}robot = \"profile=realistic preset=kobuki\"\n")).unwrap();
        assert_eq!(t.plan.axes, ["env"]);
        assert_eq!(t.config(1).robot, ["profile=realistic", "preset=kobuki"]);
        // Without `robot` the plan has no such field (cell ids of older specs stay).
        let u = spec(base).unwrap();
        assert!(!u.plan.fields.iter().any(|f| f == "robot"));

        let e = spec(&format!("{base}robot = [\"profile=ideal\", \"speed=2\"]\n")).unwrap_err().to_string();
        assert!(e.contains("t.toml:4:9: robot[1]:") && e.contains("speed"), "{e}");
        let e = spec(&format!("{base}robot = [\"profile=ideal\", \"profile\"]\n")).unwrap_err().to_string();
        assert!(e.contains("robot[1]:") && e.contains("KEY=VALUE"), "{e}");
        let e = spec(&format!("{base}robot = [\"profile=ideal\", \"\"]\n")).unwrap_err().to_string();
        assert!(e.contains("robot[1]: no overrides"), "{e}");
        let e =
            spec(&format!("{base}robot = [\"profile=ideal\", \"profile=ideal\"]\n")).unwrap_err().to_string();
        assert!(e.contains("robot: `profile=ideal` is listed twice"), "{e}");
        let e =
            spec("world = \"../paper-3x3.toml\"\nrobot = \"profile=realistic\"\n").unwrap_err().to_string();
        assert!(e.contains("robot: no cell runs the robot; add \"robot\" to `env`"), "{e}");
        let e = spec(&format!("{base}robot = 3\n")).unwrap_err().to_string();
        assert!(e.contains("robot:") && e.contains("KEY=VALUE overrides"), "{e}");
        let e = spec(&format!("{base}delay = \"exponential:4\"\n")).unwrap_err().to_string();
        assert!(e.contains("delay:") && e.contains("exponential:4s"), "{e}");
    }

    /// A setting applies to the cells whose learner has it (`max_delay` to `mmq`, not to
    /// `q`; `trace_decay` to `q-lambda`); one no learner of the sweep has, or a bad value,
    /// is refused with the field (top-level `max_delay` and `lambda_hat` too); `[beyond]`
    /// is read as `[settings]` with the same ids.
    #[test]
    fn settings_apply_to_the_learners_that_have_them() {
        use mmq_learn::LearnerSettings as S;
        let base = "world = \"../paper-3x3.toml\"\nlearner = [\"q\", \"q-lambda\", \"mmq\"]\nmax_delay = 7\nsteps = 100\n";
        let s = spec(&format!("{base}[settings]\ntrace_decay = [0.5, 0.9]\n")).unwrap();
        assert_eq!(s.plan.axes, ["learner", "settings.trace_decay"]);
        assert_eq!(s.plan.cells.len(), 6);
        let learners: Vec<&S> = (0..6).map(|c| &s.config(c).learner.settings).collect();
        assert!(matches!(learners[0], S::Q(_)) && matches!(learners[1], S::Q(_)));
        match (learners[2], learners[3]) {
            (S::QLambda(a), S::QLambda(b)) => assert_eq!((a.trace_decay, b.trace_decay), (0.5, 0.9)),
            other => panic!("{other:?}"),
        }
        assert_eq!(learners[4].max_delay(), Some(7));
        assert_eq!(learners[5], learners[4]);
        // The table's older name gives the same cells and ids, its fields keep that name.
        let t = spec(&format!("{base}[beyond]\ntrace_decay = [0.5, 0.9]\n")).unwrap();
        assert_eq!(t.plan.axes, ["learner", "beyond.trace_decay"]);
        let ids = |s: &SweepSpec| s.plan.cells.iter().map(|c| c.id.clone()).collect::<Vec<_>>();
        assert_eq!(ids(&s), ids(&t));
        assert_eq!(t.config(3).learner, s.config(3).learner);

        // `max_delay` and `lambda_hat` at the top level follow the same rule: one that no
        // learner of the sweep reads is refused, not ignored.
        let e = spec("world = \"../paper-3x3.toml\"\nlearner = [\"q\", \"mmq\"]\nlambda_hat = 0\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("t.toml:3:14: lambda_hat: no learner of the sweep (q, mmq) has this setting"),
            "{e}"
        );
        assert!(e.contains("add a learner that has it (fixed) to `learner`"), "{e}");
        let e = spec("world = \"../paper-3x3.toml\"\nlearner = \"q\"\nmax_delay = [5, 9]\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("max_delay: no learner of the sweep (q) has this setting"), "{e}");
        let u = spec("world = \"../paper-3x3.toml\"\nlearner = [\"q\", \"fixed\"]\nlambda_hat = [3, 4]\n")
            .unwrap();
        assert_eq!(
            u.config(3).learner.settings,
            S::Fixed(mmq_learn::settings::FixedSettings { lambda_hat: 4 })
        );
        assert_eq!(u.config(1).learner.settings, u.config(0).learner.settings);
        // Absent, they keep their defaults in every cell (and in the cell ids).
        let v = spec("world = \"../paper-3x3.toml\"\nlearner = \"q\"\n").unwrap();
        assert_eq!(v.plan.param(0, "max_delay"), "50");
        let e = spec(&format!("{base}[settings]\nlasso = 0.2\n")).unwrap_err().to_string();
        assert!(
            e.contains("settings.lasso: no learner of the sweep (q, q-lambda, mmq) has this setting"),
            "{e}"
        );
        assert!(e.contains("(deconv-q, deconv-model, deconv-model-time)"), "{e}");
        let e = spec(&format!("{base}[settings]\nspeed = 2\n")).unwrap_err().to_string();
        assert!(e.contains("settings.speed:") && e.contains("no learner has it"), "{e}");
        let e = spec(&format!("{base}[settings]\ntrace_decay = [0.5, 1.5]\n")).unwrap_err().to_string();
        assert!(e.contains("settings.trace_decay[1]: 1.5 is not accepted"), "{e}");
        let e = spec(&format!("{base}[settings]\ntrace_decay = \"high\"\n")).unwrap_err().to_string();
        assert!(e.contains("settings.trace_decay:") && e.contains("invalid type"), "{e}");
        let e = spec(&format!("{base}[settings]\ntrace_decay = 0.5\n[beyond]\ntrace_decay = 0.9\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("one table, [settings]"), "{e}");
    }

    /// `curve = N` stores N points of the learning curve per job; they must fall on
    /// the windows of the curve.
    #[test]
    fn curve_points_fall_on_windows() {
        let base = "world = \"../paper-3x3.toml\"\nsteps = 1000\n";
        let s = spec(&format!("{base}window = 100\ncurve = 5\n")).unwrap();
        assert_eq!(s.curve, 5);
        assert_eq!(s.plan.fixed().last().map(|f| f.0.as_str()), Some("curve"));
        let e = spec(&format!("{base}window = 300\ncurve = 5\n")).unwrap_err().to_string();
        assert!(e.contains("curve:") && e.contains("multiple of `window`"), "{e}");
        let e = spec(&format!("{base}curve = 0\n")).unwrap_err().to_string();
        assert!(e.contains("curve: 0 is not accepted"), "{e}");
    }
}
