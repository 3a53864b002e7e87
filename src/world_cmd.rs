//! `mmq world list|check|show`.

use mmq_core::{Move, World, optimum};
use mmq_lab::runner::robot_env;

use crate::Failure;
use crate::cli::{WorldAction, WorldArgs};

/// Runs `mmq world`.
pub fn world(args: WorldArgs) -> Result<(), Failure> {
    match args.action {
        WorldAction::List => {
            println!("shipped worlds (use the name as --world, or copy the file to change it):");
            for (name, text) in mmq_core::shipped::WORLDS {
                let w = World::parse(text, name)?;
                println!(
                    "  {name:<14} {}×{:<3} optimum {:.4}/step  {}",
                    w.width,
                    w.height,
                    optimum(&w).gain,
                    w.description
                );
            }
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
                    Ok(w) => {
                        let o = optimum(&w);
                        println!(
                            "ok  {}: {} {}×{}, {} free cells, optimum {:.4} reward/step",
                            f.display(),
                            w.name,
                            w.width,
                            w.height,
                            w.free_cells().count(),
                            o.gain
                        );
                    }
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
            let w = World::load(&file)?;
            let o = optimum(&w);
            println!("{} ({}×{}): {}", w.name, w.width, w.height, w.description);
            println!("\nmap:");
            print!("{}", indent(&w.ascii()));
            println!("\noptimal policy (all optimal moves; · = any):");
            let mut s = String::new();
            for r in 0..w.height {
                for c in 0..w.width {
                    let i = w.index(r, c);
                    let cell = if !w.is_free(i) {
                        "#".to_string()
                    } else if i == w.goal {
                        "G".to_string()
                    } else {
                        let arrows: String = Move::ALL
                            .iter()
                            .enumerate()
                            .filter(|(a, _)| o.is_optimal(i, *a))
                            .map(|(_, m)| m.arrow())
                            .collect();
                        if arrows.chars().count() == 4 { "·".to_string() } else { arrows }
                    };
                    s.push_str(&format!("{cell:<3}"));
                }
                s.push('\n');
            }
            print!("{}", indent(&s));
            println!(
                "\noptimal average reward: {:.6} per step (rewards: goal {}, wall {}, step {}; cell {} m; start {:?})",
                o.gain, w.rewards.goal, w.rewards.wall, w.rewards.step, w.cell_size, w.start
            );
            Ok(())
        }
    }
}

fn indent(s: &str) -> String {
    s.lines().map(|l| format!("  {l}\n")).collect()
}
