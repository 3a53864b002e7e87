//! The parsed, validated spec: every field's values checked against the rules of
//! `mmq run`, the seeds, the worlds loaded once each, and the product of the axes as
//! cells, each with its run configuration.

use std::collections::{BTreeSet, HashMap};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use mmq_core::World;
use mmq_learn::{LearnerKind, LearnerSpec, spec::Params};

use super::plan::{Plan, PlanCell, fnv1a};
use super::syntax::{OneOrMany, RawSpec, SeedsField, Source, Values};
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
        let raw: RawSpec = toml::from_str(text).map_err(|e| src.toml_error(&e))?;
        let d = RunConfig::default();
        let (dm, df) =
            (mmq_learn::settings::MmqSettings::default(), mmq_learn::settings::FixedSettings::default());
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
        let max_delay = Values::new("max_delay", raw.max_delay, dm.max_delay as u64);
        let lambda_hat = Values::new("lambda_hat", raw.lambda_hat, df.lambda_hat as u64);
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
        // `robot` and `curve`: fields after the others, only when given, so that the
        // cell ids of specs without them stay as they were.
        let robot: Option<Values<Vec<String>>> = raw.robot.map(|r| {
            let offset = r.span().start;
            let (listed, values) = match r.into_inner() {
                OneOrMany::One(x) => (false, vec![x.0]),
                m @ OneOrMany::Many(_) => (true, m.into_vec().into_iter().map(|x| x.0).collect()),
            };
            Values { name: "robot", values, listed, offset }
        });
        if let Some(r) = &robot {
            texts.push(text_of(r, |o| o.join(" ")));
        }
        let curve = match raw.curve {
            Some(c) => {
                let offset = c.span().start;
                let n = c.into_inner();
                texts.push(("curve".into(), vec![n.to_string()], false, offset));
                Some((n, offset))
            }
            None => None,
        };
        let settings_at = texts.len();
        // `[settings]` (or `[beyond]`, its name in stored specs): fields `settings.KEY`
        // after the others, in key order.
        let (prefix, table) = match (raw.settings, raw.beyond) {
            (Some(_), Some(b)) => {
                let at = b.values().next().map_or(0, |v| v.span().start);
                return Err(src.error(at, "beyond", "give the learner settings in one table, [settings]"));
            }
            (Some(t), None) => ("settings", t),
            (None, Some(b)) => ("beyond", b),
            (None, None) => ("settings", Default::default()),
        };
        let named: Vec<(String, Values<toml::Value>)> = table
            .into_iter()
            .map(|(k, v)| {
                let offset = v.span().start;
                let (listed, values) = match v.into_inner() {
                    OneOrMany::One(x) => (false, vec![x]),
                    m @ OneOrMany::Many(_) => (true, m.into_vec()),
                };
                (k, Values { name: "settings", values, listed, offset })
            })
            .collect();
        for (k, v) in &named {
            texts.push((
                format!("{prefix}.{k}"),
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

        // Each setting applies to the cells whose learner has it; one no learner of the
        // sweep has is an error, and each value is checked by the first learner that has it.
        for (k, v) in &named {
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
                    v.offset,
                    &format!("{prefix}.{k}"),
                    format!("no learner of the sweep ({}) has this setting; {fix}", names.join(", ")),
                ));
            };
            for (i, x) in v.values.iter().enumerate() {
                let item = if v.listed { format!("{prefix}.{k}[{i}]") } else { format!("{prefix}.{k}") };
                with_settings(&LearnerSpec::new(kind), &[(k.as_str(), x)])
                    .map_err(|e| src.error(v.offset, &item, plain_message(&e)))?;
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
            match &robot {
                None => worlds.push(loaded),
                Some(r) => {
                    for (k, overrides) in r.values.iter().enumerate() {
                        worlds
                            .push(with_robot(&loaded, overrides).map_err(|m| {
                                src.error(r.offset, &r.item(k), format!("{m} (world `{w}`)"))
                            })?);
                    }
                }
            }
            world_paths.push(path);
            world_digests.push(format!("{:016x}", fnv1a(&bytes)));
        }
        let settings = robot.as_ref().map_or(1, |r| r.values.len());
        let robot_at = robot.as_ref().map(|_| FIELDS.len());
        if let Some(r) = &robot {
            if !envs.contains(&EnvKind::Robot) {
                return Err(src.error(
                    r.offset,
                    "robot",
                    "no cell runs the robot; add \"robot\" to `env` (e.g. env = [\"grid\", \"robot\"]), or remove `robot`",
                ));
            }
            for (k, o) in r.values.iter().enumerate() {
                if o.is_empty() {
                    return Err(src.error(
                        r.offset,
                        &r.item(k),
                        "no overrides; give KEY=VALUE overrides of the [robot] table, e.g. \"profile=ideal\"",
                    ));
                }
            }
        }
        if let Some((n, offset)) = curve {
            if n == 0 || n > 1000 {
                return Err(src.error(
                    offset,
                    "curve",
                    format!("{n} is not accepted; use a number of points in 1..=1000, e.g. 15"),
                ));
            }
            for &st in &steps.values {
                for &w in &window.values {
                    if st % n != 0 || (st / n) % w != 0 {
                        return Err(src.error(offset, "curve", format!(
                            "{st} steps in {n} points of {} steps each do not fall on windows of {w} steps; choose `curve` so that steps / curve is a multiple of `window`",
                            st as f64 / n as f64
                        )));
                    }
                }
            }
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
                // Learner settings enter the id as `beyond.KEY`, so that a spec keeps its
                // cell ids whichever name its table has.
                let f = f.strip_prefix("settings.").map_or_else(|| f.clone(), |k| format!("beyond.{k}"));
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
            let kind = learners[idx[2]];
            let learner = LearnerSpec {
                params: Params {
                    alpha: alpha.values[idx[6]],
                    gamma: gamma.values[idx[7]],
                    epsilon: epsilon.values[idx[8]],
                    q0: q0.values[idx[9]],
                },
                ..LearnerSpec::new(kind)
            };
            // The cell's learner takes the settings it has: `max_delay`, `lambda_hat`, then
            // those of `[settings]`.
            let md = toml::Value::Integer(max_delay.values[idx[4]] as i64);
            let lh = toml::Value::Integer(lambda_hat.values[idx[5]] as i64);
            let pairs: Vec<(&str, &toml::Value)> = [("max_delay", &md), ("lambda_hat", &lh)]
                .into_iter()
                .chain(named.iter().zip(&idx[settings_at..]).map(|((k, v), &i)| (k.as_str(), &v.values[i])))
                .filter(|(k, _)| has_setting(kind, k))
                .collect();
            let learner = with_settings(&learner, &pairs).map_err(|e| LabError::Config {
                file: file_name.clone(),
                message: format!("cell {} ({}): {}", cells.len(), params.join(", "), plain_message(&e)),
            })?;
            let cfg = RunConfig {
                world: world_paths[idx[0]].clone(),
                env: envs[idx[1]],
                learner,
                delay: delay.values[idx[3]].clone(),
                steps: steps.values[idx[10]],
                seed: seeds[0],
                seeds: 1,
                window: window.values[idx[11]],
                eval_steps: eval_steps.values[idx[12]],
                baseline: baseline.values[idx[13]],
                save_tables: false,
                ledger: false,
                robot: robot.as_ref().zip(robot_at).map_or_else(Vec::new, |(r, k)| r.values[idx[k]].clone()),
                ..RunConfig::default()
            };
            cells.push(PlanCell { id, params });
            configs.push(cfg);
            world_of.push(idx[0] * settings + robot_at.map_or(0, |k| idx[k]));
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
        Ok(SweepSpec {
            file: file.to_path_buf(),
            text: text.to_string(),
            plan,
            configs,
            world_of,
            worlds,
            curve: curve.map_or(0, |c| c.0),
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
    /// is refused with the field; `[beyond]` is read as `[settings]` with the same ids.
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
