//! One cell of a sweep: the run-configuration fields a spec may set, as one serde
//! struct with the defaults of `mmq run`. A cell's values (one per field) form a TOML
//! table that is deserialised straight into [`CellFields`] and then into the cell's
//! run configuration; the same struct checks each listed value on its own and gives
//! the value's canonical text (the text cell ids hash).

use std::path::PathBuf;

use serde::{Deserialize, Serialize};
use toml::Spanned;

use super::syntax::RobotSetting;
use crate::config::{EnvKind, RunConfig};
use crate::error::LabError;
use crate::settings::with_settings;
use mmq_learn::spec::Params;
use mmq_learn::{LearnerKind, LearnerSpec};

/// The run-configuration fields of one cell, each with the default of `mmq run`
/// (`world` has none: a spec must give it).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub(super) struct CellFields {
    pub(super) world: String,
    pub(super) env: String,
    pub(super) learner: String,
    pub(super) delay: String,
    pub(super) max_delay: u64,
    pub(super) lambda_hat: u64,
    pub(super) alpha: f64,
    pub(super) gamma: f64,
    pub(super) epsilon: f64,
    pub(super) q0: f64,
    pub(super) steps: u64,
    pub(super) window: u64,
    pub(super) eval_steps: u64,
    pub(super) baseline: bool,
    #[serde(skip_serializing_if = "RobotSetting::is_empty")]
    pub(super) robot: RobotSetting,
    /// `KEY=VALUE` overrides of the world's `[swarm]` table (same syntax as `robot`).
    #[serde(skip_serializing_if = "RobotSetting::is_empty")]
    pub(super) swarm: RobotSetting,
    /// Also run the grid-optimal reference (absent: no; joins the cell only when given).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) reference: Option<bool>,
}

impl Default for CellFields {
    fn default() -> Self {
        let d = RunConfig::default();
        let p = Params::default();
        CellFields {
            world: String::new(),
            env: EnvKind::Grid.name().to_string(),
            learner: LearnerKind::Mmq.name().to_string(),
            delay: d.delay,
            max_delay: mmq_learn::settings::MmqSettings::default().max_delay as u64,
            lambda_hat: mmq_learn::settings::FixedSettings::default().lambda_hat as u64,
            alpha: p.alpha,
            gamma: p.gamma,
            epsilon: p.epsilon,
            q0: p.q0,
            steps: d.steps,
            window: d.window,
            eval_steps: d.eval_steps,
            baseline: d.baseline,
            robot: RobotSetting::default(),
            swarm: RobotSetting::default(),
            reference: None,
        }
    }
}

/// The learner settings that are fields of a cell (the others are in `[settings]`).
pub(super) const LEARNER_FIELDS: [&str; 2] = ["max_delay", "lambda_hat"];

impl CellFields {
    /// The cell whose fields `values` gives (the others at their defaults). A field
    /// that is not one, or a value of the wrong type, is the serde error's message.
    pub(super) fn from_values<'a>(
        values: impl IntoIterator<Item = (&'a str, &'a toml::Value)>,
    ) -> Result<CellFields, String> {
        let table: toml::Table = values.into_iter().map(|(k, v)| (k.to_string(), v.clone())).collect();
        CellFields::deserialize(toml::Value::Table(table)).map_err(|e| e.message().trim().replace('\n', "; "))
    }

    /// The canonical text of field `name` (numbers in shortest form, strings bare, a
    /// robot setting's overrides joined by spaces), or `None` if this cell does not
    /// serialise it.
    pub(super) fn text(&self, name: &str) -> Option<String> {
        let toml::Value::Table(t) = toml::Value::try_from(self).ok()? else { return None };
        t.get(name).map(value_text)
    }

    /// The run configuration of this cell with its world at `world`, the first seed `seed` and the learner settings `settings`
    /// (those `[settings]` gives; `max_delay` and `lambda_hat` are added for learners
    /// that have them).
    pub(super) fn run_config(
        &self,
        world: PathBuf,
        seed: u64,
        settings: &[(&str, &toml::Value)],
    ) -> Result<RunConfig, LabError> {
        let env = match self.env.as_str() {
            "grid" => EnvKind::Grid,
            "robot" => EnvKind::Robot,
            "swarm" => EnvKind::Swarm,
            e => {
                return Err(LabError::Setting {
                    field: "env".into(),
                    message: format!("`{e}` is not an environment; use grid, robot or swarm"),
                });
            }
        };
        let kind = LearnerKind::parse(&self.learner)?;
        let learner = LearnerSpec {
            params: Params { alpha: self.alpha, gamma: self.gamma, epsilon: self.epsilon, q0: self.q0 },
            ..LearnerSpec::new(kind)
        };
        let (md, lh) =
            (toml::Value::Integer(self.max_delay as i64), toml::Value::Integer(self.lambda_hat as i64));
        let pairs: Vec<(&str, &toml::Value)> = [("max_delay", &md), ("lambda_hat", &lh)]
            .into_iter()
            .chain(settings.iter().copied())
            .filter(|(k, _)| crate::settings::has_setting(kind, k))
            .collect();
        Ok(RunConfig {
            world,
            env,
            learner: with_settings(&learner, &pairs)?,
            delay: self.delay.clone(),
            steps: self.steps,
            seed,
            seeds: 1,
            window: self.window,
            eval_steps: self.eval_steps,
            baseline: self.baseline,
            reference: self.reference.unwrap_or(false),
            save_tables: false,
            ledger: false,
            robot: self.robot.0.clone(),
            // Only the swarm reads them (a spec may list env = ["robot", "swarm"]).
            swarm: if env == EnvKind::Swarm { self.swarm.0.clone() } else { Vec::new() },
            ..RunConfig::default()
        })
    }
}

/// One field of a spec: its values (one, or a list: an axis), their canonical texts,
/// and where the field is in the spec text.
#[derive(Debug)]
pub(super) struct Axis {
    /// The field's name: a [`CellFields`] field, `curve`, or `settings.KEY`.
    pub(super) name: String,
    pub(super) values: Vec<toml::Value>,
    pub(super) texts: Vec<String>,
    /// Whether the spec gives a list (the field is an axis of the product).
    pub(super) listed: bool,
    /// Whether the spec gives the field (else it holds the default).
    pub(super) given: bool,
    /// Byte offset of the value in the spec text.
    pub(super) offset: usize,
}

impl Axis {
    /// The field `name` as the spec gives it: a list is an axis, anything else one value.
    pub(super) fn given(name: String, value: Spanned<toml::Value>) -> Axis {
        let offset = value.span().start;
        let (listed, values) = match value.into_inner() {
            toml::Value::Array(v) => (true, v),
            x => (false, vec![x]),
        };
        Axis { name, texts: values.iter().map(value_text).collect(), values, listed, given: true, offset }
    }

    /// A field the spec does not give: its one default value.
    pub(super) fn default_of(name: &str, value: toml::Value) -> Axis {
        Axis {
            name: name.to_string(),
            texts: vec![value_text(&value)],
            values: vec![value],
            listed: false,
            given: false,
            offset: 0,
        }
    }

    /// The name of item `i` in messages: `delay` or `delay[2]`.
    pub(super) fn item(&self, i: usize) -> String {
        if self.listed { format!("{}[{i}]", self.name) } else { self.name.clone() }
    }
}

/// A TOML value as a parameter text: strings bare, numbers in shortest form.
pub(super) fn value_text(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        toml::Value::Integer(i) => i.to_string(),
        toml::Value::Float(f) => f.to_string(),
        toml::Value::Boolean(b) => b.to_string(),
        other => other.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cell's table deserialises into the fields, with `mmq run`'s defaults for the
    /// rest; texts are canonical (an integer given for a float field is written as
    /// the float); a field that is not one and a value of the wrong type are refused.
    #[test]
    fn cells_deserialise_with_defaults_and_canonical_texts() {
        let one = toml::Value::Integer(1);
        let c = CellFields::from_values([("alpha", &one), ("steps", &toml::Value::Integer(500))]).unwrap();
        assert_eq!((c.alpha, c.steps), (1.0, 500));
        assert_eq!(c.delay, RunConfig::default().delay);
        assert_eq!(c.text("alpha").as_deref(), Some("1"));
        let c = CellFields::from_values([("alpha", &toml::Value::Float(0.1))]).unwrap();
        assert_eq!(c.text("alpha").as_deref(), Some("0.1"));
        assert_eq!(c.text("robot"), None);
        let robot = toml::Value::Array(vec!["profile=ideal".into(), " preset=kobuki".into()]);
        let c = CellFields::from_values([("robot", &robot)]).unwrap();
        assert_eq!(c.text("robot").as_deref(), Some("profile=ideal preset=kobuki"));

        let e = CellFields::from_values([("learnr", &one)]).unwrap_err();
        assert!(e.starts_with("unknown field `learnr`, expected one of `world`"), "{e}");
        let e = CellFields::from_values([("steps", &toml::Value::String("many".into()))]).unwrap_err();
        assert!(e.starts_with("invalid type: string \"many\", expected u64"), "{e}");

        let cfg =
            CellFields::from_values([("learner", &"fixed".into()), ("lambda_hat", &toml::Value::Integer(7))])
                .unwrap()
                .run_config(PathBuf::from("w.toml"), 3, &[])
                .unwrap();
        assert_eq!(
            cfg.learner.settings,
            mmq_learn::LearnerSettings::Fixed(mmq_learn::settings::FixedSettings { lambda_hat: 7 })
        );
        assert_eq!((cfg.seed, cfg.seeds, cfg.save_tables), (3, 1, false));
    }

    /// The fields a cell deserialises are the spec's cell fields: FIELDS (the canonical
    /// order of the product and of CSV columns) and `robot`.
    #[test]
    fn cell_fields_are_the_canonical_fields_and_robot() {
        let robot = toml::Value::String("profile=ideal".into());
        let Ok(toml::Value::Table(t)) =
            toml::Value::try_from(CellFields::from_values([("robot", &robot)]).unwrap())
        else {
            panic!("a cell serialises to a table")
        };
        let mut names: Vec<&str> = t.keys().map(String::as_str).collect();
        let mut expected: Vec<&str> = super::super::FIELDS.iter().copied().chain(["robot"]).collect();
        names.sort_unstable();
        expected.sort_unstable();
        assert_eq!(names, expected);
        for name in LEARNER_FIELDS {
            assert!(t.contains_key(name), "{name}");
        }
    }
}
