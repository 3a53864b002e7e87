//! Pose and contact traces, simulated time, stats and build features.

use mmq_core::Telemetry;
use mmq_core::{Env, Start, StepTrace};

use crate::{env, stat};

#[test]
fn poses_are_sampled_at_the_period_and_contacts_name_the_wall() {
    let mut e = env("paper-9x9");
    let w = e.world().clone();
    e.set_trace(Some(0.1));
    e.reset(1, Start::State(w.index(0, 4))).unwrap();
    let t0 = e.sim_time_s();
    e.step(0).unwrap(); // into the northern boundary
    let mut tr = StepTrace::default();
    e.take_trace(&mut tr);
    let t1 = e.sim_time_s();
    assert!(t1 > t0 + 0.5);
    let n = tr.poses.len();
    assert!(
        n as f64 >= (t1 - t0) / 0.1 - 1.0 && n as f64 <= (t1 - t0) / 0.1 + 2.0,
        "{n} samples over {} s",
        t1 - t0
    );
    assert!(tr.poses.windows(2).all(|p| p[1].time_s > p[0].time_s));
    let last = tr.poses.last().unwrap();
    assert_eq!(*last, e.pose());
    assert_eq!(last.time_s, t1);
    // The robot came close to the wall and went back.
    let top = tr.poses.iter().map(|p| p.y).fold(f64::MIN, f64::max);
    assert!(top > 4.5 - 0.105 - 0.03, "highest {top}");
    assert_eq!(tr.contacts.first().map(|c| (c.started, c.wall.as_str())), Some((true, "boundary-north")));
    assert_eq!(tr.contacts.last().map(|c| (c.started, c.wall.as_str())), Some((false, "boundary-north")));
    // Taking the trace empties it.
    let mut again = StepTrace::default();
    e.take_trace(&mut again);
    assert!(again.poses.is_empty() && again.contacts.is_empty());
    // Tracing off: nothing recorded.
    e.set_trace(None);
    e.step(2).unwrap();
    e.take_trace(&mut again);
    assert!(again.poses.is_empty());
}

#[test]
fn blocks_are_named_by_row_and_column() {
    let mut e = env("maze-15x15");
    let w = e.world().clone();
    e.set_trace(Some(1.0));
    // Row 1 (0-based 0), column 7 (0-based 6) is free; east of it is the block at row 1,
    // column 8 (1-based) = `block-r1c8`.
    let cell = w.index(0, 6);
    assert!(w.is_free(cell) && !w.is_free(w.index(0, 7)));
    e.reset(1, Start::State(cell)).unwrap();
    e.step(1).unwrap();
    let mut tr = StepTrace::default();
    e.take_trace(&mut tr);
    assert!(tr.contacts.iter().any(|c| c.started && c.wall == "block-r1c8"), "{:?}", tr.contacts);
    assert!(e.walls().iter().any(|x| x.name == "block-r1c8"));
}

#[test]
fn stats_and_features() {
    let mut e = env("paper-9x9");
    e.reset(4, Start::World).unwrap();
    for a in [0, 1, 2, 3, 0, 0, 0, 0, 0, 0, 0, 0, 0] {
        e.step(a).unwrap();
    }
    assert_eq!(stat(&e, "robot/primitives"), 13.0);
    let outcomes = stat(&e, "robot/reached")
        + stat(&e, "robot/bumped")
        + stat(&e, "robot/timed_out")
        + stat(&e, "robot/goal");
    assert_eq!(outcomes, 13.0);
    assert!(stat(&e, "robot/bumped") >= 1.0);
    let steps = stat(&e, "robot/physics_steps");
    assert!((stat(&e, "robot/sim_time_s") - steps / 60.0).abs() < 1e-6);
    assert!(stat(&e, "robot/rapier_steps") <= steps);
    assert_eq!(e.sim_time_s(), stat(&e, "robot/sim_time_s"));
    let f = e.features();
    let get = |k: &str| f.iter().find(|(n, _)| n == k).map(|(_, v)| v.clone());
    assert_eq!(get("rapier2d.version").as_deref(), Some(mmq_robot::RAPIER_VERSION));
    assert_eq!(get("rapier2d.enhanced-determinism").as_deref(), Some("on"));
    assert!(get("physics.dt_s").is_some());
    // Reset clears the counters.
    e.reset(4, Start::World).unwrap();
    assert_eq!(stat(&e, "robot/primitives"), 0.0);
    assert_eq!(e.sim_time_s(), 0.0);
}
