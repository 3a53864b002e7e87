//! Fuzzes `World::parse` (the world-file parser and validator): any text must give a
//! world or a one-line error naming the file, never a panic, a hang or a huge
//! allocation; an accepted world must be self-consistent.
#![no_main]

use libfuzzer_sys::fuzz_target;
use mmq_core::{Cell, World};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    match World::parse(text, "fuzz.toml") {
        Ok(w) => {
            assert_eq!(w.cells.len(), w.width * w.height);
            assert!(w.width >= 1 && w.height >= 1);
            assert!(w.width <= mmq_core::world::MAX_SIDE && w.height <= mmq_core::world::MAX_SIDE);
            assert!(w.num_cells() <= mmq_core::world::MAX_CELLS);
            assert_ne!(w.goal, w.respawn);
            assert_eq!(w.cells[w.goal], Cell::Free);
            assert_eq!(w.cells[w.respawn], Cell::Free);
            assert!(w.cell_size.is_finite() && w.cell_size > 0.0);
            // The map prints back to a world with the same cells.
            let again = World::parse(&format!("map = \"\"\"\n{}\"\"\"\n", w.ascii()), "again.toml")
                .expect("a printed map parses");
            assert_eq!(again.cells, w.cells);
            assert_eq!((again.goal, again.respawn), (w.goal, w.respawn));
            // The exact optimum and the robot's table on small worlds (both are used by
            // every run).
            if w.num_cells() <= 400 {
                let o = mmq_core::optimum(&w);
                assert!(!o.gain.is_nan());
            }
            let _ = mmq_robot::RobotConfig::from_world(&w);
        }
        Err(e) => {
            let msg = e.to_string();
            assert!(msg.starts_with("fuzz.toml: "), "{msg}");
            assert!(!msg.contains('\n') || msg.lines().count() <= 3, "{msg}");
        }
    }
});
