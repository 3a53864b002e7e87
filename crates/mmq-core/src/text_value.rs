//! The value half of a `KEY=VALUE` given on the command line or in a sweep (`--set`,
//! `--robot`): read as a TOML value when it is one (`2`, `0.5`, `true`, `"kobuki"`),
//! else taken as bare text (`poisson:13`, `kobuki`).

use toml::{Table, Value};

/// `raw` as a TOML value, else as a string.
pub fn value_from_text(raw: &str) -> Value {
    toml::from_str::<Table>(&format!("v = {raw}"))
        .ok()
        .and_then(|mut t| t.remove("v"))
        .unwrap_or_else(|| Value::String(raw.to_string()))
}

/// `KEY=VALUE` (spaces around either trimmed) as the key and [`value_from_text`] of the
/// value; `None` without an `=` or with an empty key.
pub fn key_value(text: &str) -> Option<(&str, Value)> {
    let (key, value) = text.split_once('=')?;
    let key = key.trim();
    (!key.is_empty()).then(|| (key, value_from_text(value.trim())))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_value_pairs() {
        assert_eq!(key_value(" alpha = 0.5"), Some(("alpha", Value::Float(0.5))));
        assert_eq!(key_value("delay=poisson:13"), Some(("delay", Value::String("poisson:13".into()))));
        assert_eq!(key_value("a=b=c"), Some(("a", Value::String("b=c".into()))));
        assert_eq!(key_value("=1"), None);
        assert_eq!(key_value("alpha"), None);
    }

    #[test]
    fn toml_values_and_bare_text() {
        assert_eq!(value_from_text("2"), Value::Integer(2));
        assert_eq!(value_from_text("0.5"), Value::Float(0.5));
        assert_eq!(value_from_text("true"), Value::Boolean(true));
        assert_eq!(value_from_text("\"kobuki\""), Value::String("kobuki".into()));
        assert_eq!(value_from_text("poisson:13"), Value::String("poisson:13".into()));
        // A second line cannot smuggle in another key: only `v` is read.
        assert_eq!(value_from_text("1\nw = 2"), Value::Integer(1));
        assert_eq!(value_from_text(""), Value::String(String::new()));
    }
}
