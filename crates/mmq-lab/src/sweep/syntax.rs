//! What a spec file says before it is checked: the serde forms of its special fields
//! (a number of seeds or a list of seeds; a robot setting), the fields besides the
//! cell fields, and where in the text an error is, for messages
//! `FILE:LINE:COLUMN: FIELD: ...`.

use std::collections::BTreeMap;

use serde::de::{self, Deserializer, SeqAccess, Visitor};
use serde::{Deserialize, Serialize, Serializer};
use toml::Spanned;

use super::FIELDS;
use crate::error::LabError;

/// `seeds = N` (N seeds from `seed`) or `seeds = [s1, s2, ...]` (explicit master seeds).
#[derive(Clone, Debug)]
pub(super) enum SeedsField {
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

/// One robot setting: `KEY=VALUE` overrides of the world's `[robot]` table as `--robot`
/// takes them, in one string (separated by spaces) or as a list of strings.
#[derive(Clone, Debug, Default)]
pub(super) struct RobotSetting(pub(super) Vec<String>);

impl RobotSetting {
    pub(super) fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

/// Written as one string, the overrides separated by spaces (the text cell ids hash).
impl Serialize for RobotSetting {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.0.join(" "))
    }
}

impl<'de> Deserialize<'de> for RobotSetting {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = RobotSetting;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("KEY=VALUE overrides in a string (e.g. \"profile=realistic preset=kobuki\") or a list of them")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<RobotSetting, E> {
                Ok(RobotSetting(v.split_whitespace().map(str::to_string).collect()))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<RobotSetting, A::Error> {
                let mut v = Vec::new();
                while let Some(x) = seq.next_element::<String>()? {
                    v.push(x.trim().to_string());
                }
                Ok(RobotSetting(v))
            }
        }
        d.deserialize_any(V)
    }
}

/// What a spec says besides the cell fields: its name, seeds, curve points and learner
/// settings (see docs/sweeps.md for every field). The cell fields are read generically
/// (see `super::cell`).
#[derive(Debug, Deserialize)]
pub(super) struct Meta {
    pub(super) name: Option<String>,
    pub(super) description: Option<String>,
    pub(super) seeds: Option<Spanned<SeedsField>>,
    pub(super) seed: Option<Spanned<u64>>,
    /// Points of the learning curve stored per job (absent: none).
    pub(super) curve: Option<Spanned<u64>>,
    /// Learner settings besides `max_delay` and `lambda_hat` (`[settings]` table:
    /// `trace_decay`, `lasso`, ...), each a value or a list, applied by name to the cells
    /// whose learner has the setting.
    pub(super) settings: Option<BTreeMap<String, Spanned<toml::Value>>>,
    /// The `[settings]` table under the name specs of stored sweeps give it; read the
    /// same way, and its fields keep the prefix `beyond.` so their reports stay as they were.
    pub(super) beyond: Option<BTreeMap<String, Spanned<toml::Value>>>,
    /// Parts (`[[part]]`): each a product of its own over the top-level fields, which it
    /// may override, with its own seeds; the spec's cells are the parts' cells in order.
    pub(super) part: Option<Vec<Table>>,
}

/// The keys of [`Meta`]: every other top-level key is a cell field.
pub(super) const META: [&str; 8] =
    ["name", "description", "seeds", "seed", "curve", "settings", "beyond", "part"];

/// A TOML table with the places of its keys and values.
pub(super) type Table = BTreeMap<Spanned<String>, Spanned<toml::Value>>;

/// What a spec, or one part of it, gives: cell fields, learner settings and seeds.
#[derive(Clone, Debug)]
pub(super) struct Given {
    pub(super) fields: BTreeMap<String, Spanned<toml::Value>>,
    /// The name of the settings table: `settings`, or `beyond` in stored specs.
    pub(super) prefix: &'static str,
    pub(super) settings: BTreeMap<String, Spanned<toml::Value>>,
    pub(super) seeds: Option<Spanned<SeedsField>>,
    pub(super) seed: Option<Spanned<u64>>,
}

impl Given {
    /// What the spec's top level gives: the keys of `doc` that are not [`META`], and the
    /// settings and seeds of `meta`.
    pub(super) fn top(src: &Source<'_>, doc: Table, meta: &mut Meta) -> Result<Given, LabError> {
        let (prefix, settings) = match (meta.settings.take(), meta.beyond.take()) {
            (Some(_), Some(b)) => {
                let at = b.values().next().map_or(0, |v| v.span().start);
                return Err(src.error(at, "beyond", "give the learner settings in one table, [settings]"));
            }
            (Some(t), None) => ("settings", t),
            (None, Some(b)) => ("beyond", b),
            (None, None) => ("settings", BTreeMap::new()),
        };
        let mut g = Given {
            fields: BTreeMap::new(),
            prefix,
            settings,
            seeds: meta.seeds.take(),
            seed: meta.seed.take(),
        };
        for (key, value) in doc {
            if !META.contains(&key.get_ref().as_str()) {
                g.field(src, key, value)?;
            }
        }
        Ok(g)
    }

    /// `self` with what `part` gives over it: its fields and settings replace those of
    /// the same name, its `seeds` and `seed` the spec's.
    pub(super) fn with_part(&self, src: &Source<'_>, part: Table) -> Result<Given, LabError> {
        let mut g = self.clone();
        for (key, value) in part {
            let span = value.span();
            let at =
                |e: toml::de::Error, name: &str| src.error(span.start, name, e.message().trim().to_string());
            match key.get_ref().as_str() {
                "seeds" => {
                    let seeds = SeedsField::deserialize(value.into_inner()).map_err(|e| at(e, "seeds"))?;
                    g.seeds = Some(Spanned::new(span, seeds));
                }
                "seed" => {
                    let seed = u64::deserialize(value.into_inner()).map_err(|e| {
                        src.error(span.start, "seed", integer_limit("seed", e.message().trim().to_string()))
                    })?;
                    g.seed = Some(Spanned::new(span, seed));
                }
                "settings" if g.prefix == "settings" => {
                    let table =
                        toml::Table::deserialize(value.into_inner()).map_err(|e| at(e, "settings"))?;
                    for (k, v) in table {
                        g.settings.insert(k, Spanned::new(span.clone(), v));
                    }
                }
                name @ ("name" | "description" | "curve" | "part" | "settings" | "beyond") => {
                    return Err(src.error(
                        key.span().start,
                        name,
                        "a part gives cell fields, `seeds`, `seed` and [part.settings] only; give this at the top of the spec (with the settings in [settings])",
                    ));
                }
                _ => g.field(src, key, value)?,
            }
        }
        Ok(g)
    }

    /// Takes the cell field `key = value`; a key that is not one (of [`FIELDS`] or
    /// `robot` or `swarm`, the fields of `super::cell::CellFields`) is refused at the key.
    fn field(
        &mut self,
        src: &Source<'_>,
        key: Spanned<String>,
        value: Spanned<toml::Value>,
    ) -> Result<(), LabError> {
        let (at, name) = (key.span().start, key.into_inner());
        let cell_fields = || FIELDS.iter().chain(&["robot", "swarm", "reference"]);
        if !cell_fields().any(|f| *f == name) {
            let known: Vec<String> = cell_fields().map(|f| format!("`{f}`")).collect();
            let message =
                format!("unknown field `{name}`, expected one of {}; see docs/sweeps.md", known.join(", "));
            return Err(src.error(at, &name, message));
        }
        self.fields.insert(name, value);
        Ok(())
    }
}

/// Where in the spec text an error is, for messages `FILE:LINE:COLUMN: FIELD: ...`.
pub(super) struct Source<'a> {
    pub(super) file: &'a str,
    pub(super) text: &'a str,
}

impl Source<'_> {
    fn line_col(&self, offset: usize) -> (usize, usize) {
        let offset = offset.min(self.text.len());
        let before = &self.text[..offset];
        let line = before.matches('\n').count() + 1;
        let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
        (line, col)
    }

    pub(super) fn error(&self, offset: usize, field: &str, message: impl Into<String>) -> LabError {
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
    pub(super) fn toml_error(&self, e: &toml::de::Error) -> LabError {
        let offset = e.span().map_or(0, |s| s.start);
        let message = e.message().trim().replace('\n', "; ");
        let field = between(&message, "field `", "`")
            .or_else(|| self.key_at(offset))
            .unwrap_or_else(|| "syntax".into());
        let message = if message.starts_with("unknown field") {
            format!("{message}; see docs/sweeps.md")
        } else {
            integer_limit(&field, message)
        };
        self.error(offset, &field, message)
    }
}

/// TOML's integers are 64-bit signed: the reader refuses a larger number with a message
/// that names no limit; this one names it (and, for `seed`, where larger seeds go).
fn integer_limit(field: &str, message: String) -> String {
    if !message.contains("too large") {
        return message;
    }
    let hint = if field == "seed" {
        "use a smaller master seed, or `mmq run --seed`, which takes any up to 2^64 − 1"
    } else {
        "use a smaller number"
    };
    format!("a TOML integer is at most 9223372036854775807 (2^63 − 1); {hint}")
}

fn between(s: &str, open: &str, close: &str) -> Option<String> {
    let i = s.find(open)? + open.len();
    let j = s[i..].find(close)?;
    Some(s[i..i + j].to_string())
}
