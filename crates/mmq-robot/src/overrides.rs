//! `KEY=VALUE` overrides of a world's `[robot]` table (the CLI's `--robot`, a sweep's
//! `robot` list): merged into the table before it is resolved, so
//! `profile=realistic` and `preset=kobuki` need no copied world file.
//!
//! Keys are the table's fields; a dotted key reaches a sub-table
//! (`realistic.fix_rate_hz=2`, `noise.slip_probability=0`). A value is read as a TOML
//! value (`0.5`, `true`, `"kobuki"`), else as a bare string (`kobuki`); integers are
//! taken as floats (every numeric field is one). Later overrides win.

use toml::{Table, Value};

use crate::config::{NOISE_FIELDS, RobotConfig, RobotError, RobotTable, TABLE_FIELDS};
use crate::profile::{REALISTIC_FIELDS, RealisticTable};

fn parse_value(raw: &str) -> Value {
    match mmq_core::text_value::value_from_text(raw) {
        Value::Integer(i) => Value::Float(i as f64),
        v => v,
    }
}

fn bad(text: &str, problem: impl Into<String>, accepted: impl Into<String>) -> RobotError {
    RobotError::BadValue { text: text.to_string(), problem: problem.into(), accepted: accepted.into() }
}

/// Merges `overrides` (each `KEY=VALUE`) into a copy of `table` (a world's `[robot]`
/// table, or none) and checks the result resolves ([`RobotConfig::from_table`]).
///
/// Errors: [`RobotError::UnknownKey`] for a key naming no field,
/// [`RobotError::BadValue`] for text without `=` or a value of the wrong type, and the
/// resolved table's own errors ([`RobotError::Invalid`] names the field and its range).
pub fn apply_overrides(table: Option<&Table>, overrides: &[String]) -> Result<Table, RobotError> {
    let mut out = table.cloned().unwrap_or_default();
    for text in overrides {
        let Some((key, raw)) = text.split_once('=') else {
            return Err(bad(text, "it has no `=`", "KEY=VALUE, e.g. profile=realistic"));
        };
        let (key, raw) = (key.trim(), raw.trim());
        let value = parse_value(raw);
        let path: Vec<&str> = key.split('.').collect();
        let known = |fields: &[&str]| fields.join(", ");
        match path.as_slice() {
            [f] if TABLE_FIELDS.contains(f) && *f != "noise" && *f != "realistic" => {
                let mut one = Table::new();
                one.insert(f.to_string(), value.clone());
                Table::try_into::<RobotTable>(one)
                    .map_err(|e| bad(text, e.message().trim().to_string(), format!("a value for `{f}`")))?;
                out.insert(f.to_string(), value);
            }
            [sub, f]
                if (*sub == "noise" && NOISE_FIELDS.contains(f))
                    || (*sub == "realistic" && REALISTIC_FIELDS.contains(f)) =>
            {
                if raw.is_empty() || !matches!(value, Value::Float(_)) {
                    return Err(bad(text, "it is not a number", format!("a number for `{key}`")));
                }
                let entry = out.entry(sub.to_string()).or_insert_with(|| Value::Table(Table::new()));
                let Value::Table(t) = entry else {
                    return Err(bad(text, format!("`{sub}` in the world's table is not a table"), "a table"));
                };
                t.insert(f.to_string(), value);
                if *sub == "realistic" {
                    let check = Table::try_into::<RealisticTable>(t.clone());
                    check.map_err(|e| bad(text, e.message().trim().to_string(), "a number"))?;
                }
            }
            [f] => return Err(RobotError::UnknownKey { key: f.to_string(), known: known(&TABLE_FIELDS) }),
            ["noise", _] => {
                return Err(RobotError::UnknownKey { key: key.to_string(), known: known(&NOISE_FIELDS) });
            }
            ["realistic", _] => {
                return Err(RobotError::UnknownKey { key: key.to_string(), known: known(&REALISTIC_FIELDS) });
            }
            _ => {
                return Err(RobotError::UnknownKey {
                    key: key.to_string(),
                    known: format!("{}; sub-tables noise.*, realistic.*", known(&TABLE_FIELDS)),
                });
            }
        }
    }
    RobotConfig::from_table(&out)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Preset;
    use crate::profile::Profile;

    fn ov(xs: &[&str]) -> Vec<String> {
        xs.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn profile_and_preset_without_a_world_table() {
        let t =
            apply_overrides(None, &ov(&["profile=realistic", "preset=kobuki", "realistic.fix_rate_hz=2"]))
                .unwrap();
        let c = RobotConfig::from_table(&t).unwrap();
        assert_eq!((c.profile, c.preset), (Profile::Realistic, Preset::Kobuki));
        assert_eq!(c.realistic.fix_rate_hz, 2.0);
        // The preset's encoder, not the Burger's.
        assert_eq!(c.realistic.encoder_ticks_per_rev, 2578.33);
    }

    #[test]
    fn overrides_win_over_the_world_and_keep_the_rest() {
        let world: Table =
            toml::from_str("preset = \"kobuki\"\nmax_speed_mps = 0.5\n[noise]\nslip_probability = 0.1\n")
                .unwrap();
        let t = apply_overrides(Some(&world), &ov(&["max_speed_mps=0.3", "noise.wheel_gain_sd=0"])).unwrap();
        let c = RobotConfig::from_table(&t).unwrap();
        assert_eq!((c.max_speed_mps, c.preset), (0.3, Preset::Kobuki));
        let n = c.noise.unwrap();
        assert_eq!((n.wheel_gain_sd, n.slip_probability), (0.0, 0.1));
    }

    #[test]
    fn bad_input_is_named() {
        let e = apply_overrides(None, &ov(&["speed=1"])).unwrap_err();
        assert!(matches!(&e, RobotError::UnknownKey { key, .. } if key == "speed"), "{e}");
        let e = apply_overrides(None, &ov(&["realistic.rate=1"])).unwrap_err();
        assert!(matches!(&e, RobotError::UnknownKey { known, .. } if known.contains("fix_rate_hz")), "{e}");
        let e = apply_overrides(None, &ov(&["profile"])).unwrap_err();
        assert!(matches!(e, RobotError::BadValue { .. }), "{e}");
        let e = apply_overrides(None, &ov(&["profile=fuzzy"])).unwrap_err();
        assert!(matches!(e, RobotError::BadValue { .. }), "{e}");
        let e = apply_overrides(None, &ov(&["max_speed_mps=fast"])).unwrap_err();
        assert!(matches!(e, RobotError::BadValue { .. }), "{e}");
        let e = apply_overrides(None, &ov(&["profile=realistic", "realistic.fix_rate_hz=x"])).unwrap_err();
        assert!(matches!(e, RobotError::BadValue { .. }), "{e}");
        // In range is checked on the resolved table, naming the field.
        let e = apply_overrides(None, &ov(&["profile=realistic", "realistic.fix_rate_hz=0"])).unwrap_err();
        assert!(matches!(e, RobotError::Invalid { field: "realistic.fix_rate_hz", .. }), "{e}");
        // Realistic parameters need the realistic profile.
        let e = apply_overrides(None, &ov(&["realistic.fix_rate_hz=3"])).unwrap_err();
        assert!(matches!(e, RobotError::Invalid { field: "realistic", .. }), "{e}");
    }
}
