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
fn check(schema: &Value, v: &Value, path: &str) -> Result<(), String> {
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
    let d = serde_json::json!({"t": 0, "state": 1, "action": 2, "action_name": "S", "model": null,
        "explored": false, "next_state": 1, "event": "wall"});
    check(&decision, &d, "").unwrap();
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
/// `python3` on the PATH.
pub fn python_with_mcap() -> Option<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let candidates = [root.join("tools/.venv/bin/python"), PathBuf::from("python3")];
    candidates.into_iter().find(|py| {
        Command::new(py).args(["-c", "import mcap, jsonschema"]).output().is_ok_and(|o| o.status.success())
    })
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
