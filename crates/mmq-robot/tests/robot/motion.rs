//! The four-move primitives on the paper's 9×9 world and the 15×15 maze, noise off.

use mmq_core::Telemetry;
use mmq_core::{Env, Event, Move, Start};

use crate::{env, stat};

/// From every free cell, each move toward a free neighbour reaches it (≥ 99 %); each
/// move into the boundary yields the wall reward and leaves the robot in its cell.
#[test]
fn moves_reach_free_neighbours_and_bounce_off_the_boundary() {
    let mut e = env("paper-9x9");
    let w = e.world().clone();
    let (mut tried, mut reached, mut bumps) = (0, 0, 0);
    for cell in w.free_cells().filter(|&c| c != w.goal) {
        for (a, m) in Move::ALL.iter().enumerate() {
            e.reset(1, Start::State(cell)).unwrap();
            let st = e.step(a).unwrap();
            match w.neighbour(cell, *m) {
                Some(n) if w.is_free(n) => {
                    tried += 1;
                    if st.state == n && st.event == Event::Moved && st.reward == w.rewards.step {
                        reached += 1;
                    } else {
                        eprintln!("cell {cell} {m:?}: {st:?}");
                    }
                }
                _ => {
                    bumps += 1;
                    assert_eq!(st.state, cell, "cell {cell} {m:?}: {st:?}");
                    assert_eq!(st.event, Event::WallBump, "cell {cell} {m:?}");
                    assert_eq!(st.reward, w.rewards.wall);
                    // Back at the centre of its own cell.
                    let (cx, cy) = w.cell_center(cell);
                    let p = e.pose();
                    assert!((p.x - cx).hypot(p.y - cy) < 0.02, "cell {cell} {m:?}: {p:?}");
                }
            }
        }
    }
    assert_eq!(bumps, 4 * 8 + 4 - 2, "boundary moves (G excluded)");
    assert!(reached as f64 >= 0.99 * tried as f64, "{reached} of {tried} moves reached their cell");
}

/// A chain of moves keeps landing on cell centres (errors do not accumulate).
#[test]
fn a_long_walk_stays_on_the_grid() {
    let mut e = env("paper-9x9");
    let w = e.world().clone();
    let mut s = e.reset(3, Start::State(w.index(8, 0))).unwrap();
    // Twice around a loop next to the boundary, avoiding G: from the bottom-left cell
    // N×7 to row 1, E×8, S×7, W×8 back.
    let path = [(0, 7), (1, 8), (2, 7), (3, 8)];
    for _ in 0..2 {
        for &(a, n) in &path {
            for _ in 0..n {
                let st = e.step(a).unwrap();
                assert_eq!(st.event, Event::Moved, "{s} {a}: {st:?}");
                let (dr, dc) = Move::ALL[a].delta();
                let (r, c) = w.row_col(s);
                assert_eq!(st.state, w.index((r as isize + dr) as usize, (c as isize + dc) as usize));
                s = st.state;
            }
        }
        let p = e.pose();
        let (cx, cy) = w.cell_center(s);
        assert!((p.x - cx).hypot(p.y - cy) < 0.015, "{p:?}");
    }
    assert_eq!(stat(&e, "robot/timed_out"), 0.0);
}

/// An action in G yields the goal reward and puts the robot at rest at the centre of S.
#[test]
fn goal_teleports_to_respawn() {
    let mut e = env("paper-9x9");
    let w = e.world().clone();
    for a in 0..4 {
        e.reset(5, Start::State(w.goal)).unwrap();
        let t0 = e.sim_time_s();
        let st = e.step(a).unwrap();
        assert_eq!((st.state, st.reward, st.event), (w.respawn, w.rewards.goal, Event::Teleport));
        assert!(!st.terminated && !st.truncated);
        let p = e.pose();
        assert_eq!((p.x, p.y), w.cell_center(w.respawn));
        assert_eq!(e.sim_time_s(), t0);
        // At rest: the next move starts from standstill and goes where it should.
        let st = e.step(0).unwrap();
        assert_eq!(st.state, w.neighbour(w.respawn, mmq_core::Move::N).unwrap());
    }
    assert_eq!(stat(&e, "robot/goal"), 1.0);
}

/// Reaching G by driving, then acting in G.
#[test]
fn drive_into_goal_then_collect() {
    let mut e = env("paper-9x9");
    let w = e.world().clone();
    e.reset(5, Start::State(w.index(0, 1))).unwrap();
    let st = e.step(3).unwrap(); // W into G
    assert_eq!((st.state, st.event), (w.goal, Event::Moved));
    let st = e.step(1).unwrap();
    assert_eq!((st.state, st.reward, st.event), (w.respawn, 10.0, Event::Teleport));
}

/// In the maze, every move into a blocked cell gives the wall reward and the robot
/// stays in (returns to the centre of) its cell; moves to free cells reach them.
#[test]
fn maze_blocks_push_back() {
    let mut e = env("maze-15x15");
    let w = e.world().clone();
    let (mut block_bumps, mut moves, mut reached) = (0, 0, 0);
    for cell in w.free_cells().filter(|&c| c != w.goal) {
        for (a, m) in Move::ALL.iter().enumerate() {
            let Some(n) = w.neighbour(cell, *m) else { continue };
            e.reset(2, Start::State(cell)).unwrap();
            let st = e.step(a).unwrap();
            if w.is_free(n) {
                moves += 1;
                reached += usize::from(st.state == n && st.event == Event::Moved);
            } else {
                block_bumps += 1;
                assert_eq!((st.state, st.reward, st.event), (cell, -1.0, Event::WallBump), "{cell} {m:?}");
                let (cx, cy) = w.cell_center(cell);
                let p = e.pose();
                assert!((p.x - cx).hypot(p.y - cy) < 0.02, "cell {cell} {m:?}: {p:?}");
            }
        }
    }
    assert!(block_bumps > 100, "{block_bumps}");
    assert!(reached as f64 >= 0.99 * moves as f64, "{reached} of {moves}");
}

/// Bumping again while already touching a wall still counts (the narrow-phase check),
/// and a bump is reported with its wall in the contact count.
#[test]
fn repeated_bumps_all_count() {
    let mut e = env("paper-9x9");
    let w = e.world().clone();
    e.reset(1, Start::State(w.index(0, 4))).unwrap();
    for i in 1..=5 {
        let st = e.step(0).unwrap();
        assert_eq!((st.state, st.reward, st.event), (w.index(0, 4), -1.0, Event::WallBump), "bump {i}");
    }
    assert_eq!(stat(&e, "robot/bumped"), 5.0);
    assert!(stat(&e, "robot/contacts") >= 5.0);
}

/// Each preset drives and bumps correctly on the paper world.
#[test]
fn presets_work() {
    for p in mmq_robot::Preset::ALL {
        let w = crate::world("paper-9x9");
        let mut e = mmq_robot::RobotEnv::new(&w, p.config()).unwrap();
        e.reset(1, Start::State(w.index(4, 4))).unwrap();
        for (a, expect) in [(0, w.index(3, 4)), (1, w.index(3, 5)), (2, w.index(4, 5)), (3, w.index(4, 4))] {
            let st = e.step(a).unwrap();
            assert_eq!((st.state, st.event), (expect, Event::Moved), "{p}: action {a}");
        }
        e.reset(1, Start::State(w.index(8, 4))).unwrap();
        let st = e.step(2).unwrap();
        assert_eq!((st.state, st.event), (w.index(8, 4), Event::WallBump), "{p}");
    }
}

/// Errors: out-of-range actions and starts; runaway states become `EnvError::Physics`.
#[test]
fn errors_are_typed() {
    use mmq_core::EnvError;
    let mut e = env("maze-15x15");
    e.reset(0, Start::World).unwrap();
    assert_eq!(e.step(4), Err(EnvError::InvalidAction { action: 4, num_actions: 4 }));
    assert_eq!(e.reset(0, Start::State(7)), Err(EnvError::InvalidStart(7)), "cell 7 is blocked");
    assert_eq!(e.reset(0, Start::State(15 * 15)), Err(EnvError::InvalidStart(225)));
    e.reset(0, Start::Respawn).unwrap();
    e.step(0).unwrap();
    e.debug_set_velocity(1e4, 0.0);
    match e.step(0) {
        Err(EnvError::Physics { step, message }) => {
            assert_eq!(step, 2);
            assert!(message.contains("speed") || message.contains("outside"), "{message}");
        }
        other => panic!("expected a physics error, got {other:?}"),
    }
    e.reset(0, Start::Respawn).unwrap();
    e.debug_set_velocity(f64::NAN, 0.0);
    match e.step(1) {
        Err(EnvError::Physics { message, .. }) => {
            assert!(message.contains("non-finite") || message.contains("quarantine"), "{message}")
        }
        other => panic!("expected a physics error, got {other:?}"),
    }
}

/// `Start::World` follows the world's rule with the seeded stream.
#[test]
fn start_rule() {
    let mut e = env("paper-9x9");
    let w = e.world().clone();
    let starts: Vec<usize> = (0..40).map(|s| e.reset(s, Start::World).unwrap()).collect();
    assert!(starts.iter().all(|&s| s != w.goal && w.is_free(s)));
    assert!(starts.iter().collect::<std::collections::HashSet<_>>().len() > 20);
    assert_eq!(starts, (0..40).map(|s| e.reset(s, Start::World).unwrap()).collect::<Vec<_>>());
    assert_eq!(e.reset(9, Start::Respawn).unwrap(), w.respawn);
    let mut w2 = w.clone();
    w2.start = mmq_core::StartRule::Respawn;
    let mut e2 = mmq_robot::RobotEnv::new(&w2, Default::default()).unwrap();
    assert_eq!(e2.reset(9, Start::World).unwrap(), w.respawn);
}

/// Noise off, the robot's cell sequence under random actions is the grid's
/// (`World::transition`), on the open 9×9 world and in the maze.
#[test]
fn cells_follow_the_grid_dynamics() {
    use rand::RngExt;
    for (name, n) in [("paper-9x9", 600), ("maze-15x15", 600)] {
        let mut e = env(name);
        let w = e.world().clone();
        let mut rng = mmq_core::seed::rng_from_seed(77);
        let mut s = e.reset(8, Start::World).unwrap();
        for i in 0..n {
            let a = rng.random_range(0..4);
            let (next, reward, event) = w.transition(s, Move::ALL[a]);
            let st = e.step(a).unwrap();
            assert_eq!(
                (st.state, st.reward, st.event),
                (next, reward, event),
                "{name}, step {i}: {a} in {s}"
            );
            s = st.state;
        }
    }
}
