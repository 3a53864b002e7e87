//! One product of a sweep: the fields a spec (or one of its parts) gives, every value
//! checked on its own against the rules of `mmq run`, the worlds loaded once each, and
//! the cells of the product, each with its id and its run configuration.

use std::collections::{BTreeSet, HashMap};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use mmq_core::World;
use mmq_learn::{LearnerKind, LearnerSpec};
use toml::Spanned;

use super::cell::{Axis, CellFields, LEARNER_FIELDS};
use super::plan::{PlanCell, fnv1a};
use super::syntax::{Given, SeedsField, Source};
use super::{FIELDS, MAX_JOBS};
use crate::config::{EnvKind, RunConfig};
use crate::error::LabError;
use crate::settings::{has_setting, learners_with, with_settings};

/// The cells of one product, with what they need to run.
pub(super) struct Product {
    /// The fields, in canonical order, and whether each is a list (an axis).
    pub(super) fields: Vec<(String, bool)>,
    pub(super) seeds: Vec<u64>,
    pub(super) cells: Vec<PlanCell>,
    pub(super) configs: Vec<RunConfig>,
    /// Per cell: index into `worlds`.
    pub(super) world_of: Vec<usize>,
    /// Distinct worlds, each with its robot setting applied (world-major: world `w`
    /// with robot setting `r` is `w × settings + r`).
    pub(super) worlds: Vec<World>,
}

/// The fields of a product: every field's values as an axis, in canonical order.
struct Axes {
    axes: Vec<Axis>,
    /// The axes before this one are cell fields ([`CellFields`]).
    n_fields: usize,
    /// The axes from this one on are learner settings, named by `keys`.
    settings_at: usize,
    keys: Vec<String>,
}

impl Axes {
    fn at(&self, name: &str) -> Option<usize> {
        self.axes.iter().position(|a| a.name == name)
    }

    fn named(&self, name: &str) -> &Axis {
        &self.axes[self.at(name).unwrap_or_else(|| panic!("no field `{name}`"))]
    }
}

/// Worlds loaded once each: per world value its path and the digest of its text, and
/// per (world, robot setting) the world with the setting applied.
struct Worlds {
    paths: Vec<PathBuf>,
    digests: Vec<String>,
    loaded: Vec<World>,
}

/// The product of what `g` gives. `curve` is the spec's, `base` the directory relative
/// world paths start from, `budget` the jobs the product may have at most.
pub(super) fn product(
    src: &Source<'_>,
    mut g: Given,
    curve: Option<&Spanned<u64>>,
    base: &Path,
    budget: usize,
) -> Result<Product, LabError> {
    let (seeds, seed) = (g.seeds.take(), g.seed.take());
    let ax = axes(src, g, curve)?;
    check_values(src, &ax)?;
    let seeds = seeds_of(src, seeds, seed)?;
    let robot = ax.at("robot").map(|k| &ax.axes[k]);
    let worlds = load_worlds(src, &ax.axes[0], robot, base)?;
    if let Some(r) = robot
        && !ax.named("env").texts.iter().any(|e| e == EnvKind::Robot.name())
    {
        return Err(src.error(
            r.offset,
            "robot",
            "no cell runs the robot; add \"robot\" to `env` (e.g. env = [\"grid\", \"robot\"]), or remove `robot`",
        ));
    }
    if let Some(s) = ax.at("swarm").map(|k| &ax.axes[k])
        && !ax.named("env").texts.iter().any(|e| e == EnvKind::Swarm.name())
    {
        return Err(src.error(
            s.offset,
            "swarm",
            "no cell runs the swarm; add \"swarm\" to `env` (e.g. env = \"swarm\"), or remove `swarm`",
        ));
    }
    if let Some(c) = curve {
        check_curve(
            src,
            *c.get_ref(),
            c.span().start,
            &ax.named("steps").values,
            &ax.named("window").values,
        )?;
    }
    cells(src, &ax, seeds, worlds, budget)
}

/// The fields `g` gives in FIELDS order (absent ones at their defaults), then `robot` and
/// `curve` only when given, so that the cell ids of specs without them stay as they
/// were; then the learner settings. Each value of a cell field is read on its own (its
/// type, and its canonical text); empty lists and values listed twice are refused.
fn axes(src: &Source<'_>, mut g: Given, curve: Option<&Spanned<u64>>) -> Result<Axes, LabError> {
    let defaults = match toml::Value::try_from(CellFields::default()) {
        Ok(toml::Value::Table(t)) => t,
        _ => unreachable!("a struct serialises to a table"),
    };
    let mut axes = Vec::new();
    for name in FIELDS {
        match (g.fields.remove(name), defaults.get(name)) {
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
    if let Some(v) = g.fields.remove("robot") {
        axes.push(Axis::given("robot".into(), v));
    }
    if let Some(v) = g.fields.remove("swarm") {
        axes.push(Axis::given("swarm".into(), v));
    }
    if let Some(v) = g.fields.remove("reference") {
        axes.push(Axis::given("reference".into(), v));
    }
    debug_assert!(
        g.fields.is_empty(),
        "a cell field outside FIELDS, robot, swarm and reference: {:?}",
        g.fields
    );
    let n_fields = axes.len();
    for axis in &mut axes {
        for i in 0..axis.values.len() {
            let cell = CellFields::from_values([(axis.name.as_str(), &axis.values[i])])
                .map_err(|m| src.error(axis.offset, &axis.item(i), m))?;
            axis.texts[i] = cell.text(&axis.name).unwrap_or_default();
        }
    }
    if let Some(c) = curve {
        let n = toml::Value::Integer(*c.get_ref() as i64);
        axes.push(Axis { offset: c.span().start, ..Axis::default_of("curve", n) });
    }
    let settings_at = axes.len();
    let keys: Vec<String> = g.settings.keys().cloned().collect();
    let prefix = g.prefix;
    axes.extend(g.settings.into_iter().map(|(k, v)| Axis::given(format!("{prefix}.{k}"), v)));
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
    Ok(Axes { axes, n_fields, settings_at, keys })
}

/// Every value against the rules of `mmq run`. A learner setting (`max_delay`,
/// `lambda_hat` when given, those of `[settings]`) applies to the cells whose learner has
/// it; one no learner of the sweep has is an error, and each value is checked by the
/// first learner that has it.
fn check_values(src: &Source<'_>, ax: &Axes) -> Result<(), LabError> {
    for axis in &ax.axes[..ax.n_fields] {
        for (i, v) in axis.values.iter().enumerate() {
            let cell = CellFields::from_values([(axis.name.as_str(), v)])
                .map_err(|m| src.error(axis.offset, &axis.item(i), m))?;
            check_value(&axis.name, &cell).map_err(|m| src.error(axis.offset, &axis.item(i), m))?;
        }
    }
    let learners: Vec<LearnerKind> =
        ax.named("learner").texts.iter().filter_map(|l| LearnerKind::parse(l).ok()).collect();
    let learner_settings = ax.axes[..ax.n_fields]
        .iter()
        .filter(|a| a.given && LEARNER_FIELDS.contains(&a.name.as_str()))
        .map(|a| (a.name.as_str(), a))
        .chain(ax.keys.iter().map(String::as_str).zip(&ax.axes[ax.settings_at..]));
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
    Ok(())
}

/// The worlds of `world`, loaded once each and hashed for the cell ids, each with every
/// robot setting applied (world-major).
fn load_worlds(
    src: &Source<'_>,
    world: &Axis,
    robot: Option<&Axis>,
    base: &Path,
) -> Result<Worlds, LabError> {
    let mut w = Worlds { paths: Vec::new(), digests: Vec::new(), loaded: Vec::new() };
    for (i, name) in world.texts.iter().enumerate() {
        let p = Path::new(name);
        let path = if p.is_absolute() { p.to_path_buf() } else { base.join(p) };
        // World::load reads at most MAX_FILE_BYTES (or takes the shipped copy); the
        // digest is of the text it parsed.
        let loaded =
            World::load(&path).map_err(|e| src.error(world.offset, &world.item(i), e.to_string()))?;
        w.digests.push(format!("{:016x}", fnv1a(loaded.source.as_bytes())));
        match robot {
            None => w.loaded.push(loaded),
            Some(r) => {
                for (k, setting) in r.values.iter().enumerate() {
                    let overrides = CellFields::from_values([("robot", setting)]).map(|c| c.robot.0);
                    w.loaded.push(
                        overrides
                            .and_then(|o| with_robot(&loaded, &o))
                            .map_err(|m| src.error(r.offset, &r.item(k), format!("{m} (world `{name}`)")))?,
                    );
                }
            }
        }
        w.paths.push(path);
    }
    Ok(w)
}

/// The cells of the product, first field outermost, each with its id (a hash of its
/// values as written and of its world's text) and its values deserialised into its
/// fields and from them into its run configuration.
fn cells(
    src: &Source<'_>,
    ax: &Axes,
    seeds: Vec<u64>,
    worlds: Worlds,
    budget: usize,
) -> Result<Product, LabError> {
    let axes = &ax.axes;
    let lens: Vec<usize> = axes.iter().map(|a| a.values.len()).collect();
    let n_cells = lens.iter().try_fold(1usize, |a, &l| a.checked_mul(l)).unwrap_or(usize::MAX);
    if n_cells.saturating_mul(seeds.len()) > budget {
        return Err(src.error(
            0,
            "seeds",
            format!(
                "{n_cells} cells × {} seeds is more than {MAX_JOBS} jobs{}; split the sweep",
                seeds.len(),
                if budget < MAX_JOBS { " with the parts before" } else { "" }
            ),
        ));
    }
    let robot_at = ax.at("robot");
    let robot_settings = robot_at.map_or(1, |k| axes[k].values.len());
    let mut cells = Vec::with_capacity(n_cells);
    let mut configs = Vec::with_capacity(n_cells);
    let mut world_of = Vec::with_capacity(n_cells);
    let mut ids = HashMap::new();
    let mut idx = vec![0usize; axes.len()];
    for _ in 0..n_cells {
        let params: Vec<String> = idx.iter().zip(axes).map(|(&i, a)| a.texts[i].clone()).collect();
        let mut key = String::from("mmq-sweep-cell/1\n");
        for (a, v) in axes.iter().zip(&params) {
            // Learner settings enter the id as `beyond.KEY`, so that a spec keeps its
            // cell ids whichever name its table has.
            let f =
                a.name.strip_prefix("settings.").map_or_else(|| a.name.clone(), |k| format!("beyond.{k}"));
            let _ = writeln!(key, "{f}={v}");
        }
        let _ = writeln!(key, "world_bytes={}", worlds.digests[idx[0]]);
        let id = format!("{:016x}", fnv1a(key.as_bytes()));
        if let Some(other) = ids.insert(id.clone(), cells.len()) {
            return Err(LabError::Config {
                file: src.file.to_string(),
                message: format!(
                    "cells {other} and {} hash to the same id {id}; change a value slightly",
                    cells.len()
                ),
            });
        }
        let in_cell = |k: usize| (k < ax.n_fields).then(|| (axes[k].name.as_str(), &axes[k].values[idx[k]]));
        let settings: Vec<(&str, &toml::Value)> = ax
            .keys
            .iter()
            .zip(&idx[ax.settings_at..])
            .zip(&axes[ax.settings_at..])
            .map(|((k, &i), a)| (k.as_str(), &a.values[i]))
            .collect();
        let cfg = CellFields::from_values((0..axes.len()).filter_map(in_cell))
            .map_err(|message| LabError::Config { file: src.file.to_string(), message })
            .and_then(|cell| cell.run_config(worlds.paths[idx[0]].clone(), seeds[0], &settings))
            .map_err(|e| LabError::Config {
                file: src.file.to_string(),
                message: format!("cell {} ({}): {}", cells.len(), params.join(", "), plain_message(&e)),
            })?;
        let world = idx[0] * robot_settings + robot_at.map_or(0, |k| idx[k]);
        if cfg.env == EnvKind::Swarm {
            let checked = cfg
                .validate()
                .and_then(|_| crate::swarm::check_swarm(&cfg, &worlds.loaded[world]).map(|_| ()));
            if let Err(e) = checked {
                return Err(LabError::Config {
                    file: src.file.to_string(),
                    message: format!("cell {} ({}): {}", cells.len(), params.join(", "), plain_message(&e)),
                });
            }
        }
        cells.push(PlanCell { id, params, seeds: None });
        configs.push(cfg);
        world_of.push(world);
        // Odometer: the last field varies fastest.
        for k in (0..idx.len()).rev() {
            idx[k] += 1;
            if idx[k] < lens[k] {
                break;
            }
            idx[k] = 0;
        }
    }
    Ok(Product {
        fields: axes.iter().map(|a| (a.name.clone(), a.listed)).collect(),
        seeds,
        cells,
        configs,
        world_of,
        worlds: worlds.loaded,
    })
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
        "swarm" if cell.swarm.is_empty() => {
            Err("no overrides; give KEY=VALUE overrides of the [swarm] table, e.g. \"robots=4 consult=peers k=2\"".into())
        }
        "swarm" => mmq_robot::swarm::apply_swarm_overrides(None, &cell.swarm.0).map(|_| ()).map_err(|e| e.to_string()),
        "max_delay" | "lambda_hat" => {
            let x = if name == "max_delay" { cell.max_delay } else { cell.lambda_hat };
            if usize::try_from(x).is_err() || x > 1_000_000 {
                return Err(format!("{x} is not accepted; use at most 1000000 steps"));
            }
            Ok(())
        }
        // The swarm's delays emerge: alone, its cell is checked without the default delay.
        "env" if cell.env == EnvKind::Swarm.name() => CellFields { delay: "none".into(), ..cell.clone() }
            .run_config(PathBuf::new(), 0, &[])
            .and_then(|c| c.validate())
            .map(|_| ())
            .map_err(|e| plain_message(&e)),
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
pub(super) fn plain_message(e: &LabError) -> String {
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
