//! A robot that controls on an estimate: its estimate is a second `/tf` frame
//! (`robot_estimate`) with its own pose topic and body, its localisation fixes have a
//! topic of their own; a robot on the true pose writes none of them.

use std::collections::HashMap;

use mmq_log::messages::topics;
use mmq_log::{McapRecorder, RecorderConfig};
use serde_json::Value;

use crate::common::{self, ESTIMATE_OFFSET};
use crate::schemas::validate_all;

/// Messages (log time, JSON) by topic.
type ByTopic = HashMap<String, Vec<(u64, Value)>>;

/// Messages per topic, and the `/tf` messages per child frame.
fn messages(path: &std::path::Path) -> (ByTopic, HashMap<String, usize>) {
    let bytes = std::fs::read(path).unwrap();
    let mut by_topic: HashMap<String, Vec<(u64, Value)>> = HashMap::new();
    let mut frames = HashMap::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let v: Value = serde_json::from_slice(&m.data).unwrap();
        if m.channel.topic == topics::TF {
            *frames.entry(v["child_frame_id"].as_str().unwrap().to_string()).or_insert(0) += 1;
        }
        by_topic.entry(m.channel.topic.clone()).or_default().push((m.log_time, v));
    }
    (by_topic, frames)
}

#[test]
fn estimates_and_fixes_are_recorded_next_to_the_truth() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("est.mcap");
    let mut rec = McapRecorder::create(RecorderConfig::new(&path)).unwrap();
    let steps = 20;
    common::run_robot_with(&common::world("room-12x6"), &mut rec, steps, 3, true);
    drop(rec);
    validate_all(&path);
    let (by_topic, frames) = messages(&path);
    let poses = &by_topic[topics::POSE];
    let estimates = &by_topic[topics::POSE_ESTIMATE];
    // One estimate with every kept pose sample but the start pose (which has none).
    assert_eq!(estimates.len(), poses.len() - 1);
    assert_eq!(frames["robot_estimate"], estimates.len());
    assert_eq!(frames["robot"], poses.len());
    // Same times, offset as the run made it.
    let truth: HashMap<u64, &Value> = poses.iter().map(|(t, v)| (*t, v)).collect();
    for (t, e) in estimates {
        let p = truth[t];
        let dx = e["pose"]["position"]["x"].as_f64().unwrap() - p["pose"]["position"]["x"].as_f64().unwrap();
        let dy = e["pose"]["position"]["y"].as_f64().unwrap() - p["pose"]["position"]["y"].as_f64().unwrap();
        assert!((dx - ESTIMATE_OFFSET.0).abs() < 1e-9 && (dy - ESTIMATE_OFFSET.1).abs() < 1e-9, "{dx} {dy}");
    }
    // One fix per step, half-way through it (the run's clock: step t spans t..t+1 s).
    let fixes = &by_topic[topics::FIX];
    assert_eq!(fixes.len() as u64, steps);
    for (i, (t, _)) in fixes.iter().enumerate() {
        assert_eq!(*t, i as u64 * 1_000_000_000 + 500_000_000);
    }
    // The estimate's body once, in its frame.
    let body = &by_topic[topics::ROBOT_ESTIMATE];
    assert!(!body.is_empty());
    assert_eq!(body[0].1["entities"][0]["frame_id"], "robot_estimate");
}

#[test]
fn a_robot_on_the_true_pose_writes_no_estimate() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ideal.mcap");
    let mut rec = McapRecorder::create(RecorderConfig::new(&path)).unwrap();
    common::run_robot(&common::world("room-12x6"), &mut rec, 20, 3);
    drop(rec);
    let (by_topic, frames) = messages(&path);
    for t in [topics::POSE_ESTIMATE, topics::FIX, topics::ROBOT_ESTIMATE] {
        assert!(!by_topic.contains_key(t), "{t}");
    }
    assert_eq!(frames.keys().collect::<Vec<_>>(), vec!["robot"]);
}
