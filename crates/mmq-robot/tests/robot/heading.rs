//! The heading action set: forward one cell, turn left, turn right; heading in the state.

use mmq_core::{Env, Event, Start};
use mmq_robot::{ActionSet, RobotConfig, RobotEnv};

fn env() -> RobotEnv {
    let w = crate::world("paper-9x9");
    let cfg = RobotConfig { actions: ActionSet::Heading, ..RobotConfig::default() };
    RobotEnv::new(&w, cfg).unwrap()
}

#[test]
fn heading_primitives() {
    let mut e = env();
    let w = e.world().clone();
    assert_eq!(e.num_states(), 81 * 4);
    assert_eq!(e.num_actions(), 3);
    assert_eq!(e.action_names(), ["forward", "left", "right"]);
    // Centre cell facing north (heading 0 = N, 1 = E, 2 = S, 3 = W).
    let c = w.index(4, 4);
    let s = e.reset(1, Start::State(c * 4)).unwrap();
    assert_eq!((s, e.state_cell(s)), (c * 4, c));
    let st = e.step(0).unwrap(); // forward: north
    assert_eq!((st.state, st.event), (w.index(3, 4) * 4, Event::Moved));
    let st = e.step(2).unwrap(); // right: now east
    assert_eq!((st.state, st.event, st.reward), (w.index(3, 4) * 4 + 1, Event::Moved, 0.0));
    let st = e.step(0).unwrap();
    assert_eq!(st.state, w.index(3, 5) * 4 + 1);
    let st = e.step(1).unwrap(); // left: north again
    assert_eq!(st.state, w.index(3, 5) * 4);
    let st = e.step(1).unwrap(); // west
    assert_eq!(st.state, w.index(3, 5) * 4 + 3);
    // Forward into the boundary from the west edge.
    let s = e.reset(1, Start::State(w.index(4, 0) * 4 + 3)).unwrap();
    let st = e.step(0).unwrap();
    assert_eq!((st.state, st.event, st.reward), (s, Event::WallBump, -1.0));
    // In G any action teleports to S, keeping the heading.
    e.reset(1, Start::State(w.goal * 4 + 2)).unwrap();
    let st = e.step(1).unwrap();
    assert_eq!((st.state, st.event, st.reward), (w.respawn * 4 + 2, Event::Teleport, 10.0));
}

#[test]
fn heading_set_is_deterministic() {
    mmq_core::env::check_determinism(env, 11, 150).unwrap();
}
