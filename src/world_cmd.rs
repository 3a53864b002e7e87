//! `mmq world list|check|show`.

use mmq_core::World;
use mmq_lab::runner::robot_env;

use crate::Failure;
use crate::cli::{WorldAction, WorldArgs};

/// Runs `mmq world`.
pub fn world(args: WorldArgs) -> Result<(), Failure> {
    match args.action {
        WorldAction::List => {
            print!("{}", mmq_report::terminal::shipped_worlds()?);
            Ok(())
        }
        WorldAction::Check { files } => {
            let mut bad = 0;
            let total = files.len();
            for f in files {
                // A `[robot]` table is checked too (against the world's cell size): the
                // robot environment would refuse it at the start of `mmq run --env robot`.
                let checked = World::load(&f).map_err(|e| e.to_string()).and_then(|w| {
                    if w.robot.is_some() {
                        robot_env(&w).map_err(|e| e.to_string())?;
                    }
                    Ok(w)
                });
                match checked {
                    Ok(w) => println!("{}", mmq_report::terminal::world_ok(&f, &w)),
                    Err(e) => {
                        eprintln!("error: {e}");
                        bad += 1;
                    }
                }
            }
            if bad > 0 {
                return Err(crate::input_error(format!("{bad} of {total} world files are invalid")));
            }
            Ok(())
        }
        WorldAction::Show { file } => {
            print!("{}", mmq_report::text::world(&World::load(&file)?));
            Ok(())
        }
    }
}
