//! Studies: the paper's figures, the learner comparison and any study to come, each one
//! or more sweep specs run by the sweep engine into its resumable store, then read back
//! for a report. A study's jobs keep their seed's record ([`SeedRecord`]) beside their
//! metrics; [`groups`] turns a store into one [`Group`] per cell.
//!
//! The paper's specs ship in the binary ([`SPECS`]) and in `worlds/sweeps/`; a folder
//! of edited copies replaces them by name. [`Budget`] is the one rule for what `--quick`,
//! `--steps`, `--seeds` and `--seed` do to a spec.

mod budget;
mod group;
mod timing;

use std::path::{Path, PathBuf};

pub use crate::output::RUNS;
pub use crate::sweep::{RunRecord, SeedRecord};
pub use budget::{Budget, PAPER_STEPS, PAPER_WINDOW};
pub use group::{Group, configs, groups};
pub use timing::{StepRewards, last_steps};

use crate::error::LabError;

/// The paper's studies as sweep specs, shipped in the binary so that `mmq paper` runs
/// from any folder; the same files are in `worlds/sweeps/`, where `mmq sweep` runs them
/// and a copy with one line changed is the same study of a variant.
pub const SPECS: &[(&str, &str)] = &[
    ("paper-fig2", include_str!("../../../../worlds/sweeps/paper-fig2.toml")),
    ("paper-fig3", include_str!("../../../../worlds/sweeps/paper-fig3.toml")),
    ("paper-fig4", include_str!("../../../../worlds/sweeps/paper-fig4.toml")),
    ("paper-fig6", include_str!("../../../../worlds/sweeps/paper-fig6.toml")),
    ("paper-fig6-robot", include_str!("../../../../worlds/sweeps/paper-fig6-robot.toml")),
    ("paper-horizon", include_str!("../../../../worlds/sweeps/paper-horizon.toml")),
    ("paper-sensitivity", include_str!("../../../../worlds/sweeps/paper-sensitivity.toml")),
    ("paper-comparison", include_str!("../../../../worlds/sweeps/paper-comparison.toml")),
];

/// The text of the study spec `name` and the file that names it: `name.toml` in
/// `folder` when there is one (relative world paths start from the folder), else the
/// built-in copy.
pub(crate) fn spec_text(folder: Option<&Path>, name: &str) -> Result<(String, PathBuf), LabError> {
    if let Some(d) = folder.filter(|d| !d.is_dir()) {
        return Err(LabError::Config {
            file: d.display().to_string(),
            message: "not a folder; give the folder that holds your copies of figure specs (e.g. an edited paper-fig6.toml)".into(),
        });
    }
    if let Some(file) = edited_spec(folder, name) {
        let text = mmq_core::files::read_text_bounded(&file, crate::sweep::MAX_SPEC_BYTES).map_err(|e| {
            LabError::Config {
                file: file.display().to_string(),
                message: format!("cannot read the spec: {e}"),
            }
        })?;
        return Ok((text, file));
    }
    let text = SPECS.iter().find(|s| s.0 == name).map(|s| s.1).ok_or_else(|| LabError::Config {
        file: format!("{name}.toml"),
        message: format!(
            "no shipped figure spec of that name; the shipped ones: {}",
            SPECS.iter().map(|s| s.0).collect::<Vec<_>>().join(", ")
        ),
    })?;
    Ok((text.to_string(), PathBuf::from(format!("{name}.toml"))))
}

/// The file in `folder` that replaces the built-in study spec `name`, if there is one.
pub fn edited_spec(folder: Option<&Path>, name: &str) -> Option<PathBuf> {
    folder.map(|d| d.join(format!("{name}.toml"))).filter(|f| f.exists())
}

/// The study spec `name` as a message names it: the edited file in `folder`, or the
/// built-in copy.
pub fn spec_source(folder: Option<&Path>, name: &str) -> String {
    edited_spec(folder, name).map_or_else(|| format!("the built-in {name}.toml"), |f| f.display().to_string())
}

/// The store of study `name` inside a report folder: `OUT/runs/NAME`.
pub fn store_of(out: &Path, name: &str) -> PathBuf {
    out.join(RUNS).join(name)
}
