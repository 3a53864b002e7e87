//! What a spec file says before it is checked: the serde forms of its fields (one value
//! or a list; a number of seeds or a list of seeds), the raw spec, and where in the text
//! an error is, for messages `FILE:LINE:COLUMN: FIELD: ...`.

use std::collections::BTreeMap;
use std::marker::PhantomData;

use serde::Deserialize;
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use toml::Spanned;

use crate::error::LabError;

/// One value or a list of values of a spec field.
#[derive(Debug)]
pub(super) enum OneOrMany<T> {
    One(T),
    Many(Vec<T>),
}

impl<T> OneOrMany<T> {
    pub(super) fn into_vec(self) -> Vec<T> {
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
#[derive(Debug)]
pub(super) struct RobotSetting(pub(super) Vec<String>);

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

pub(super) type Field<T> = Option<Spanned<OneOrMany<T>>>;

/// The spec as written (see docs/sweeps.md for every field).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSpec {
    pub(super) name: Option<String>,
    pub(super) description: Option<String>,
    pub(super) world: Field<String>,
    pub(super) env: Field<String>,
    pub(super) learner: Field<String>,
    pub(super) delay: Field<String>,
    pub(super) max_delay: Field<u64>,
    pub(super) lambda_hat: Field<u64>,
    pub(super) alpha: Field<f64>,
    pub(super) gamma: Field<f64>,
    pub(super) epsilon: Field<f64>,
    pub(super) q0: Field<f64>,
    pub(super) steps: Field<u64>,
    pub(super) window: Field<u64>,
    pub(super) eval_steps: Field<u64>,
    pub(super) baseline: Field<bool>,
    pub(super) seeds: Option<Spanned<SeedsField>>,
    pub(super) seed: Option<Spanned<u64>>,
    /// Robot settings (an axis like the others; see docs/sweeps.md).
    pub(super) robot: Field<RobotSetting>,
    /// Points of the learning curve stored per job (absent: none).
    pub(super) curve: Option<Spanned<u64>>,
    /// Learner settings besides `max_delay` and `lambda_hat` (`[settings]` table:
    /// `trace_decay`, `lasso`, ...), each a value or a list, applied by name to the cells
    /// whose learner has the setting.
    pub(super) settings: Option<BTreeMap<String, Spanned<OneOrMany<toml::Value>>>>,
    /// The `[settings]` table under the name specs of stored sweeps give it; read the
    /// same way, and its fields keep the prefix `beyond.` so their reports stay as they were.
    pub(super) beyond: Option<BTreeMap<String, Spanned<OneOrMany<toml::Value>>>>,
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
pub(super) struct Values<T> {
    pub(super) name: &'static str,
    pub(super) values: Vec<T>,
    pub(super) listed: bool,
    pub(super) offset: usize,
}

impl<T> Values<T> {
    pub(super) fn new(name: &'static str, field: Field<T>, default: T) -> Self {
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
    pub(super) fn item(&self, i: usize) -> String {
        if self.listed { format!("{}[{i}]", self.name) } else { self.name.to_string() }
    }
}
