//! compare: the same run twice matches; a different run is caught at its first
//! differing step, topic and field.

use mmq_log::{compare, read_log};

use crate::common::record_grid;

#[test]
fn same_seed_matches_and_other_seed_differs() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b, c) = (dir.path().join("a.mcap"), dir.path().join("b.mcap"), dir.path().join("c.mcap"));
    record_grid(&a, |_| {}, 1500, 9);
    // Different flushing (chunking) must not matter: only the content is compared.
    record_grid(&b, |cfg| cfg.flush_every_steps = 37, 1500, 9);
    record_grid(&c, |_| {}, 1500, 10);
    let (la, lb, lc) = (read_log(&a).unwrap(), read_log(&b).unwrap(), read_log(&c).unwrap());
    compare(&la, &lb).unwrap();
    let m = compare(&la, &lc).unwrap_err();
    assert!(m.step.is_some());
    assert!(m.to_string().contains("logs differ on"), "{m}");
}

#[test]
fn reports_the_first_differing_step_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.mcap");
    record_grid(&a, |_| {}, 800, 2);
    let la = read_log(&a).unwrap();
    // An action changed at step 300.
    let mut lb = la.clone();
    lb.decisions[300].msg.action_name = "X".into();
    let m = compare(&la, &lb).unwrap_err();
    assert_eq!(
        (m.topic.as_str(), m.index, m.step, m.field.as_str()),
        ("/rl/decision", 300, Some(300), "action_name")
    );
    assert_eq!((m.a.clone(), m.b.as_str()), (format!("\"{}\"", la.decisions[300].msg.action_name), "\"X\""));
    // A delay inside a delivery, earlier than the decision change: reported first.
    let i = lb.delivered.iter().position(|d| !d.msg.parts.is_empty() && d.msg.t < 300).unwrap();
    lb.delivered[i].msg.parts[0].delay += 1;
    let m = compare(&la, &lb).unwrap_err();
    assert_eq!((m.topic.as_str(), m.index, m.field.as_str()), ("/rl/reward/delivered", i, "parts[0].delay"));
    // A pose nudged by one ulp.
    let mut lc = la.clone();
    lc.poses[50].x = f64::from_bits(lc.poses[50].x.to_bits() + 1);
    let m = compare(&la, &lc).unwrap_err();
    assert_eq!((m.topic.as_str(), m.index, m.field.as_str(), m.step), ("/robot/pose", 50, "x", Some(49)));
    // A missing tail.
    let mut ld = la.clone();
    ld.emitted.pop();
    let m = compare(&la, &ld).unwrap_err();
    assert_eq!((m.field.as_str(), m.a.as_str(), m.b.as_str()), ("(message)", "present", "absent"));
}
