//! `mmq world list|check|show`.

use mmq_core::World;
use mmq_lab::runner::check_world;

use crate::Failure;
use crate::cli::WorldAction;

/// Runs `mmq world`.
pub fn world(action: WorldAction) -> Result<(), Failure> {
    match action {
        WorldAction::List => {
            print!("{}", mmq_report::terminal::shipped_worlds()?);
            Ok(())
        }
        WorldAction::Check { files } => {
            let mut bad = 0;
            let total = files.len();
            for f in files {
                match check_world(&f) {
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
        WorldAction::Show { file, toml: false } => {
            print!("{}", mmq_report::text::world(&World::load(&file)?));
            Ok(())
        }
        WorldAction::Show { file, toml: true } => {
            // The file as read (a shipped world's own text): valid TOML that loads as
            // this world.
            let w = World::load(&file)?;
            print!("{}{}", w.source, if w.source.ends_with('\n') { "" } else { "\n" });
            Ok(())
        }
    }
}
