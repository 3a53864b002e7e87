//! Every message validates against its channel's JSON schema: here with a small
//! validator of the JSON Schema subset the schemas use, and with the official Python
//! `mcap` and `jsonschema` packages through `tools/validate_mcap.py` when available.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use mmq_log::{McapRecorder, RecorderConfig};
use serde_json::Value;

use crate::common::{self, record_grid};

/// Validates `v` against the subset of JSON Schema used by the Foxglove and mmq schemas
/// (type, properties, required, additionalProperties = false, items, oneOf of consts,
/// enum, minimum, maximum). Returns the first error as "path: problem".
pub fn check(schema: &Value, v: &Value, path: &str) -> Result<(), String> {
    let err = |m: String| Err(format!("{path}: {m}"));
    if let Some(alts) = schema.get("oneOf").and_then(Value::as_array) {
        let n = alts.iter().filter(|a| check(a, v, path).is_ok()).count();
        if n != 1 {
            return err(format!("{v} matches {n} of the oneOf alternatives"));
        }
    }
    if let Some(c) = schema.get("const")
        && c != v
    {
        return err(format!("{v} is not {c}"));
    }
    if let Some(e) = schema.get("enum").and_then(Value::as_array)
        && !e.contains(v)
    {
        return err(format!("{v} is not one of {e:?}"));
    }
    if let Some(t) = schema.get("type") {
        let types: Vec<&str> = match t {
            Value::String(s) => vec![s.as_str()],
            Value::Array(a) => a.iter().filter_map(Value::as_str).collect(),
            _ => vec![],
        };
        let ok = types.iter().any(|t| match *t {
            "object" => v.is_object(),
            "array" => v.is_array(),
            "string" => v.is_string(),
            "number" => v.is_number(),
            "integer" => v.is_i64() || v.is_u64(),
            "boolean" => v.is_boolean(),
            "null" => v.is_null(),
            _ => false,
        });
        if !ok {
            return err(format!("{v} is not of type {t}"));
        }
    }
    if let Some(x) = v.as_f64() {
        if let Some(min) = schema.get("minimum").and_then(Value::as_f64)
            && x < min
        {
            return err(format!("{x} < minimum {min}"));
        }
        if let Some(max) = schema.get("maximum").and_then(Value::as_f64)
            && x > max
        {
            return err(format!("{x} > maximum {max}"));
        }
    }
    if let Some(obj) = v.as_object() {
        let props = schema.get("properties").and_then(Value::as_object);
        for r in schema.get("required").and_then(Value::as_array).into_iter().flatten() {
            let r = r.as_str().unwrap();
            if !obj.contains_key(r) {
                return err(format!("required field `{r}` missing"));
            }
        }
        for (k, x) in obj {
            match props.and_then(|p| p.get(k)) {
                Some(s) => check(s, x, &format!("{path}/{k}"))?,
                None if schema.get("additionalProperties") == Some(&Value::Bool(false)) => {
                    return err(format!("field `{k}` is not in the schema"));
                }
                None => {}
            }
        }
    }
    if let (Some(items), Some(arr)) = (schema.get("items"), v.as_array()) {
        for (i, x) in arr.iter().enumerate() {
            check(items, x, &format!("{path}/{i}"))?;
        }
    }
    Ok(())
}

/// What Foxglove's JSON schema parser (the app's `parseJsonSchema`, which turns a
/// `jsonschema` schema into message definitions) would refuse in `schema`: the root and
/// every object must be `"type": "object"` with `properties`; each property either a
/// `oneOf` of numeric `const`s (an enum) or exactly one `type` of boolean, string
/// (`contentEncoding` none or base64), number, integer, object or array; array items of
/// boolean, string (no `contentEncoding`), number, integer or object. No `null`, no
/// type unions. Returns one line per problem, with its path.
pub fn foxglove_subset_problems(schema: &Value) -> Vec<String> {
    fn object(s: &Value, path: &str, out: &mut Vec<String>) {
        if s.get("type") != Some(&Value::from("object")) {
            out.push(format!(
                "{path}: expected \"type\": \"object\", got {}",
                s.get("type").unwrap_or(&Value::Null)
            ));
            return;
        }
        let Some(props) = s.get("properties").and_then(Value::as_object) else {
            out.push(format!("{path}: an object without `properties`"));
            return;
        };
        for (name, f) in props {
            let p = format!("{path}.{name}");
            if let Some(alts) = f.get("oneOf") {
                let ok = alts
                    .as_array()
                    .is_some_and(|a| a.iter().all(|x| x.get("const").is_some_and(Value::is_number)));
                if !ok {
                    out.push(format!("{p}: oneOf alternatives must be numeric consts"));
                }
                continue;
            }
            match f.get("type").and_then(Value::as_str) {
                Some("boolean" | "number" | "integer") => {}
                Some("string") => match f.get("contentEncoding").and_then(Value::as_str) {
                    None | Some("base64") => {}
                    Some(e) => out.push(format!("{p}: unsupported contentEncoding {e}")),
                },
                Some("object") => object(f, &p, out),
                Some("array") => {
                    let items = f.get("items").unwrap_or(&Value::Null);
                    match items.get("type").and_then(Value::as_str) {
                        Some("boolean" | "number" | "integer") => {}
                        Some("string") if items.get("contentEncoding").is_none() => {}
                        Some("object") => object(items, &format!("{p}[]"), out),
                        _ => out.push(format!(
                            "{p}[]: unsupported array item type {}",
                            items.get("type").unwrap_or(&Value::Null)
                        )),
                    }
                }
                _ => out.push(format!("{p}: unsupported type {}", f.get("type").unwrap_or(&Value::Null))),
            }
        }
    }
    let mut out = Vec::new();
    object(schema, "", &mut out);
    out
}

/// The schemas of the channels of a file, by name.
fn schemas_in(path: &Path) -> HashMap<String, Value> {
    let bytes = std::fs::read(path).unwrap();
    let summary = mcap::read::Summary::read(&bytes).unwrap().expect("a summary");
    summary.schemas.values().map(|s| (s.name.clone(), serde_json::from_slice(&s.data).unwrap())).collect()
}

#[test]
fn the_foxglove_subset_check_refuses_what_foxglove_refuses() {
    let ok = serde_json::json!({"type": "object", "properties": {
        "a": {"type": "integer"}, "b": {"type": "string", "contentEncoding": "base64"},
        "c": {"type": "array", "items": {"type": "object", "properties": {"x": {"type": "number"}}}},
        "d": {"oneOf": [{"const": 0, "title": "A"}, {"const": 1, "title": "B"}]}}});
    assert_eq!(foxglove_subset_problems(&ok), Vec::<String>::new());
    for (bad, what) in [
        (serde_json::json!({"type": ["integer", "null"]}), ".f: unsupported type"),
        (serde_json::json!({"type": "null"}), ".f: unsupported type"),
        (serde_json::json!({"type": "string", "contentEncoding": "hex"}), "contentEncoding"),
        (
            serde_json::json!({"type": "array", "items": {"type": ["number", "null"]}}),
            ".f[]: unsupported array item",
        ),
        (serde_json::json!({"type": "object"}), "without `properties`"),
        (
            serde_json::json!({"type": "object", "properties": {"g": {"type": ["string", "null"]}}}),
            ".f.g: unsupported type",
        ),
        (serde_json::json!({"oneOf": [{"const": "a"}]}), "numeric consts"),
    ] {
        let schema = serde_json::json!({"type": "object", "properties": {"f": bad}});
        let p = foxglove_subset_problems(&schema);
        assert!(p.len() == 1 && p[0].contains(what), "{bad}: {p:?}");
    }
}

#[test]
fn every_schema_is_one_foxglove_reads() {
    // Every schema the crate can register...
    for (topic, name, text) in mmq_log::messages::CHANNELS.iter().chain([&mmq_log::messages::LOG_CHANNEL]) {
        let v: Value = serde_json::from_str(text).unwrap();
        assert_eq!(foxglove_subset_problems(&v), Vec::<String>::new(), "{name} ({topic})");
    }
    // ...and every schema in the files written, the estimating robot's included.
    let dir = tempfile::tempdir().unwrap();
    let (grid, robot) = grid_and_robot_logs(dir.path());
    let est = dir.path().join("est.mcap");
    let mut rec = McapRecorder::create(RecorderConfig::new(&est)).unwrap();
    common::run_robot_with(&common::world("room-12x6"), &mut rec, 10, 3, true);
    drop(rec);
    for f in [grid, robot, est] {
        let schemas = schemas_in(&f);
        assert!(schemas.contains_key("mmq.Decision"));
        for (name, v) in schemas {
            assert_eq!(foxglove_subset_problems(&v), Vec::<String>::new(), "{name} in {}", f.display());
        }
    }
}

/// Checks every message of a file against its channel's schema; returns messages per
/// schema name.
pub fn validate_all(path: &Path) -> HashMap<String, usize> {
    let bytes = std::fs::read(path).unwrap();
    let mut per_schema = HashMap::new();
    let mut schemas: HashMap<String, Value> = HashMap::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let schema = m.channel.schema.as_ref().expect("every channel has a schema");
        assert_eq!(schema.encoding, "jsonschema");
        assert_eq!(m.channel.message_encoding, "json");
        let s = schemas
            .entry(schema.name.clone())
            .or_insert_with(|| serde_json::from_slice(&schema.data).unwrap());
        let v: Value = serde_json::from_slice(&m.data).unwrap();
        if let Err(e) = check(s, &v, "") {
            panic!(
                "{} message at {} does not validate against {}: {e}\n{v}",
                m.channel.topic, m.log_time, schema.name
            );
        }
        // A timestamp, where there is one at the top, is the message's log time.
        if let Some(ts) = v.get("timestamp").filter(|_| schema.name != "foxglove.SceneUpdate") {
            let ns = ts["sec"].as_u64().unwrap() * 1_000_000_000 + ts["nsec"].as_u64().unwrap();
            assert_eq!(ns, m.log_time, "{}", m.channel.topic);
        }
        *per_schema.entry(schema.name.clone()).or_insert(0) += 1;
    }
    per_schema
}

fn grid_and_robot_logs(dir: &Path) -> (PathBuf, PathBuf) {
    let grid = dir.join("grid.mcap");
    record_grid(&grid, |_| {}, 1000, 21);
    let robot = dir.join("robot.mcap");
    let mut rec = McapRecorder::create(RecorderConfig::new(&robot)).unwrap();
    common::run_robot(&common::world("room-12x6"), &mut rec, 100, 3);
    drop(rec);
    (grid, robot)
}

#[test]
fn the_validator_catches_what_foxglove_would_refuse() {
    let schema: Value = serde_json::from_str(mmq_log::messages::schemas::FRAME_TRANSFORM).unwrap();
    let good = serde_json::json!({"timestamp": {"sec": 1, "nsec": 2}, "parent_frame_id": "world",
        "child_frame_id": "robot", "translation": {"x": 0.0, "y": 1.0, "z": 0.0},
        "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}});
    check(&schema, &good, "").unwrap();
    let mut missing = good.clone();
    missing.as_object_mut().unwrap().remove("rotation");
    assert!(check(&schema, &missing, "").unwrap_err().contains("rotation"));
    let mut bad_ns = good.clone();
    bad_ns["timestamp"]["nsec"] = Value::from(2_000_000_000u64);
    assert!(check(&schema, &bad_ns, "").is_err());
    let grid: Value = serde_json::from_str(mmq_log::messages::schemas::GRID).unwrap();
    let field = &grid["properties"]["fields"]["items"];
    assert!(check(field, &serde_json::json!({"name": "v", "offset": 0, "type": 7}), "").is_ok());
    assert!(check(field, &serde_json::json!({"name": "v", "offset": 0, "type": "FLOAT32"}), "").is_err());
    let decision: Value = serde_json::from_str(mmq_log::messages::schemas::DECISION).unwrap();
    let d = serde_json::json!({"t": 0, "state": 1, "action": 2, "action_name": "S",
        "explored": false, "next_state": 1, "event": "wall"});
    check(&decision, &d, "").unwrap();
    let mut with_model = d.clone();
    with_model["model"] = Value::from(3);
    check(&decision, &with_model, "").unwrap();
    // No learner's model is left out, never null (Foxglove has no null type).
    with_model["model"] = Value::Null;
    assert!(check(&decision, &with_model, "").is_err());
    let mut extra = d.clone();
    extra["surprise"] = Value::from(1);
    assert!(check(&decision, &extra, "").is_err());
}

#[test]
fn every_message_validates_against_its_schema() {
    let dir = tempfile::tempdir().unwrap();
    let (grid, robot) = grid_and_robot_logs(dir.path());
    let g = validate_all(&grid);
    for name in [
        "foxglove.FrameTransform",
        "foxglove.PoseInFrame",
        "foxglove.SceneUpdate",
        "foxglove.Grid",
        "foxglove.Log",
        "mmq.Decision",
        "mmq.RewardEmitted",
        "mmq.RewardDelivered",
        "mmq.Teleport",
    ] {
        assert!(g.get(name).copied().unwrap_or(0) > 0, "grid log has no {name}");
    }
    let r = validate_all(&robot);
    assert!(r["mmq.Contact"] > 0);
}

/// The Python interpreter with `mcap` and `jsonschema`: `tools/.venv` first, then the
/// `python3` on the PATH. Without one, a test that needs it is skipped with a note, except
/// under CI (`CI` set to anything but `false` or empty), where a missing tool is a failure:
/// CI installs it, so its absence means a check silently stopped running.
pub fn python_with_mcap() -> Option<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let candidates = [root.join("tools/.venv/bin/python"), PathBuf::from("python3")];
    let found = candidates.into_iter().find(|py| {
        Command::new(py).args(["-c", "import mcap, jsonschema"]).output().is_ok_and(|o| o.status.success())
    });
    let under_ci = std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false");
    assert!(
        found.is_some() || !under_ci,
        "CI is set but no Python has the `mcap` and `jsonschema` packages: \
         pip install -r tools/requirements.txt (into tools/.venv or the python3 on the PATH)"
    );
    found
}

#[test]
fn official_python_reader_validates_our_files() {
    let Some(py) = python_with_mcap() else {
        println!(
            "note: skipped: no Python with the `mcap` and `jsonschema` packages \
             (pip install -r tools/requirements.txt, or into tools/.venv)"
        );
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (grid, robot) = grid_and_robot_logs(dir.path());
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tools/validate_mcap.py");
    let out = Command::new(&py).arg(&script).arg(&grid).arg(&robot).output().unwrap();
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "validate_mcap.py failed:\n{text}");
    assert!(text.contains("/rl/decision") && text.contains("OK"), "{text}");
    // And it does refuse a damaged file.
    let bytes = std::fs::read(&grid).unwrap();
    let cut = dir.path().join("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let out = Command::new(&py).arg(&script).arg("-q").arg(&cut).output().unwrap();
    assert!(!out.status.success(), "a cut file passed validation");
}
