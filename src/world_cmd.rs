//! `mmq world list|check|show`.

use mmq_core::World;
use mmq_report::text;

use crate::Failure;
use crate::cli::WorldAction;
use crate::progress::Bars;

/// Runs `mmq world`.
pub fn world(action: WorldAction) -> Result<(), Failure> {
    match action {
        WorldAction::List => print!("{}", mmq_report::terminal::shipped_worlds()?),
        WorldAction::Check { files } => mmq_report::worlds::check(&files, &Bars::new(false))?,
        WorldAction::Show { file, toml } => {
            let w = World::load(&file)?;
            print!("{}", if toml { text::world_toml(&w) } else { text::world(&w) });
        }
    }
    Ok(())
}
