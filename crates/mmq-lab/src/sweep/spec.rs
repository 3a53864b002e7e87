//! The parsed, validated spec: its product of cells (`super::product`), or the products
//! of its parts one after the other, each cell with its run configuration and world.

use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use mmq_core::World;

use super::plan::{Plan, PlanCell};
use super::product::{Product, product};
use super::syntax::{Given, Meta, Source, Table};
use super::{FIELDS, MAX_JOBS, MAX_SPEC_BYTES};

use crate::config::RunConfig;
use crate::error::LabError;
use crate::resolved::Resolved;

/// The parsed, validated spec with its resolved worlds and every cell's configuration.
#[derive(Debug)]
pub struct SweepSpec {
    /// The spec file as given.
    pub file: PathBuf,
    /// Its text (copied into the output directory).
    pub text: String,
    /// Cells, seeds and swept axes.
    pub plan: Plan,
    /// Per cell: its resolved run (world path resolved and loaded, shared by the cells
    /// on it; delay parsed; one seed; no tables).
    pub(super) runs: Vec<Resolved>,
    /// Per cell: index into `worlds`.
    pub(super) world_of: Vec<usize>,
    /// Distinct worlds, each with its robot setting applied (world-major: world `w`
    /// with robot setting `r` is `w × settings + r`).
    pub(super) worlds: Vec<Arc<World>>,
    /// Points of the learning curve stored per job (0: none; spec `curve`).
    pub(super) curve: u64,
    /// Whether each job also stores its seed's record ([`super::SeedRecord`]),
    /// which a study's report is drawn from; a job without one is not finished then.
    pub(super) records: bool,
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
        let mut meta: Meta = toml::from_str(text).map_err(|e| src.toml_error(&e))?;
        let doc: Table = toml::from_str(text).map_err(|e| src.toml_error(&e))?;
        let top = Given::top(&src, doc, &mut meta)?;
        let givens = match meta.part.take() {
            None => vec![top],
            Some(parts) if parts.is_empty() => {
                return Err(src.error(0, "part", "no parts; give at least one [[part]], or none at all"));
            }
            Some(parts) => parts.into_iter().map(|p| top.with_part(&src, p)).collect::<Result<_, _>>()?,
        };
        let base = file.parent().map(Path::to_path_buf).unwrap_or_default();
        let mut products = Vec::with_capacity(givens.len());
        let mut jobs = 0;
        for g in givens {
            let p = product(&src, g, meta.curve.as_ref(), &base, MAX_JOBS - jobs)?;
            jobs += p.cells.len() * p.seeds.len();
            products.push(p);
        }
        let name = meta.name.unwrap_or_else(|| {
            file.file_stem().map_or_else(|| "sweep".into(), |s| s.to_string_lossy().into_owned())
        });
        let mut spec = join(products, &file_name)?;
        spec.plan.name = name;
        spec.plan.description = meta.description.unwrap_or_default();
        spec.file = file.to_path_buf();
        spec.text = text.to_string();
        spec.curve = meta.curve.map_or(0, |c| c.into_inner());
        Ok(spec)
    }

    /// The run configuration of cell `c` (one seed, no tables).
    pub fn config(&self, c: usize) -> &RunConfig {
        self.runs[c].cfg()
    }

    /// The world of cell `c`.
    pub fn world(&self, c: usize) -> &World {
        self.runs[c].world()
    }

    /// The resolved run of cell `c` (one seed, no tables).
    pub fn run(&self, c: usize) -> &Resolved {
        &self.runs[c]
    }

    /// The same spec, whose jobs also store their seed's record
    /// ([`super::SeedRecord`]): a study's report is drawn from those.
    pub fn with_records(self) -> SweepSpec {
        SweepSpec { records: true, ..self }
    }

    /// Whether the jobs store their seed's record.
    pub fn keeps_records(&self) -> bool {
        self.records
    }
}

/// The spec of the products' cells one after the other: the union of their fields in
/// canonical order (a field a part lacks reads `–` in its cells), every field that is a
/// list in some part or differs between cells an axis, and each cell with its part's
/// seeds when the parts' seeds differ. One product is the spec as it is.
fn join(products: Vec<Product>, file: &str) -> Result<SweepSpec, LabError> {
    // FIELDS, then `robot`, `curve` and the settings.
    let rank = |f: &str| match f {
        "robot" => FIELDS.len(),
        "swarm" => FIELDS.len() + 1,
        "reference" => FIELDS.len() + 2,
        "curve" => FIELDS.len() + 3,
        f => FIELDS.iter().position(|x| *x == f).unwrap_or(FIELDS.len() + 4),
    };
    let mut fields: Vec<String> = Vec::new();
    for p in &products {
        for (f, _) in &p.fields {
            if !fields.contains(f) {
                fields.push(f.clone());
            }
        }
    }
    fields.sort_by(|a, b| (rank(a), a).cmp(&(rank(b), b)));
    let same_seeds = products.iter().all(|p| p.seeds == products[0].seeds);
    let (mut seeds, mut cells) = (Vec::new(), Vec::new());
    let (mut configs, mut world_of, mut worlds) = (Vec::new(), Vec::new(), Vec::new());
    let mut listed = BTreeSet::new();
    let mut ids = HashMap::new();
    for p in products {
        let at: Vec<Option<usize>> =
            fields.iter().map(|f| p.fields.iter().position(|(g, _)| g == f)).collect();
        listed.extend(p.fields.iter().filter(|f| f.1).map(|f| f.0.clone()));
        for s in &p.seeds {
            if !seeds.contains(s) {
                seeds.push(*s);
            }
        }
        for cell in p.cells {
            if let Some(other) = ids.insert(cell.id.clone(), cells.len()) {
                return Err(LabError::Config {
                    file: file.to_string(),
                    message: format!(
                        "cells {other} and {} are the same cell ({}); a cell may be in one part only",
                        cells.len(),
                        cell.id
                    ),
                });
            }
            let params =
                at.iter().map(|i| i.map_or_else(|| "–".to_string(), |i| cell.params[i].clone())).collect();
            let own = (!same_seeds).then(|| p.seeds.clone());
            cells.push(PlanCell { id: cell.id, params, seeds: own });
        }
        let offset = worlds.len();
        configs.extend(p.configs);
        world_of.extend(p.world_of.iter().map(|w| w + offset));
        worlds.extend(p.worlds.into_iter().map(Arc::new));
    }
    // Each cell's delay parsed once, here (its fields were checked one by one already).
    let runs = configs
        .into_iter()
        .zip(&world_of)
        .enumerate()
        .map(|(c, (cfg, &w))| {
            let dist = cfg.validate().map_err(|e| LabError::Config {
                file: file.to_string(),
                message: format!("cell {c}: {}", super::product::plain_message(&e)),
            })?;
            Ok(Resolved::from_parts(cfg, worlds[w].clone(), dist))
        })
        .collect::<Result<Vec<_>, LabError>>()?;
    let axes = (0..fields.len())
        .filter(|&i| listed.contains(&fields[i]) || cells.iter().any(|c| c.params[i] != cells[0].params[i]))
        .map(|i| fields[i].clone())
        .collect();
    let plan = Plan::new(String::new(), String::new(), fields, axes, seeds, cells);
    Ok(SweepSpec {
        file: PathBuf::new(),
        text: String::new(),
        plan,
        runs,
        world_of,
        worlds,
        curve: 0,
        records: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::EnvKind;
    use mmq_learn::LearnerKind;

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
        // TOML's integers stop at 2^63 − 1: the error names the limit and where larger
        // seeds go, at the top and in a part alike.
        let top = "world = \"../paper-3x3.toml\"\nseed = 18446744073709551615\n";
        let part = "world = \"../paper-3x3.toml\"\n[[part]]\nseed = 18446744073709551615\n";
        for text in [top, part] {
            let e = spec(text).unwrap_err().to_string();
            assert!(e.contains("seed: a TOML integer is at most 9223372036854775807"), "{e}");
            assert!(e.contains("mmq run --seed"), "{e}");
        }
        assert_eq!(
            spec("world = \"../paper-3x3.toml\"\nseed = 9223372036854775807\n").unwrap().plan.seeds[0],
            i64::MAX as u64
        );
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
        // The plan's fixed parameters leave out those no learner of the sweep reads.
        let fixed: Vec<String> = v.plan.fixed().into_iter().map(|f| f.0).collect();
        assert!(
            fixed.contains(&"alpha".to_string())
                && !fixed.iter().any(|f| f == "max_delay" || f == "lambda_hat")
        );
        let w = spec("world = \"../paper-3x3.toml\"\nlearner = [\"q\", \"fixed\"]\n").unwrap();
        let fixed: Vec<String> = w.plan.fixed().into_iter().map(|f| f.0).collect();
        assert!(fixed.contains(&"lambda_hat".to_string()) && !fixed.contains(&"max_delay".to_string()));
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

    /// A spec in parts: each `[[part]]` is a product over the top-level fields, which it
    /// overrides, with its own seeds and settings; the cells are the parts' cells in
    /// order, each with its part's seeds, and the jobs follow them.
    #[test]
    fn parts_are_products_of_their_own() {
        let base = "world = \"../paper-3x3.toml\"\nlearner = [\"q\", \"mmq\"]\nsteps = 100\nseeds = 2\n";
        let s = spec(&format!(
            "{base}[[part]]\ndelay = [\"poisson:1\", \"poisson:2\"]\n[[part]]\nlearner = \"deconv-q\"\ndelay = \"poisson:3\"\nseeds = [7, 8, 9]\n[part.settings]\ntold_delay = \"poisson:3\"\n"
        ))
        .unwrap();
        let p = &s.plan;
        assert_eq!(p.cells.len(), 5);
        assert_eq!(p.axes, ["learner", "delay", "settings.told_delay"]);
        assert_eq!(p.param(4, "learner"), "deconv-q");
        assert_eq!(
            (p.param(0, "settings.told_delay"), p.param(4, "settings.told_delay")),
            ("–", "poisson:3")
        );
        assert_eq!((p.seeds_of(0), p.seeds_of(4)), (&[0, 1][..], &[7, 8, 9][..]));
        assert_eq!(p.seeds, [0, 1, 7, 8, 9]);
        assert_eq!(p.jobs(), 4 * 2 + 3);
        assert_eq!((p.job(7), p.job(8), p.job(10)), ((3, 1), (4, 7), (4, 9)));
        assert_eq!((p.cell_jobs(3), p.cell_jobs(4)), (6..8, 8..11));
        assert!(!p.uniform());
        let told = s.config(4).learner.settings.deconv().and_then(|d| d.told_delay.clone());
        assert_eq!(told.as_deref(), Some("poisson:3"));
        assert_eq!((s.config(1).delay.as_str(), s.config(4).steps), ("poisson:2", 100));
        // A part alone is the spec it describes, with the same cell ids.
        let alone = spec(&format!("{base}delay = [\"poisson:1\", \"poisson:2\"]\n")).unwrap();
        let ids = |p: &Plan| p.cells.iter().map(|c| c.id.clone()).collect::<Vec<_>>();
        assert_eq!(ids(&alone.plan), ids(p)[..4]);
        assert!(alone.plan.uniform());
        assert_eq!((alone.plan.seeds.len(), alone.plan.jobs()), (2, 8));

        let e = spec(&format!("{base}[[part]]\ndelay = \"poisson:1\"\n[[part]]\ndelay = \"poisson:1\"\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("are the same cell") && e.contains("one part only"), "{e}");
        let e = spec(&format!("{base}[[part]]\ndelai = \"poisson:1\"\n")).unwrap_err().to_string();
        assert!(e.contains("t.toml:6:1: delai: unknown field `delai`"), "{e}");
        let e = spec(&format!("{base}[[part]]\nname = \"x\"\n")).unwrap_err().to_string();
        assert!(e.contains("name: a part gives cell fields"), "{e}");
        let e = spec(&format!("{base}[[part]]\nalpha = [0.1, 2]\n")).unwrap_err().to_string();
        assert!(e.contains("t.toml:6:9: alpha[1]: 2 is not accepted"), "{e}");
        let e = spec(&format!("{base}part = []\n")).unwrap_err().to_string();
        assert!(e.contains("part: no parts"), "{e}");
        let e = spec(&format!("{base}[[part]]\nseeds = \"all\"\n")).unwrap_err().to_string();
        assert!(e.contains("t.toml:6:9: seeds:"), "{e}");
    }
}
